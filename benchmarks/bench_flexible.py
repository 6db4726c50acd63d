"""The flexible-joint controllers' cost per step, as a ratio to a bare ``mj_step``.

Single-arm path: each controller closes the loop (:func:`twolink.simulation.sim.simulate`, 10 s at
1 kHz) on the flexible-joint arm, and its time per control step is divided by the time
of a bare ``mj_step`` loop on the same model in the same process (constant torques,
nothing else). Rigid CTC on the same arm is the reference row. Batch path: the same laws
on the batch engine (:func:`twolink.simulation.batch.simulate_batch`), N arms with their own
stiffness, time per arm and step over the same bare single-arm step. Absolute times are
noisy on shared machines, so only ratios (best of several repeats) are claimed.

The arm: K = 500 N m/rad, D = 2 N m s/rad (rigid CTC needs D above about J Kd to be
stable; docs/control.md), J = 0.05 kg m^2; ωn = 10 rad/s; a septic 1 rad move in 2 s.

    python benchmarks/bench_flexible.py
"""

from __future__ import annotations

import math
import time

import mujoco
import numpy as np

from twolink.arm.params import ArmParams, Flexibility
from twolink.arm.plant import Plant
from twolink.controllers.ctc import ComputedTorque
from twolink.controllers.flexible import CompositeControl, FlexibleFeedbackLinearisation, MotorPD
from twolink.foundation.references import ArmReference, Septic
from twolink.simulation.batch import Arm, BatchPlant, simulate_batch
from twolink.simulation.sim import simulate

DURATION, DT, REPEATS = 10.0, 1e-3, 5
KP, KD = 100.0, 20.0
BATCH_SIZES = (1, 100, 1000)
BATCH_DURATION = 1.0
LAWS = {
    "ctc (rigid law)": lambda p, ref, f: ComputedTorque(p, ref, KP, KD, torque_limit=math.inf),
    "motor_pd": lambda p, ref, f: MotorPD(p, ref, KP, KD, joints=f, torque_limit=math.inf),
    "composite": lambda p, ref, f: CompositeControl(
        p, ref, KP, KD, joints=f, torque_limit=math.inf
    ),
    "flexible_fl": lambda p, ref, f: FlexibleFeedbackLinearisation(
        p, ref, KP, KD, joints=f, torque_limit=math.inf
    ),
}


def bare_loop(plant: Plant) -> float:
    """Seconds per bare ``mj_step`` (best of the repeats)."""
    model, data = plant.model, plant.data
    steps = round(DURATION / DT)
    best = np.inf
    for _ in range(REPEATS):
        plant.reset()
        data.ctrl[:] = (1.0, 0.5)
        start = time.perf_counter()
        for _ in range(steps):
            mujoco.mj_step(model, data)
        best = min(best, time.perf_counter() - start)
    return best / steps


def closed_loop(plant: Plant, controller) -> float:
    """Seconds per control step of the single-arm loop (best of the repeats)."""
    best = np.inf
    for _ in range(REPEATS):
        start = time.perf_counter()
        traj = simulate(plant, controller, DURATION, control_dt=DT)
        best = min(best, time.perf_counter() - start)
        assert traj.ok, traj.message
    return best / (len(traj.t) - 1)


def batch_loop(p: ArmParams, ref: ArmReference, law, n: int) -> float:
    """Seconds per arm and control step of the batch engine, N arms of their own K."""
    ks = np.geomspace(300.0, 3000.0, n)
    flexes = [Flexibility((k, k), (2.0, 2.0), (0.05, 0.05)) for k in ks]
    plant = BatchPlant([Arm(p, f) for f in flexes], DT)
    controllers = [law(p, ref, f) for f in flexes]
    steps = round(BATCH_DURATION / DT)
    best = np.inf
    for _ in range(max(1, REPEATS // 2)):
        start = time.perf_counter()
        run = simulate_batch(plant, controllers, [BATCH_DURATION] * n, DT)
        best = min(best, time.perf_counter() - start)
        assert all(s == "ok" for s in run.status), run.message
    return best / (n * steps)


def main() -> None:
    p = ArmParams()
    flex = Flexibility((500.0, 500.0), (2.0, 2.0), (0.05, 0.05))
    ref = ArmReference(Septic(0.0, 1.0, 2.0), Septic(0.0, 0.5, 2.0))
    plant = Plant.build(p, flex, timestep=DT)
    bare = bare_loop(plant)
    print(f"bare mj_step, flexible arm: {bare * 1e6:6.2f} µs per step")
    print(
        f"{'controller':18s} {'single-arm':>12s}"
        + "".join(f"{f'batch N={n}':>14s}" for n in BATCH_SIZES)
    )
    for name, law in LAWS.items():
        single = closed_loop(plant, law(p, ref, flex)) / bare
        batch = [batch_loop(p, ref, law, n) / bare for n in BATCH_SIZES]
        print(f"{name:18s} {single:11.2f}x" + "".join(f"{b:13.2f}x" for b in batch))
    print("(ratios: time per control step, or per arm and step, over one bare mj_step)")


if __name__ == "__main__":
    main()
