"""Joint-space reference trajectories: position, velocity and acceleration of each joint.

Each per-joint reference is a small frozen dataclass with

- ``ref(t) -> (q, v, a)``: plain Python floats, for the 1 kHz control loop (``math`` only,
  no numpy on this path);
- ``ref.sample(t) -> ndarray (3, N)``: the same values for an array of times, vectorised,
  equal to the scalar path sample for sample;
- ``ref.final``: the value the reference settles at (the target used by the step metrics);
- ``ref.derivatives(t, n)`` and ``ref.sample_derivatives(t, n)``: position and its first
  ``n`` derivatives (n <= 4: jerk and snap too), what feedback linearisation of the
  flexible-joint arm needs (``controllers/flexible.py``). Not part of the protocol: a
  reference without them is refused there, not guessed. Derivatives are those of the
  segment in force (the impulses at a step or corner are never fed forward).

Every piecewise reference is right-continuous: at a switching time (``t0`` of a step, the
corners of a ramp) it takes the value of the segment that starts there. Times are assumed
finite; the scalar path does not check them, to stay cheap.

:class:`ArmReference` pairs two joint references, and :func:`make_reference` builds one from a
kind name and keyword parameters (the form a TOML scenario file gives).
"""

from __future__ import annotations

import math
from dataclasses import MISSING, asdict, dataclass, fields
from typing import Any, ClassVar, Protocol, runtime_checkable

import numpy as np

from twolink.foundation.reference_fields import (
    REQUIRED,
    _as_times,
    _check_order,
    _validate_fields,
)

__all__ = [
    "ArmReference",
    "JointReference",
    "Quintic",
    "Ramp",
    "Septic",
    "Sine",
    "Step",
    "make_reference",
    "reference_params",
]


@runtime_checkable
class JointReference(Protocol):
    """What the controllers and the simulation loop need from a one-joint reference."""

    def __call__(self, t: float) -> tuple[float, float, float]: ...

    def sample(self, t: np.ndarray) -> np.ndarray: ...

    @property
    def final(self) -> float: ...


def _held(value: float, n: int) -> tuple[float, ...]:
    """A value held still: it and ``n`` zero derivatives."""
    return (value,) + (0.0,) * n


@dataclass(frozen=True, slots=True)
class Step:
    """A step from ``initial`` to ``final`` at time ``t0``.

    Velocity and acceleration are 0 everywhere: the step's derivative is an impulse, which is
    not fed forward (a controller sees only the position jump, through its error).

    Parameters
    ----------
    initial : float, default 0.0
        Value before ``t0``.
    final : float
        Value from ``t0`` on (the step is right-continuous: at ``t0`` it is already ``final``).
    t0 : float, default 0.0
        Time of the step [s].
    """

    kind: ClassVar[str] = "step"

    initial: float = 0.0
    final: float = REQUIRED
    t0: float = 0.0

    def __post_init__(self) -> None:
        _validate_fields(self)

    def __call__(self, t: float) -> tuple[float, float, float]:
        """Return ``(position, velocity, acceleration)`` at time ``t``."""
        if t < self.t0:
            return (self.initial, 0.0, 0.0)
        return (self.final, 0.0, 0.0)

    def sample(self, t: np.ndarray) -> np.ndarray:
        """Vectorised ``__call__``: rows (position, velocity, acceleration), shape (3, *t.shape)."""
        t = _as_times(t)
        out = np.zeros((3, *t.shape))
        out[0] = np.where(t < self.t0, self.initial, self.final)
        return out

    def derivatives(self, t: float, n: int) -> tuple[float, ...]:
        """Position and its first ``n`` derivatives at ``t`` (all zero: impulses not fed)."""
        _check_order(n)
        return _held(self.initial if t < self.t0 else self.final, n)

    def sample_derivatives(self, t: np.ndarray, n: int) -> np.ndarray:
        """Vectorised :meth:`derivatives`: shape (n + 1, *t.shape)."""
        _check_order(n)
        out = np.zeros((n + 1, *np.shape(t)))
        out[:3] = self.sample(t)[: n + 1]
        return out


@dataclass(frozen=True, slots=True)
class _Move:
    """A move from ``initial`` to ``final`` that starts at ``t0`` and lasts ``duration``,
    held still before and after: the fields and validation :class:`Ramp`,
    :class:`Quintic` and :class:`Septic` share (documented on each)."""

    initial: float = 0.0
    final: float = REQUIRED
    duration: float = REQUIRED
    t0: float = 0.0

    def __post_init__(self) -> None:
        _validate_fields(self, positive=("duration",))


