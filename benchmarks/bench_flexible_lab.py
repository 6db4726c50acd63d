"""The lab-ready flexible-joint law's cost per control step, against flexible-FL-I's.

Both laws close the single-arm loop (:func:`twolink.simulation.experiment.run_scenario`) on
the realistic joints with the model error, behind 17-bit encoders with the differenced rate
(``twolink.studies.judgments.flexible_limits``' cell), 3 s at 1 kHz; the time per control step of
each (best of the repeats, the two interleaved in one process) and their ratio. Absolute
times are noisy on shared machines, so the ratio is the claim.

    python benchmarks/bench_flexible_lab.py
"""

from __future__ import annotations

import time

from twolink.simulation.experiment import build_controller, run_scenario
from twolink.studies.judgments.flexible_limits import scenario

REPEATS = 7
LAWS = ("flexible_fl_integral", "flexible_fl_kalman")


def per_step(law: str) -> float:
    s = scenario(law, "realistic", "error", "17-bit, differenced")
    controller = build_controller(s)
    start = time.perf_counter()
    traj = run_scenario(s, controller)
    return (time.perf_counter() - start) / (len(traj.t) - 1)


def main() -> None:
    best = {law: float("inf") for law in LAWS}
    for _ in range(REPEATS):
        for law in LAWS:
            best[law] = min(best[law], per_step(law))
    for law in LAWS:
        print(f"{law:22s} {best[law] * 1e6:7.1f} µs per control step")
    ratio = best["flexible_fl_kalman"] / best["flexible_fl_integral"]
    print(f"flexible-FL-KF / flexible-FL-I: {ratio:.2f}x")


if __name__ == "__main__":
    main()
