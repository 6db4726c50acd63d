"""Tests of the joint references: scalar vs vectorised, derivatives, shapes, validation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from twolink.foundation.references import (
    ArmReference,
    Quintic,
    Ramp,
    Septic,
    Sine,
    Step,
    make_reference,
    reference_params,
)

REFERENCES = [
    Step(initial=0.2, final=-1.3, t0=0.5),
    Ramp(initial=-0.4, final=1.1, duration=2.5, t0=0.7),
    Ramp(initial=1.0, final=0.25, duration=0.3),
    Sine(amplitude=0.8, frequency_hz=0.7, offset=0.1, phase=0.3),
    Quintic(initial=0.5, final=-1.0, duration=1.7, t0=0.4),
    Septic(initial=0.5, final=-1.0, duration=1.7, t0=0.4),
]
IDS = ["step", "ramp", "ramp-down", "sine", "quintic", "septic"]


def _times(ref) -> np.ndarray:
    """A grid through, before and after the reference's switching times, corners included."""
    t = np.linspace(-1.0, 5.0, 6001)
    corners = [getattr(ref, "t0", 0.0)]
    if hasattr(ref, "duration"):
        corners.append(ref.t0 + ref.duration)
    return np.sort(np.concatenate([t, corners]))


@pytest.mark.parametrize("ref", REFERENCES, ids=IDS)
def test_scalar_path_equals_vectorised(ref) -> None:
    t = _times(ref)
    scalar = np.array([ref(float(ti)) for ti in t]).T
    vector = ref.sample(t)
    assert vector.shape == (3, t.size)
    if isinstance(ref, Sine):
        # math.sin and np.sin may differ in the last bit on some platforms.
        np.testing.assert_allclose(vector, scalar, rtol=0, atol=1e-13)
    else:
        np.testing.assert_array_equal(vector, scalar)


@pytest.mark.parametrize("ref", REFERENCES, ids=IDS)
def test_scalar_path_returns_python_floats(ref) -> None:
    for t in (-1.0, 0.5, 1.0, 10.0):
        values = ref(t)
        assert len(values) == 3
        assert all(type(v) is float for v in values)
    assert type(ref.final) is float


def test_fields_are_stored_as_floats() -> None:
    ref = Ramp(initial=0, final=np.int64(2), duration=np.float32(4.0))
    assert ref(1.0) == (0.5, 0.5, 0.0)
    assert all(type(v) is float for v in (ref.initial, ref.final, ref.duration, ref.t0))


def _central_difference(f, t: np.ndarray, h: float) -> np.ndarray:
    return (f(t + h) - f(t - h)) / (2.0 * h)


@pytest.mark.parametrize(
    ("ref", "t"),
    [
        # Off the ends 0.4 and 2.1, where the jerk jumps and a difference of v is O(h) off.
        (Quintic(initial=0.5, final=-1.0, duration=1.7, t0=0.4), np.linspace(-0.5, 3.0, 70)),
        (Sine(amplitude=0.8, frequency_hz=0.7, offset=0.1, phase=0.3), np.linspace(0, 3, 61)),
        # Inside the ramp's three segments, away from the corners at 0.7 and 3.2.
        (Ramp(initial=-0.4, final=1.1, duration=2.5, t0=0.7), np.r_[-0.5:0.6:0.1, 0.8:3.1:0.1]),
        (Ramp(initial=-0.4, final=1.1, duration=2.5, t0=0.7), np.linspace(3.3, 5.0, 18)),
    ],
    ids=["quintic", "sine", "ramp-before-during", "ramp-after"],
)
def test_derivatives_match_finite_differences(ref, t: np.ndarray) -> None:
    h = 1e-5
    _, v, a = ref.sample(t)
    v_fd = _central_difference(lambda s: ref.sample(s)[0], t, h)
    a_fd = _central_difference(lambda s: ref.sample(s)[1], t, h)
    # Central differences: truncation O(h^2 q''') ~ 1e-9, rounding O(eps / h) ~ 1e-11.
    np.testing.assert_allclose(v, v_fd, rtol=0, atol=1e-7)
    np.testing.assert_allclose(a, a_fd, rtol=0, atol=1e-6)


def test_ramp_rises_linearly_then_saturates() -> None:
    ref = Ramp(initial=1.0, final=3.0, duration=4.0, t0=2.0)
    assert ref(0.0) == (1.0, 0.0, 0.0)
    assert ref(2.0) == (1.0, 0.5, 0.0)  # right-continuous: the ramp has started at t0
    assert ref(4.0) == (2.0, 0.5, 0.0)
    assert ref(6.0) == (3.0, 0.0, 0.0)  # the corner belongs to the hold
    for t in (6.0 + 1e-9, 7.0, 100.0, 1e6):
        assert ref(t) == (3.0, 0.0, 0.0)
    assert ref.final == 3.0


def test_ramp_downwards() -> None:
    ref = Ramp(initial=0.5, final=-0.5, duration=2.0)
    assert ref(1.0) == (0.0, -0.5, 0.0)
    assert ref(5.0) == (-0.5, 0.0, 0.0)


