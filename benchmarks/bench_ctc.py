"""CTC closed loop vs a bare mj_step loop: the cost of control, as a ratio.

Both loops run 10 s of simulated time at 1 kHz on the same model in the same process;
the baseline steps MuJoCo with constant torques and does nothing else. Absolute times
are noisy on shared machines, so only the ratio (best of several repeats) is claimed.
Target: <= 3x.

    python benchmarks/bench_ctc.py
"""

from __future__ import annotations

import math
import time

import mujoco

from twolink.arm.params import ArmParams
from twolink.arm.plant import Plant
from twolink.controllers.ctc import ComputedTorque
from twolink.foundation.references import ArmReference, Step
from twolink.simulation.sim import simulate

DURATION, DT, REPEATS = 10.0, 1e-3, 5


def bare_loop(plant: Plant) -> float:
    model, data = plant.model, plant.data
    plant.reset()
    data.ctrl[:] = (1.0, 0.5)
    start = time.perf_counter()
    for _ in range(round(DURATION / DT)):
        mujoco.mj_step(model, data)
    return time.perf_counter() - start


def closed_loop(plant: Plant, controller) -> float:
    start = time.perf_counter()
    traj = simulate(plant, controller, DURATION, control_dt=DT)
    elapsed = time.perf_counter() - start
    assert traj.ok, traj.message
    return elapsed


def main() -> None:
    p = ArmParams()
    plant = Plant.build(p, timestep=DT)
    ctc = ComputedTorque(
        p, ArmReference(Step(0.0, 1.0), Step(0.0, 0.5)), kp=4.0, kd=2.4, torque_limit=math.inf
    )
    bare = min(bare_loop(plant) for _ in range(REPEATS))
    loop = min(closed_loop(plant, ctc) for _ in range(REPEATS))
    print(f"bare mj_step loop, {DURATION:g} s at 1 kHz: {bare * 1e3:7.1f} ms")
    print(f"CTC closed loop (simulate):        {loop * 1e3:7.1f} ms")
    print(f"ratio CTC / bare: {loop / bare:.2f}x (target <= 3x)")


if __name__ == "__main__":
    main()
