"""Every command, every file twolink reads back, hostile (issue 38): owner records,
journals, locks, seals, chunks, manifests, marks, `.fis` and TOML inputs as pipes, folders,
hard links, nested 100,000 deep, of the wrong type, with terminal escapes, huge. Each
ends within its alarm, with no traceback and an exit code of the README's list
(0, 1, 2, 3), and where twolink refuses, with one error line.

The planted files below a folder's owner record are reached the way a forger reaches
them: the record is re-forged to list them with their SHA-256 (docs/reliability.md: the
record proves what twolink wrote against damage and mistakes, not against a forger), so
that each reader's own defence is tested, not only the ownership check in front of it."""

from __future__ import annotations

import hashlib
import json
import os
import re
import signal
from pathlib import Path

import pytest
from cli_inputs import QUICK, STEP, SWEEP, invoke

from twolink.foundation.io import JOURNAL_NAME, LOCK_NAME, OWNER_NAME, ForeignOutput

EXIT_CODES = {0, 1, 2, 3}  # README, "Exit codes" (130 / 143: signals, not faults)


@pytest.fixture(autouse=True)
def no_hang():
    def hung(signum, frame):
        raise TimeoutError("hung: more than 60 s")

    previous = signal.signal(signal.SIGALRM, hung)
    signal.alarm(60)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


def ends_well(result, refused: bool = False) -> None:
    """No traceback, an exit code of the README's list, one error line where refused."""
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(
        result.exception
    )
    assert result.exit_code in EXIT_CODES, result.output
    assert "Traceback" not in result.output and "\x1b" not in result.output
    if refused:
        assert result.exit_code in (2, 3), result.output
        lines = [x for x in result.output.splitlines() if x.lower().startswith("error")]
        assert len(lines) == 1, result.output


def plant(path: Path, kind: str, outside: Path) -> None:
    """Make ``path`` a hostile file of ``kind``."""
    if path.exists() or path.is_symlink():
        if path.is_dir() and not path.is_symlink():
            import shutil

            shutil.rmtree(path)
        else:
            path.unlink()
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "folder":
        path.mkdir()
    elif kind == "hardlink":
        outside.write_text("someone else's bytes")
        os.link(outside, path)
    elif kind == "symlink-dev-zero":
        path.symlink_to("/dev/zero")
    elif kind == "deep":
        path.write_text("[" * 100_000 + "]" * 100_000)
    elif kind == "list":
        path.write_text("[1, 2, 3]")
    elif kind == "escapes":
        path.write_text(json.dumps({"command": "\x1b[2J\x1b[H", "digest": "\x1b]0;x\x07"}))
    elif kind == "garbage":
        path.write_bytes(os.urandom(4096))
    elif kind == "empty":
        path.write_bytes(b"")
    else:
        raise AssertionError(kind)


KINDS = ["fifo", "folder", "hardlink", "symlink-dev-zero", "deep", "list", "escapes", "garbage"]


