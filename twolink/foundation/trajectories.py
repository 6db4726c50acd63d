"""The field's test moves beside the paper's steps and ramps: a multi-sine joint
trajectory (persistently exciting: what an adaptive law needs to learn the arm's
parameters) and a circle of the tip in task space, through the arm's inverse kinematics.

Both are joint references (:class:`twolink.foundation.references.JointReference`), kinds
``"multisine"`` and ``"circle"`` of a scenario's ``[reference.jointN]``. Neither settles,
so their :attr:`final` is NaN, as a sine's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from twolink.foundation.reference_fields import _check_order, _validate_fields

__all__ = ["Circle", "MultiSine", "circle_point", "forward_kinematics"]

MAX_HARMONICS = 64


def _whole(obj: object, name: str, allowed: tuple[int, ...] | None, low: int = 1) -> None:
    value = getattr(obj, name)
    owner = type(obj).__name__
    if value != int(value) or (allowed is not None and int(value) not in allowed):
        raise ValueError(f"{owner}.{name} must be one of {allowed or 'the integers'}, got {value}")
    if allowed is None and not low <= value <= MAX_HARMONICS:
        raise ValueError(f"{owner}.{name} must be {low} to {MAX_HARMONICS}, got {value}")


@dataclass(frozen=True, slots=True)
class MultiSine:
    """``offset + amplitude * sum_{k=1..harmonics} (1 - cos(2 pi k frequency_hz t))``.

    It starts at rest at ``offset`` (position and rate; the acceleration starts at
    ``amplitude * sum (2 pi k f)²``, fed forward) and repeats every ``1 / frequency_hz``.
    With ``harmonics`` frequencies it excites up to ``2 harmonics`` parameters of a
    linear model (persistent excitation; Slotine & Li 1991, sec. 8.2).

    Parameters
    ----------
    amplitude : float
        Each harmonic's amplitude [rad] (may be negative or zero).
    frequency_hz : float
        The base frequency [Hz], > 0.
    harmonics : int
        How many harmonics of it, 1 to 64.
    offset : float, default 0.0
        The start [rad].
    """

    kind: ClassVar[str] = "multisine"

    amplitude: float
    frequency_hz: float
    harmonics: float = 3.0
    offset: float = 0.0

    def __post_init__(self) -> None:
        _validate_fields(self, positive=("frequency_hz",))
        _whole(self, "harmonics", None)

    @property
    def final(self) -> float:
        """NaN: a multi-sine has no value it settles at."""
        return math.nan

    def __call__(self, t: float) -> tuple[float, float, float]:
        """Return ``(position, velocity, acceleration)`` at time ``t``."""
        q, v, a = self.offset, 0.0, 0.0
        for k in range(1, int(self.harmonics) + 1):
            w = 2.0 * math.pi * k * self.frequency_hz
            c, s = math.cos(w * t), math.sin(w * t)
            q += self.amplitude * (1.0 - c)
            v += self.amplitude * w * s
            a += self.amplitude * w * w * c
        return q, v, a

    def sample(self, t: np.ndarray) -> np.ndarray:
        """Vectorised ``__call__``: rows (position, velocity, acceleration), shape (3, *t.shape)."""
        t = np.asarray(t, dtype=float)
        q, v, a = np.full(t.shape, self.offset), np.zeros(t.shape), np.zeros(t.shape)
        for k in range(1, int(self.harmonics) + 1):
            w = 2.0 * math.pi * k * self.frequency_hz
            c, s = np.cos(w * t), np.sin(w * t)
            q = q + self.amplitude * (1.0 - c)
            v = v + self.amplitude * w * s
            a = a + self.amplitude * w * w * c
        return np.stack([q, v, a])

    def derivatives(self, t: float, n: int) -> tuple[float, ...]:
        """Position and its first ``n`` derivatives at ``t`` (n <= 4)."""
        return tuple(float(x) for x in self.sample_derivatives(np.array(float(t)), n))

    def sample_derivatives(self, t: np.ndarray, n: int) -> np.ndarray:
        """Vectorised :meth:`derivatives`: shape (n + 1, *t.shape). The k-th derivative
        of ``1 - cos(w t)`` is ``-w^k cos(w t + k pi / 2)``."""
        _check_order(n)
        t = np.asarray(t, dtype=float)
        out = np.zeros((n + 1, *t.shape))
        out[0] = self.offset
        for k in range(1, int(self.harmonics) + 1):
            w = 2.0 * math.pi * k * self.frequency_hz
            out[0] += self.amplitude * (1.0 - np.cos(w * t))
            for order in range(1, n + 1):
                out[order] -= self.amplitude * w**order * np.cos(w * t + order * math.pi / 2)
        return out


def forward_kinematics(q1, q2, l1: float, l2: float):
    """The tip ``(x, y)`` of the arm at ``(q1, q2)`` (θ1 from the horizontal, θ2 relative)."""
    return (
        l1 * np.cos(q1) + l2 * np.cos(q1 + q2),
        l1 * np.sin(q1) + l2 * np.sin(q1 + q2),
    )


def circle_point(c: Circle, t):
    """The circle's point, velocity and acceleration at ``t``: three (x, y) pairs."""
    w = 2.0 * math.pi / c.period
    th = c.phase + w * np.asarray(t, dtype=float)
    cos, sin = np.cos(th), np.sin(th)
    r = c.radius
    return (
        (c.centre_x + r * cos, c.centre_y + r * sin),
        (-r * w * sin, r * w * cos),
        (-r * w * w * cos, -r * w * w * sin),
    )


