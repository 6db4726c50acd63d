"""The controller protocol the simulation loop knows controllers by."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Protocol, runtime_checkable

from twolink.foundation.references import ArmReference


@runtime_checkable
class Controller(Protocol):
    """A control law for the arm.

    ``__call__(t, q, qd)`` takes the time [s] and the measured link angles and rates
    (two floats each) and returns the joint torques ``(tau1, tau2)`` [N m]. It is called
    once per control period, so it must be cheap. ``reset()`` clears any internal state
    before a new run. ``reference`` is the reference the controller tracks.

    A controller of flexible joints that also reads the motors sets the class attribute
    ``needs_motor = True`` and is called ``(t, q, qd, motor_q, motor_qd)`` instead, with
    the rotor angles and rates (``controllers/flexible.py``); the simulation loop and the
    batch engine check for it, so a rigid controller needs neither.
    """

    reference: ArmReference

    def reset(self) -> None: ...

    def __call__(
        self, t: float, q: Sequence[float], qd: Sequence[float]
    ) -> tuple[float, float]: ...


def pair(
    name: str, value: float | Sequence[float], *, positive: bool = False, allow_inf: bool = False
) -> tuple[float, float]:
    """A per-joint pair of floats >= 0 from a scalar or a 2-sequence; errors name ``name``.

    NaN is always refused; ``inf`` only with ``allow_inf`` (e.g. "no torque limit").
    """
    values = (value, value) if isinstance(value, int | float) else tuple(value)
    if len(values) != 2:
        raise ValueError(f"{name} must be a number or a pair, got {value!r}")
    out = []
    for v in values:
        if isinstance(v, bool) or not isinstance(v, int | float) or math.isnan(v):
            raise ValueError(f"{name} must be numbers, got {value!r}")
        if math.isinf(v) and not allow_inf:
            raise ValueError(f"{name} must be finite numbers, got {value!r}")
        if v < 0 or (positive and v == 0):
            raise ValueError(f"{name} must be {'> 0' if positive else '>= 0'}, got {value!r}")
        out.append(float(v))
    return out[0], out[1]


def saturate(tau: float, limit: float) -> float:
    """Clip ``tau`` to [-limit, limit]; ``limit`` may be inf."""
    return -limit if tau < -limit else limit if tau > limit else tau


def integrate_unless_winding_up(z: float, e: float, raw: float, tau: float, dt: float) -> float:
    """One forward-Euler step of an integrator ``z`` of the error ``e``, held while the
    torque is at its limit and the error would push it further (conditional integration,
    the anti-windup of the laws with integral action): ``raw`` the torque asked for,
    ``tau`` the one applied."""
    return z + e * dt if tau == raw or (e > 0) != (raw > 0) else z
