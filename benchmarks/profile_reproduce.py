"""Where ``twolink reproduce`` spends its time: a profile, phase by phase.

Runs the shipped reproduction once in a subprocess (``--no-trace``, a fresh output
folder), with the step log on (:mod:`twolink.foundation.steplog`), and prints:

- per phase ("[2/4] +7.8 s runs: ..." on stderr): its wall time and share, the CPU the
  command's processes used over it as a share of wall x cores, and its serial share (the
  share of its wall time in which they kept at most one core busy);
- the arm-steps (one arm advanced one physics step) per phase and per regime, counted from
  the step log, not timed: the same on any machine;
- the arm-steps computed more than once: arms whose records (states and torques, bit for
  bit) another arm of the reproduction already computed;
- the single-arm runs (outside the batch engine) that a batch could carry.

The CPU is sampled from /proc every 0.2 s (Linux); other jobs on the machine lower it, so
the load average is printed beside it.

    python benchmarks/profile_reproduce.py                  # the shipped manifest
    python benchmarks/profile_reproduce.py --json prof.json # and the numbers as JSON
    python benchmarks/profile_reproduce.py --log FOLDER     # an existing step log only
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter, defaultdict
from pathlib import Path

PHASE = re.compile(rb"\[(\d+)/(\d+)\] \+[\d.]+ s (\w+)")
TICK = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


def _tree_cpu(root: int) -> tuple[dict[int, float], int]:
    """CPU seconds (user + system) of ``root`` and its descendants, by pid, and how many
    of them are runnable now (state R: running, or waiting for a core)."""
    parents: dict[int, int] = {}
    cpu: dict[int, float] = {}
    running: set[int] = set()
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat", "rb") as f:
                fields = f.read().rsplit(b")", 1)[1].split()
        except OSError:
            continue
        parents[int(entry)] = int(fields[1])
        cpu[int(entry)] = (int(fields[11]) + int(fields[12])) / TICK
        if fields[0] == b"R":
            running.add(int(entry))
    mine, frontier = {root}, [root]
    while frontier:
        p = frontier.pop()
        kids = [c for c, pp in parents.items() if pp == p and c not in mine]
        mine.update(kids)
        frontier += kids
    return {p: cpu[p] for p in mine if p in cpu}, len(mine & running)


def run_profiled(command: list[str], log: Path | None, period: float = 0.2) -> dict:
    """Run ``command`` with the step log into ``log`` (None: none); its phases' start
    times, the CPU samples (time, CPU seconds so far, processes runnable), its wall time."""
    env = dict(os.environ, **({"TWOLINK_STEP_LOG": str(log)} if log is not None else {}))
    start = time.time()
    proc = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    phases: list[tuple[float, str]] = []

    def read() -> None:  # each phase line as it arrives, with its time
        text, found = b"", set()
        while chunk := proc.stderr.read1(4096):  # type: ignore[union-attr]
            text += chunk
            for m in PHASE.finditer(text, max(0, len(text) - len(chunk) - 200)):
                if m.start() not in found:
                    found.add(m.start())
                    phases.append((time.time(), m.group(3).decode()))

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    seen: dict[int, float] = {}
    samples = [(start, 0.0, 1)]
    while proc.poll() is None:
        time.sleep(period)
        cpu, running = _tree_cpu(proc.pid)
        seen.update(cpu)
        samples.append((time.time(), sum(seen.values()), running))
    end = time.time()
    reader.join(timeout=5)
    if proc.returncode:
        sys.exit(f"{' '.join(command)}: exit status {proc.returncode}")
    return {"start": start, "end": end, "phases": phases, "samples": samples}


def read_log(log: Path) -> list[dict]:
    """Every engine call of a step log folder, by start time."""
    lines = []
    for path in sorted(log.glob("steps-*.jsonl")):
        lines += [json.loads(line) for line in path.read_text().splitlines() if line]
    return sorted(lines, key=lambda r: r["start"])


def regime(record: dict, sweeps: dict[str, str]) -> str:
    """What an engine call computed: a sweep's folder, or the function that asked; "(links
    that bend)" after it where the arms' links bend (a dearer arm-step: docs/flexible_links.md)."""
    label = _regime(record, sweeps)
    return label + " (links that bend)" if record.get("engine") == "links" else label


