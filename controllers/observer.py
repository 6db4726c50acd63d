"""Computed torque with a nonlinear disturbance observer (CTC-DOB).

The observer has the structure of Chen, Ballance, Gawthrop & O'Reilly 2000 ("A nonlinear
disturbance observer for robotic manipulators", IEEE Trans. Industrial Electronics 47(4),
932-938): ``d^ = z + p(q, qd)``, ``dz/dt = -L z + L (n^ - tau - p)``, with the choice
``p = M^(q) qd / T`` (the arm's generalised momentum; De Luca & Mattone 2003), whose
``L = I / T`` makes the estimate's error obey ``dd~/dt = -d~ / T`` exactly for a
constant lumped torque and the model's arm: one time constant T on every joint and pose
(Chen et al.'s ``p = c qd`` gives ``L = c M^-1(q)``, rates that vary with the pose).
In integral form, with ``M^ dqd/dt + C^ qd + G^ = tau + d`` and ``dM^/dt = C^ + C^T``::

    d^(t) = (M^(q) qd - M^(q0) qd0 - ∫ (tau + C^T(q, qd) qd - G^(q) + d^) dt) / T

``d`` lumps every torque the model lacks: a load, friction, the model's own error. The
law cancels it: ``tau = M^ (qdd_d + Kd de + Kp e) + H^ + G^ - d^``, saturated; the
observer integrates the torque applied (after the limit), so it cannot wind up.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

from twolink.arm.dynamics import terms
from twolink.controllers.base import saturate
from twolink.controllers.ctc import ComputedTorque

# The observer's time constant [s]: a fifth of the shipped loop's 1/ωn = 67 ms, so the
# estimate settles well inside the loop's own response.
DEFAULT_OBSERVER_TIME = 0.013

__all__ = ["DEFAULT_OBSERVER_TIME", "DisturbanceObserverCTC", "momentum_terms"]


def momentum_terms(model, q1, q2, w1, w2, cos=math.cos, sin=math.sin):
    """``(p1, p2, c1, c2, m11, m12, m22, n1, n2)``: the model's momentum ``M^ qd``, the
    observer's drift ``C^T qd - G^`` and the CTC terms (:func:`terms`) at (q, qd). With
    the Christoffel C, ``C^T qd = (0, -h w1 (w1 + w2))``, ``h = m2 l1 l2 sin q2 / 2``."""
    m11, m12, m22, n1, n2 = terms(model, q1, q2, w1, w2, cos=cos, sin=sin)
    h = model.m2 * model.l1 * model.l2 * sin(q2) / 2
    g2 = model.m2 * model.l2 * cos(q1 + q2) * model.g / 2
    g1 = (model.m1 / 2 + model.m2) * model.l1 * cos(q1) * model.g + g2
    p1, p2 = m11 * w1 + m12 * w2, m12 * w1 + m22 * w2
    return p1, p2, -g1, -h * w1 * (w1 + w2) - g2, m11, m12, m22, n1, n2


@dataclass
class DisturbanceObserverCTC(ComputedTorque):
    """CTC with the disturbance observer of the module's docstring.

    Discrete at the control period: at instant k, ``d^_k = (P_k - I_k) / T`` with
    ``P = M^ qd``, then ``I_{k+1} = I_k + dt (tau_k + C^T qd - G^ + d^_k)`` (forward
    Euler, tau_k the torque applied). The first call sets ``I_0 = P_0`` (d^ starts at 0).

    Parameters
    ----------
    observer_time : float
        T [s], the estimate's time constant (:data:`DEFAULT_OBSERVER_TIME`); at least
        ``control_dt`` (a shorter one makes the discrete observer unstable).
    control_dt : float
        The control period [s].
    (the rest as :class:`~controllers.ctc.ComputedTorque`)
    """

    observer_time: float = DEFAULT_OBSERVER_TIME
    control_dt: float = 1e-3
    internal_state: ClassVar[tuple[str, ...]] = ("integral",)

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (math.isfinite(self.control_dt) and self.control_dt > 0):
            raise ValueError(f"control_dt must be > 0, got {self.control_dt!r}")
        t = self.observer_time
        if isinstance(t, bool) or not isinstance(t, int | float) or not math.isfinite(t):
            raise ValueError(f"observer_time must be a finite number, got {t!r}")
        if t < self.control_dt:
            raise ValueError(f"observer_time must be >= control_dt {self.control_dt}, got {t!r}")
        self.observer_time = float(t)
        self.reset()

    def reset(self) -> None:
        """Forget the estimate: the next call starts it at 0."""
        self.integral = None

    def estimate(self, p1: float, p2: float) -> tuple[float, float]:
        """d^ from the momentum (P1, P2) and the observer's state."""
        (i1, i2), t = self.integral, self.observer_time
        return (p1 - i1) / t, (p2 - i2) / t

    def __call__(self, t: float, q: Sequence[float], qd: Sequence[float]) -> tuple[float, float]:
        a1, a2, e1, e2, de1, de2 = self.errors(t, q, qd)
        p1, p2, c1, c2, m11, m12, m22, n1, n2 = momentum_terms(self.model, *q, *qd)
        if self.integral is None:
            self.integral = (p1, p2)
        d1, d2 = self.estimate(p1, p2)
        (kp1, kp2), (kd1, kd2), (lim1, lim2) = self.kp, self.kd, self.torque_limit
        v1 = a1 + kd1 * de1 + kp1 * e1
        v2 = a2 + kd2 * de2 + kp2 * e2
        tau1 = saturate(m11 * v1 + m12 * v2 + n1 - d1, lim1)
        tau2 = saturate(m12 * v1 + m22 * v2 + n2 - d2, lim2)
        i1, i2 = self.integral
        dt = self.control_dt
        self.integral = (i1 + dt * (tau1 + c1 + d1), i2 + dt * (tau2 + c2 + d2))
        return tau1, tau2
