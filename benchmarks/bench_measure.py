"""What measuring a sweep's runs costs: the per-run path (``measure`` of each run, its
loop linearised alone) against a chunk's runs measured together (``measure_runs``: the
loops linearised on one batch model, ``linearise_many``; the fuzzy share through the
compiled kernel), in the same process on the same runs: a chunk simulated and measured
each way (one trajectory at a time, as a sweep's chunk; the measuring is the chunk's time
less the time spent making its trajectories), the simulation alone, and the
linearisations alone each way.

The runs are a chunk of the regime map's plan (``twolink regimes``: 4 controllers a
sample, g x 1.1, 4 s); ``--samples 15`` is the half chunk of a 30-sample plan (60 runs,
what ``run_chunk_part`` computes in ``regimes -n 30 --workers 2``), ``--samples 150`` a
whole chunk of the full map (600 runs). Every figure is a median over ``--repeats``, the tasks
interleaved (a machine whose load drifts slows them alike); the answers of both paths are
checked equal (σ and every metric) before timing. The yardstick: a bare single-arm
``mj_step`` (``bench_batch.bare_step_us``), timed before and after.

    python benchmarks/bench_measure.py [--samples 15 150] [--repeats 3]
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numba  # noqa: F401  (a sweep worker has it loaded: the batch laws use it)

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_batch  # noqa: E402

from twolink.simulation import experiment as ex
from twolink.simulation.stability import linearise
from twolink.simulation.stability_batch import linearise_many
from twolink.studies.judgments.regimes import DEFAULT_STUDY
from twolink.sweep import chunks, load_sweep


def timed(f, repeats: int) -> float:
    """Median wall time of ``f()`` [s]."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        f()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def numpy_share(engine, e, de):
    """The fuzzy share's engine call before: the engine's numpy path."""
    return engine(e, de)


def case(samples: int, repeats: int) -> dict[str, float]:
    plan = load_sweep(DEFAULT_STUDY, {"samples": max(30, samples)})
    _, arms = chunks._chunk_arms(plan, 0, range(samples))
    scenarios, controllers = [s for _, s, _ in arms], [c for _, _, c in arms]
    items = []  # what the linearisations start from: no trajectory is held

    def simulate():  # one trajectory at a time, as a chunk
        items.clear()
        for k, traj in ex.iter_scenarios(scenarios, controllers):
            items.append((scenarios[k], controllers[k], ex.rest_guess(traj)))

    clock = {"simulating": 0.0, "measuring": 0.0}  # of the last chunk computed

    def _runs():  # the chunk's trajectories, the time spent making them counted apart
        runs = ex.iter_scenarios(scenarios, controllers)
        while True:
            start = time.perf_counter()
            try:
                run = next(runs)
            except StopIteration:
                return
            finally:
                clock["simulating"] += time.perf_counter() - start
            yield run

    def per_run():  # the chunk before: each run measured alone as it comes
        original = ex._fuzzy_output
        ex._fuzzy_output = numpy_share
        clock["simulating"] = 0.0
        start = time.perf_counter()
        try:
            return [ex.measure(scenarios[k], t, controllers[k]) for k, t in _runs()]
        finally:
            ex._fuzzy_output = original
            clock["measuring"] = time.perf_counter() - start - clock["simulating"]

    def together():  # the chunk now
        clock["simulating"] = 0.0
        start = time.perf_counter()
        out = ex.measure_runs((scenarios[k], t, controllers[k]) for k, t in _runs())
        clock["measuring"] = time.perf_counter() - start - clock["simulating"]
        return out

    simulate()  # warm: numba's kernels, MuJoCo
    old, new = per_run(), together()
    assert all(repr(a) == repr(b) for a, b in zip(old, new, strict=True)), "answers differ"
    n = len(arms)
    tasks = {
        "simulate": simulate,
        "simulate + measure each alone": per_run,
        "simulate + measure_runs": together,
        "linearise, each alone": lambda: [
            linearise(s, ex.build_plant(s), c, near=nr) for s, c, nr in items
        ],
        "linearise_many": lambda: linearise_many(items),
    }
    times: dict[str, list[float]] = {name: [] for name in tasks}
    times["measuring alone"], times["measuring together"] = [], []
    for _ in range(repeats):  # interleaved: a machine whose load drifts slows all alike
        for name, task in tasks.items():
            times[name].append(timed(task, 1))
            if task is per_run:
                times["measuring alone"].append(clock["measuring"])
            if task is together:
                times["measuring together"].append(clock["measuring"])
    out: dict[str, float] = {"runs": n}
    out.update({name: statistics.median(ts) / n for name, ts in times.items()})
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, nargs="+", default=[15, 150])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    print("| ms per run | " + " | ".join(f"{s} samples" for s in args.samples) + " |")
    print("|---|" + "---:|" * len(args.samples))
    before = bench_batch.bare_step_us()
    results = [case(s, args.repeats) for s in args.samples]
    step_us = 0.5 * (before + bench_batch.bare_step_us())
    keys = [k for k in results[0] if k != "runs"]
    print("| runs | " + " | ".join(str(r["runs"]) for r in results) + " |")
    for key in keys:
        print(f"| {key} | " + " | ".join(f"{1e3 * r[key]:.3f}" for r in results) + " |")
    ratio = [r["measuring alone"] / r["measuring together"] for r in results]
    lin = [r["linearise, each alone"] / r["linearise_many"] for r in results]
    print("| measuring, alone / together | " + " | ".join(f"{x:.1f}x" for x in ratio) + " |")
    print("| linearising, alone / together | " + " | ".join(f"{x:.1f}x" for x in lin) + " |")
    print(
        "| measuring together, in bare single-arm mj_step calls | "
        + " | ".join(f"{1e6 * r['measuring together'] / step_us:.0f}" for r in results)
        + " |"
    )
    print(f"\nyardstick: a bare single-arm mj_step {step_us:.2f} µs (before and after, mean)")
    if any(math.isnan(x) for x in ratio):
        raise SystemExit("no timing")


if __name__ == "__main__":
    main()
