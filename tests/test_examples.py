"""examples/: each script runs from a temporary folder, says what it should, writes its
files there and nothing into the clone."""

from __future__ import annotations

import subprocess
import sys

import pytest
from clone_guard import REPO, clone_files, written

EXAMPLES = REPO / "examples"
# script -> (what its output must hold, the files it writes); slow ones run more plants or
# the exact evaluation of a .fis at every control step
CASES = {
    "01_one_run.py": (["θ1: rise 1.013 s, settling 1.730 s, Mp 0.00 %"], ["theta1_step.png"]),
    "03_sweep_dataframe.py": (
        ["(40, 53) rows x columns;", "read back: (40, 53) equal: True"],
        ["sweep_out/results.parquet"],
    ),
    "04_recording.py": (["time_s 1001 samples;"], ["theta1_step.rrd"]),
}
SLOW = {
    "02_compare.py": (["FCM-CTC against CTC on 10 plants, theta1_step"], ["compare.png"]),
    "05_matlab_fis.py": (["F(e, ė) on", "my_pd.fis  θ1: rise"], ["my_pd.fis"]),
}


def run_example(name: str, says: list[str], writes: list[str], tmp_path) -> str:
    before = clone_files()
    done = subprocess.run(
        [sys.executable, str(EXAMPLES / name)], cwd=tmp_path, capture_output=True, text=True,
        timeout=900,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    for text in says:
        assert text in done.stdout, (text, done.stdout[-3000:])
    for path in writes:
        assert (tmp_path / path).is_file(), path
    assert written(before) == []
    return done.stdout


@pytest.mark.parametrize("name", sorted(CASES))
def test_an_example_runs_from_any_folder(name, tmp_path):
    run_example(name, *CASES[name], tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SLOW))
def test_a_longer_example_runs_from_any_folder(name, tmp_path):
    out = run_example(name, *SLOW[name], tmp_path)
    if name == "05_matlab_fis.py":  # the .fis term acts: it rises sooner than plain CTC
        rise = {line.split()[0]: float(line.split("rise ")[1].split()[0])
                for line in out.splitlines() if " rise " in line}  # fmt: skip
        assert rise["my_pd.fis"] < rise["CTC"]


def test_every_example_is_tested_and_listed():
    scripts = {p.name for p in EXAMPLES.glob("*.py")}
    assert scripts == set(CASES) | set(SLOW)
    listing = (EXAMPLES / "README.md").read_text()
    assert all(f"`{s}`" in listing for s in scripts)
