"""Wall time of ``twolink reproduce`` on issue 17's scope and as shipped, beside a machine
yardstick timed in the same run.

The issue's scope is the reproduction as it was when the issue measured it (~28 s then):
CTC and FCM-CTC on every experiment of ``runs/paper/reproduce.toml``, on both variants,
with the stiffness x bandwidth map, the figures and the recordings, but without the
baselines, the claims sweep, the gain study and the calibration section that came later.
This script writes that manifest (absolute paths into ``runs/paper``) to a temporary
folder and runs the command in a subprocess, start-up included, each time into a fresh
output folder (so the design is computed, not reused).

The yardstick is the bare single-arm ``mj_step`` loop of ``bench_batch.py`` (ctrl set
each step), as the time of 10^6 steps in this process: this VM's speed varies from day
to day by up to 1.8x, so the times are also printed as multiples of it.

    python benchmarks/bench_reproduce.py              # issue scope, 3 runs
    python benchmarks/bench_reproduce.py --shipped    # the three shipped figures instead

``--shipped`` prints the three figures the main job is held to, in yardsticks, with the
load average beside each: ``twolink reproduce --no-trace``, the full regime map
(``twolink regimes``) and ``twolink regimes -n 30 --workers 2``; ``--repeats`` times each,
their median; ``--only 0,2`` picks figures. Limits on 2 cores: 6, 15 and 0.75 yardsticks.
Each is also given in CPU seconds over the yardstick's CPU seconds, which a loaded
machine disturbs less than wall time.
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_batch import bare_step_us  # this folder is on the path when run as a script

PAPER = Path(__file__).resolve().parents[1] / "runs" / "paper"
# What issue 17 measured: the paper's two controllers, no later studies.
LATER_KEYS = ("claims_study", "gain_study", "calibration", "proposed", "baseline")
SCOPE_CONTROLLERS = ("CTC", "FCM-CTC")


def scope_manifest(folder: Path) -> Path:
    """The shipped manifest cut to issue 17's scope, written into ``folder``."""
    text = (PAPER / "reproduce.toml").read_text()
    text = re.sub(rf"^({'|'.join(LATER_KEYS)}) = .*$", "", text, flags=re.M)
    lines, skip = [], False
    for line in text.splitlines():
        if line.startswith("["):
            name = line.strip().removeprefix("[controllers.").removesuffix("]")
            skip = line.startswith("[controllers.") and name not in SCOPE_CONTROLLERS
        if not skip:
            lines.append(line)
    # Paths are relative to the manifest: make them absolute into runs/paper.
    text = re.sub(
        r'"([^"]+\.toml)"', lambda m: f'"{(PAPER / m.group(1)).resolve()}"', "\n".join(lines)
    )
    path = folder / "scope.toml"
    path.write_text(text + "\n")
    return path


def yardstick() -> float:
    """Seconds for 10^6 bare single-arm ``mj_step`` calls: bench_batch's baseline (ctrl
    set each step), the median of 5 runs of 200,000 steps."""
    return bare_step_us(repeats=5, steps=200_000)  # µs per step = s per 10^6 steps


def timed(*args: str) -> float:
    """Wall seconds of ``twolink ARGS`` in a subprocess, start-up included."""
    command = [sys.executable, "-m", "twolink", *args]
    start = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def timed_cpu(*args: str) -> tuple[float, float]:
    """Wall and CPU seconds (every process of the command, sampled from /proc) of
    ``twolink ARGS``."""
    from profile_reproduce import run_profiled

    run = run_profiled([sys.executable, "-m", "twolink", *args], None)
    return run["end"] - run["start"], run["samples"][-1][1]


def reproduce(manifest: Path | None, out: Path) -> float:
    extra = ["--manifest", str(manifest)] if manifest is not None else []
    return timed("reproduce", "--out", str(out), *extra)


# The shipped figures: (label, the command's arguments after its output folder, limit).
SHIPPED = (
    ("reproduce --no-trace", ("reproduce", "--no-trace"), 6.0),
    ("regimes (the full map)", ("regimes",), 15.0),
    ("regimes -n 30 --workers 2", ("regimes", "-n", "30", "--workers", "2"), 0.75),
)


def load() -> str:
    return "load " + "/".join(f"{x:.1f}" for x in os.getloadavg())


def shipped(folder: Path, repeats: int, only: tuple[int, ...]) -> None:
    """The shipped figures (``only``: their indices), each in yardsticks timed just before
    and after it; wall and CPU (the CPU one against the yardstick's own CPU time, which
    other jobs on the machine disturb less)."""
    from profile_reproduce import yardstick as yardsticks

    print(
        f"{'command':<28} {'wall s':>7} {'yardsticks':>10} {'CPU s':>7} {'CPU yardsticks':>14}"
        "  limit (wall)"
    )
    for label, args, limit in (SHIPPED[i] for i in only):
        unit, took, loads = [yardsticks()], [], []
        for i in range(repeats):
            loads.append(load())
            out = folder / f"{args[0]}{len(took)}-{i}"
            took.append(timed_cpu(args[0], "--out", str(out), *args[1:]))
            unit.append(yardsticks())
        wall = statistics.median(t for t, _ in took)
        cpu = statistics.median(c for _, c in took)
        u_wall = statistics.median(u for u, _ in unit)
        u_cpu = statistics.median(c for _, c in unit)
        print(
            f"{label:<28} {wall:7.1f} {wall / u_wall:10.2f} {cpu:7.1f} {cpu / u_cpu:14.2f}"
            f"  {limit:g}  (yardstick {u_wall:.2f} s wall, {u_cpu:.2f} s CPU; {', '.join(loads)})"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument(
        "--shipped", action="store_true", help="the three shipped figures, in yardsticks"
    )
    parser.add_argument(
        "--only",
        default="0,1,2",
        help="--shipped: which (0 reproduce, 1 map, 2 -n 30)",
    )
    args = parser.parse_args()
    if args.shipped:
        with tempfile.TemporaryDirectory() as tmp:
            shipped(Path(tmp), args.repeats, tuple(int(i) for i in args.only.split(",")))
        return
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        manifest = scope_manifest(folder)
        before = yardstick()
        scope = [reproduce(manifest, folder / f"scope{i}") for i in range(args.repeats)]
        after = yardstick()
    unit = (before + after) / 2
    print(f"yardstick: 10^6 bare single-arm mj_steps {before:.2f} s before, {after:.2f} s after")
    print(
        "reproduce, issue scope: "
        + ", ".join(f"{t:.1f} s ({t / unit:.2f}x)" for t in scope)
        + " (target 10 s)"
    )


if __name__ == "__main__":
    main()
