"""Joint friction in the plant ([plant.friction]): MuJoCo's dry friction (frictionloss) and
viscous damping, with the Stribeck dip as an applied force, checked against closed forms
and an independent integration (scipy's solve_ivp of the analytic dynamics).

Tolerances, each by a written rule:
- stiction and the dead band: one count of a 17-bit encoder, 2 pi / 2**17 = 4.8e-5 rad
  (what a real arm's controller could see at all);
- solve_ivp, Coulomb + viscous (MuJoCo's RK4 with its constraint-based dry friction):
  the next decade above the measured error (4.3e-10 rad -> 1e-9);
- solve_ivp with the Stribeck dip, which the plant holds over a step: first order in the
  step (the error halves with it, ratio in [1.9, 2.1]) and the next decade above the
  measured error at 1 ms (3.1e-4 rad -> 1e-3);
- batch against single: as tests/test_batch.py (1e-12 rad).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from twolink.arm import dynamics
from twolink.arm.params import ArmParams, Flexibility, Friction
from twolink.arm.plant import Plant, build_model
from twolink.controllers.baselines import IntegralComputedTorque
from twolink.controllers.ctc import ComputedTorque
from twolink.foundation.references import ArmReference, Step
from twolink.simulation.batch import Arm, BatchPlant, simulate_batch
from twolink.simulation.config import ConfigError, load_scenario, merge
from twolink.simulation.metrics import oscillation_amplitude, step_metrics
from twolink.simulation.sim import simulate

ENCODER_COUNT = 2 * math.pi / 2**17  # rad
BASE = "runs/paper/theta1_step.toml"
F = (1.0, 0.5)  # N m: joint 2's is enough to hold it while joint 1 moves (M21/M11 F1 < F2)


def held(p: ArmParams, friction: Friction, tau, seconds: float = 2.0) -> Plant:
    plant = Plant.build(p, friction=friction)
    plant.reset()
    for _ in range(round(seconds / plant.dt)):
        plant.step(*tau)
    return plant


# ------------------------------------------------------------------ (a) stiction


@pytest.mark.parametrize("breakaway", [None, (1.5, 0.75)])
def test_stiction_holds_below_breakaway_and_slides_above(breakaway):
    """A horizontal arm (g = 0) under a constant torque on joint 1: below the breakaway
    torque it stays put (to an encoder count over 2 s); above it joint 1 slides with
    joint 2 held by its own friction, at the closed-form acceleration (tau - F_c) / M11
    once it moves fast against the Stribeck scale."""
    p = ArmParams(g=0.0)
    friction = Friction(coulomb=F, breakaway=breakaway, stribeck_velocity=0.01)
    fs = friction.breakaway[0]
    plant = held(p, friction, (0.99 * fs, 0.0))
    assert np.abs(plant.q).max() < ENCODER_COUNT
    tau = 1.2 * fs
    plant = held(p, friction, (tau, 0.0))
    m11 = dynamics.mass_matrix(p, np.zeros(2))[0, 0]  # joint 2 stuck at 0
    expected = (tau - F[0]) / m11  # rad/s^2, sliding fast against v_s
    before = plant.qd[0]
    for _ in range(1000):
        plant.step(tau, 0.0)
    assert abs(plant.q[1]) < ENCODER_COUNT
    assert plant.qd[0] - before == pytest.approx(expected * 1.0, rel=1e-3)


def test_friction_sits_on_the_motor_side_of_a_flexible_joint():
    fr = Friction(coulomb=F, viscous=(0.1, 0.2))
    rigid = build_model(ArmParams(), friction=fr)
    assert list(rigid.dof_frictionloss) == list(F) and list(rigid.dof_damping) == [0.1, 0.2]
    flexible = build_model(ArmParams(), Flexibility(), friction=fr)
    assert list(flexible.dof_frictionloss) == [0, 0, *F]
    assert list(flexible.dof_damping) == [0, 0, 0.1, 0.2]
    # The rotor holds under a torque below breakaway; the arm hangs on its springs.
    plant = Plant.build(ArmParams(g=0.0), Flexibility(), friction=fr)
    plant.reset()
    for _ in range(2000):
        plant.step(0.99 * F[0], 0.0)
    assert abs(plant.motor_q[0]) < ENCODER_COUNT


# --------------------------------------------------------------- (b) dead band


def test_computed_torque_stops_short_by_the_dead_band():
    """Critically damped CTC (exact model) on joint 1, joint 2 held at 0 by its friction:
    ë + Kd ė + Kp e = F1 / M11 while sliding, a linear system shifted by the dead band
    F1 / (M11 Kp), which it approaches monotonically. ess (the project's step metric) is
    that band."""
    p, kp = ArmParams(), 4.0
    ref = ArmReference(Step(final=0.5), Step(final=0.0))
    ctc = ComputedTorque(model=p, reference=ref, kp=kp, kd=2 * math.sqrt(kp))
    run = simulate(Plant.build(p, friction=Friction(coulomb=F)), ctc, 10.0)
    band = F[0] / (dynamics.mass_matrix(p, np.zeros(2))[0, 0] * kp)  # 0.09375 rad
    ess = step_metrics(run.t, run.q[:, 0], 0.5).steady_state_error
    assert abs(ess - band) < ENCODER_COUNT  # measured: 8e-6 rad
    assert abs(run.e[-1, 1]) < ENCODER_COUNT
    # Without friction the same loop reaches the target.
    free = simulate(Plant.build(p), ctc, 10.0)
    assert step_metrics(free.t, free.q[:, 0], 0.5).steady_state_error < ENCODER_COUNT


# -------------------------------------------------- (c) an independent integration


def _reference_run(p, friction, tau, q0, qd0, t):
    fc, fs = np.array(friction.coulomb), np.array(friction.breakaway)
    b, vs = np.array(friction.viscous), friction.stribeck_velocity

    def rhs(_, x):
        v = x[2:]
        f = (fc + (fs - fc) * np.exp(-((v / vs) ** 2))) * np.sign(v) + b * v
        return np.concatenate([v, dynamics.forward_dynamics(p, x[:2], v, tau - f)])

    x0 = np.concatenate([q0, qd0])
    sol = solve_ivp(rhs, (0, t[-1]), x0, method="DOP853", rtol=1e-12, atol=1e-12, t_eval=t)
    return sol.y[:2].T, sol.y[2:].T


def _mujoco_run(p, friction, tau, q0, qd0, dt, seconds):
    plant = Plant.build(p, friction=friction, timestep=dt)
    plant.reset(q0, qd0)
    q, qd = [], []
    for _ in range(round(seconds / dt)):
        plant.step(*tau)
        q.append(plant.q)
        qd.append(plant.qd)
    return np.array(q), np.array(qd)


# Both joints slide the whole second without stopping (asserted): dry friction is then
# -F sign(qd) and the two models are the same ODE.
SLIDE = dict(p=ArmParams(g=0.0), tau=np.array([3.0, 2.0]), q0=(-0.5, 0.5), qd0=(0.5, 0.5))


def test_sliding_matches_solve_ivp_coulomb_viscous():
    fr = Friction(coulomb=F, viscous=(0.2, 0.1))
    q, qd = _mujoco_run(friction=fr, dt=1e-3, seconds=1.0, **SLIDE)
    assert qd.min() > 0.1
    ref_q, _ = _reference_run(friction=fr, t=np.arange(1, 1001) * 1e-3, **SLIDE)
    assert np.abs(q - ref_q).max() < 1e-9  # measured 4.3e-10 rad


def test_sliding_matches_solve_ivp_stribeck_to_first_order():
    fr = Friction(coulomb=F, viscous=(0.2, 0.1), breakaway=(1.6, 0.8), stribeck_velocity=1.0)
    errors = []
    for dt in (1e-3, 5e-4):
        q, qd = _mujoco_run(friction=fr, dt=dt, seconds=1.0, **SLIDE)
        assert qd.min() > 0.1
        t = np.arange(1, len(q) + 1) * dt
        errors.append(np.abs(q - _reference_run(friction=fr, t=t, **SLIDE)[0]).max())
    assert errors[0] < 1e-3  # measured 3.1e-4 rad
    assert 1.9 < errors[0] / errors[1] < 2.1  # measured 2.00


# ------------------------------------------------------------- what friction shows


def test_integral_action_hunts_against_stiction():
    """CTC with integral action against friction with a Stribeck dip (F_s = 2 F_c): the
    integrator winds up to breakaway, the joint slips past the target and sticks, over and
    over (stick-slip hunting). The oscillation measure reads the cycle: half the distance
    between the last two places joint 1 stuck."""
    p = ArmParams()
    ref = ArmReference(Step(final=0.5), Step(final=0.0))
    ci = IntegralComputedTorque(model=p, reference=ref, kp=4.0, kd=2.4, ki=4.0)
    fr = Friction(coulomb=(2.0, 1.0), breakaway=(4.0, 2.0), stribeck_velocity=0.02)
    run = simulate(Plant.build(p, friction=fr), ci, 40.0)
    moving = np.abs(run.qd[:, 0]) > 1e-3
    stuck = run.e[1:][np.diff(moving.astype(int)) == -1, 0]  # where each slip ended
    assert len(stuck) >= 6 and np.all(np.sign(stuck[1:]) != np.sign(stuck[:-1]))
    cycle = abs(stuck[-1] - stuck[-2]) / 2  # 0.1336 rad
    amplitude = oscillation_amplitude(run.t, run.e)[0]
    assert amplitude == pytest.approx(cycle, rel=1e-2)


# ---------------------------------------------------- batch, MJX, the scenario file


def test_batch_runs_friction_as_the_single_arm():
    p = ArmParams()
    ref = ArmReference(Step(final=0.5), Step(final=-0.3))
    stribeck = Friction(coulomb=F, viscous=(0.1, 0.05), breakaway=(1.5, 0.7))
    arms = [
        Arm(p, friction=stribeck),
        Arm(p),
        Arm(p.scaled(m2=1.3), Flexibility(), friction=Friction(coulomb=(0.3, 0.2))),
        Arm(p, friction=Friction(viscous=(0.5, 0.5))),
    ]

    def controller():
        return ComputedTorque(model=p, reference=ref, kp=16.0, kd=8.0)

    batch = simulate_batch(BatchPlant(arms), [controller() for _ in arms], [2.0] * len(arms))
    for i, a in enumerate(arms):
        plant = Plant.build(a.params, a.flexibility, friction=a.friction)
        single = simulate(plant, controller(), 2.0)
        b = batch.trajectory(i)
        np.testing.assert_allclose(b.q, single.q, rtol=0, atol=1e-12, err_msg=f"arm {i}")
        np.testing.assert_allclose(b.motor_q, single.motor_q, rtol=0, atol=1e-12)


def test_mjx_refuses_friction_before_compiling():
    from twolink.simulation.mjx_engine import prepare_batch_mjx

    p = ArmParams()
    ref = ArmReference(Step(final=0.5), Step(final=0.0))
    arms = [Arm(p, friction=Friction(coulomb=F))]
    with pytest.raises(
        ValueError, match=r"mjx backend runs no joint friction \(\[plant.friction\]\)"
    ):
        prepare_batch_mjx(arms, 1e-3, [ComputedTorque(model=p, reference=ref)], [1.0])


def test_scenario_friction_keys():
    table = {
        "coulomb": [0.5, 0.2],
        "viscous": 0.1,
        "breakaway": [0.6, 0.25],
        "stribeck_velocity": 0.05,
    }
    s = load_scenario(BASE, {"plant": {"friction": table}})
    assert s.plant.friction == Friction((0.5, 0.2), (0.1, 0.1), (0.6, 0.25), 0.05)
    assert s.to_dict()["plant"]["friction"]["breakaway"] == [0.6, 0.25]
    assert "friction" not in load_scenario(BASE).to_dict()["plant"]
    run = __import__("twolink.simulation.experiment", fromlist=["build_plant"])
    assert run.build_plant(s).friction == s.plant.friction
    assert run._arm(s).friction == s.plant.friction


@pytest.mark.parametrize(
    ("table", "key", "problem"),
    [
        ({"coulomb": "1"}, "plant.friction.coulomb", "must be a number"),
        ({"coulomb": [1, -1]}, "plant.friction.coulomb", "must be >= 0"),
        ({"viscous": [1, 2, 3]}, "plant.friction.viscous", "must be a number or a list of 2"),
        ({"coulomb": 1, "breakaway": 0.5}, "plant.friction.breakaway", "must be >= coulomb"),
        ({"stribeck_velocity": 0}, "plant.friction.stribeck_velocity", "must be > 0"),
        ({"coulomb": math.nan}, "plant.friction.coulomb", "must be finite"),
        ({"dry": 1}, "plant.friction.dry", "unknown key"),
    ],
)
def test_scenario_friction_errors_name_the_file_and_key(table, key, problem):
    with pytest.raises(ConfigError, match=rf"theta1_step.toml: {key}: {problem}"):
        load_scenario(BASE, merge({}, {"plant": {"friction": table}}))
