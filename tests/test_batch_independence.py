"""An arm's run depends on its own plant and controller alone, never on its batch-mates.

Two ways it could not: one controller object shared by a chunk's arms (a law called arm by
arm keeps its state itself), and MuJoCo's constraint solver deciding for all arms at once
(joint friction is a constraint). docs/batch.md, "Independent arms"."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from twolink import sweep as sw
from twolink.arm.params import ArmParams, Friction
from twolink.arm.plant import Plant
from twolink.controllers import batch as batch_module
from twolink.controllers.observer import DisturbanceObserverCTC
from twolink.simulation.batch import Arm, BatchPlant
from twolink.sweep.chunks import _chunk_arms, run_chunk, run_chunk_part

REPO = Path(__file__).resolve().parents[1]
BASE = REPO / "runs" / "paper" / "base.toml"

# Two plants in one chunk, a stateful law (the observer's estimate) and CTC.
TWO = f"""
name = "two"
scenario = "{BASE}"
samples = 2
seed = 3
chunk_size = 2

[overrides]
duration = 0.4

[reference.joint1]
kind = "step"
final = 1.0

[reference.joint2]
kind = "step"
final = 0.5

[parameters]
m1 = {{ dist = "uniform", low = 0.7, high = 1.3 }}
m2 = {{ dist = "uniform", low = 0.7, high = 1.3 }}

[controllers.dob]
kind = "ctc_dob"

[controllers.ctc]
kind = "ctc"
"""


@pytest.fixture
def plan(tmp_path):
    path = tmp_path / "two.toml"
    path.write_text(TWO)
    return sw.load_sweep(path)


def test_a_law_called_arm_by_arm_gets_one_object_per_arm(plan, monkeypatch):
    """With CTC-DOB's batch form taken away, each arm of a 2-plant chunk still gets its
    single-arm rows to the bit (a shared object mixes the two observers' estimates)."""
    laws = {k: v for k, v in batch_module._LAWS.items() if k is not DisturbanceObserverCTC}
    monkeypatch.setattr(batch_module, "_LAWS", laws)
    _, arms = _chunk_arms(plan, 0)
    dob = [c for _, _, c in arms if isinstance(c, DisturbanceObserverCTC)]
    assert len(dob) == 2 and not batch_module.batched(dob[0])
    assert dob[0] is not dob[1]
    together = run_chunk(plan, 0).rows
    alone = [row for i in (0, 1) for row in run_chunk_part(plan, 0, i, i + 1)[0].rows]
    assert len(together) == 4
    for a, b in zip(together, alone, strict=True):
        np.testing.assert_array_equal(np.array(a[3:-2], float), np.array(b[3:-2], float))
        assert a[:3] == b[:3] and a[-2:] == b[-2:]


def test_a_law_with_a_batch_form_keeps_one_object(plan):
    """The batched laws are not copied: one object (one batch law, one fuzzy engine) per
    controller name, as the rows that are byte-identical to before rely on."""
    _, arms = _chunk_arms(plan, 0)
    for kind in (DisturbanceObserverCTC,):
        objs = [c for _, _, c in arms if type(c) is kind]
        assert batch_module.batched(objs[0]) and objs[0] is objs[1]


# ----------------------------------------------------------------------------- friction


def _arms(n: int) -> list[Arm]:
    """n different arms with stiction and a Stribeck dip, as the lab sweep draws them."""
    rng = np.random.default_rng(1)
    out = []
    for _ in range(n):
        p = ArmParams(m1=rng.uniform(0.7, 1.3), m2=rng.uniform(0.7, 1.3), l1=1.0, l2=1.0, g=9.81)
        c = (rng.uniform(1.0, 2.0), rng.uniform(0.25, 0.5))
        f = Friction(coulomb=c, breakaway=(1.3 * c[0], 1.3 * c[1]), stribeck_velocity=0.05)
        out.append(Arm(p, friction=f))
    return out


def _run(plant: BatchPlant, steps: int) -> np.ndarray:
    """Arm 0's link angles under a torque that holds, slides and sticks it."""
    q = []
    for k in range(steps):
        t = k * plant.dt
        arm = np.arange(plant.n_arms)
        hold = 19.6 * np.cos(plant.data.qpos[plant.q_index[:, 0]])
        tau = np.stack([hold + 3 * np.sin(3 * t + arm), 5 * np.sin(2 * t + arm)], axis=1)
        plant.apply(tau)
        mujoco.mj_step(plant.model, plant.data)
        q.append(plant.data.qpos[plant.q_index[0]].copy())
    return np.array(q)


def test_a_friction_arm_runs_the_same_alone_and_in_a_batch():
    """Arm 0 alone, beside 5 others and beside 59 (MuJoCo's sparse algebra) moves the same
    to the bit over 1.5 s of sticking and sliding."""
    arms = _arms(60)
    alone = _run(BatchPlant(arms[:1]), 1500)
    for n in (6, 60):
        np.testing.assert_array_equal(_run(BatchPlant(arms[:n]), 1500), alone)


def test_a_friction_arm_runs_the_same_as_a_plant_and_in_a_batch():
    """A single Plant with a Stribeck dip sums the dip and the torques as the batch does,
    so the two run the same to the bit (MuJoCo adds applied, then actuator forces)."""
    arm = _arms(1)[0]
    plant = Plant.build(arm.params, friction=arm.friction)
    batch = BatchPlant([arm])
    for k in range(1500):
        t = k * plant.dt
        tau = (19.6 * np.cos(plant.data.qpos[0]) + 3 * np.sin(3 * t), 5 * np.sin(2 * t))
        plant.step(*tau)
        batch.apply(np.array([tau]))
        mujoco.mj_step(batch.model, batch.data)
        np.testing.assert_array_equal(plant.data.qpos[:2], batch.data.qpos[batch.q_index[0]])
