"""The batch engine against the single-arm reference path: every arm of a batch runs as it
does alone (rigid and flexible, every controller, its own gravity, noise and duration),
and an arm that diverges stops as it does alone without disturbing the others.

Tolerance: 1e-12 rad on angles. Arms whose gravity is the batch model's are bit-identical
where numpy's cos/sin round as libm's (machines without AVX-512); an arm with another
gravity gets the difference as MuJoCo's gravity compensation, two terms where the single
model has one, which rounds differently (~1e-16). The fuzzy term's numpy path agrees with
its pure-Python path to 1e-12 (controllers/fuzzy/engine.py).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from twolink.arm.params import ArmParams, Flexibility
from twolink.arm.plant import Plant, incline
from twolink.controllers.batch import batch_laws
from twolink.controllers.ctc import ComputedTorque
from twolink.simulation import experiment
from twolink.simulation.batch import Arm, BatchPlant, model_gravity, simulate_batch
from twolink.simulation.config import load_scenario, merge
from twolink.simulation.experiment import measure, run_scenario, run_scenarios
from twolink.simulation.sim import simulate
from twolink.simulation.vocabulary import joint_values

BASE = "runs/paper/theta1_step.toml"
ANGLE_TOL = 1e-12  # rad
TORQUE_TOL = 1e-10  # N m: torques are ~20 N m, so this is ~1e-12 relative


def scenario(**overrides):
    both = {"reference": {"joint2": {"kind": "step", "final": 0.5}}, "duration": 1.5}
    return load_scenario(BASE, merge(both, overrides))


def assert_same_run(single, batch):
    assert batch.status == single.status and batch.message == single.message
    assert np.array_equal(batch.t, single.t)
    for name, tol in (("q", ANGLE_TOL), ("qd", 1e-10), ("motor_q", ANGLE_TOL), ("tau", TORQUE_TOL)):
        a, b = getattr(single, name), getattr(batch, name)
        assert a.shape == b.shape, name
        np.testing.assert_allclose(b, a, rtol=0, atol=tol, err_msg=name)
    for name in ("q_ref", "qd_ref", "qdd_ref"):
        assert np.array_equal(getattr(batch, name), getattr(single, name)), name


def assert_same_metrics(s, single, batch):
    if not single.ok and len(single.t) < 2:
        return
    ms, mb = measure(s, single), measure(s, batch)
    for j in (1, 2):
        a, b = joint_values(ms, j), joint_values(mb, j)
        assert a.keys() == b.keys()
        for key in a:
            assert (math.isnan(a[key]) and math.isnan(b[key])) or abs(a[key] - b[key]) <= 1e-9, (
                j,
                key,
            )


def check_against_single(scenarios):
    batch = run_scenarios(scenarios)
    for s, b in zip(scenarios, batch, strict=True):
        single = run_scenario(s)
        assert_same_run(single, b)
        assert_same_metrics(s, single, b)
    return batch


def test_rigid_arms_each_with_own_masses_lengths_payload_and_gravity():
    scenarios = [
        scenario(),
        scenario(plant={"scale": {"m1": 1.3, "l2": 0.9}, "payload": 0.2}),
        scenario(plant={"scale": {"g": 1.1, "m2": 0.8}}),
        scenario(arm={"g": 0.0}),  # horizontal arm: all its weight compensated away
        scenario(arm={"g": -9.81}),  # upside down
    ]
    check_against_single(scenarios)


def test_arms_with_the_models_gravity_are_bit_identical_when_numpy_rounds_as_libm():
    x = np.linspace(-7, 7, 10001)
    if not np.array_equal(np.cos(x), [math.cos(v) for v in x]):
        pytest.skip("numpy's SIMD cos rounds differently from libm on this machine")
    scenarios = [scenario(), scenario(plant={"scale": {"m1": 1.2}, "payload": 0.1}), scenario()]
    for s, b in zip(scenarios, run_scenarios(scenarios), strict=True):
        assert run_scenario(s).equals(b)


def test_flexible_and_rigid_arms_share_a_batch():
    flex = {"flexibility": {"k": [500.0, 300.0], "d": [1.0, 2.0], "j": [0.05, 0.08]}}
    scenarios = [
        scenario(plant=flex),
        scenario(),
        scenario(plant={**flex, "scale": {"g": 1.05}, "payload": 0.1}),
    ]
    batch = check_against_single(scenarios)
    assert batch[0].motor_q.shape == (len(batch[0].t), 2) and batch[1].motor_q.shape == (0, 2)


@pytest.mark.parametrize(
    "controller",
    [
        {"kind": "ctc", "kp": [9.0, 16.0], "kd": [6.0, 8.0], "torque_limit": 15.0},
        {"kind": "fuzzy_ctc", "fuzzy": {"ke": 2.0, "ku": 3.0}},
        {"kind": "fcm_ctc", "rule_base": "paper"},
        {"kind": "fcm_ctc", "rule_base": "paper", "fuzzy": {"mode": "replace", "kde": 0.5}},
        {"kind": "pd_gravity", "kp": 25.0, "kd": 10.0},
        {"kind": "ctc_integral", "kp": 25.0, "kd": 10.0, "ki": 12.5, "torque_limit": 20.0},
        {"kind": "fuzzy_pd", "rule_base": "paper", "fuzzy": {"ku": 20.0}},
    ],
    ids=[
        "ctc saturating",
        "fuzzy_ctc",
        "fcm_ctc",
        "fcm_ctc replace",
        "pd_gravity",
        "ctc_integral saturating",
        "fuzzy_pd",
    ],
)
def test_every_controller_kind(controller):
    scenarios = [
        scenario(controller=controller),
        scenario(
            controller=controller,
            plant={"scale": {"m2": 1.3}},
            sensor={"noise_std_rad": 0.002},
            seed=3,
        ),
        scenario(
            controller=controller,
            reference={"joint1": {"kind": "ramp", "final": 0.8, "duration": 0.6}},
        ),
    ]
    check_against_single(scenarios)


def test_mixed_controllers_durations_noise_and_starts_in_one_batch():
    # CTC, CTC-I and both fuzzy CTCs share one evaluation of the model terms (arms in
    # another order than the laws'), PD-G has its own law.
    scenarios = [
        scenario(duration=0.7),
        scenario(controller={"kind": "fcm_ctc", "rule_base": "paper"}, duration=1.2),
        scenario(
            sensor={"noise_std_rad": 0.01}, seed=7, initial={"q": [0.3, -0.2], "qd": [0.5, 0.0]}
        ),
        scenario(controller={"kind": "ctc_integral", "ki": 12.5, "torque_limit": 20.0}),
        scenario(controller={"kind": "fuzzy_ctc"}, sensor={"noise_std_rad": 0.005}, seed=8),
        scenario(controller={"kind": "pd_gravity", "kp": 25.0, "kd": 10.0}, duration=1.0),
        scenario(controller={"kind": "ctc_integral"}, plant={"scale": {"m2": 1.2}}),
    ]
    check_against_single(scenarios)


def test_fuzzy_laws_beyond_64_inputs_take_the_numpy_path_and_agree():
    # 40 arms of one fuzzy law: 80 inputs per call, past the pure-Python path's 64.
    rng = np.random.default_rng(5)
    scenarios = [
        scenario(
            controller={"kind": "fcm_ctc", "rule_base": "paper"},
            plant={"scale": {"m1": rng.uniform(0.8, 1.2), "m2": rng.uniform(0.8, 1.2)}},
            duration=0.5,
        )
        for _ in range(40)
    ]
    check_against_single(scenarios)


def test_a_diverging_arm_stops_as_alone_and_leaves_the_others_untouched():
    # discrete loop unstable at 1 kHz; no actuator limit, so nothing bounds its torque
    wild = {"kind": "ctc", "kp": 1e7, "kd": 10.0, "torque_limit": math.inf}
    scenarios = [
        scenario(),
        scenario(controller=wild),
        scenario(controller={"kind": "fcm_ctc", "rule_base": "paper"}),
        scenario(initial={"q": [200.0, 0.0]}),  # out of bounds at once: one sample kept
        # torque out of bounds at once
        scenario(controller={"kind": "ctc", "kp": 1e11, "torque_limit": math.inf}),
    ]
    batch = check_against_single(scenarios)
    assert [b.status for b in batch] == ["ok", "diverged", "ok", "diverged", "diverged"]
    assert len(batch[3].t) == 1 and np.isnan(batch[3].tau).all()
    assert len(batch[4].t) == 1 and "torque out of bounds" in batch[4].message


def test_an_arm_mujoco_refuses_gets_its_error_and_the_others_run():
    scenarios = [scenario(), scenario(arm={"m1": 1e-12}), scenario()]
    batch = run_scenarios(scenarios)
    assert isinstance(batch[1], ValueError) and "MuJoCo cannot build" in str(batch[1])
    assert_same_run(run_scenario(scenarios[0]), batch[0])
    assert_same_run(run_scenario(scenarios[2]), batch[2])


def test_records_are_split_into_batches_under_the_memory_bound(monkeypatch):
    monkeypatch.setattr(experiment, "BATCH_RECORD_BYTES", 3 * 1501 * 6 * 8)  # 3 arms a batch
    sizes = []

    class Counting(BatchPlant):
        def __init__(self, arms, timestep, model_g=None):
            sizes.append(len(arms))
            super().__init__(arms, timestep, model_g)

    monkeypatch.setattr("twolink.simulation.batch.BatchPlant", Counting)
    scenarios = [scenario(plant={"scale": {"m1": 1 + i / 20}}) for i in range(7)]
    check_against_single(scenarios)
    assert sizes == [3, 3, 1]


def test_batch_plant_state_layout_matches_single_plants():
    arms = [
        Arm(ArmParams(m1=1.2)),
        Arm(ArmParams(), Flexibility()),
        Arm(ArmParams(g=3.0), payload=0.5),
    ]
    bp = BatchPlant(arms, 1e-3)
    assert model_gravity([a.params.g for a in arms]) == 9.81
    q0 = np.array([[0.1, 0.2], [0.3, -0.4], [-0.5, 0.6]])
    bp.reset(q0, -q0)
    for i, a in enumerate(arms):
        single = Plant.build(a.params, a.flexibility, a.payload)
        single.reset(q0[i], -q0[i])
        assert np.array_equal(bp.data.qpos[bp.q_index[i]], single.q)
        assert np.array_equal(bp.data.qvel[bp.v_index[i]], single.qd)
        # MuJoCo's bias forces (gravity and Coriolis) per arm, against the arm alone
        bias = bp.data.qfrc_bias[bp.v_index[i]]
        np.testing.assert_allclose(bias, single.bias()[:2], rtol=1e-14, atol=1e-14)


def test_model_gravity_is_the_largest_so_that_every_arm_gets_a_share_of_it():
    assert model_gravity([0.0, 9.81, 3.0, 10.5]) == 10.5
    assert model_gravity([0.0, 0.0]) == 0.0
    assert model_gravity([0.0, -2.0, 1.0]) == -2.0
    with pytest.raises(ValueError, match="cannot exceed"):
        incline(1.5)


@pytest.mark.parametrize("gs", [(9.81, 10.3, 0.0, 3.0), (-2.0, 1.0, 0.0, -0.5), (0.0, 0.0)])
def test_tilted_arms_feel_their_own_gravity(gs):
    # Each arm's gravity torques (MuJoCo's bias at rest) equal those of the arm alone in a
    # model with its own g, at several postures, to rounding (a level arm, g = 0, in a
    # vertical plane: ~4e-15 N m); no gravity compensation is left to pay.
    arms = [Arm(ArmParams(g=g, m1=1.3, l2=0.8), payload=0.1) for g in gs]
    bp = BatchPlant(arms, 1e-3)
    assert bp.model.ngravcomp == 0 and bp.model.ngeom == 0
    rng = np.random.default_rng(3)
    for _ in range(5):
        q0 = rng.uniform(-3, 3, (len(arms), 2))
        bp.reset(q0, np.zeros_like(q0))
        for i, a in enumerate(arms):
            single = Plant.build(a.params, payload=a.payload)
            single.reset(q0[i], (0.0, 0.0))
            np.testing.assert_allclose(
                bp.data.qfrc_bias[bp.v_index[i]], single.bias()[:2], rtol=1e-13, atol=1e-13
            )


def test_custom_controllers_run_arm_by_arm():
    s = scenario()

    class Damped:  # not a ComputedTorque: called per arm like the single loop calls it
        reference = s.reference

        def reset(self):
            self.calls = 0

        def __call__(self, t, q, qd):
            self.calls += 1
            return (20.0 - 5.0 * qd[0], 5.0 - 2.0 * qd[1])

    c1, c2 = Damped(), Damped()
    laws = batch_laws(
        [c1, ComputedTorque(s.arm, s.reference, kp=4.0, kd=2.4, torque_limit=math.inf), c2],
        np.arange(3) * 1e-3,
    )
    assert len(laws) == 2
    bp = BatchPlant([Arm(s.arm)] * 2, s.timestep)
    batch = simulate_batch(bp, [c1, c2], [0.5, 0.3], s.control_dt)
    alone = Damped()
    single = simulate(Plant.build(s.arm), alone, 0.5)
    assert_same_run(single, batch.trajectory(0))
    assert_same_run(simulate(Plant.build(s.arm), Damped(), 0.3), batch.trajectory(1))


def test_the_docs_example_runs_as_written():
    text = (Path(__file__).resolve().parents[1] / "docs" / "batch.md").read_text()
    code = text.split("```python\n", 1)[1].split("```", 1)[0]
    namespace: dict = {}
    exec(compile(code, "docs/batch.md", "exec"), namespace)  # noqa: S102
    assert [t.ok for t in namespace["trajectories"]] == [True] * 3
