"""Slotine-Li adaptive computed torque (Slotine & Li 1987, "On the adaptive control of
robot manipulators", Int. J. Robotics Research 6(3), 49-59).

With this project's errors ``e = q_d - q`` (Slotine and Li's ``s`` is minus this one)::

    s = de + Λ e,   qdr = qd_d + Λ e,   qddr = qdd_d + Λ de
    tau = Y(q, qd, qdr, qddr) â + K_D s,   dâ/dt = Γ Y^T s

``Y a = M qddr + C qdr + G`` is the arm's regressor (:mod:`twolink.arm.regressor`; C the
Coriolis matrix with ``dM/dt - 2C`` skew). With the true structure, no saturation and
``ã = â - a``, ``V = s^T M s / 2 + ã^T Γ^-1 ã / 2`` has ``dV/dt = -s^T K_D s <= 0``: the
error goes to zero, and ``â`` to the plant's ``a`` where the reference excites it
persistently.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

from twolink.arm.regressor import N_PARAMETERS, parameters, regressor_rows
from twolink.controllers.base import saturate
from twolink.controllers.baselines import straight_inertia
from twolink.controllers.ctc import ComputedTorque
from twolink.controllers.uncertainty import DEFAULT_UNCERTAINTY, Uncertainty

# Adaptation gains Γ (diagonal), per parameter a1..a5 (units: a_i's per (Y^T s)_i per s).
# 20 times the nominal arm's a_i: of the steps x1, x10, x100, x1000 from a fifth of it, the
# lowest error on a claims plant before the torque's variation grows. The claims study
# tunes Γ by search.
DEFAULT_GAMMA = (30.0, 10.0, 10.0, 300.0, 100.0)

__all__ = ["DEFAULT_GAMMA", "AdaptiveComputedTorque", "adaptive_gains", "gammas", "lyapunov"]


def adaptive_gains(c: ComputedTorque) -> tuple[tuple[float, float], tuple[float, float]]:
    """``(Λ, K_D)`` per joint from a law's ``kp`` and ``kd``: ``Λ_j = sqrt(kp_j)`` [1/s],
    ``K_D,j = (kd_j / 2) M^_jj`` [N m s/rad] (M^ at q2 = 0). The shipped kp = ωn²,
    kd = 2 ωn give the rule Λ = ωn, K_D = ωn M^_jj: with the exact model each joint's
    error then has a double pole at -ωn, as CTC's."""
    d1, d2 = straight_inertia(c.model)
    (kp1, kp2), (kd1, kd2) = c.kp, c.kd
    return (math.sqrt(kp1), math.sqrt(kp2)), (kd1 / 2 * d1, kd2 / 2 * d2)


def gammas(value: float | Sequence[float]) -> tuple[float, ...]:
    """Γ's diagonal: a number (all five) or five numbers, each >= 0 and finite."""
    values = (value,) * N_PARAMETERS if isinstance(value, int | float) else tuple(value)
    if len(values) != N_PARAMETERS:
        raise ValueError(f"gamma must be a number or {N_PARAMETERS} numbers, got {value!r}")
    for v in values:
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) or v < 0:
            raise ValueError(f"gamma must be finite numbers >= 0, got {value!r}")
    return tuple(float(v) for v in values)