def forge(out: Path) -> None:
    """Re-forge ``out``'s owner record to list every regular file under it as it is."""
    record = json.loads((out / OWNER_NAME).read_text())
    files = {}
    for p in sorted(out.rglob("*")):
        rel = p.relative_to(out).as_posix()
        if p.is_file() and not p.is_symlink() and rel not in (LOCK_NAME, OWNER_NAME):
            files[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
    record["files"] = files
    (out / OWNER_NAME).write_text(json.dumps(record))


COMMANDS = {
    "run": lambda f: ["run", STEP, *QUICK],
    "models": lambda f: ["models"],
    "sweep": lambda f: ["sweep", f, "--no-plots"],
    "gains": lambda f: ["gains", "--set", "plants=2"],
    "calibrate": lambda f: ["calibrate", "--set", "maxiter=1"],
    "regimes": lambda f: ["regimes", "-n", "10"],
}


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("name", [OWNER_NAME, JOURNAL_NAME, LOCK_NAME])
@pytest.mark.parametrize("command", list(COMMANDS))
def test_every_folder_command_on_a_hostile_record_journal_or_lock(tmp_path, command, name, kind):
    # a record twolink did not write is refused whatever it is; a lock with odd bytes is
    # still a lock, and a journal of a killed command that lists nothing claims nothing
    # (it is removed, never written through: a new one is made exclusively)
    harmless = {
        LOCK_NAME: ("deep", "list", "escapes", "garbage"),
        JOURNAL_NAME: ("deep", "list", "escapes", "garbage", "hardlink"),
    }
    if command in ("gains", "calibrate", "regimes") and (
        kind not in ("fifo", "deep", "hardlink") or kind in harmless.get(name, ())
    ):
        pytest.skip("the same code path as run's; the refusals alone keep the suite fast")
    sweep_file = tmp_path / "tiny.toml"
    sweep_file.write_text(SWEEP)
    out = tmp_path / "out"
    out.mkdir()
    plant(out / name, kind, tmp_path / "outside")
    result = invoke(*COMMANDS[command](sweep_file), "--out", out)
    ends_well(result)
    if kind not in harmless.get(name, ()):
        assert result.exit_code == 2, result.output
    if kind == "hardlink":
        assert (tmp_path / "outside").read_text() == "someone else's bytes"


@pytest.mark.parametrize("kind", ["fifo", "folder", "hardlink", "symlink-dev-zero", "escapes"])
@pytest.mark.parametrize("where", ["design --out", "design --figure", "fis --out"])
def test_every_named_output_file_hostile(tmp_path, where, kind):
    command, option = where.split()
    target = tmp_path / ("f.png" if option == "--figure" else "rules.toml")
    plant(target, kind, tmp_path / "outside")
    extra = ["--out", tmp_path / "r.toml"] if option == "--figure" else []
    result = invoke(command, option, target, *extra)
    ends_well(result, refused=True)
    if kind == "hardlink":
        assert (tmp_path / "outside").read_text() == "someone else's bytes"


@pytest.mark.parametrize("kind", ["deep", "list", "escapes", "garbage", "empty", "folder"])
@pytest.mark.parametrize(
    "planted", ["manifest.json", "chunks/chunk_00000.json", "chunks/chunk_00000.parquet"]
)
def test_a_sweeps_read_backs_hostile_behind_a_forged_record(tmp_path, planted, kind):
    sweep_file = tmp_path / "tiny.toml"
    sweep_file.write_text(SWEEP)
    out = tmp_path / "out"
    assert invoke("sweep", sweep_file, "--out", out, "--no-plots").exit_code == 0
    plant(out / planted, kind, tmp_path / "outside")
    forge(out)
    result = invoke("sweep", sweep_file, "--out", out, "--no-plots")
    ends_well(result)
    if kind == "escapes" and planted == "manifest.json":  # it names another sweep, escaped
        assert result.exit_code == 2 and "different sweep" in result.output
    elif kind != "folder":  # damaged: computed again, or the whole sweep reused
        assert result.exit_code == 0, result.output


@pytest.mark.parametrize("kind", ["deep", "list", "escapes", "garbage", "empty", "folder"])
@pytest.mark.parametrize("planted", ["seal.json", "metrics.json", "config.toml"])
def test_a_run_folders_read_backs_hostile_behind_a_forged_record(tmp_path, planted, kind):
    out = tmp_path / "out"
    assert invoke("run", STEP, "--out", out, *QUICK).exit_code == 0
    plant(out / planted, kind, tmp_path / "outside")
    forge(out)
    ends_well(invoke("run", STEP, "--out", out, *QUICK))


@pytest.mark.parametrize("kind", ["fifo", "deep", "list", "garbage", "symlink-dev-zero"])
def test_the_direct_readers_of_seals_and_chunks_on_their_own(tmp_path, kind):
    # no ownership check in front: the bounded reader alone
    from twolink.foundation.io import seal_intact, write_seal
    from twolink.sweep import load_sweep
    from twolink.sweep.execution import _prepare_out, _valid_chunk

    (tmp_path / "a.npz").write_bytes(b"x")
    write_seal(tmp_path, ["a.npz"])
    plant(tmp_path / "seal.json", kind, tmp_path / "outside")
    assert not seal_intact(tmp_path)
    sweep_file = tmp_path / "tiny.toml"
    sweep_file.write_text(SWEEP)
    plan = load_sweep(sweep_file)
    out = tmp_path / "s"
    (out / "chunks").mkdir(parents=True)
    (out / "chunks" / "chunk_00000.parquet").write_bytes(b"PAR1")
    plant(out / "chunks" / "chunk_00000.json", kind, tmp_path / "outside2")
    assert _valid_chunk(plan, out, 0) is None
    plant(out / "manifest.json", kind, tmp_path / "outside3")
    if kind in ("symlink-dev-zero", "fifo"):  # refused, never read or written through
        with pytest.raises(ForeignOutput, match="symbolic link|not a regular file"):
            _prepare_out(plan, out, fresh=False)
    else:
        _prepare_out(plan, out, fresh=False)


def _fis(tmp_path: Path) -> str:
    assert invoke("fis", "paper", "--out", tmp_path / "ok.fis").exit_code == 0
    return (tmp_path / "ok.fis").read_text()


TRIMF = r"'trimf',\[(\S+) (\S+) (\S+)\]"
FIS_DAMAGE = {
    "short-params": lambda t: re.sub(TRIMF, r"'trimf',[\1 \2]", t, count=1),
    "huge-index": lambda t: t.replace("[Rules]\n", "[Rules]\n1" + "0" * 400 + " 1, 1 (1) : 1\n"),
    "and-prod": lambda t: t.replace("AndMethod='min'", "AndMethod='prod'"),
    "defuzz-mom": lambda t: t.replace("DefuzzMethod='centroid'", "DefuzzMethod='mom'"),
    "no-system": lambda t: t.replace("[System]", "[Nothing]"),
    "binary": lambda t: "\x00\xff" * 100,
}


@pytest.mark.parametrize("damage", list(FIS_DAMAGE))
def test_a_hostile_fis_file_in_coverage_fis_and_run(tmp_path, damage):
    text = FIS_DAMAGE[damage](_fis(tmp_path))
    assert damage == "binary" or text != _fis(tmp_path), "the damage must change the file"
    bad = tmp_path / "bad.fis"
    bad.write_text(text)
    scenario = tmp_path / "s.toml"
    scenario.write_text(
        f'extends = "{STEP.as_posix()}"\nduration = 0.05\n'
        f'[controller]\nkind = "fcm_ctc"\nrule_base = "{bad.as_posix()}"\n'
    )
    # coverage and run evaluate any MATLAB FIS with its own methods
    # (controllers/fuzzy/fis/matlab.py): there prod and mom are used, not ignored; `fis` takes
    # a rule base's rules only, and a method that would be ignored is refused
    used = damage in ("and-prod", "defuzz-mom")
    ends_well(invoke("coverage", bad), refused=not used)
    ends_well(invoke("run", scenario, "--out", tmp_path / "o", *QUICK), refused=not used)
    result = invoke("fis", bad, "--out", tmp_path / "o.fis")
    ends_well(result, refused=True)
    if used:
        assert "would be ignored" in result.output


TOML_DAMAGE = {
    "deep": "a = " + "[" * 500 + "]" * 500 + "\n",
    "resolution": f'extends = "{STEP.as_posix()}"\n[sensor]\nresolution_rad = 5e-324\n',
    "ctc-continuous": (
        f'extends = "{STEP.as_posix()}"\n[controller]\nkind = "ctc"\n'
        'fuzzy = { inference = "continuous" }\n'
    ),
    "binary": "\x00\x01\x02",
}


@pytest.mark.parametrize("damage", list(TOML_DAMAGE))
@pytest.mark.parametrize(
    "command",
    [
        lambda f, o: ["run", f, "--out", o, *QUICK],
        lambda f, o: ["sweep", f, "--out", o],
        lambda f, o: ["gains", f, "--out", o],
        lambda f, o: ["calibrate", f, "--out", o],
        lambda f, o: ["regimes", f, "--out", o],
        lambda f, o: ["reproduce", "--manifest", f, "--out", o],
        lambda f, o: ["design", "--config", f, "--out", Path(o) / "r.toml"],
        lambda f, o: ["coverage", f],
    ],
    ids=["run", "sweep", "gains", "calibrate", "regimes", "reproduce", "design", "coverage"],
)
def test_a_hostile_toml_file_in_every_command(tmp_path, command, damage):
    f = tmp_path / "x.toml"
    f.write_text(TOML_DAMAGE[damage])
    ends_well(invoke(*command(f, tmp_path / "out")), refused=True)
    assert not (tmp_path / "out").exists()


def test_extends_through_a_link_loop_in_a_sweep_and_a_scenario(tmp_path):
    (tmp_path / "a.toml").write_text('extends = "b.toml"\n')
    (tmp_path / "b.toml").symlink_to(tmp_path / "a.toml")
    for args in (["run", tmp_path / "a.toml", *QUICK], ["sweep", tmp_path / "a.toml"]):
        ends_well(invoke(*args, "--out", tmp_path / "o"), refused=True)


def test_chunks_a_file_is_refused(tmp_path):
    sweep_file = tmp_path / "tiny.toml"
    sweep_file.write_text(SWEEP)
    out = tmp_path / "out"
    assert invoke("sweep", sweep_file, "--out", out, "--no-plots").exit_code == 0
    import shutil

    shutil.rmtree(out / "chunks")
    (out / "chunks").write_text("a file")
    forge(out)
    ends_well(invoke("sweep", sweep_file, "--out", out, "--no-plots"), refused=True)
