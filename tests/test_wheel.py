"""twolink as a package, not a checkout: the wheel ``python -m build`` makes, installed
(not editable) into a fresh venv, runs its commands on their defaults from a temporary
folder, finds its shipped files inside site-packages, and writes nothing into the clone.

The fresh venv gets the wheel with ``--no-deps`` and this venv's site-packages through a
``.pth`` file (its dependencies, not its twolink: an editable install is a finder that a
``.pth`` path line does not run), so the test needs no network. The build runs without
isolation where the build backend is installed (``setuptools``, ``wheel``: in the test
extra), else isolated (which downloads them).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import sysconfig
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import pytest
from clone_guard import REPO, clone_files, written

from twolink.foundation import shipped

BUILD_BACKEND = ("setuptools", 69), ("wheel", 0)


def _backend_installed() -> bool:
    try:
        return all(int(version(n).split(".")[0]) >= v for n, v in BUILD_BACKEND)
    except PackageNotFoundError:
        return False


@pytest.fixture(scope="module")
def wheel_venv(tmp_path_factory) -> Path:
    """A fresh venv with the wheel of this clone installed (not editable)."""
    tmp = tmp_path_factory.mktemp("wheel")
    dist = tmp / "dist"
    build = [sys.executable, "-m", "build", "--outdir", str(dist), str(REPO)]
    if _backend_installed():
        build.insert(3, "--no-isolation")
    done = subprocess.run(build, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    wheels = sorted(dist.glob("twolink-*.whl"))
    assert len(wheels) == 1 and len(list(dist.glob("twolink-*.tar.gz"))) == 1
    venv = tmp / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    python = venv / "bin" / "python"
    purelib = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        capture_output=True, text=True, check=True,
    ).stdout.strip()  # fmt: skip
    ours = {sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]}
    Path(purelib, "twolink_test_dependencies.pth").write_text("\n".join(sorted(ours)) + "\n")
    pip = [sys.executable, "-m", "pip", "--python", str(python), "install", "-q"]
    done = subprocess.run(
        [*pip, "--no-deps", "--no-index", str(wheels[0])], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    return venv


def in_venv(venv: Path, args: list[str], cwd: Path, timeout: float = 300):
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    env["PATH"] = f"{venv / 'bin'}:{env.get('PATH', '')}"
    return subprocess.run(
        args, cwd=cwd, capture_output=True, text=True, timeout=timeout, env=env
    )  # fmt: skip


def test_the_wheel_holds_every_shipped_file(wheel_venv):
    import zipfile

    wheel = next((wheel_venv.parent / "dist").glob("twolink-*.whl"))
    names = set(zipfile.ZipFile(wheel).namelist())
    shipped_folders = (
        (REPO / "runs", "twolink/runs"),
        (REPO / "models", "twolink/models"),
        (REPO / "controllers" / "rulebases", "twolink/controllers/rulebases"),
    )
    for folder, package in shipped_folders:
        for path in folder.rglob("*"):
            if path.is_file() and "__pycache__" not in path.parts:
                assert f"{package}/{path.relative_to(folder).as_posix()}" in names, path


def test_the_installed_wheel_runs_from_any_folder_and_writes_nothing_in_the_clone(
    wheel_venv, tmp_path
):
    before = clone_files()
    python = str(wheel_venv / "bin" / "python")
    where = in_venv(wheel_venv, [python, "-c", (
        "import twolink, twolink.controllers\n"
        "from twolink.foundation import shipped\n"
        "from twolink.studies.designs import calibrate, design, gains\n"
        "from twolink.studies.judgments import regimes\n"
        "from twolink.studies.reproduction import manifest\n"
        "from twolink.sweep import load_sweep\n"
        "print(twolink.__file__)\n"
        "print(shipped.runs_dir(), shipped.models_dir(), shipped.rulebases_dir())\n"
        "print(shipped.clone_root())\n"
        "print(manifest.load_manifest().claims_study)\n"
        "gains.load_gain_study(); calibrate.load_calibration(); design.load_design_config()\n"
        "print(load_sweep(regimes.DEFAULT_STUDY).name, twolink.load_rule_base('designed'))\n"
    )], tmp_path)  # fmt: skip
    assert where.returncode == 0, where.stderr
    lines = where.stdout.splitlines()
    site = str(wheel_venv)
    assert lines[0].startswith(site) and "site-packages/twolink/" in lines[0]
    assert all(p.startswith(site) for p in lines[1].split()), lines[1]
    assert lines[2] == "None"  # not a clone: --install has nothing to write into
    assert lines[3].startswith(site)

    run = in_venv(wheel_venv, ["twolink", "run", "paper/theta1_step"], tmp_path)
    assert run.returncode == 0, run.stderr
    folder = tmp_path / "results" / "theta1_step"
    assert {"metrics.json", "trajectory.npz", "trace.rrd", "config.toml"} <= {
        p.name for p in folder.iterdir()
    }
    assert "outcome: met spec" in run.stdout

    for command in (["design", "--install"], ["models", "--install"], ["calibrate", "--install"],
                    ["gains", "--install", "--set", "plants=1"]):  # fmt: skip
        refused = in_venv(wheel_venv, ["twolink", *command], tmp_path)
        assert refused.returncode == 2, (command, refused.stdout, refused.stderr)
        error = refused.stderr.strip().splitlines()
        assert len(error) == 1 and re.match(r"error: --install rewrites the shipped", error[0])
        assert "nothing to install into" in error[0]
    assert written(before) == []


def readme_blocks() -> list[str]:
    text = (REPO / "README.md").read_text().split("## Use it as a library", 1)[1]
    return re.findall(r"```python\n(.*?)```", text, re.S)


@pytest.mark.slow
def test_the_wheel_reproduces_and_runs_the_readme_from_a_temporary_folder(wheel_venv, tmp_path):
    """The README's first command's job (`twolink reproduce`, here without recordings)
    and its library blocks, from the installed wheel in a folder of their own: about
    3 min on 2 cores."""
    before = clone_files()
    done = in_venv(wheel_venv, ["twolink", "reproduce", "--no-trace"], tmp_path, timeout=1800)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert re.search(r"^\d+ runs: \d+ met the spec", done.stdout, re.M), done.stdout[-2000:]
    report = (tmp_path / "results" / "reproduce" / "report.md").read_text()
    assert "Table 2" in report
    python = str(wheel_venv / "bin" / "python")
    for k, block in enumerate(readme_blocks()):
        folder = tmp_path / f"block{k}"
        folder.mkdir()
        ran = in_venv(wheel_venv, [python, "-c", block], folder, timeout=600)
        assert ran.returncode == 0, (k, ran.stderr[-3000:])
        assert any(folder.iterdir())  # it wrote its figure (and sweep) there
    assert written(before) == []


def test_the_clone_is_what_an_editable_install_runs_from():
    assert shipped.clone_root() == REPO  # the fixture's wheel is the other case