def test_step_switches_at_t0() -> None:
    ref = Step(initial=-1.0, final=2.0, t0=1.0)
    assert ref(0.999) == (-1.0, 0.0, 0.0)
    assert ref(1.0) == (2.0, 0.0, 0.0)
    assert ref(3.0) == (2.0, 0.0, 0.0)
    assert ref.final == 2.0


def test_quintic_boundary_conditions_and_symmetry() -> None:
    ref = Quintic(initial=1.0, final=3.0, duration=2.0, t0=1.0)
    assert ref(1.0) == (1.0, 0.0, 0.0)
    assert ref(3.0) == (3.0, 0.0, 0.0)
    # Continuity at the ends: the polynomial itself goes to the end values with zero slope.
    for t, q_end in ((1.0 + 1e-6, 1.0), (3.0 - 1e-6, 3.0)):
        q, v, a = ref(t)
        assert q == pytest.approx(q_end, abs=1e-12)
        assert v == pytest.approx(0.0, abs=1e-9)
        assert a == pytest.approx(0.0, abs=1e-4)
    # Midpoint: half-way, at the peak velocity 15/8 * D / T, with zero acceleration.
    q, v, a = ref(2.0)
    assert q == pytest.approx(2.0, abs=1e-15)
    assert v == pytest.approx(15.0 / 8.0 * 2.0 / 2.0, abs=1e-15)
    assert a == pytest.approx(0.0, abs=1e-14)


def test_sine_values_and_final() -> None:
    ref = Sine(amplitude=2.0, frequency_hz=0.25, offset=1.0)
    w = 2.0 * math.pi * 0.25
    q, v, a = ref(1.0)  # a quarter period: the crest
    assert q == pytest.approx(3.0, abs=1e-15)
    assert v == pytest.approx(0.0, abs=1e-15)
    assert a == pytest.approx(-2.0 * w * w, abs=1e-15)
    assert math.isnan(ref.final)


def test_sample_keeps_the_shape_of_t() -> None:
    ref = Quintic(initial=0.0, final=1.0, duration=1.0)
    assert ref.sample(np.zeros((4, 5))).shape == (3, 4, 5)
    assert ref.sample(0.5).shape == (3,)


def test_arm_reference() -> None:
    j1 = Ramp(initial=0.0, final=1.0, duration=2.0)
    j2 = Quintic(initial=1.0, final=-1.0, duration=3.0, t0=0.5)
    arm = ArmReference(j1, j2)
    (q1, q2), (v1, v2), (a1, a2) = arm(1.0)
    assert (q1, v1, a1) == j1(1.0)
    assert (q2, v2, a2) == j2(1.0)
    assert all(type(x) is float for x in (q1, q2, v1, v2, a1, a2))
    assert arm.final == (1.0, -1.0)

    t = np.linspace(0.0, 4.0, 41)
    qd, vd, ad = arm.sample(t)
    for arr in (qd, vd, ad):
        assert arr.shape == (41, 2)
    for k, arr in enumerate((qd, vd, ad)):
        np.testing.assert_array_equal(arr[:, 0], j1.sample(t)[k])
        np.testing.assert_array_equal(arr[:, 1], j2.sample(t)[k])
    scalar = np.array([arm(float(ti)) for ti in t])  # (N, 3, 2)
    np.testing.assert_array_equal(scalar[:, 0], qd)
    np.testing.assert_array_equal(scalar[:, 1], vd)
    np.testing.assert_array_equal(scalar[:, 2], ad)


def test_arm_reference_rejects_non_references() -> None:
    with pytest.raises(ValueError, match="joint2"):
        ArmReference(Step(0.0, 1.0), 1.0)


def test_references_are_frozen() -> None:
    ref = Step(0.0, 1.0)
    with pytest.raises(AttributeError):
        ref.final = 2.0


@pytest.mark.parametrize(
    ("cls", "kwargs", "field"),
    [
        (Step, {"initial": math.nan, "final": 1.0}, "initial"),
        (Step, {"initial": 0.0, "final": "1"}, "final"),
        (Step, {"initial": 0.0, "final": 1.0, "t0": math.inf}, "t0"),
        (Step, {"initial": True, "final": 1.0}, "initial"),
        (Ramp, {"initial": 0.0, "final": 1.0, "duration": 0.0}, "duration"),
        (Ramp, {"initial": 0.0, "final": 1.0, "duration": -1.0}, "duration"),
        (Ramp, {"initial": 0.0, "final": None, "duration": 1.0}, "final"),
        (Sine, {"amplitude": 1.0, "frequency_hz": 0.0}, "frequency_hz"),
        (Sine, {"amplitude": 1.0, "frequency_hz": 1.0, "phase": math.nan}, "phase"),
        (Sine, {"amplitude": [1.0], "frequency_hz": 1.0}, "amplitude"),
        (Quintic, {"initial": 0.0, "final": 1.0, "duration": -2.0}, "duration"),
        (Quintic, {"initial": 0.0, "final": -math.inf, "duration": 2.0}, "final"),
    ],
)
def test_validation_names_the_field(cls, kwargs, field) -> None:
    with pytest.raises(ValueError, match=rf"{cls.__name__}\.{field}\b"):
        cls(**kwargs)


