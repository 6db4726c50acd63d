"""The batch laws against the single-arm laws where it is hardest for them to agree: with
the torque at its limit for long stretches and, for the laws with integral action, the
integrator held by anti-windup.

Every law of ``controllers/batch.py``, ``controllers/flexible.py`` and
``controllers/flexible_robust.py`` runs a move its torque limit cannot follow, and each
case first proves it does what it is for: the single arm's torque sits at the limit on
both joints for many control steps, and (integral laws) the same run with the
anti-windup switched off moves the arm differently. Then every arm of a batch must equal
its single-arm run to the bit (angles, rates, rotors, torques), where numpy's cos/sin
round as libm's (this machine: checked below, else 1e-12 as tests/test_batch.py). The
exact Mamdani engine's numpy path (more than 64 inputs per call) is held to 1e-12 instead,
as documented in controllers/fuzzy/engine.py; its pure-Python path, the table and the
continuous inference are held to the bit on both paths.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from twolink.controllers import baselines, flexible_robust
from twolink.simulation.config import load_scenario, merge
from twolink.simulation.experiment import run_scenario, run_scenarios

BASE = "runs/paper/theta1_step.toml"
FLEX = {"flexibility": {"k": [500.0, 300.0], "d": [0.2, 0.1], "j": [0.05, 0.08]}}
_x = np.linspace(-7.0, 7.0, 20001)
LIBM = np.array_equal(np.cos(_x), [math.cos(v) for v in _x]) and np.array_equal(
    np.sin(_x), [math.sin(v) for v in _x]
)

# kind -> (controller table, plant table, limits (N m), flexible)
RIGID = {"reference": {"joint2": {"kind": "step", "final": 0.5}}, "duration": 1.2}
FAST = {
    "duration": 1.0,
    "reference": {
        "joint1": {"kind": "septic", "final": 1.0, "duration": 0.4},
        "joint2": {"kind": "quintic", "final": 0.5, "duration": 0.4},
    },
}
LAWS = {
    "ctc": ({"kind": "ctc", "kp": [100.0, 64.0], "kd": [20.0, 16.0]}, RIGID, [30.0, 8.0]),
    "ctc_integral": (
        {"kind": "ctc_integral", "kp": 100.0, "kd": 20.0, "ki": 400.0},
        RIGID,
        [30.0, 8.0],
    ),
    "pd_gravity": ({"kind": "pd_gravity", "kp": 100.0, "kd": 20.0}, RIGID, [22.0, 8.0]),
    "fuzzy_ctc": ({"kind": "fuzzy_ctc", "fuzzy": {"ke": 2.0, "ku": 30.0}}, RIGID, [30.0, 8.0]),
    "fcm_ctc": ({"kind": "fcm_ctc", "rule_base": "designed"}, RIGID, [30.0, 8.0]),
    "adaptive_ctc": ({"kind": "adaptive_ctc", "kp": 100.0, "kd": 20.0}, RIGID, [30.0, 8.0]),
    "sliding_mode": ({"kind": "sliding_mode", "kp": 100.0, "kd": 20.0}, RIGID, [25.0, 8.0]),
    "ctc_dob": ({"kind": "ctc_dob", "kp": 100.0, "kd": 20.0}, RIGID, [30.0, 8.0]),
    "fcm_ctc table": (
        {"kind": "fcm_ctc", "rule_base": "designed", "fuzzy": {"engine": "table"}},
        RIGID,
        [30.0, 8.0],
    ),
    "fcm_ctc continuous": (
        {"kind": "fcm_ctc", "rule_base": "designed", "fuzzy": {"inference": "continuous"}},
        RIGID,
        [30.0, 8.0],
    ),
    "fuzzy_pd": (
        {"kind": "fuzzy_pd", "rule_base": "paper", "fuzzy": {"ku": 60.0}},
        RIGID,
        [30.0, 8.0],
    ),
    "motor_pd": ({"kind": "motor_pd", "kp": 100.0, "kd": 20.0}, FAST, [40.0, 10.0]),
    "composite": ({"kind": "composite", "kp": 100.0, "kd": 20.0}, FAST, [40.0, 10.0]),
    "flexible_fl": ({"kind": "flexible_fl", "kp": 100.0, "kd": 20.0}, FAST, [40.0, 10.0]),
    "flexible_fl_integral": (
        {"kind": "flexible_fl_integral", "kp": 100.0, "kd": 20.0},
        FAST,
        [40.0, 10.0],
    ),
}
INTEGRAL = {"ctc_integral": baselines, "flexible_fl_integral": flexible_robust}


def scenarios_for(name):
    controller, base, limits = LAWS[name]
    flexible = base is FAST
    plant = {"plant": FLEX} if flexible else {}
    common = merge(base, merge(plant, {"controller": {**controller, "torque_limit": limits}}))
    return [
        load_scenario(BASE, common),
        load_scenario(BASE, merge(common, {"plant": {"scale": {"m2": 1.2}, "payload": 0.1}})),
        load_scenario(
            BASE, merge(common, {"sensor": {"noise_std_rad": 0.002}, "seed": 3, "duration": 0.8})
        ),
    ]


def assert_saturates(traj, limits):
    for j, limit in enumerate(limits):
        at_limit = np.abs(traj.tau[:, j]) == limit
        assert 20 <= at_limit.sum() < len(traj.t) - 20, (j, int(at_limit.sum()))


def assert_bitwise(single, batch, exact=True):
    assert batch.status == single.status == "ok", (single.status, single.message)
    for field in ("t", "q", "qd", "motor_q", "tau"):
        a, b = getattr(single, field), getattr(batch, field)
        assert a.shape == b.shape, field
        if exact and LIBM:
            assert np.array_equal(a, b), (field, float(np.abs(a - b).max()))
        else:
            np.testing.assert_allclose(b, a, rtol=0, atol=1e-12, err_msg=field)


@pytest.mark.parametrize("name", list(LAWS))
def test_saturated_batch_laws_equal_the_single_arm_laws_to_the_bit(name, monkeypatch):
    scenarios = scenarios_for(name)
    limits = LAWS[name][2]
    singles = [run_scenario(s) for s in scenarios]
    assert_saturates(singles[0], limits)
    for single, batch in zip(singles, run_scenarios(scenarios), strict=True):
        assert_bitwise(single, batch)
    if name in INTEGRAL:  # the anti-windup holds the integral in this run: without it ...
        always = lambda z, e, raw, tau, dt: z + e * dt  # noqa: E731
        monkeypatch.setattr(INTEGRAL[name], "integrate_unless_winding_up", always)
        windup = run_scenario(scenarios[0])
        assert np.abs(windup.q - singles[0].q).max() > 1e-3


@pytest.mark.parametrize("name", ["fcm_ctc", "fcm_ctc table", "fcm_ctc continuous", "fuzzy_pd"])
def test_fuzzy_laws_past_the_pure_python_path_agree_when_saturated(name):
    # 40 arms of one law: 80 inputs per call, the engines' numpy paths.
    rng = np.random.default_rng(11)
    scenarios = [_scaled(name, rng) for _ in range(40)]
    exact = name not in ("fcm_ctc", "fuzzy_pd")  # the Mamdani numpy path: 1e-12
    for s, batch in zip(scenarios, run_scenarios(scenarios), strict=True):
        assert_bitwise(run_scenario(s), batch, exact=exact)


def _scaled(name, rng):
    controller, base, limits = LAWS[name]
    data = merge(base, {"controller": {**controller, "torque_limit": limits}})
    scale = {"m1": float(rng.uniform(0.8, 1.2)), "m2": float(rng.uniform(0.8, 1.2))}
    return load_scenario(BASE, merge(data, {"plant": {"scale": scale}, "duration": 0.6}))
