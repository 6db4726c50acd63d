"""The batch engine's cost per arm-step of the field's laws, against CTC's in the same run.

For N arms (default 1, 100 and 1,000; each with its own drawn plant, as in
``runs/sweeps/robustness.toml``) on the claims' quintic move, the time of
:func:`twolink.simulation.batch.simulate_batch` per arm and control step under each law,
divided by CTC's time measured in the same process (MuJoCo's step included in both).
Ratios, not seconds: the machine's speed cancels.

    python benchmarks/bench_field_laws.py             # N = 1, 100, 1000
    python benchmarks/bench_field_laws.py --arms 1000
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
from bench_batch import drawn_arms  # the robustness sweep's plants, as that benchmark's

from twolink.simulation.batch import BatchPlant, simulate_batch
from twolink.simulation.config import load_scenario
from twolink.simulation.experiment import build_controller

ROOT = Path(__file__).resolve().parents[1]
LAWS = {"CTC": "ctc", "CTC-I": "ctc_integral", "ACTC": "adaptive_ctc"}
LAWS.update({"SMC": "sliding_mode", "CTC-DOB": "ctc_dob"})
QUINTIC = {
    "reference": {
        "joint1": {"kind": "quintic", "final": 1.0, "duration": 2.0},
        "joint2": {"kind": "quintic", "final": 0.5, "duration": 2.0},
    }
}
ARM_STEPS = 40_000  # per measurement


def step_us(n: int, kind: str) -> float:
    """simulate_batch's time per arm and control step [µs] under ``kind``."""
    s = load_scenario(ROOT / "runs/paper/base.toml", {**QUINTIC, "controller": {"kind": kind}})
    steps = max(50, ARM_STEPS // n)
    plant = BatchPlant(drawn_arms(n, np.random.default_rng(n), s.arm), s.timestep)
    controllers = [build_controller(s) for _ in range(n)]
    start = time.perf_counter()
    run = simulate_batch(plant, controllers, [steps * s.control_dt] * n, s.control_dt)
    elapsed = time.perf_counter() - start
    assert all(st == "ok" for st in run.status), f"a benchmark arm diverged under {kind}"
    return elapsed / (n * (steps + 1)) * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arms", type=int, nargs="*", default=[1, 100, 1000])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    names = list(LAWS)
    print("cost per arm-step against CTC's (median of", args.repeats, "runs, interleaved)")
    print(f"{'arms':>6} {'CTC µs':>8} " + " ".join(f"{n:>8}" for n in names[1:]))
    for n in args.arms:
        times = {name: [] for name in names}
        for _ in range(args.repeats):  # interleaved, so drifts of the machine hit every law
            for name in names:
                times[name].append(step_us(n, LAWS[name]))
        ctc = statistics.median(times["CTC"])
        ratios = [statistics.median(times[name]) / ctc for name in names[1:]]
        print(f"{n:>6} {ctc:>8.2f} " + " ".join(f"{r:>8.2f}" for r in ratios), flush=True)


if __name__ == "__main__":
    main()