@dataclass(frozen=True, slots=True)
class Ramp(_Move):
    """The paper's saturating ramp: linear from ``initial`` to ``final`` over ``duration``.

    Holds ``initial`` before ``t0``, rises (or falls) linearly during
    ``[t0, t0 + duration)``, then holds ``final``. Velocity is the slope during the ramp and 0
    outside it; acceleration is 0 everywhere (the impulses at the two corners are not fed
    forward).

    Parameters
    ----------
    initial, final : float
        Start and end values; ``initial`` defaults to 0.0, ``final`` is required.
    duration : float
        Time taken to go from ``initial`` to ``final`` [s], > 0.
    t0 : float, default 0.0
        Time the ramp starts [s].
    """

    kind: ClassVar[str] = "ramp"

    def __call__(self, t: float) -> tuple[float, float, float]:
        """Return ``(position, velocity, acceleration)`` at time ``t``."""
        s = t - self.t0
        if s < 0.0:
            return (self.initial, 0.0, 0.0)
        if s < self.duration:
            slope = (self.final - self.initial) / self.duration
            return (self.initial + slope * s, slope, 0.0)
        return (self.final, 0.0, 0.0)

    def sample(self, t: np.ndarray) -> np.ndarray:
        """Vectorised ``__call__``: rows (position, velocity, acceleration), shape (3, *t.shape)."""
        s = _as_times(t) - self.t0
        slope = (self.final - self.initial) / self.duration
        before = s < 0.0
        during = ~before & (s < self.duration)
        out = np.zeros((3, *s.shape))
        out[0] = np.where(
            before, self.initial, np.where(during, self.initial + slope * s, self.final)
        )
        out[1] = np.where(during, slope, 0.0)
        return out

    def derivatives(self, t: float, n: int) -> tuple[float, ...]:
        """Position and its first ``n`` derivatives at ``t`` (zero beyond the velocity)."""
        _check_order(n)
        return (*self(t), 0.0, 0.0)[: n + 1]

    def sample_derivatives(self, t: np.ndarray, n: int) -> np.ndarray:
        """Vectorised :meth:`derivatives`: shape (n + 1, *t.shape)."""
        _check_order(n)
        out = np.zeros((n + 1, *np.shape(t)))
        out[: min(n + 1, 3)] = self.sample(t)[: n + 1]
        return out


@dataclass(frozen=True, slots=True)
class Sine:
    """A sinusoid ``offset + amplitude * sin(2 pi frequency_hz t + phase)``.

    It never settles, so :attr:`final` is NaN: step metrics make no sense against it, and
    :func:`twolink.simulation.metrics.step_metrics` refuses a NaN target.

    Parameters
    ----------
    amplitude : float
        Amplitude (may be negative or zero).
    frequency_hz : float
        Frequency [Hz], > 0.
    offset : float, default 0.0
        Mean value.
    phase : float, default 0.0
        Phase at ``t = 0`` [rad].
    """

    kind: ClassVar[str] = "sine"

    amplitude: float
    frequency_hz: float
    offset: float = 0.0
    phase: float = 0.0

    def __post_init__(self) -> None:
        _validate_fields(self, positive=("frequency_hz",))

    @property
    def final(self) -> float:
        """NaN: a sine has no value it settles at."""
        return math.nan

    def __call__(self, t: float) -> tuple[float, float, float]:
        """Return ``(position, velocity, acceleration)`` at time ``t``."""
        w = 2.0 * math.pi * self.frequency_hz
        arg = w * t + self.phase
        s = self.amplitude * math.sin(arg)
        return (self.offset + s, self.amplitude * w * math.cos(arg), -(w * w) * s)

    def sample(self, t: np.ndarray) -> np.ndarray:
        """Vectorised ``__call__``: rows (position, velocity, acceleration), shape (3, *t.shape)."""
        w = 2.0 * math.pi * self.frequency_hz
        arg = w * _as_times(t) + self.phase
        s = self.amplitude * np.sin(arg)
        return np.stack([self.offset + s, self.amplitude * w * np.cos(arg), -(w * w) * s])

    def derivatives(self, t: float, n: int) -> tuple[float, ...]:
        """Position and its first ``n`` derivatives at ``t`` (the first three as
        :meth:`__call__`, to the bit)."""
        _check_order(n)
        w = 2.0 * math.pi * self.frequency_hz
        arg = w * t + self.phase
        s = self.amplitude * math.sin(arg)
        c = self.amplitude * w * math.cos(arg)
        w2 = w * w
        return (self.offset + s, c, -w2 * s, -w2 * c, w2 * w2 * s)[: n + 1]

    def sample_derivatives(self, t: np.ndarray, n: int) -> np.ndarray:
        """Vectorised :meth:`derivatives`: shape (n + 1, *t.shape)."""
        _check_order(n)
        w = 2.0 * math.pi * self.frequency_hz
        arg = w * _as_times(t) + self.phase
        s = self.amplitude * np.sin(arg)
        c = self.amplitude * w * np.cos(arg)
        w2 = w * w
        return np.stack([self.offset + s, c, -w2 * s, -w2 * c, w2 * w2 * s][: n + 1])


