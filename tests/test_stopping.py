"""Stopping is clean: after SIGTERM or SIGKILL of `twolink sweep` or `twolink reproduce`
no worker is left, nothing is written into --out afterwards, and a rerun completes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def children(pid: int) -> set[int]:
    """Live (not zombie) processes whose parent is ``pid``, from /proc."""
    out = set()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        state, ppid = fields[0], int(fields[1])
        if ppid == pid and state != "Z":
            out.add(int(stat.parent.name))
    return out


def descendants(pid: int) -> set[int]:
    """Live children of ``pid``, their children, and so on: forked pool workers are the
    fork server's children, not the command's."""
    found, todo = set(), [pid]
    while todo:
        new = children(todo.pop())
        todo += new - found
        found |= new
    return found


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def snapshot(folder: Path) -> dict[str, int]:
    return {str(p): p.stat().st_mtime_ns for p in folder.rglob("*") if p.is_file()}


COMMANDS = {
    "sweep": lambda out: [
        "sweep", str(REPO / "runs/sweeps/robustness.toml"), "-n", "40", "--out", str(out),
        "--workers", "2", "--no-plots", "--no-progress",
    ],
    "reproduce": lambda out: ["reproduce", "--out", str(out), "--workers", "2", "--no-trace"],
}  # fmt: skip


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("signum", [signal.SIGKILL, signal.SIGTERM], ids=["KILL", "TERM"])
@pytest.mark.parametrize("command", sorted(COMMANDS))
@pytest.mark.slow
def test_a_killed_command_leaves_no_worker_and_writes_nothing_after(tmp_path, command, signum):
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "twolink", *COMMANDS[command](out)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 120
    workers: set[int] = set()
    # The pool is up and working: a resource tracker and two workers, or a fork server, its
    # resource tracker and at least one worker.
    while len(workers) < 3:
        assert proc.poll() is None, "finished before the pool was seen"
        assert time.monotonic() < deadline, "no pool workers appeared"
        workers = descendants(proc.pid)
        time.sleep(0.05)
    time.sleep(1.0)
    workers |= descendants(proc.pid)
    os.kill(proc.pid, signum)
    proc.wait(timeout=60)
    before = snapshot(out)
    time.sleep(5.0)
    assert not [w for w in workers if alive(w)], "pool workers outlived the command"
    assert snapshot(out) == before, "files were written into --out after the command ended"
    rerun = subprocess.run(
        [sys.executable, "-m", "twolink", *COMMANDS[command](out)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert rerun.returncode == 0, rerun.stderr
