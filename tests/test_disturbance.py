"""Disturbances ([disturbance]): torques on the links the controllers do not know about,
checked against closed forms. Tolerances: the next decade above the measured error
(written next to each), or an error's order in the step where the check is a limit dt -> 0.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from twolink.arm import dynamics
from twolink.arm.disturbance import (
    Disturbance,
    PayloadPickup,
    SineLoad,
    TorqueImpulse,
    TorqueStep,
)
from twolink.arm.params import ArmParams, Flexibility, Friction
from twolink.arm.plant import Plant, build_model
from twolink.controllers.ctc import ComputedTorque
from twolink.foundation.references import ArmReference, Step
from twolink.simulation.batch import Arm, BatchPlant, simulate_batch
from twolink.simulation.config import ConfigError, load_scenario
from twolink.simulation.experiment import _arm, build_plant
from twolink.simulation.sim import simulate

BASE = "runs/paper/theta1_step.toml"
REF = ArmReference(Step(final=0.5), Step(final=0.3))


def test_step_moves_computed_torque_by_the_closed_form():
    """CTC on an exact model under a step load d: ë + Kd ė + Kp e = -M(q)⁻¹ d, so the
    error settles at e = -M(q_end)⁻¹ d / Kp."""
    p, kp = ArmParams(), 16.0
    d = Disturbance(steps=(TorqueStep(joint=1, time=2.0, size=3.0),))
    run = simulate(Plant.build(p, disturbance=d), ComputedTorque(p, REF, kp=kp, kd=8.0), 8.0)
    expected = -np.linalg.solve(dynamics.mass_matrix(p, run.q[-1]), [3.0, 0.0]) / kp
    np.testing.assert_allclose(run.e[-1], expected, rtol=0, atol=1e-9)  # measured 7e-11 rad
    free = simulate(Plant.build(p), ComputedTorque(p, REF, kp=kp, kd=8.0), 8.0)
    before = run.t <= 2.0  # nothing before it acts: the sample at 2 s is measured before
    assert np.array_equal(run.q[before], free.q[before])
    assert not np.array_equal(run.q[run.t > 2.0][:1], free.q[free.t > 2.0][:1])


@pytest.mark.parametrize("joint", [1, 2])
def test_impulse_changes_momentum_by_its_size(joint):
    """An impulse J over one physics step changes M q̇ by J (the limit dt -> 0; over a
    finite step the arm's own forces and its turning add O(dt)): measured 2e-4 N m s of
    0.2 at 1 ms, and ten times less at 0.1 ms."""
    p, size = ArmParams(g=0.0), 0.2
    errors = []
    for dt in (1e-3, 1e-4):
        d = Disturbance(impulses=(TorqueImpulse(joint=joint, time=0.5, size=size),))
        plant = Plant.build(p, disturbance=d, timestep=dt)
        plant.reset((0.3, 0.4), (0.1, -0.1))
        for _ in range(round(0.5 / dt)):
            plant.step(0.0, 0.0)
        q, qd = plant.q, plant.qd
        plant.step(0.0, 0.0)
        momentum = dynamics.mass_matrix(p, q) @ (plant.qd - qd)
        errors.append(np.abs(momentum - np.eye(2)[joint - 1] * size).max())
    assert errors[0] < 1e-3 * 2  # within 1 % of 0.2 N m s at 1 ms
    assert errors[0] / errors[1] > 5  # first order: shrinks with the step


def test_payload_picked_up_sags_by_the_closed_form():
    """A payload m picked up at the tip mid-run: link 2 becomes what a plant built with it
    is (MuJoCo's mass, inertia and derived constants equal to the bit), and CTC on the
    nominal model sags by its unknown gravity, M^(q) Kp e = m g (l1 c1 + l2 c12, l2 c12)
    (the analytic tip load, as holding_motor_q's). A reset puts the payload down."""
    p, kp, m = ArmParams(), 16.0, 0.5
    plant = Plant.build(p, disturbance=Disturbance(pickup=PayloadPickup(mass=m, time=3.0)))
    ctc = ComputedTorque(p, REF, kp=kp, kd=8.0)
    run = simulate(plant, ctc, 16.0)
    built = build_model(p, payload=m)
    for name in ("body_mass", "body_ipos", "body_inertia", "body_subtreemass", "dof_invweight0"):
        assert np.array_equal(getattr(plant.model, name), getattr(built, name)), name
    q = run.q[-1]
    c1, c12 = math.cos(q[0]), math.cos(q[0] + q[1])
    load = m * p.g * np.array([p.l1 * c1 + p.l2 * c12, p.l2 * c12])
    expected = np.linalg.solve(dynamics.mass_matrix(p, q), load) / kp
    np.testing.assert_allclose(run.e[-1], expected, rtol=0, atol=1e-9)  # measured 5e-11 rad
    free = simulate(Plant.build(p), ctc, 16.0)
    assert np.array_equal(run.q[run.t <= 3.0], free.q[free.t <= 3.0])
    again = simulate(plant, ctc, 16.0)  # the same plant, reset: picked up again at 3 s
    assert again.equals(run)
    plant.reset()
    assert np.array_equal(plant.model.body_mass, build_model(p).body_mass)


def test_torque_of_each_kind():
    d = Disturbance(
        steps=(TorqueStep(2, 1.0, 0.5),),
        impulses=(TorqueImpulse(1, 0.25, 0.01),),
        sines=(SineLoad(1, 2.0, 0.5),),
    )
    dt = 1e-3
    assert list(d.torque(0.999, dt)) == [2.0 * math.sin(math.pi * 0.999), 0.0]
    assert list(d.torque(1.0, dt)) == [2.0 * math.sin(math.pi), 0.5]
    assert d.torque(0.25, dt)[0] == pytest.approx(10.0 + 2.0 * math.sin(math.pi * 0.25))
    assert d.torque(0.251, dt)[0] == pytest.approx(2.0 * math.sin(math.pi * 0.251))


def test_batch_applies_disturbances_as_the_single_arm():
    p = ArmParams()
    d = Disturbance(
        steps=(TorqueStep(1, 0.5, 2.0),),
        impulses=(TorqueImpulse(2, 0.7, 0.1),),
        sines=(SineLoad(2, 1.0, 2.0),),
        pickup=PayloadPickup(0.4, 0.9),
    )
    arms = [
        Arm(p, disturbance=d),
        Arm(p),
        Arm(
            p,
            Flexibility(),
            disturbance=d,
            friction=Friction(coulomb=(0.2, 0.2), breakaway=(0.3, 0.3)),
        ),
        Arm(p, friction=Friction(coulomb=(0.3, 0.3), breakaway=(0.5, 0.5)), disturbance=d),
    ]
    laws = [ComputedTorque(p, REF, kp=16.0, kd=8.0) for _ in arms]
    batch = simulate_batch(BatchPlant(arms), laws, [1.5] * len(arms))
    for i, a in enumerate(arms):
        plant = Plant.build(a.params, a.flexibility, friction=a.friction, disturbance=a.disturbance)
        single = simulate(plant, ComputedTorque(p, REF, kp=16.0, kd=8.0), 1.5)
        b = batch.trajectory(i)
        np.testing.assert_allclose(b.q, single.q, rtol=0, atol=1e-12, err_msg=f"arm {i}")
        np.testing.assert_allclose(b.motor_q, single.motor_q, rtol=0, atol=1e-12)


def test_mjx_refuses_disturbances_before_compiling():
    from twolink.simulation.mjx_engine import prepare_batch_mjx

    p = ArmParams()
    arms = [Arm(p, disturbance=Disturbance(steps=(TorqueStep(1, 0.0, 1.0),)))]
    with pytest.raises(ValueError, match=r"mjx backend applies no \[disturbance\]"):
        prepare_batch_mjx(arms, 1e-3, [ComputedTorque(p, REF)], [1.0])


def test_scenario_disturbance_keys():
    table = {
        "step": [{"joint": 1, "time": 2.0, "size": 1.5}],
        "impulse": {"joint": 2, "time": 1.0, "size": 0.1},
        "sine": [{"joint": 2, "amplitude": 0.5, "frequency": 1.0}],
        "payload": {"mass": 0.3, "time": 4.0},
    }
    s = load_scenario(BASE, {"disturbance": table})
    assert s.disturbance == Disturbance(
        (TorqueStep(1, 2.0, 1.5),),
        (TorqueImpulse(2, 1.0, 0.1),),
        (SineLoad(2, 0.5, 1.0),),
        PayloadPickup(0.3, 4.0),
    )
    assert s.to_dict()["disturbance"]["payload"] == {"mass": 0.3, "time": 4.0}
    assert s.to_dict()["disturbance"]["impulse"] == [{"joint": 2, "time": 1.0, "size": 0.1}]
    assert "disturbance" not in load_scenario(BASE).to_dict()
    assert build_plant(s).disturbance == s.disturbance == _arm(s).disturbance


@pytest.mark.parametrize(
    ("table", "key", "problem"),
    [
        ({"step": {"joint": 3, "time": 1, "size": 1}}, r"disturbance.step\[0\].joint", "1 or 2"),
        ({"step": {"joint": 1, "size": 1}}, r"disturbance.step\[0\].time", "missing"),
        (
            {"impulse": {"joint": 1, "time": -1, "size": 1}},
            r"disturbance.impulse\[0\].time",
            ">= 0",
        ),
        ({"sine": {"joint": 1, "amplitude": "a", "frequency": 1}}, "amplitude", "a number"),
        ({"sine": [{"joint": 1, "amplitude": 1, "frequency": 1, "phase": 0}]}, "phase", "unknown"),
        ({"ramp": {}}, "disturbance.ramp", "unknown key"),
        ({"payload": {"mass": -1, "time": 1}}, "disturbance.payload.mass", ">= 0"),
        ({"step": 3}, "disturbance.step", "table or an array of tables"),
    ],
)
def test_scenario_disturbance_errors_name_the_file_and_key(table, key, problem):
    with pytest.raises(ConfigError, match=rf"theta1_step.toml: .*{key}.*{problem}"):
        load_scenario(BASE, {"disturbance": table})


def test_batch_arms_with_different_disturbances_each_get_their_own():
    """Arms sharing a disturbance are evaluated together (one torque per physics step);
    arms with another one, interleaved with them, still get their own (as alone, to the
    batch engine's rounding: tests/test_batch.py)."""
    p = ArmParams()
    ramp = Disturbance(steps=(TorqueStep(1, 0.3, 1.5),), sines=(SineLoad(2, 0.5, 1.0),))
    kick = Disturbance(impulses=(TorqueImpulse(1, 0.4, 0.2),))
    arms = [Arm(p, disturbance=ramp), Arm(p, disturbance=kick), Arm(p, disturbance=ramp)]
    arms.append(Arm(p, Flexibility(), disturbance=kick))
    laws = [ComputedTorque(p, REF, kp=16.0, kd=8.0) for _ in arms]
    batch = simulate_batch(BatchPlant(arms), laws, [1.0] * len(arms))
    for i, a in enumerate(arms):
        plant = Plant.build(a.params, a.flexibility, disturbance=a.disturbance)
        single = simulate(plant, ComputedTorque(p, REF, kp=16.0, kd=8.0), 1.0)
        b = batch.trajectory(i)
        np.testing.assert_allclose(b.q, single.q, rtol=0, atol=1e-12, err_msg=f"arm {i}")
