"""Nothing of the user's lost (issue 38, the sequel of tests/test_nothing_lost.py): ownership
proven by content, hard links, marks, the library's writing calls, planted records, pipes
and devices, swapped folders, killed commands' temporaries. Each case failed on the main
before owner records carried SHA-256s (docs/reliability.md)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from cli_inputs import QUICK, STEP, SWEEP, invoke, one_error_line, tree

from twolink.foundation.io import (
    LOCK_NAME,
    OWNER_NAME,
    ForeignOutput,
    output_lock,
    seal_intact,
    write_seal,
)


@pytest.fixture(autouse=True)
def no_hang():
    """A test that hangs (a pipe opened for reading) fails after 120 s instead."""

    def hung(signum, frame):
        raise TimeoutError("hung: more than 120 s")

    previous = signal.signal(signal.SIGALRM, hung)
    signal.alarm(120)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


CHEAP = {  # a command and the name of one of its outputs; each refuses before its work
    "run": (["run", STEP, *QUICK], "config.toml"),
    "run-plots": (["run", STEP, *QUICK], "angles.png"),
    "run-seal": (["run", STEP, *QUICK], "seal.json"),
    "models": (["models"], "scene.xml"),
    "calibrate": (["calibrate", "--set", "maxiter=1"], "calibrated.toml"),
    "gains": (["gains", "--set", "plants=2"], "gains.csv"),
}


@pytest.mark.parametrize("case", CHEAP, ids=list(CHEAP))
def test_a_users_file_with_twolinks_name_is_not_adopted(tmp_path, case):
    args, name = CHEAP[case]
    out = tmp_path / "mine"
    out.mkdir()
    (out / name).write_text('# my scenario\nextends = "base.toml"\n')
    before = tree(out)
    result = invoke(*args, "--out", out)
    assert result.exit_code == 2, result.output
    one_error_line(result)
    assert name in result.output and tree(out) == before


@pytest.mark.parametrize(
    "args, name",
    [
        (["sweep", "{sweep}", "--no-plots"], "summary.json"),
        (["models"], "twolink.xml"),
        (["run", STEP, *QUICK], "metrics.json"),
    ],
    ids=["sweep", "models", "run"],
)
def test_a_lock_alone_makes_no_folder_twolinks(tmp_path, args, name):
    sweep_file = tmp_path / "tiny.toml"
    sweep_file.write_text(SWEEP)
    out = tmp_path / "out"
    out.mkdir()
    (out / LOCK_NAME).write_text("")
    (out / name).write_text("mine")
    before = tree(out)
    result = invoke(*[str(a).format(sweep=sweep_file) for a in args], "--out", out)
    assert result.exit_code == 2 and name in result.output, result.output
    assert tree(out) == before


def test_a_lock_alone_makes_no_reproduction_folder(tmp_path):
    from twolink.studies.reproduction.reproduce import reproduce

    out = tmp_path / "out"
    out.mkdir()
    (out / LOCK_NAME).write_text("")
    (out / "report.md").write_text("my report")
    with pytest.raises(ForeignOutput, match="report.md"):
        reproduce(out=out, progress=False)
    assert (out / "report.md").read_text() == "my report"


def test_the_record_lists_only_what_the_command_wrote_with_its_sha256(tmp_path):
    import hashlib
    import json

    from twolink.foundation.io import atomic_write_text, check_ownership, owned_output

    out = tmp_path / "out"
    with owned_output(out, "demo"):
        atomic_write_text(out / "result.txt", "ours")
        (out / "thesis.tex").write_text("written while the command ran")  # the user's
    record = json.loads((out / OWNER_NAME).read_text())
    assert record["files"] == {"result.txt": hashlib.sha256(b"ours").hexdigest()}
    with pytest.raises(ForeignOutput, match="thesis.tex"):
        check_ownership(out, "demo")
    (out / "thesis.tex").unlink()
    check_ownership(out, "demo")  # only its own file: the folder is the command's
    (out / "result.txt").write_text("edited by the user")  # same name, other bytes
    with pytest.raises(ForeignOutput, match="changed since twolink wrote it"):
        check_ownership(out, "demo")


def test_a_refused_command_writes_no_record(tmp_path):
    from twolink.foundation.io import owned_output
    from twolink.simulation.config import load_scenario
    from twolink.simulation.experiment import measure, run_scenario
    from twolink.studies.reproduction.run_folder import write_run

    out = tmp_path / "run"
    s = load_scenario(STEP, {"duration": 0.05})
    traj = run_scenario(s)
    with pytest.raises(ForeignOutput), owned_output(tmp_path / "held", "run"):
        (tmp_path / "held" / "run").mkdir()
        (tmp_path / "held" / "run" / "mine.txt").write_text("x")
        write_run(tmp_path / "held" / "run", s, traj, measure(s, traj), False, False)
    assert not (tmp_path / "held" / OWNER_NAME).exists()
    # a run's name in a library call's folder is not a run's file unless its seal says so
    out.mkdir()
    (out / "angles.png").write_bytes(b"my plot")
    with pytest.raises(ForeignOutput, match="angles.png"):
        write_run(out, s, traj, measure(s, traj), True, False)
    assert (out / "angles.png").read_bytes() == b"my plot"


@pytest.mark.parametrize(
    "planted",
    [
        {"command": "sweep", "entries": ["thesis.tex"]},  # a record of a twolink before
        {"kind": "twolink owner record", "version": 2, "command": "sweep", "source": None,
         "files": {"thesis.tex": "0" * 64}},  # a copied record: other bytes
        {"kind": "twolink owner record", "version": 2, "command": "\x1b[2J\x1b[Hsweep",
         "source": "\x1b]0;x\x07", "files": {}},  # terminal escapes
        [1, 2, 3],
        {"files": "x" * 10},
    ],
    ids=["old-entries", "copied-hash", "escapes", "a-list", "wrong-type"],
)  # fmt: skip
def test_a_planted_owner_record_hands_nothing_over(tmp_path, planted):
    import json

    sweep_file = tmp_path / "tiny.toml"
    sweep_file.write_text(SWEEP)
    out = tmp_path / "out"
    out.mkdir()
    (out / "thesis.tex").write_text("chapter 1")
    (out / OWNER_NAME).write_text(json.dumps(planted))
    for args in (["sweep", sweep_file, "--no-plots"], ["models"]):
        result = invoke(*args, "--out", out)
        assert result.exit_code == 2, result.output
        assert "\x1b" not in result.output and "\x07" not in result.output
        one_error_line(result)
    assert (out / "thesis.tex").read_text() == "chapter 1"


def test_a_deep_or_huge_record_or_seal_is_no_traceback(tmp_path):
    from twolink.foundation.io import check_ownership

    out = tmp_path / "out"
    out.mkdir()
    (out / OWNER_NAME).write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(ForeignOutput):
        check_ownership(out, "run")
    (tmp_path / "s").mkdir()
    (tmp_path / "s" / "seal.json").write_text("{" + '"a":' * 0 + "[" * 100_000 + "]" * 100_000)
    assert not seal_intact(tmp_path / "s")


@pytest.mark.parametrize("planted", ["fifo", "folder", "hardlink", "symlink"])
def test_the_lock_is_only_ever_a_file_twolink_made(tmp_path, planted):
    # output_lock alone, without the folder checks before it (each defence on its own)
    out = tmp_path / "out"
    out.mkdir()
    victim = tmp_path / "snapshot_of_the_lock"
    victim.write_text("precious")
    lock = out / LOCK_NAME
    {
        "fifo": lambda: os.mkfifo(lock),
        "folder": lambda: lock.mkdir(),
        "hardlink": lambda: os.link(victim, lock),
        "symlink": lambda: lock.symlink_to(victim),
    }[planted]()
    start = time.perf_counter()
    with pytest.raises(ForeignOutput, match=LOCK_NAME), output_lock(out):
        pass
    assert time.perf_counter() - start < 5 and victim.read_text() == "precious"


@pytest.mark.parametrize("command", ["run", "models", "sweep", "reproduce"])
def test_a_lock_hard_linked_outside_is_never_written(tmp_path, command):
    sweep_file = tmp_path / "tiny.toml"
    sweep_file.write_text(SWEEP)
    out = tmp_path / "out"
    out.mkdir()
    snapshot = tmp_path / "snapshot.lock"
    snapshot.write_text("a snapshot's bytes")
    os.link(snapshot, out / LOCK_NAME)
    args = {
        "run": ["run", STEP, *QUICK],
        "models": ["models"],
        "sweep": ["sweep", sweep_file, "--no-plots"],
        "reproduce": ["reproduce", "--no-trace", "--set", "duration=0.05"],
    }[command]
    result = invoke(*args, "--out", out)
    assert result.exit_code == 2 and "hard link" in result.output, result.output
    assert snapshot.read_text() == "a snapshot's bytes"


def test_a_log_is_never_appended_through_a_hard_link(tmp_path):
    from twolink.foundation.io import append_line

    other = tmp_path / "other.log"
    other.write_text("theirs\n")
    os.link(other, tmp_path / "computed.log")
    with pytest.raises(ForeignOutput, match="hard link"):
        append_line(tmp_path / "computed.log", "chunk 1")
    assert other.read_text() == "theirs\n"


@pytest.mark.parametrize(
    "name, data",
    [
        ("notes.md", b"# Notes\nrule_base.toml is written by twolink design.\n"),
        ("rules.toml", b"# my rules, not written by twolink\n"),
        ("fig.png", "png-comment"),
    ],
    ids=["md-mention", "toml-not", "png-comment"],
)
def test_the_mark_is_an_exact_header_not_a_substring(tmp_path, name, data):
    path = tmp_path / name
    if data == "png-comment":
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig = plt.figure()
        fig.savefig(path, format="png", metadata={"Comment": "not written by twolink"})
        plt.close(fig)
    else:
        path.write_bytes(data)
    before = path.read_bytes()
    option = "--figure" if name.endswith(".png") else "--out"
    result = invoke("design", option, path, *(["--out", tmp_path / "r.toml"] * (option != "--out")))
    assert result.exit_code == 2 and "did not write" in result.output, result.output
    assert path.read_bytes() == before
    from twolink.foundation.io import carries_mark

    assert not carries_mark(path)


def test_design_rule_base_in_the_library_keeps_the_command_lines_rules(tmp_path):
    import twolink

    out = tmp_path / "design"
    out.mkdir()
    (out / "validation.csv").write_text("my table")
    with pytest.raises(ForeignOutput, match="validation.csv"):
        twolink.design_rule_base(out=out)
    assert (out / "validation.csv").read_text() == "my table"
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "link").symlink_to(tmp_path / "elsewhere")
    with pytest.raises(ForeignOutput, match="symbolic link"):
        twolink.design_rule_base(out=tmp_path / "link")
    assert list((tmp_path / "elsewhere").iterdir()) == []


def test_run_sweep_in_the_library_keeps_the_command_lines_rules(tmp_path):
    import twolink

    sweep_file = tmp_path / "tiny.toml"
    sweep_file.write_text(SWEEP)
    out = tmp_path / "out"
    out.mkdir()
    (out / LOCK_NAME).write_text("")  # a lock alone made the folder twolink's before
    (out / "summary.json").write_text("mine")
    with pytest.raises(ForeignOutput, match="summary.json"):
        twolink.run_sweep(sweep_file, out, workers=1)
    assert (out / "summary.json").read_text() == "mine"


@pytest.mark.parametrize("kind", ["fifo", "dev-zero", "dotdot"])
def test_a_seal_naming_a_pipe_or_device_is_not_intact_at_once(tmp_path, kind):
    import json

    (tmp_path / "a.npz").write_bytes(b"x")
    write_seal(tmp_path, ["a.npz"])
    if kind == "fifo":
        os.mkfifo(tmp_path / "p")
        name = "p"
    else:
        name = "/dev/zero" if kind == "dev-zero" else "../../../../dev/zero"
    # the intact file first: the check reaches the planted name
    sealed = json.loads((tmp_path / "seal.json").read_text())
    (tmp_path / "seal.json").write_text(json.dumps({**sealed, name: "0" * 64}))
    start = time.perf_counter()
    assert not seal_intact(tmp_path)
    assert time.perf_counter() - start < 2


@pytest.mark.parametrize("what", ["record", "journal"])
def test_a_named_pipe_as_the_owner_record_is_refused_at_once(tmp_path, what):
    from twolink.foundation.io import JOURNAL_NAME

    out = tmp_path / "out"
    out.mkdir()
    os.mkfifo(out / (OWNER_NAME if what == "record" else JOURNAL_NAME))
    start = time.perf_counter()
    for args in (["models"], ["run", STEP, *QUICK]):
        result = invoke(*args, "--out", out)
        assert result.exit_code == 2, result.output
    assert time.perf_counter() - start < 10


@pytest.mark.parametrize("target", ["fifo", "/dev/zero"])
def test_fis_out_a_pipe_or_device_is_refused_at_once(tmp_path, target):
    path = tmp_path / "rules.fis"
    if target == "fifo":
        os.mkfifo(path)
    else:
        path = Path(target)
    start = time.perf_counter()
    result = invoke("fis", "--out", path)
    assert result.exit_code == 2 and "not a regular file" in result.output, result.output
    assert time.perf_counter() - start < 10


def test_a_folder_swapped_for_a_link_gets_no_record_through_it(tmp_path):
    from twolink.foundation.io import atomic_write_text, owned_output

    out, elsewhere = tmp_path / "out", tmp_path / "elsewhere"
    elsewhere.mkdir()
    with pytest.raises(ForeignOutput, match="replaced"), owned_output(out, "demo"):
        atomic_write_text(out / "a.txt", "ours")
        out.rename(tmp_path / "moved")
        out.symlink_to(elsewhere)
    assert list(elsewhere.iterdir()) == []
    # and a write after the swap, before the record, goes nowhere either
    out.unlink()
    with pytest.raises(ForeignOutput, match="replaced"), owned_output(out, "demo"):
        out.rename(tmp_path / "moved2")
        out.symlink_to(elsewhere)
        atomic_write_text(out / "b.txt", "ours")
    assert list(elsewhere.iterdir()) == []


def test_a_killed_commands_temporaries_are_removed_by_the_next(tmp_path):
    from twolink.foundation.io import atomic_path, check_ownership, owned_output

    out = tmp_path / "out"
    code = (
        "import os; from twolink.foundation.io import atomic_path, owned_output\n"
        f"with owned_output({str(out)!r}, 'demo'):\n"
        f"    with atomic_path({str(out / 'big.bin')!r}) as tmp:\n"
        "        open(tmp, 'wb').write(b'x' * 100000); os.kill(os.getpid(), 9)\n"
    )
    subprocess.run([sys.executable, "-c", code], check=False)
    assert [p for p in out.iterdir() if p.name.endswith(".tmp")]
    check_ownership(out, "demo")  # listed by the journal: twolink's own temporary
    with owned_output(out, "demo"), atomic_path(out / "small.txt") as tmp:
        tmp.write_text("x")
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]


ALL_FOLDER_COMMANDS = {
    "run": ["run", STEP, *QUICK],
    "models": ["models"],
    "sweep": ["sweep", "{sweep}", "--no-plots"],
    "reproduce": ["reproduce", "--no-trace"],
    "gains": ["gains", "--set", "plants=2"],
    "calibrate": ["calibrate", "--set", "maxiter=1"],
    "regimes": ["regimes", "-n", "10"],
}


@pytest.mark.parametrize("command", list(ALL_FOLDER_COMMANDS))
def test_no_space_for_the_locks_pid_exits_3_naming_the_lock(tmp_path, monkeypatch, command):
    # 0 bytes free: the first byte any command writes is the lock's pid (ENOSPC, simulated)
    import errno

    def full(*args):
        raise OSError(errno.ENOSPC, "No space left on device")

    sweep_file = tmp_path / "tiny.toml"
    sweep_file.write_text(SWEEP)
    monkeypatch.setattr(os, "pwrite", full)
    args = [str(a).format(sweep=sweep_file) for a in ALL_FOLDER_COMMANDS[command]]
    result = invoke(*args, "--out", tmp_path / "out")
    assert result.exit_code == 3, result.output
    one_error_line(result)
    assert f"{tmp_path / 'out' / LOCK_NAME}" in result.output and "No space left" in result.output


@pytest.mark.slow  # ~1 min: nine processes, design and fis do their whole work first
@pytest.mark.parametrize(
    "command", [*ALL_FOLDER_COMMANDS, "design", "fis"], ids=[*ALL_FOLDER_COMMANDS, "design", "fis"]
)
def test_zero_bytes_writable_exits_3_naming_a_file_in_every_command(tmp_path, command):
    import resource

    sweep_file = tmp_path / "tiny.toml"
    sweep_file.write_text(SWEEP)
    if command in ALL_FOLDER_COMMANDS:
        args = [str(a).format(sweep=sweep_file) for a in ALL_FOLDER_COMMANDS[command]]
        args += ["--out", str(tmp_path / "out")]
    else:
        args = [command, "--out", str(tmp_path / f"out.{'toml' if command == 'design' else 'fis'}")]

    def preexec() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (0, 0))

    r = subprocess.run(
        [sys.executable, "-m", "twolink", *args],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        preexec_fn=preexec,
        timeout=300,
    )
    assert r.returncode == 3, r.stderr
    assert "Traceback" not in r.stderr and f"cannot write {tmp_path}" in r.stderr, r.stderr


def test_a_full_disk_in_a_reproduction_exits_3_naming_the_file(tmp_path):
    import resource

    def preexec() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (20_000, 20_000))

    out = tmp_path / "r"
    r = subprocess.run(
        [sys.executable, "-m", "twolink", "reproduce", "--out", str(out), "--no-trace"],
        capture_output=True,
        text=True,
        preexec_fn=preexec,
        timeout=300,
    )
    assert r.returncode == 3, r.stderr  # exit 2 naming no file before
    assert "Traceback" not in r.stderr and f"cannot write {out}" in r.stderr


def test_a_journal_with_another_name_is_never_appended_by_a_worker(tmp_path):
    # a pool worker appends to the journal by its path: never into a hard link (on its own,
    # without the exclusive create that the command holding the folder does first)
    from twolink.foundation.io import JOURNAL_NAME, note_written

    out = tmp_path / "out"
    out.mkdir()
    (out / LOCK_NAME).write_text("")
    other = tmp_path / "someone_elses.txt"
    other.write_text("theirs")
    os.link(other, out / JOURNAL_NAME)
    (out / "a.txt").write_text("x")
    import fcntl

    with open(out / LOCK_NAME) as lock:  # held, as the command that runs the worker holds it
        fcntl.flock(lock, fcntl.LOCK_EX)
        with pytest.raises(ForeignOutput, match="journal"):
            note_written(out / "a.txt")
    assert other.read_text() == "theirs"


def test_every_writer_goes_through_twolinks_own():
    # A file written past twolink.foundation.io (shutil.copy, Path.write_text, a rename)
    # is not in the journal, so the owner record would not list it and the next command
    # would refuse its own folder (seen: the search's files copied into a reproduction).
    import re

    pattern = re.compile(
        r"shutil\.(copy|move)\w*\(|\.write_text\(|\.write_bytes\(|os\.(rename|replace)\("
    )
    root = Path(__file__).resolve().parents[1]
    offenders = []
    for path in [*(root / "twolink").rglob("*.py"), *(root / "controllers").rglob("*.py")]:
        if "foundation" in path.parts:
            continue
        for n, line in enumerate(path.read_text().splitlines(), 1):
            if pattern.search(line) and "(f, tmp)" not in line:  # a copy into a temporary
                offenders.append(f"{path.relative_to(root)}:{n}")
    assert offenders == []
