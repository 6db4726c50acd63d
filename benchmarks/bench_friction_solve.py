"""What joint friction costs the batch engine's step: the lab arm's 40 drawn plants
stepped 2,000 times in one MuJoCo model, under the shipped friction solve, under other
solver settings, and without friction (the baseline). Each is timed ROUNDS times,
interleaved (one timing is noisy on a shared machine); prints the median µs per
arm-step, its range, and the median's ratio to the baseline's.

    python benchmarks/bench_friction_solve.py
"""

from __future__ import annotations

import dataclasses
import time

import mujoco
import numpy as np

import twolink.simulation.batch as batch
from twolink.simulation.config import scenario_from_dict
from twolink.simulation.experiment import _arm
from twolink.sweep.plan import load_sweep

ARMS, STEPS, ROUNDS = 40, 2000, 5


def step_cost(arms, model_g: float) -> float:
    """µs per arm-step of ``arms`` in one batch model, a fixed torque pattern applied."""
    m = batch.batch_model(arms, 0.001, model_g=model_g)
    d = mujoco.MjData(m)
    phase = np.arange(m.nv)
    start = time.perf_counter()
    for k in range(STEPS):
        d.qfrc_applied[:] = 3.0 * np.sin(0.01 * k + phase)
        mujoco.mj_step(m, d)
    return (time.perf_counter() - start) / (STEPS * len(arms)) * 1e6


def main() -> None:
    plan = load_sweep("runs/sweeps/lab.toml")
    arms = []
    for i in range(ARMS):
        values, seed = plan.draw(i)
        arms.append(_arm(scenario_from_dict(plan.sample_data(values, seed), "lab")))
    shipped = batch.solve_arms_apart

    def with_option(change):
        def solve(spec):
            shipped(spec)
            change(spec)

        return solve

    def warm(spec):
        spec.option.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_WARMSTART)

    def loose(spec):
        spec.option.tolerance = 1e-8

    settings = {
        "shipped (cold start, sparse, tolerance 1e-15)": shipped,
        "tolerance 1e-8": with_option(loose),
        "warm start": with_option(warm),
        "MuJoCo's defaults": lambda spec: None,
    }
    g = plan.model_gravity()
    bare = [dataclasses.replace(a, friction=None) for a in arms]
    costs: dict[str, list[float]] = {"no friction (baseline)": []} | {k: [] for k in settings}
    try:
        for _ in range(ROUNDS):
            batch.solve_arms_apart = shipped
            costs["no friction (baseline)"].append(step_cost(bare, g))
            for label, solve in settings.items():
                batch.solve_arms_apart = solve  # what batch_model calls to set the friction solve
                costs[label].append(step_cost(arms, g))
    finally:
        batch.solve_arms_apart = shipped
    base = float(np.median(costs["no friction (baseline)"]))
    for label, c in costs.items():
        med = float(np.median(c))
        print(
            f"{label}: {med:.2f} µs/arm-step (range {min(c):.2f}-{max(c):.2f}), "
            f"{med / base:.2f}x the baseline"
        )


if __name__ == "__main__":
    main()