# The moves' polynomials in s, Horner forms, per unit of move (times ``final - initial``,
# over ``duration`` to the power of the order): one expression for a float (the scalar
# path) and an array (the vectorised one), so both round the same way, to the bit.


def _quintic_pva(s):
    """The quintic's position, velocity and acceleration."""
    return (
        s * s * s * (10.0 + s * (-15.0 + s * 6.0)),
        s * s * (30.0 + s * (-60.0 + s * 30.0)),
        s * (60.0 + s * (-180.0 + s * 120.0)),
    )


def _quintic_jerk_snap(s):
    """The quintic's jerk and snap."""
    return 60.0 + s * (-360.0 + s * 360.0), -360.0 + s * 720.0


def _septic(s):
    """The septic's position and its first four derivatives."""
    s2 = s * s
    return (
        s2 * s2 * (35.0 + s * (-84.0 + s * (70.0 - 20.0 * s))),
        s2 * s * (140.0 + s * (-420.0 + s * (420.0 - 140.0 * s))),
        s2 * (420.0 + s * (-1680.0 + s * (2100.0 - 840.0 * s))),
        s * (840.0 + s * (-5040.0 + s * (8400.0 - 4200.0 * s))),
        840.0 + s * (-10080.0 + s * (25200.0 - 16800.0 * s)),
    )