def _regime(record: dict, sweeps: dict[str, str]) -> str:
    if record["sweep"]:
        name, digest = record["sweep"].split(":")
        return sweeps.get(digest, f"sweep {name}")
    callers = " ".join(record["callers"])
    for key, label in (
        ("reproduce._execute", "paper runs (metrics.csv)"),
        ("designs.design", "design"),
        ("designs.calibration", "calibration rerun"),
        ("designs.gains", "gain study"),
        ("designs.frontier", "frontier / fair opponent"),
        ("designs.matching", "frontier / fair opponent"),
        ("designs.search", "search (strongest table)"),
        ("figures.hunting", "hunting figure"),
    ):
        if key in callers:
            return label
    generic = ("twolink.simulation.", "twolink.foundation.", "twolink.studies.reproduction.quiet")
    named = [c for c in record["callers"] if not c.startswith(generic)]
    return named[-1] if named else "?"


def sweep_folders(out: Path) -> dict[str, str]:
    """Each sweep folder of a reproduction by its plan's digest (first 12 digits)."""
    found = {}
    for manifest in out.glob("*/manifest.json"):
        try:
            digest = json.loads(manifest.read_text())["digest"]
        except (ValueError, KeyError, OSError):
            continue
        found[str(digest)[:12]] = manifest.parent.name + "/"
    return found


def profile(records: list[dict], run: dict | None, sweeps: dict[str, str], cores: int) -> dict:
    """The numbers this script prints, as a dict."""
    bounds: list[tuple[str, float, float]] = []
    if run is not None:
        marks = [(run["start"], "start-up"), *[(t, n) for t, n in run["phases"]]]
        ends = [t for t, _ in marks[1:]] + [run["end"]]
        bounds = [(n, t, e) for (t, n), e in zip(marks, ends, strict=True)]

    def phase_of(t: float) -> str:
        for name, a, b in bounds:
            if a <= t < b:
                return name
        return "?" if bounds else "all"

    phases: dict[str, dict] = {}
    for name, a, b in bounds:
        pts = [x for x in run["samples"] if a - 0.2 <= x[0] <= b + 0.2]  # type: ignore[index]
        cpu = pts[-1][1] - pts[0][1] if len(pts) > 1 else 0.0
        span = max(pts[-1][0] - pts[0][0], 1e-9) if len(pts) > 1 else max(b - a, 1e-9)
        runnable = [x[2] for x in pts[1:]] or [1]
        phases[name] = {
            "wall_s": b - a,
            "cpu_s": cpu,
            "cpu_share": cpu / (span * cores),
            # load-independent: how many of the command's processes wanted a core
            "serial_share": sum(n <= 1 for n in runnable) / len(runnable),
            "runnable_mean": sum(runnable) / len(runnable),
            "arm_steps": 0,
        }
    by_regime: dict[str, dict] = defaultdict(
        lambda: {"arm_steps": 0, "useful": 0, "calls": 0, "engine_s": 0.0}
    )
    digests: Counter = Counter()
    first: dict[str, str] = {}  # digest -> the regime that computed it first
    twice: Counter = Counter()  # (first regime, again in) -> arms
    repeated_steps = 0
    single = {"runs": 0, "arm_steps": 0}
    for r in records:
        where = phase_of(r["end"])
        phases.setdefault(where, {"arm_steps": 0})["arm_steps"] += r["arm_steps"]
        label = regime(r, sweeps)
        reg = by_regime[label]
        reg["arm_steps"] += r["arm_steps"]
        reg["useful"] += r["useful_arm_steps"]
        reg["calls"] += 1
        reg["engine_s"] += r["end"] - r["start"]
        per_arm = r["useful_arm_steps"] / max(r["arms"], 1)
        for d in r["digests"]:
            if digests[d]:
                repeated_steps += per_arm
                twice[f"{first[d]} -> {label}"] += 1
            else:
                first[d] = label
            digests[d] += 1
        if r["engine"] == "single":
            single["runs"] += 1
            single["arm_steps"] += r["arm_steps"]
    total = sum(r["arm_steps"] for r in records)
    return {
        "wall_s": (run["end"] - run["start"]) if run else None,
        "cores": cores,
        "phases": phases,
        "regimes": dict(by_regime),
        "arm_steps": total,
        "arms": sum(digests.values()),
        "arms_repeated": sum(n - 1 for n in digests.values() if n > 1),
        "arm_steps_repeated": round(repeated_steps),
        "repeated_where": dict(twice),
        "single_arm": single,
    }


