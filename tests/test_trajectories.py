"""The field's test moves (twolink/foundation/trajectories.py): the multi-sine and the
tip's circle, against closed forms, finite differences and forward kinematics; as
scenario kinds and as the shipped runs/field/ scenarios."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from twolink.foundation.references import make_reference, reference_params
from twolink.foundation.trajectories import Circle, MultiSine, circle_point, forward_kinematics
from twolink.simulation.config import ConfigError, load_scenario

REPO = Path(__file__).resolve().parents[1]
T = np.linspace(0.0, 6.0, 60001)  # 0.1 ms


def finite_differences(ref, t=T):
    """Central differences of the sampled position and rate: (rate, acceleration)."""
    x = ref.sample(t)
    h = t[1] - t[0]
    return (x[0, 2:] - x[0, :-2]) / (2 * h), (x[1, 2:] - x[1, :-2]) / (2 * h), x[:, 1:-1]


@pytest.mark.parametrize(
    "ref",
    [
        MultiSine(amplitude=0.1, frequency_hz=0.2, harmonics=3),
        MultiSine(amplitude=-0.3, frequency_hz=1.1, harmonics=1, offset=0.4),
        Circle(joint=1, radius=0.3, period=4.0),
        Circle(joint=2, radius=0.5, period=1.5, centre_x=-0.4, centre_y=1.1, elbow=-1.0),
    ],
)
def test_rates_and_accelerations_are_the_derivatives(ref):
    """Rates and accelerations equal central differences of the positions and rates
    (to their O(h²) error, h = 0.1 ms); the scalar path equals the vectorised one."""
    v, a, x = finite_differences(ref)
    scale = np.abs(x).max(axis=1)
    assert np.abs(v - x[1]).max() < 1e-6 * max(1.0, scale[2])
    assert np.abs(a - x[2]).max() < 1e-5 * max(1.0, scale[2])
    for t in (0.0, 0.37, 2.5, 5.9):
        np.testing.assert_allclose(ref(t), ref.sample(np.array(t)), rtol=1e-14, atol=1e-14)
    assert math.isnan(ref.final)


def test_the_multisines_jerk_and_snap_are_the_derivatives():
    ref = MultiSine(amplitude=0.1, frequency_hz=0.7, harmonics=3)
    d = ref.sample_derivatives(T, 4)
    h = T[1] - T[0]
    for k in (3, 4):
        fd = (d[k - 1, 2:] - d[k - 1, :-2]) / (2 * h)
        assert np.abs(fd - d[k, 1:-1]).max() < 1e-5 * np.abs(d[k]).max()
    np.testing.assert_allclose(d[:3], ref.sample(T), rtol=0, atol=1e-13 * np.abs(d[2]).max())


def test_the_multisine_is_its_closed_form_and_starts_at_rest():
    ref = MultiSine(amplitude=0.1, frequency_hz=0.2, harmonics=3, offset=0.05)
    w = 2 * np.pi * 0.2 * np.arange(1, 4)
    want = 0.05 + 0.1 * np.sum(1 - np.cos(np.outer(T, w)), axis=1)
    np.testing.assert_allclose(ref.sample(T)[0], want, rtol=0, atol=1e-15)
    q, v, a = ref(0.0)
    assert (q, v) == (0.05, 0.0) and a == pytest.approx(0.1 * np.sum(w**2))
    np.testing.assert_allclose(ref.sample(T + 5.0)[0], ref.sample(T)[0], atol=1e-12)


def test_the_circle_is_the_tips_path():
    """Forward kinematics of the sampled angles is the circle (to rounding), at the
    circle's own speed, for both elbows; θ1 is continuous round the circle."""
    for elbow in (1.0, -1.0):
        c1, c2 = (
            Circle(joint=j, radius=0.35, period=2.0, centre_x=0.2, centre_y=1.3, elbow=elbow)
            for j in (1, 2)
        )
        q1, q2 = c1.sample(T), c2.sample(T)
        x, y = forward_kinematics(q1[0], q2[0], 1.0, 1.0)
        (px, py), _, _ = circle_point(c1, T)
        assert np.abs(x - px).max() < 1e-14 and np.abs(y - py).max() < 1e-14
        assert np.all(np.sign(np.sin(q2[0])) == elbow)
        assert np.abs(np.diff(q1[0])).max() < 1e-2  # no wrap
        # the tip's velocity from the joint rates: J qd
        vx = -np.sin(q1[0]) * q1[1] - np.sin(q1[0] + q2[0]) * (q1[1] + q2[1])
        (_, _), (wx, _), _ = circle_point(c1, T)
        np.testing.assert_allclose(vx, wx, rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"radius": 1.2}, "reach"),
        ({"centre_x": 0.1, "centre_y": 0.1, "radius": 0.13}, "base"),
        ({"joint": 3}, "joint"),
        ({"elbow": 0.5}, "elbow"),
        ({"period": 0.0}, "period"),
    ],
)
def test_bad_circles_are_refused(params, message):
    args = {"joint": 1, "radius": 0.3, "period": 2.0, **params}
    with pytest.raises(ValueError, match=message):
        make_reference("circle", **args)


def test_bad_multisines_are_refused():
    for params, message in (
        ({"harmonics": 2.5}, "harmonics"),
        ({"harmonics": 0}, "harmonics"),
        ({"frequency_hz": -1.0}, "frequency_hz"),
    ):
        with pytest.raises(ValueError, match=message):
            make_reference("multisine", **{"amplitude": 0.1, "frequency_hz": 0.2, **params})


def test_both_round_trip_through_their_parameters():
    for ref in (MultiSine(0.1, 0.2, 3), Circle(joint=2, radius=0.3, period=4.0)):
        assert make_reference(**reference_params(ref)) == ref


def test_the_shipped_field_scenarios_run_and_the_circle_starts_on_its_reference():
    circle = load_scenario("field/circle")
    (q1, q2), (w1, w2), _ = circle.reference.joint1.joints(0.0)
    np.testing.assert_allclose(circle.q0, (q1, q2), rtol=0, atol=1e-15)
    np.testing.assert_allclose(circle.qd0, (w1, w2), rtol=0, atol=1e-15)
    assert circle.reference.joint1.l1 == circle.arm.l1  # filled in from [arm]
    sine = load_scenario("field/multisine")
    assert sine.controller.kind == "adaptive_ctc" and sine.reference.joint1.kind == "multisine"


def test_a_circle_must_be_the_same_for_both_joints():
    base = {"kind": "circle", "radius": 0.3, "period": 4.0, "replace": True}
    with pytest.raises(ConfigError, match="reference.joint2: a circle"):
        load_scenario(
            "runs/paper/theta1_step.toml",
            {"reference": {"joint1": base, "joint2": {**base, "radius": 0.2}}},
        )
    with pytest.raises(ConfigError, match="reference.joint1.joint: must be 1"):
        load_scenario(
            "runs/paper/theta1_step.toml",
            {"reference": {"joint1": {**base, "joint": 2}, "joint2": base}},
        )


def test_the_new_kinds_and_keys_are_documented():
    doc = (REPO / "docs" / "scenarios.md").read_text()
    for cls in (MultiSine, Circle):
        assert f'`"{cls.kind}"`' in doc
        for name in cls.__dataclass_fields__:
            assert f"`{name}`" in doc, (cls.kind, name)
    for key in ("gamma", "eta", "phi", "observer_time"):
        assert f"`{key}`" in doc
    for kind in ("adaptive_ctc", "sliding_mode", "ctc_dob"):
        assert f'`"{kind}"`' in doc