@dataclass(frozen=True, slots=True)
class _RestToRest(_Move):
    """A polynomial move, at rest at both ends: what :class:`Quintic` and :class:`Septic`
    share beyond a move's fields (the held ends). Each gives its polynomial in
    ``s = (t - t0) / duration`` (in [0, 1) during the move): ``_moving`` for
    :meth:`derivatives`, and its own vectorised paths.
    """

    def derivatives(self, t: float, n: int) -> tuple[float, ...]:
        """Position and its first ``n`` derivatives (n <= 4) at time ``t``: ``initial``
        (before ``t0``) or ``final`` (from ``t0 + duration`` on) and zeros outside the
        move, the polynomial's inside."""
        _check_order(n)
        s = (t - self.t0) / self.duration
        if s < 0.0:
            return _held(self.initial, n)
        if s >= 1.0:
            return _held(self.final, n)
        return self._moving(t, s, n)

    def _moving(self, t: float, s: float, n: int) -> tuple[float, ...]:
        """The polynomial's position and first ``n`` derivatives at ``t`` (``s`` in [0, 1))."""
        raise NotImplementedError

    def _phases(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Vectorised: ``s`` at the times ``t`` and where they fall before, after and
        during the move."""
        s = (_as_times(t) - self.t0) / self.duration
        before = s < 0.0
        after = s >= 1.0
        return s, before, after, ~before & ~after

    def _position(self, before: np.ndarray, after: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Vectorised position: ``initial`` before, ``final`` after, and
        ``initial + (final - initial) p`` during the move (``p`` the polynomial at ``s``)."""
        d = self.final - self.initial
        return np.where(before, self.initial, np.where(after, self.final, self.initial + d * p))


@dataclass(frozen=True, slots=True)
class Quintic(_RestToRest):
    """A smooth point-to-point move: the quintic with zero velocity and acceleration at both ends.

    With ``s = (t - t0) / duration`` in [0, 1] the position is
    ``initial + (final - initial) (10 s^3 - 15 s^4 + 6 s^5)`` (the minimum-jerk profile);
    before ``t0`` it holds ``initial`` and after ``t0 + duration`` it holds ``final``.
    Position, velocity and acceleration are continuous everywhere. The jerk jumps at both
    ends (from 0 to ``60 (final - initial) / duration^3`` at ``t0``, and back at the end):
    a step that feedback linearisation of a flexible joint cannot follow.

    Parameters
    ----------
    initial, final : float
        Start and end values; ``initial`` defaults to 0.0, ``final`` is required.
    duration : float
        Duration of the move [s], > 0.
    t0 : float, default 0.0
        Start time [s].
    """

    kind: ClassVar[str] = "quintic"

    def __call__(self, t: float) -> tuple[float, float, float]:
        """Return ``(position, velocity, acceleration)`` at time ``t``."""
        s = (t - self.t0) / self.duration
        if s < 0.0:
            return (self.initial, 0.0, 0.0)
        if s >= 1.0:
            return (self.final, 0.0, 0.0)
        d = self.final - self.initial
        p, v, a = _quintic_pva(s)
        return (
            self.initial + d * p,
            d * v / self.duration,
            d * a / (self.duration * self.duration),
        )

    def sample(self, t: np.ndarray) -> np.ndarray:
        """Vectorised ``__call__``: rows (position, velocity, acceleration), shape (3, *t.shape)."""
        s, before, after, during = self._phases(t)
        d = self.final - self.initial
        p, v, a = _quintic_pva(s)
        out = np.zeros((3, *s.shape))
        out[0] = self._position(before, after, p)
        out[1] = np.where(during, d * v / self.duration, 0.0)
        out[2] = np.where(during, d * a / (self.duration * self.duration), 0.0)
        return out

    def _moving(self, t: float, s: float, n: int) -> tuple[float, ...]:
        T = self.duration
        d = self.final - self.initial
        j, snap = _quintic_jerk_snap(s)
        return (*self(t), d * j / (T * T * T), d * snap / (T * T * T * T))[: n + 1]

    def sample_derivatives(self, t: np.ndarray, n: int) -> np.ndarray:
        """Vectorised :meth:`derivatives`: shape (n + 1, *t.shape)."""
        _check_order(n)
        s = (_as_times(t) - self.t0) / self.duration
        during = (s >= 0.0) & (s < 1.0)
        T = self.duration
        d = self.final - self.initial
        out = np.zeros((n + 1, *s.shape))
        out[: min(n + 1, 3)] = self.sample(t)[: n + 1]
        if n >= 3:
            j, snap = _quintic_jerk_snap(s)
            out[3] = np.where(during, d * j / (T * T * T), 0.0)
        if n >= 4:
            out[4] = np.where(during, d * snap / (T * T * T * T), 0.0)
        return out


@dataclass(frozen=True, slots=True)
class Septic(_RestToRest):
    """A rest-to-rest move with continuous jerk: the 7th-order polynomial with zero velocity,
    acceleration and jerk at both ends.

    With ``s = (t - t0) / duration`` in [0, 1] the position is
    ``initial + (final - initial) (35 s^4 - 84 s^5 + 70 s^6 - 20 s^7)``; before ``t0`` it
    holds ``initial`` and after ``t0 + duration`` it holds ``final``. Position, velocity,
    acceleration and jerk are continuous everywhere; the snap (4th derivative) jumps at
    both ends, by ``840 (final - initial) / duration^4``. Feedback linearisation of the
    flexible-joint arm feeds the snap forward and needs the jerk continuous
    (``docs/control.md``, "Flexible-joint controllers").

    Parameters
    ----------
    initial, final : float
        Start and end values; ``initial`` defaults to 0.0, ``final`` is required.
    duration : float
        Duration of the move [s], > 0.
    t0 : float, default 0.0
        Start time [s].
    """

    kind: ClassVar[str] = "septic"

    def __call__(self, t: float) -> tuple[float, float, float]:
        """Return ``(position, velocity, acceleration)`` at time ``t``."""
        return self.derivatives(t, 2)  # type: ignore[return-value]

    def _moving(self, t: float, s: float, n: int) -> tuple[float, ...]:
        T = self.duration
        d = self.final - self.initial
        p, v, a, j, snap = _septic(s)
        return (
            self.initial + d * p,
            d * v / T,
            d * a / (T * T),
            d * j / (T * T * T),
            d * snap / (T * T * T * T),
        )[: n + 1]

    def sample(self, t: np.ndarray) -> np.ndarray:
        """Vectorised ``__call__``: rows (position, velocity, acceleration), shape (3, *t.shape)."""
        return self.sample_derivatives(t, 2)

    def sample_derivatives(self, t: np.ndarray, n: int) -> np.ndarray:
        """Vectorised :meth:`derivatives`: shape (n + 1, *t.shape)."""
        _check_order(n)
        s, before, after, during = self._phases(t)
        T = self.duration
        d = self.final - self.initial
        rows = _septic(s)
        out = np.zeros((n + 1, *s.shape))
        out[0] = self._position(before, after, rows[0])
        scale = 1.0
        for k in range(1, n + 1):
            scale = scale * T
            out[k] = np.where(during, d * rows[k] / scale, 0.0)
        return out


@dataclass(frozen=True, slots=True)
class ArmReference:
    """The references of both joints.

    Parameters
    ----------
    joint1, joint2 : JointReference
        Reference of joint 1 (θ1) and joint 2 (θ2).
    """

    joint1: JointReference
    joint2: JointReference

    def __post_init__(self) -> None:
        for name in ("joint1", "joint2"):
            ref = getattr(self, name)
            if not isinstance(ref, JointReference):
                raise ValueError(
                    f"ArmReference.{name} must be a joint reference (Step, Ramp, Sine, "
                    f"Quintic, Septic, ...), got {ref!r}"
                )

    def __call__(
        self, t: float
    ) -> tuple[tuple[float, float], tuple[float, float], tuple[float, float]]:
        """Return ``((q1d, q2d), (v1d, v2d), (a1d, a2d))`` at time ``t``, as floats."""
        q1, v1, a1 = self.joint1(t)
        q2, v2, a2 = self.joint2(t)
        return ((q1, q2), (v1, v2), (a1, a2))

    def sample(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Vectorised ``__call__``.

        Parameters
        ----------
        t : ndarray, shape (N,)
            Times [s].

        Returns
        -------
        qd, vd, ad : ndarray, shape (N, 2)
            Desired positions, velocities and accelerations; column j is joint j + 1.
        """
        s1 = self.joint1.sample(t)
        s2 = self.joint2.sample(t)
        qd, vd, ad = (np.stack([s1[k], s2[k]], axis=-1) for k in range(3))
        return qd, vd, ad

    @property
    def final(self) -> tuple[float, float]:
        """The values both joints settle at (NaN for a joint that never settles)."""
        return (self.joint1.final, self.joint2.final)


def _reference_classes() -> dict[str, type]:
    from twolink.foundation.trajectories import FIELD_REFERENCES

    return {cls.kind: cls for cls in (Step, Ramp, Sine, Quintic, Septic, *FIELD_REFERENCES)}


def make_reference(kind: str, **params: Any) -> Step | Ramp | Sine | Quintic | Septic:
    """Build a joint reference from its kind name and parameters.

    Parameters
    ----------
    kind : {"step", "ramp", "sine", "quintic", "septic", "multisine", "circle"}
        Which reference (the last two: :mod:`twolink.foundation.trajectories`).
    **params
        The class's fields, e.g. ``make_reference("ramp", initial=0, final=1, duration=5)``.

    Returns
    -------
    Step or Ramp or Sine or Quintic or Septic

    Raises
    ------
    ValueError
        For an unknown kind, an unknown or missing parameter, or an invalid value; the
        message names the kind or the parameter.
    """
    classes = _reference_classes()
    cls = classes.get(kind)
    if cls is None:
        raise ValueError(f"unknown reference kind {kind!r}; expected one of {sorted(classes)}")
    names = [f.name for f in fields(cls)]
    unknown = sorted(set(params) - set(names))
    if unknown:
        raise ValueError(
            f"unknown parameter(s) {unknown} for reference kind {kind!r}; expected {names}"
        )
    missing = [
        f.name
        for f in fields(cls)
        if f.name not in params
        and (f.default is MISSING or f.default is REQUIRED)
        and f.default_factory is MISSING
    ]
    if missing:
        raise ValueError(f"missing parameter(s) {missing} for reference kind {kind!r}")
    return cls(**params)


def reference_params(ref: Step | Ramp | Sine | Quintic | Septic) -> dict[str, Any]:
    """The inverse of :func:`make_reference`: ``{"kind": ..., **fields}``.

    ``make_reference(**reference_params(ref)) == ref``; handy for writing a resolved config.
    """
    return {"kind": ref.kind, **asdict(ref)}
