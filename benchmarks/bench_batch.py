"""The batch engine's cost per arm-step, against a bare single-arm ``mj_step`` loop.

For N = 1, 10, 100, 1,000 and 10,000 arms (each with its own drawn masses, lengths,
gravity and payload, as in ``runs/sweeps/robustness.toml``) under CTC and FCM-CTC, the
time of :func:`twolink.simulation.batch.simulate_batch` per arm and control step, divided by the
time of one ``mj_step`` of a single arm called from Python with its torques set each
step (the baseline, measured in the same process just before). Then, with ``--sweep``,
the wall time of a whole in-process ``twolink sweep runs/sweeps/robustness.toml``
(start-up, drawing, measuring and writing included) per arm-step, against the same
baseline. A log-log figure of the scaling is written to ``docs/figures/batch_scaling.png``.

    python benchmarks/bench_batch.py             # the table and the figure
    python benchmarks/bench_batch.py --sweep     # and the in-process sweep
"""

from __future__ import annotations

import argparse
import math
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import mujoco
import numpy as np

from twolink.arm.plant import Plant
from twolink.simulation.batch import Arm, BatchPlant, simulate_batch
from twolink.simulation.config import load_scenario
from twolink.simulation.experiment import build_controller

ROOT = Path(__file__).resolve().parents[1]
SIZES = (1, 10, 100, 1000, 10000)
SCENARIOS = {"CTC": "runs/paper/theta1_step.toml", "FCM-CTC": "runs/theta1_step_fcm.toml"}
# The fuzzy term's other two engines (docs/fuzzy.md): the lookup table and the continuous
# inference, on the same scenario.
VARIANTS = {
    "FCM-CTC table": ("FCM-CTC", {"controller": {"fuzzy": {"engine": "table"}}}),
    "FCM-CTC continuous": ("FCM-CTC", {"controller": {"fuzzy": {"inference": "continuous"}}}),
}
ARM_STEPS = 400_000  # per measurement: enough to time, few enough for N = 10,000


def bare_step_us(repeats: int = 5, steps: int = 20_000) -> float:
    """One single-arm ``mj_step`` with its ctrl set, from Python [µs] (median)."""
    s = load_scenario(ROOT / SCENARIOS["CTC"])
    plant = Plant.build(s.plant_params, payload=0.1)
    model, data = plant.model, plant.data
    times = []
    for _ in range(repeats):
        plant.reset((0.3, 0.2))
        start = time.perf_counter()
        for _ in range(steps):
            data.ctrl[0] = 15.0
            data.ctrl[1] = 5.0
            mujoco.mj_step(model, data)
        times.append((time.perf_counter() - start) / steps * 1e6)
    return statistics.median(times)


def drawn_arms(n: int, rng: np.random.Generator, arm) -> list[Arm]:
    """Arms drawn as robustness.toml draws them (factors on the nominal arm)."""
    return [
        Arm(
            arm.scaled(
                m1=rng.uniform(0.7, 1.3),
                m2=rng.uniform(0.7, 1.3),
                l1=rng.uniform(0.9, 1.1),
                l2=rng.uniform(0.9, 1.1),
                g=float(np.clip(rng.normal(1.0, 0.02), 0.9, 1.1)),
            ),
            payload=rng.uniform(0.0, 0.2),
        )
        for _ in range(n)
    ]