def print_profile(p: dict, load: str) -> None:
    mega = 1e6
    if p["wall_s"] is not None:
        print(f"reproduce --no-trace: {p['wall_s']:.1f} s wall on {p['cores']} cores ({load})")
    print(f"{'phase':<10} {'wall s':>7} {'share':>6} {'cpu s':>6} {'cpu/(wall*cores)':>17}"
          f" {'serial':>7} {'runnable':>9} {'Marm-steps':>11}")  # fmt: skip
    wall = p["wall_s"] or 1.0
    for name, ph in p["phases"].items():
        if "wall_s" in ph:
            print(
                f"{name:<10} {ph['wall_s']:7.1f} {ph['wall_s'] / wall:6.1%} {ph['cpu_s']:6.1f} "
                f"{ph['cpu_share']:17.0%} {ph['serial_share']:7.0%} {ph['runnable_mean']:9.2f} "
                f"{ph['arm_steps'] / mega:11.1f}"
            )
        else:
            blank = f"{'':>7} {'':>6} {'':>6} {'':>17} {'':>7} {'':>9}"
            print(f"{name:<10} {blank} {ph['arm_steps'] / mega:11.1f}")
    head = f"{'calls':>6} {'Marm-steps':>11} {'of them useful':>15} {'engine s':>9}"
    print(f"\n{'regime':<34} {head}")
    for name, reg in sorted(p["regimes"].items(), key=lambda kv: -kv[1]["arm_steps"]):
        print(
            f"{name:<34} {reg['calls']:6d} {reg['arm_steps'] / mega:11.1f} "
            f"{reg['useful'] / mega:15.1f} {reg['engine_s']:9.1f}"
        )
    print(
        f"\ntotal: {p['arm_steps'] / mega:.1f} M arm-steps over {p['arms']} arms; "
        f"computed more than once: {p['arms_repeated']} arms, "
        f"{p['arm_steps_repeated'] / mega:.1f} M arm-steps "
        f"({p['arm_steps_repeated'] / max(p['arm_steps'], 1):.1%})"
    )
    for where, n in p["repeated_where"].items():
        print(f"  {n} arms: {where}")
    s = p["single_arm"]
    print(
        f"single-arm runs outside the batch engine: {s['runs']} "
        f"({s['arm_steps'] / mega:.2f} M arm-steps)"
    )


def yardstick() -> tuple[float, float]:
    """10^6 bare single-arm ``mj_step`` calls: (wall s, CPU s of this process), the
    median of 5 runs of 200,000 steps (bench_batch's loop)."""
    from bench_batch import bare_step_us  # this folder is on the path when run as a script

    cpu = time.process_time()
    wall = bare_step_us(repeats=5, steps=200_000)
    return wall, (time.process_time() - cpu) / 5 / 0.2


def load_average() -> str:
    return "load " + " ".join(f"{x:.2f}" for x in os.getloadavg())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--manifest", help="a reproduction manifest (default: the shipped one)")
    parser.add_argument("--log", type=Path, help="profile an existing step log folder only")
    parser.add_argument("--out", type=Path, help="the reproduction's folder (default: temporary)")
    parser.add_argument("--json", type=Path, help="write the numbers here too")
    args = parser.parse_args()
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    if args.log is not None:
        sweeps = sweep_folders(args.out) if args.out else {}
        p = profile(read_log(args.log), None, sweeps, cores or 1)
        print_profile(p, load_average())
        return
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp) / "reproduce"
        log = Path(tmp) / "steps"
        log.mkdir()
        command = [sys.executable, "-m", "twolink", "reproduce", "--no-trace", "--out", str(out)]
        if args.manifest:
            command += ["--manifest", args.manifest]
        before = load_average()
        unit = [yardstick()]
        run = run_profiled(command, log)
        unit.append(yardstick())
        load = f"{before} before, {load_average()} after"
        p = profile(read_log(log), run, sweep_folders(out), cores or 1)
        if args.out is not None:  # kept beside the reproduction
            shutil.copytree(log, args.out.with_name(args.out.name + "-steps"), dirs_exist_ok=True)
    p["load"] = load
    p["yardstick_wall_s"], p["yardstick_cpu_s"] = (sorted(x) for x in zip(*unit, strict=True))
    print_profile(p, load)
    wall, cpu = p["yardstick_wall_s"], p["yardstick_cpu_s"]
    total_cpu = sum(ph.get("cpu_s", 0.0) for ph in p["phases"].values())
    print(
        f"yardstick (10^6 bare mj_steps): {wall[0]:.2f}-{wall[1]:.2f} s wall, "
        f"{cpu[0]:.2f}-{cpu[1]:.2f} s CPU; the reproduction: {p['wall_s'] / max(wall):.2f}-"
        f"{p['wall_s'] / min(wall):.2f} yardsticks wall, {total_cpu:.1f} s CPU = "
        f"{total_cpu / max(cpu):.1f}-{total_cpu / min(cpu):.1f} CPU yardsticks"
    )
    if args.json:
        args.json.write_text(json.dumps(p, indent=1) + "\n")


if __name__ == "__main__":
    main()