@dataclass
class AdaptiveComputedTorque(ComputedTorque):
    """Slotine-Li adaptive computed torque (the module's docstring), saturated.

    The estimate starts at the model's parameters (no payload) and is updated once per
    control period by forward Euler, then projected on a box (see below). Two rules keep
    it sound where the theory does not hold:

    - **Projection**: each ``â_i`` is clipped to ``[low_i, high_i]``, the box of
      :meth:`Uncertainty.box <controllers.uncertainty.Uncertainty.box>` over the declared
      plant set (default: the claims studies'). The true ``a`` lies in it, and for a
      diagonal Γ clipping to a box that holds ``a`` never increases ``ã^T Γ^-1 ã``, so V
      keeps its proof; and ``â`` stays a physical arm's (positive inertias and levers).
    - **No wind-up**: while either joint's torque is at its limit the estimate is held
      (``dV/dt <= 0`` needs the torque the law asked for).

    Parameters
    ----------
    gamma : float or 5 floats
        Γ's diagonal, per parameter (:data:`DEFAULT_GAMMA`); 0 turns adaptation off.
    control_dt : float
        The control period [s], the update's step.
    uncertainty : Uncertainty
        The declared plant set whose box the projection keeps ``â`` in.
    (``kp`` and ``kd`` set Λ and K_D, :func:`adaptive_gains`; the rest as
    :class:`~controllers.ctc.ComputedTorque`)
    """

    gamma: float | Sequence[float] = DEFAULT_GAMMA
    control_dt: float = 1e-3
    uncertainty: Uncertainty = DEFAULT_UNCERTAINTY
    # its own state, for the stability check's linearisation (twolink.simulation.stability)
    internal_state: ClassVar[tuple[str, ...]] = ("a_hat",)

    def __post_init__(self) -> None:
        super().__post_init__()
        self.gamma = gammas(self.gamma)
        if not (math.isfinite(self.control_dt) and self.control_dt > 0):
            raise ValueError(f"control_dt must be > 0, got {self.control_dt!r}")
        self.lam, self.k_d = adaptive_gains(self)
        low, high = self.uncertainty.box(self.model)
        self.low, self.high = tuple(low.tolist()), tuple(high.tolist())
        self.a_nominal = tuple(parameters(self.model).tolist())
        self.reset()

    def reset(self) -> None:
        """The estimate back to the model's parameters."""
        self.a_hat = self.a_nominal

    def __call__(self, t: float, q: Sequence[float], qd: Sequence[float]) -> tuple[float, float]:
        a1, a2, e1, e2, de1, de2 = self.errors(t, q, qd)
        (l1, l2), (k1, k2) = self.lam, self.k_d
        s1, s2 = de1 + l1 * e1, de2 + l2 * e2
        w1, w2 = qd
        r1, r2 = w1 + s1, w2 + s2  # qdr = qd_d + Λ e = qd + s
        row1, row2 = regressor_rows(q[0], q[1], w1, w2, r1, r2, a1 + l1 * de1, a2 + l2 * de2)
        a = self.a_hat
        raw1 = sum(y * x for y, x in zip(row1, a, strict=True)) + k1 * s1
        raw2 = sum(y * x for y, x in zip(row2, a, strict=True)) + k2 * s2
        lim1, lim2 = self.torque_limit
        tau1, tau2 = saturate(raw1, lim1), saturate(raw2, lim2)
        if tau1 == raw1 and tau2 == raw2:
            dt = self.control_dt
            self.a_hat = tuple(
                min(max(x + dt * g * (y1 * s1 + y2 * s2), lo), hi)
                for x, g, y1, y2, lo, hi in zip(
                    a, self.gamma, row1, row2, self.low, self.high, strict=True
                )
            )
        return tau1, tau2


def lyapunov(c: AdaptiveComputedTorque, t: float, q, qd, mass, a) -> tuple[float, float]:
    """``(V, s^T K_D s)`` of the law ``c`` at ``(t, q, qd)`` against the plant's true
    inertia matrix ``mass`` (2, 2) and parameters ``a`` (5,): ``V = s^T M s / 2 +
    ã^T Γ^-1 ã / 2`` with its current estimate (Γ > 0 needed), and the dissipation rate
    that the theory says is ``-dV/dt``."""
    import numpy as np

    (r1, r2), (v1, v2), _ = c.reference(t)
    lam = np.array(c.lam)
    e = np.subtract((r1, r2), q)
    s = np.subtract((v1, v2), qd) + lam * e
    a_err = np.subtract(c.a_hat, a)
    v = 0.5 * s @ np.asarray(mass) @ s + 0.5 * float(np.sum(a_err**2 / np.array(c.gamma)))
    return float(v), float(s @ (np.array(c.k_d) * s))
