"""Ctrl-C a reproduction at random moments and count how each one ends.

    python benchmarks/ctrl_c_probe.py [-n 80] [--tree PATH ...]

Each trial starts ``python -m twolink reproduce --no-trace`` into a fresh folder, sends
SIGINT after a random 0.3-3 s (the same moments for every tree, from a fixed seed), and
classifies the ending: "ok" is exit 130 with the one-line message and no traceback.
Several ``--tree`` (checkouts, e.g. ``git archive <commit> | tar -x -C DIR``) are run
alternately, so they share the machine's load. Loading the cores makes the rare endings
commoner (docs/sweeps.md: three ``python -c "while True: pass"`` on two cores).
"""

from __future__ import annotations

import argparse
import collections
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def trial(tree: Path, delay_s: float) -> str:
    """How one Ctrl-C after ``delay_s`` ended a reproduction run from ``tree``."""
    with tempfile.TemporaryDirectory() as tmp:
        proc = subprocess.Popen(
            [sys.executable, "-m", "twolink", "reproduce", "--out", f"{tmp}/r", "--no-trace"],
            cwd=tree,  # `python -m` imports twolink from here
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
        )
        time.sleep(delay_s)
        if proc.poll() is not None:
            return "ended before the Ctrl-C"
        proc.send_signal(signal.SIGINT)
        try:
            _, err = proc.communicate(timeout=90)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
            return "still running 90 s later"
    clean = "interrupted" in err and "Traceback" not in err and "Exception ignored" not in err
    if proc.returncode == 130:
        return "ok" if clean else "130 with a traceback"
    if proc.returncode == -signal.SIGINT:
        return "died by SIGINT"
    if proc.returncode == 0:
        return "Ctrl-C lost (ran to the end)"
    return f"exit {proc.returncode}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", type=int, default=80, help="trials per tree")
    parser.add_argument("--tree", type=Path, action="append", help="a checkout (default: this)")
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()
    trees = args.tree or [REPO]
    rng = random.Random(args.seed)
    counts = {tree: collections.Counter() for tree in trees}
    for i in range(args.n):
        delay_s = rng.uniform(0.3, 3.0)
        for tree in trees:
            outcome = trial(tree, delay_s)
            counts[tree][outcome] += 1
            if outcome != "ok":
                print(f"trial {i}: {tree}: {outcome} after {delay_s:.2f} s", flush=True)
    for tree, c in counts.items():
        print(f"{tree}: " + ", ".join(f"{k} {v}" for k, v in c.most_common()))


if __name__ == "__main__":
    main()