@pytest.mark.parametrize("ref", REFERENCES, ids=IDS)
def test_make_reference_round_trip(ref) -> None:
    params = reference_params(ref)
    assert params["kind"] == type(ref).__name__.lower()
    assert make_reference(**params) == ref


def test_make_reference_builds_each_kind() -> None:
    assert make_reference("step", initial=0, final=1) == Step(0.0, 1.0)
    assert make_reference("ramp", initial=0, final=1, duration=2) == Ramp(0.0, 1.0, 2.0)
    assert make_reference("sine", amplitude=1, frequency_hz=2) == Sine(1.0, 2.0)
    assert make_reference("quintic", initial=0, final=1, duration=2) == Quintic(0.0, 1.0, 2.0)


def test_make_reference_errors_name_the_problem() -> None:
    with pytest.raises(ValueError, match="'parabola'"):
        make_reference("parabola", initial=0.0)
    with pytest.raises(ValueError, match="'slope'"):
        make_reference("ramp", initial=0.0, final=1.0, duration=1.0, slope=2.0)
    with pytest.raises(ValueError, match="'duration'"):
        make_reference("quintic", initial=0.0, final=1.0)
    with pytest.raises(ValueError, match=r"Ramp\.duration"):
        make_reference("ramp", initial=0.0, final=1.0, duration=-1.0)


def test_initial_defaults_to_zero_and_the_rest_is_required():
    from twolink.foundation.references import Quintic, Ramp, Step

    assert Step(final=1.0) == Step(0.0, 1.0)  # positional use unchanged
    assert Ramp(final=1.0, duration=2.0) == Ramp(0.0, 1.0, 2.0)
    assert Quintic(final=-0.5, duration=1.0)(0.0) == (0.0, 0.0, 0.0)
    for make, message in (
        (lambda: Step(), "Step.final is required"),
        (lambda: Step(1.0), "Step.final is required"),
        (lambda: Ramp(final=1.0), "Ramp.duration is required"),
    ):
        with pytest.raises(ValueError, match=message):
            make()
    with pytest.raises(ValueError, match=r"missing parameter\(s\) \['final'\]"):
        make_reference("step", initial=0.0)


# The moves' values, every path and order, on the grid of ``_times`` (before, during, after
# and the corners), as SHA-256 of their float64 bytes: pinned from the code before Quintic
# and Septic shared their held ends (_RestToRest), and they and Ramp their fields (_Move),
# so that refactor (or any later one) changes no sample by a bit. Only + - * / and
# comparisons: the same bits on every IEEE platform.
MOVES = {
    "ramp-up": Ramp(initial=-0.4, final=1.1, duration=2.5, t0=0.7),
    "ramp-down": Ramp(initial=1.0, final=0.25, duration=0.3),
    "quintic-up": Quintic(initial=0.5, final=-1.0, duration=1.7, t0=0.4),
    "quintic-down": Quintic(initial=1.25, final=-0.3, duration=0.45, t0=-0.2),
    "septic-up": Septic(initial=0.5, final=-1.0, duration=1.7, t0=0.4),
    "septic-down": Septic(initial=1.25, final=-0.3, duration=0.45, t0=-0.2),
}
MOVE_DIGESTS = {
    "ramp-up": "418da21c639fe417dca21f6f0b86450f14573dedf0adee0f91182435236fabc9",
    "ramp-down": "4d2d0c4c24c523e4c7bea38c48ddc17ffce114dbfca9c8b3b4ec006c79433ae0",
    "quintic-up": "707afcb295f9b9841a35a6291cd763bdd4eeb0b0ead2ec9816387f2b1b8afe08",
    "quintic-down": "5e2be3c737cdf9fb88b29c1f1def5f30ed910ae3313a3ea5bb90163dc52b92ee",
    "septic-up": "9248c6f7bf85d5ca0cb16d471ab87b8c2c97a7e1a791bcedbb1b5c55166fade9",
    "septic-down": "8e43d8083885d2c842d545137e778c8296e74a87404be8d4aaf7331297af6fc8",
}


def _move_bytes(ref) -> bytes:
    t = _times(ref)
    arrays = [ref.sample(t), np.array([ref(float(ti)) for ti in t])]
    for n in range(5):
        arrays.append(ref.sample_derivatives(t, n))
        arrays.append(np.array([ref.derivatives(float(ti), n) for ti in t]))
    return b"".join(np.ascontiguousarray(a, dtype="<f8").tobytes() for a in arrays)


@pytest.mark.parametrize("name", sorted(MOVES))
def test_move_samples_are_bit_identical_to_the_pinned_ones(name) -> None:
    import hashlib

    digest = hashlib.sha256(_move_bytes(MOVES[name])).hexdigest()
    assert digest == MOVE_DIGESTS[name], f"{name}: a sample changed (not bit-identical)"
