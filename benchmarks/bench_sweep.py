"""A CTC vs FCM-CTC robustness sweep on all cores: wall time, and the cost per run as a ratio.

The sweep is ``runs/sweeps/robustness.toml`` (4 s at 1 kHz per run, four controllers per
sample; ``--issue-workload``: 10 s, CTC and FCM-CTC) with N samples. The per-run cost of
the sweep is

    wall time x workers / (samples x controllers)

and the baseline is one closed-loop run of the same length in this process (the median
over repeats of each controller on the nominal arm, averaged over the controllers). Their
ratio is what the sweep machinery costs on top of the simulations themselves: worker
start-up, drawing, model building, measuring, pickling and writing the chunks.
Target: <= 1.3x. Absolute times are noisy on shared machines; the ratio is the claim.

Runs side by side on all cores are slower than one run alone on an idle machine (shared
caches, SMT siblings, turbo limits, other tenants), and that is not the sweep's doing; so
the script also times the same single runs in ``workers`` bare processes at once (no sweep
code) and prints the ratio against that parallel baseline too.

    python benchmarks/bench_sweep.py            # N = 100, a quick check
    python benchmarks/bench_sweep.py --n 1000   # the full figure
    python benchmarks/bench_sweep.py --n 1000 --issue-workload --chunk-size 250

``--issue-workload`` runs the sweep as issue 17 measured it (152.9 s with the single-arm
loop): CTC and FCM-CTC only, 10 s runs (a copy of the file in a temporary folder).
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import statistics
import tempfile
import time
import tomllib
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from twolink.foundation.io import to_toml
from twolink.simulation.config import scenario_from_dict
from twolink.simulation.experiment import build_controller, build_plant, run_scenario
from twolink.sweep import format_summary, load_sweep, run_sweep, save_sweep_plots

SWEEP = Path(__file__).resolve().parents[1] / "runs" / "sweeps" / "robustness.toml"
REPEATS = 3
PARALLEL_REPEATS = 5  # long enough that the processes' start-ups do not matter


def single_run_seconds(plan, repeats: int = REPEATS) -> dict[str, float]:
    """Median time of one closed-loop run per controller, nominal arm, in this process."""
    out = {}
    for name in plan.controller_names:
        s = scenario_from_dict(plan.controller_data(name), plan.file)
        controller, plant = build_controller(s), build_plant(s)
        run_scenario(s, controller, plant)  # warm-up: lazy imports, caches
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            traj = run_scenario(s, controller, plant)
            times.append(time.perf_counter() - start)
            assert traj.ok, traj.message
        out[name] = statistics.median(times)
    return out


def issue_workload(folder: Path) -> Path:
    """The sweep file as issue 17 measured it: CTC and FCM-CTC only, 10 s runs."""
    data = tomllib.loads(SWEEP.read_text())
    data["scenario"] = str((SWEEP.parent / data["scenario"]).resolve())
    data["overrides"]["duration"] = 10.0
    data["controllers"] = {k: data["controllers"][k] for k in ("CTC", "FCM-CTC")}
    path = folder / "issue17.toml"
    path.write_text(to_toml(data))
    return path


def _single_in_worker(sweep: Path, over: dict) -> dict[str, float]:
    return single_run_seconds(load_sweep(sweep, over), PARALLEL_REPEATS)


def parallel_single_run_seconds(sweep: Path, over: dict, workers: int) -> float:
    """One run's time when ``workers`` bare processes run them side by side (mean)."""
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(workers, mp_context=ctx) as ex:
        results = list(ex.map(_single_in_worker, [sweep] * workers, [over] * workers))
    return statistics.mean(t for r in results for t in r.values())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=100, help="samples (default 100)")
    parser.add_argument("--workers", type=int, default=None, help="default: all cores")
    parser.add_argument("--executor", default="process", choices=("process", "dask"))
    parser.add_argument("--chunk-size", type=int, default=None, help="default: the file's")
    parser.add_argument("--out", type=Path, default=None, help="keep the results here")
    parser.add_argument(
        "--issue-workload", action="store_true", help="CTC and FCM-CTC only, 10 s runs"
    )
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        sweep = issue_workload(Path(tmp)) if args.issue_workload else SWEEP
        measure_sweep(args, sweep, Path(tmp) / "sweep")


def measure_sweep(args: argparse.Namespace, sweep: Path, out: Path) -> None:
    """Time the sweep ``sweep`` into ``args.out`` (else ``out``) and print the figures."""
    over: dict = {"samples": args.n}
    if args.chunk_size:
        over["chunk_size"] = args.chunk_size
    plan = load_sweep(sweep, over)
    base = plan.base
    print(
        f"sweep {SWEEP.name}{' (issue 17 workload)' if args.issue_workload else ''}: "
        f"N = {plan.samples}, controllers {list(plan.controller_names)}, "
        f"{base['duration']:g} s at {1 / base['control_dt']:g} Hz per run, "
        f"chunks of {plan.chunk_size}, {os.cpu_count()} cores"
    )
    before = single_run_seconds(plan)

    out = args.out or out
    outcome = run_sweep(
        plan,
        out,
        executor=args.executor,
        workers=args.workers,
        progress=True,
        plots=False,
        fresh=True,
    )
    start = time.perf_counter()
    save_sweep_plots(out, outcome.results)
    plots_s = time.perf_counter() - start

    # Timed before and after the sweep: the machine's speed drifts (shared hosts).
    after = single_run_seconds(plan)
    single = {name: (before[name] + after[name]) / 2 for name in before}
    baseline = statistics.mean(single.values())
    runs = plan.samples * len(plan.controllers)
    per_run = outcome.wall_s * outcome.workers / runs
    print(format_summary(outcome.summary))
    for name in plan.controller_names:
        print(
            f"one closed-loop run in this process, {name:8s}: {single[name] * 1e3:7.1f} ms "
            f"(before {before[name] * 1e3:.1f}, after {after[name] * 1e3:.1f})"
        )
    print(f"sweep wall time, {outcome.workers} {args.executor} workers: {outcome.wall_s:.1f} s")
    print(f"  (plots afterwards: {plots_s:.1f} s, not counted)")
    print(f"per-run cost = wall x workers / (samples x controllers) = {per_run * 1e3:.1f} ms")
    print(f"single closed-loop run (mean over controllers):           {baseline * 1e3:.1f} ms")
    print(f"ratio per-run cost / single run: {per_run / baseline:.2f}x (target <= 1.3x)")
    # Where a ratio above 1 comes from: inside the workers (parallel slowdown, other load)
    # or outside them (start-up, scheduling, the last chunks' tail).
    print(
        f"  inside the workers: {outcome.busy_s / runs * 1e3:.1f} ms per run "
        f"({outcome.busy_s / runs / baseline:.2f}x); worker utilisation "
        f"{outcome.busy_s / (outcome.wall_s * outcome.workers):.1%}"
    )
    side_by_side = parallel_single_run_seconds(sweep, over, outcome.workers)
    print(
        f"single run with {outcome.workers} bare processes side by side: "
        f"{side_by_side * 1e3:.1f} ms ({side_by_side / baseline:.2f}x the lone run)"
    )
    print(f"ratio per-run cost / side-by-side run: {per_run / side_by_side:.2f}x")


if __name__ == "__main__":
    main()