def batch_step_us(n: int, controller_name: str) -> float:
    """Time of simulate_batch per arm and control step [µs]."""
    base, overrides = VARIANTS.get(controller_name, (controller_name, None))
    s = load_scenario(ROOT / SCENARIOS[base], overrides)
    steps = max(20, ARM_STEPS // n)
    plant = BatchPlant(drawn_arms(n, np.random.default_rng(n), s.arm), s.timestep)
    controller = build_controller(s)
    start = time.perf_counter()
    run = simulate_batch(plant, [controller] * n, [steps * s.control_dt] * n, s.control_dt)
    elapsed = time.perf_counter() - start
    assert all(st == "ok" for st in run.status), "a benchmark arm diverged"
    return elapsed / (n * (steps + 1)) * 1e6


def compile_kernels() -> None:
    """Compile (or load) the fuzzy kernels before timing (controllers/fuzzy/kernels.py)."""
    from twolink.controllers.fuzzy import kernels

    if kernels.available():
        for name in VARIANTS:
            batch_step_us(100, name)
        batch_step_us(100, "FCM-CTC")
    print(f"fuzzy kernels compiled (numba): {kernels.available()}\n")


def mujoco_step_us(n: int) -> float:
    """The floor: ``mj_step`` of the batch's model alone, per arm [µs]."""
    s = load_scenario(ROOT / SCENARIOS["CTC"])
    plant = BatchPlant(drawn_arms(n, np.random.default_rng(n), s.arm), s.timestep)
    plant.reset(np.full((n, 2), 0.3), np.zeros((n, 2)))
    steps = max(20, ARM_STEPS // n)
    start = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(plant.model, plant.data)
    return (time.perf_counter() - start) / (n * steps) * 1e6


def sweep_step_us(threads: int | None = None) -> tuple[float, int]:
    """Wall time of an in-process robustness sweep (a fresh process, start-up included)
    per arm-step [µs], and its arm-steps; ``threads``: its ``--workers`` (default: all
    cores)."""
    from twolink.simulation.config import scenario_from_dict
    from twolink.sweep import load_sweep

    plan = load_sweep(ROOT / "runs/sweeps/robustness.toml")
    values, seed = plan.draw(0)  # a sample's scenario: the sweep's overrides (duration) apply
    s = scenario_from_dict(plan.sample_data(values, seed), plan.file)
    arm_steps = plan.samples * len(plan.controller_names) * round(s.duration / s.control_dt)
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "twolink", "sweep", str(ROOT / "runs/sweeps/robustness.toml"),
             "--executor", "inprocess", "--out", tmp, "--no-plots", "--no-progress",
             *(["--workers", str(threads)] if threads else [])],
            check=True, capture_output=True,
        )  # fmt: skip
        wall = time.perf_counter() - start
    return wall / arm_steps * 1e6, arm_steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sweep", action="store_true", help="also time the in-process sweep")
    parser.add_argument(
        "--figure", type=Path, default=ROOT / "docs/figures/batch_scaling.png", help="PNG path"
    )
    parser.add_argument(
        "--sizes", type=int, nargs="+", default=list(SIZES), help="batch sizes N to time"
    )
    parser.add_argument(
        "--repeats",
        type=int,
        default=1,
        help="time every row this many times, interleaved, and keep the least (on a shared, "
        "loaded machine the least time is the one least disturbed)",
    )
    args = parser.parse_args()
    sizes = args.sizes

    bare = bare_step_us()
    print(f"baseline: bare single-arm mj_step loop {bare:.2f} µs per step\n")
    print(
        f"{'N':>7}  {'controller':<18}  {'µs/arm-step':>11}  {'/ bare':>6}  {'/ mj_step':>9}"
        "   (/ mj_step: over MuJoCo's own step of the same batch model, this run)"
    )
    names = ("mj_step alone", *SCENARIOS, *VARIANTS)
    results: dict[str, list[float]] = {name: [] for name in names}
    compile_kernels()
    for n in sizes:
        best = dict.fromkeys(results, math.inf)
        for _ in range(args.repeats):
            for name in results:
                us = mujoco_step_us(n) if name == "mj_step alone" else batch_step_us(n, name)
                best[name] = min(best[name], us)
        for name, us in best.items():
            results[name].append(us)
            own = us / best["mj_step alone"]
            print(f"{n:>7}  {name:<18}  {us:>11.2f}  {us / bare:>5.2f}x  {own:>8.2f}x", flush=True)
    if args.sweep:
        for threads, label in ((1, "one thread"), (None, "threads on all cores")):
            us, arm_steps = sweep_step_us(threads)
            print(
                f"\nin-process sweep runs/sweeps/robustness.toml, {label} ({arm_steps:,} "
                f"arm-steps, start-up included): {us:.2f} µs per arm-step, "
                f"{us / bare:.2f}x the bare loop"
            )

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4.2), layout="constrained")
    for name, values in results.items():
        style = ":" if name == "mj_step alone" else "-"
        ax.loglog(sizes, np.array(values) / bare, "o" + style, label=f"batch, {name}")
    ax.axhline(1.0, color="k", ls="--", lw=1, label="bare single-arm mj_step loop")
    ax.set_xlabel("arms in one batch (N)")
    ax.set_ylabel("time per arm-step / bare mj_step")
    ax.set_title(f"Batch engine scaling (bare loop {bare:.1f} µs per step)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    args.figure.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.figure, dpi=110)
    print(f"\nfigure: {args.figure}")


if __name__ == "__main__":
    main()