@dataclass(frozen=True, slots=True)
class Circle:
    """Joint ``joint``'s angle on a circle of the tip, travelled at a constant speed.

    The tip goes round the circle of centre (``centre_x``, ``centre_y``) and ``radius``
    [m] once every ``period`` [s] (anticlockwise, from the angle ``phase``). The joint
    angles are the arm's inverse kinematics, ``elbow`` +1 (θ2 > 0) or -1; rates and
    accelerations from the Jacobian, ``qd = J^-1 pd``, ``qdd = J^-1 (pdd - dJ/dt qd)``.
    The circle must keep clear of the workspace's edges and of the base (|l1 - l2| < |p|
    < l1 + l2 with a margin of 1 % of l1 + l2), so the arm never straightens or folds and
    θ1 never wraps. ``l1``, ``l2``: the arm's lengths (a scenario fills in ``[arm]``'s).
    One reference per joint: ``joint1`` and ``joint2`` of a scenario name the same circle.
    """

    kind: ClassVar[str] = "circle"

    joint: float
    radius: float
    period: float
    centre_x: float = 1.2
    centre_y: float = 0.6
    phase: float = 0.0
    elbow: float = 1.0
    l1: float = 1.0
    l2: float = 1.0

    def __post_init__(self) -> None:
        _validate_fields(self, positive=("radius", "period", "l1", "l2"))
        _whole(self, "joint", (1, 2))
        _whole(self, "elbow", (-1, 1))
        reach = math.hypot(self.centre_x, self.centre_y)
        margin = 0.01 * (self.l1 + self.l2)
        if reach + self.radius > self.l1 + self.l2 - margin:
            raise ValueError("Circle: the circle leaves the arm's reach (l1 + l2, 1 % margin)")
        if reach - self.radius < abs(self.l1 - self.l2) + margin:
            raise ValueError("Circle: the circle comes within |l1 - l2| (1 % margin) of the base")

    @property
    def final(self) -> float:
        """NaN: a circle has no value it settles at."""
        return math.nan

    def joints(self, t):
        """``(q, qd, qdd)`` of both joints at ``t``, each a pair (arrays for an array)."""
        (x, y), (vx, vy), (ax, ay) = circle_point(self, t)
        l1, l2 = self.l1, self.l2
        c2 = (x * x + y * y - l1 * l1 - l2 * l2) / (2 * l1 * l2)
        s2 = self.elbow * np.sqrt(1.0 - c2 * c2)
        q2 = np.arctan2(s2, c2)
        # θ1 relative to the centre's direction, so it is continuous round the circle
        base = math.atan2(self.centre_y, self.centre_x)
        cb, sb = math.cos(base), math.sin(base)
        q1 = base + np.arctan2(-sb * x + cb * y, cb * x + sb * y)
        q1 = q1 - np.arctan2(l2 * s2, l1 + l2 * c2)
        s1, c1 = np.sin(q1), np.cos(q1)
        s12, c12 = np.sin(q1 + q2), np.cos(q1 + q2)
        det = l1 * l2 * s2

        def solve(bx, by):  # J^-1 b, J = [[-l1 s1 - l2 s12, -l2 s12], [l1 c1 + l2 c12, l2 c12]]
            return (
                (l2 * c12 * bx + l2 * s12 * by) / det,
                (-(l1 * c1 + l2 * c12) * bx - (l1 * s1 + l2 * s12) * by) / det,
            )

        w1, w2 = solve(vx, vy)
        w12 = w1 + w2
        jx = -l1 * c1 * w1 * w1 - l2 * c12 * w12 * w12  # dJ/dt qd
        jy = -l1 * s1 * w1 * w1 - l2 * s12 * w12 * w12
        a1, a2 = solve(ax - jx, ay - jy)
        return (q1, q2), (w1, w2), (a1, a2)

    def __call__(self, t: float) -> tuple[float, float, float]:
        """Return ``(position, velocity, acceleration)`` of the joint at time ``t``."""
        q, w, a = self.joints(t)
        j = int(self.joint) - 1
        return float(q[j]), float(w[j]), float(a[j])

    def sample(self, t: np.ndarray) -> np.ndarray:
        """Vectorised ``__call__``: rows (position, velocity, acceleration), shape (3, *t.shape)."""
        q, w, a = self.joints(np.asarray(t, dtype=float))
        j = int(self.joint) - 1
        return np.stack([q[j], w[j], a[j]])


FIELD_REFERENCES = (MultiSine, Circle)
__all__ += ["FIELD_REFERENCES"]
