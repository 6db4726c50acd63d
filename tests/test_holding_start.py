"""A flexible arm starts at rest: its springs twisted to hold it up at the start pose
(``[plant.flexibility] start = "holding"``, the default), on the single path and in a batch.

The twist is analytic (twolink.arm.plant.holding_motor_q: K⁻¹ G(q), payload included); the
independent reference is MuJoCo itself: its gravity load at rest (``qfrc_bias``) is the
same, and with the motors giving the springs' torque every acceleration of a held arm is
zero.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from twolink.arm import dynamics
from twolink.arm.params import ArmParams, Flexibility
from twolink.arm.plant import Plant, holding_motor_q
from twolink.simulation.batch import Arm, BatchPlant
from twolink.simulation.config import ConfigError, load_scenario
from twolink.simulation.experiment import build_plant, run_scenario, run_scenarios, start_motor_q
from twolink.simulation.sim import simulate

BASE = "runs/paper/theta1_step.toml"


def random_arms(n: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    for i in range(n):
        p = ArmParams(
            m1=rng.uniform(0.5, 2.0),
            m2=rng.uniform(0.5, 2.0),
            l1=rng.uniform(0.5, 1.5),
            l2=rng.uniform(0.5, 1.5),
            g=rng.choice([9.81, rng.uniform(8.0, 11.0)]),
        )
        flex = Flexibility(
            k=tuple(rng.uniform(20.0, 1e4, 2)),
            d=tuple(rng.uniform(0.0, 2.0, 2)),
            j=tuple(rng.uniform(0.05, 0.5, 2)),
        )
        q0 = rng.uniform(-1.5, 1.5, 2)
        payload = 0.0 if i % 4 == 0 else float(rng.uniform(0.05, 0.5))
        yield p, flex, payload, q0


def test_the_twist_is_mujocos_gravity_load_and_holds_a_single_arm_still():
    for p, flex, payload, q0 in random_arms(20):
        plant = Plant.build(p, flex, payload)
        phi = holding_motor_q(p, flex, q0, payload)
        plant.reset(q0, (0.0, 0.0))  # MuJoCo's gravity load at rest, springs relaxed
        mujoco_phi = q0 + plant.data.qfrc_bias[:2] / np.array(flex.k)
        np.testing.assert_allclose(phi, mujoco_phi, rtol=0, atol=1e-12)
        if payload == 0.0:
            expected = dynamics.holding_motor_angles(p, np.array(flex.k), q0)
            np.testing.assert_array_equal(phi, expected)
        plant.reset(q0, (0.0, 0.0), motor_q=phi)
        plant.data.ctrl[:] = np.array(flex.k) * (phi - q0)  # the motors hold the springs
        mujoco.mj_forward(plant.model, plant.data)
        np.testing.assert_allclose(plant.data.qacc, 0.0, atol=1e-9)
        plant.data.ctrl[:] = 0.0  # and the twist is real: without the motors, it moves
        mujoco.mj_forward(plant.model, plant.data)
        assert np.abs(plant.data.qacc).max() > 1e-3


def test_held_arms_of_a_batch_do_not_accelerate_whatever_their_gravity():
    arms = list(random_arms(12, seed=1))
    batch = BatchPlant([Arm(p, flex, payload) for p, flex, payload, _ in arms])
    q0 = np.array([a[3] for a in arms])
    holding = np.arange(len(arms)) % 3 != 0  # a third of them relaxed
    batch.reset(q0, np.zeros_like(q0), holding)
    phi = batch.data.qpos[batch.motor_index]
    np.testing.assert_array_equal(phi[~holding], q0[~holding])
    for i, (p, flex, payload, q) in enumerate(arms):  # the single arm's own twist, exactly
        if holding[i]:
            np.testing.assert_array_equal(phi[i], holding_motor_q(p, flex, q, payload))
    batch.data.qfrc_applied[batch.force_index] = batch.stiffness * (phi - q0)
    mujoco.mj_forward(batch.model, batch.data)
    qacc = batch.data.qacc
    held = np.concatenate([batch.v_index[holding], batch.motor_v_index[holding]])
    np.testing.assert_allclose(qacc[held], 0.0, atol=1e-9)
    relaxed = batch.v_index[~holding]  # relaxed arms fall: the check can fail
    assert np.abs(qacc[relaxed]).min() > 1e-3


def scenario(**plant):
    return load_scenario(BASE, {"plant": plant, "duration": 0.6})


def test_a_holding_start_runs_alike_alone_and_in_a_batch_and_is_the_default():
    flex = {"k": [300.0, 150.0], "d": [0.5, 0.5], "j": [0.1, 0.1]}
    scenarios = [
        scenario(flexibility=flex),
        scenario(flexibility=flex, payload=0.2, scale={"g": 0.93}),
        scenario(flexibility={**flex, "start": "relaxed"}),
        scenario(),  # a rigid arm beside them
    ]
    assert [s.plant.springs for s in scenarios[:3]] == ["holding", "holding", "relaxed"]
    for s, batch in zip(scenarios, run_scenarios(scenarios), strict=True):
        single = run_scenario(s)
        assert batch.status == single.status and np.array_equal(batch.t, single.t)
        for name, tol in (("q", 1e-12), ("qd", 1e-10), ("motor_q", 1e-12), ("tau", 1e-10)):
            a, b = getattr(single, name), getattr(batch, name)  # tests/test_batch.py's
            assert a.shape == b.shape, name
            np.testing.assert_allclose(b, a, rtol=0, atol=tol, err_msg=name)
    held = run_scenario(scenarios[0])
    assert np.abs(held.motor_q[0] - held.q[0]).min() > 1e-3  # twisted at t = 0
    assert "start" in scenarios[0].to_dict()["plant"]["flexibility"]


def test_a_scenario_holds_its_true_plant_not_the_controllers_model():
    flex = {"k": [300.0, 150.0], "d": [0.5, 0.5], "j": [0.1, 0.1]}
    s = load_scenario(
        BASE,
        {
            "plant": {"flexibility": flex, "payload": 0.3, "scale": {"g": 0.9, "m2": 1.2}},
            "initial": {"q": [0.4, -0.7]},
        },
    )
    plant = build_plant(s)
    phi = np.array(start_motor_q(s))
    plant.reset(s.q0, (0.0, 0.0), motor_q=phi)
    plant.data.ctrl[:] = np.array(flex["k"]) * (phi - s.q0)
    mujoco.mj_forward(plant.model, plant.data)
    np.testing.assert_allclose(plant.data.qacc, 0.0, atol=1e-9)
    model_phi = holding_motor_q(s.arm, s.plant.flexibility, s.q0)  # the nominal arm's
    assert np.abs(model_phi - phi).max() > 1e-3
    assert start_motor_q(load_scenario(BASE)) is None  # a rigid arm has no twist


def test_relaxed_is_the_old_start_exactly():
    s = scenario(flexibility={"k": [300.0, 150.0], "start": "relaxed"})
    from twolink.simulation.experiment import build_controller, build_plant

    old = simulate(build_plant(s), build_controller(s), s.duration, s.control_dt, s.q0, s.qd0)
    new = run_scenario(s)
    np.testing.assert_array_equal(new.q, old.q)
    np.testing.assert_array_equal(new.motor_q[0], new.q[0])


def test_a_bad_start_names_the_key_and_the_file():
    with pytest.raises(ConfigError) as err:
        scenario(flexibility={"k": [300.0, 150.0], "start": "loose"})
    text = str(err.value)
    assert "plant.flexibility.start" in text and "theta1_step.toml" in text
    assert "holding" in text and "relaxed" in text
