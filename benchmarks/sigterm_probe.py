"""SIGTERM a reproduction at given moments and measure how it ends (docs/sweeps.md,
"Stopping and resuming").

    python benchmarks/sigterm_probe.py --delays 3,4.5,6 [--fresh-numba] [--group] [--trace]
        [--tree PATH ...]

Each trial starts ``python -m twolink reproduce --workers 2 --no-trace`` into a fresh
folder (stderr to a file, not a pipe: the fork server and the workers inherit it), sends
SIGTERM after each delay, and prints one JSON line: the exit code, seconds from the
signal to the command's exit and to the last of its processes gone (workers, fork
server, resource tracker), any "Traceback" or "Exception ignored" on stderr, the
temporaries left in the folder, and what was still running 2.5 s after the signal.
``--fresh-numba`` gives each trial its own empty NUMBA_CACHE_DIR (the compiled fuzzy
kernels are then compiled in the fork server and the workers, as on a fresh clone);
``--group`` sends the SIGTERM to the command's whole process group (as ``timeout`` or a
service manager do); ``--trace`` keeps the recordings (rerun), as a plain ``twolink
reproduce`` does. Several ``--tree`` (checkouts, e.g. ``git archive <commit> | tar -x
-C DIR``) run alternately, so they share the machine's load.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _children(pid: int) -> set[int]:
    out = set()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid and fields[0] != "Z":
            out.add(int(stat.parent.name))
    return out


def _descendants(pid: int) -> set[int]:
    found, todo = set(), [pid]
    while todo:
        new = _children(todo.pop()) - found
        todo += new
        found |= new
    return found


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def _command_line(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")[:100].decode()
    except OSError:
        return "?"


def trial(tree: Path, delay_s: float, fresh_numba: bool, group: bool, trace: bool) -> dict:
    """How one SIGTERM ``delay_s`` into a reproduction run from ``tree`` ended."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "r"
        env = dict(os.environ)
        if fresh_numba:
            env["NUMBA_CACHE_DIR"] = str(Path(tmp) / "numba")
        cmd = [sys.executable, "-m", "twolink", "reproduce", "--out", str(out), "--workers", "2"]
        with open(Path(tmp) / "stderr", "w+") as err:
            proc = subprocess.Popen(
                cmd if trace else [*cmd, "--no-trace"],
                cwd=tree,  # `python -m` imports twolink from here
                stdout=subprocess.DEVNULL,
                stderr=err,
                env=env,
                start_new_session=True,
            )
            seen: set[int] = set()
            end = time.monotonic() + delay_s
            while time.monotonic() < end:
                seen |= _descendants(proc.pid)
                time.sleep(0.05)
            seen |= _descendants(proc.pid)
            (os.killpg if group else os.kill)(proc.pid, signal.SIGTERM)
            sent = time.monotonic()
            try:
                proc.wait(timeout=90)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
            exited = time.monotonic() - sent
            late: dict[int, str] = {}
            while [p for p in seen if _alive(p)] and time.monotonic() - sent < 30:
                if time.monotonic() - sent > 2.5 and not late:
                    late = {p: _command_line(p) for p in seen if _alive(p)}
                time.sleep(0.02)
            gone = time.monotonic() - sent
            err.seek(0)
            text = err.read()
        left = [
            str(p.relative_to(out)) for p in out.rglob("*") if p.name.endswith((".tmp", ".old"))
        ]
    return {
        "tree": str(tree),
        "delay_s": delay_s,
        "trace": trace,
        "exit": proc.returncode,
        "exit_s": round(exited, 2),
        "all_gone_s": round(gone, 2),
        "traceback": "Traceback" in text or "Exception ignored" in text,
        "last_line": (text.strip().splitlines() or [""])[-1][:100],
        "temporaries": left,
        "running_after_2.5_s": late,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--delays", default="3,4.5,6", help="seconds, comma-separated")
    parser.add_argument("--tree", type=Path, action="append", help="a checkout (default: this)")
    parser.add_argument("--fresh-numba", action="store_true", help="an empty numba cache each")
    parser.add_argument("--group", action="store_true", help="SIGTERM the process group")
    parser.add_argument("--trace", action="store_true", help="with the recordings")
    args = parser.parse_args()
    for delay_s in (float(d) for d in args.delays.split(",")):
        for tree in args.tree or [REPO]:
            print(
                json.dumps(trial(tree, delay_s, args.fresh_numba, args.group, args.trace)),
                flush=True,
            )


if __name__ == "__main__":
    main()
