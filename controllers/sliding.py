"""Sliding-mode control with a boundary layer (Slotine & Li, *Applied Nonlinear Control*,
Prentice Hall 1991, ch. 7; the robot form of sec. 7.4 and Slotine 1985).

With this project's errors ``e = q_d - q``::

    s = de + λ e,   qdr = qd_d + λ e,   qddr = qdd_d + λ de
    tau = M^(q) qddr + C^(q, qd) qdr + G^(q) + K sat(s / φ)

per joint, ``sat`` the unit saturation. K = F + η bounds the model's torque error over
the declared plant set (:func:`controllers.uncertainty.sliding_gain`), so outside the
layer ``d/dt (s^T M s / 2) <= -Σ η_i |s_i|``: s reaches the layer |s_i| <= φ_i in finite
time, and inside it each error ends within ``φ_i / λ_i``. The layer trades that
precision for a continuous torque (no chattering).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

from twolink.arm.regressor import parameters, regressor_rows
from twolink.controllers.base import pair, saturate
from twolink.controllers.baselines import straight_inertia
from twolink.controllers.ctc import ComputedTorque
from twolink.controllers.uncertainty import DEFAULT_UNCERTAINTY, Uncertainty, sliding_gain

# The sliding margin η [N m] per joint and the envelope the gain covers: the claims
# studies' 2 s quintic moves (peak rates 0.94 and 0.47 rad/s, accelerations 1.44 and
# 0.72 rad/s²) with room for the tracking transient.
DEFAULT_ETA = (1.0, 0.5)
DEFAULT_RATE_BOUND = (1.5, 1.5)  # rad/s, |qd| and |qdr|
DEFAULT_ACCEL_BOUND = (3.0, 3.0)  # rad/s², |qddr|

__all__ = ["DEFAULT_ETA", "SlidingMode", "sat"]


def _key(u: Uncertainty) -> tuple:
    """``u`` as hashable values (its factors are a dict)."""
    return tuple(sorted(u.factors.items())), u.payload, u.friction, u.viscous


@functools.lru_cache(maxsize=256)
def _gain(model, eta, rate, accel, factors, payload, friction, viscous):
    """:func:`sliding_gain`'s K, computed once per design (a sweep builds one law per arm)."""
    u = Uncertainty(dict(factors), payload, friction, viscous)
    return sliding_gain(model, eta, rate, accel, u)[0]


def sat(x: float) -> float:
    """The unit saturation: x clipped to [-1, 1]."""
    return -1.0 if x < -1.0 else 1.0 if x > 1.0 else x


@dataclass
class SlidingMode(ComputedTorque):
    """Sliding mode with a boundary layer (the module's docstring), saturated.

    Parameters
    ----------
    eta : float or pair of float
        η [N m]: the sliding margin added to the model-error bound.
    gain : pair of float or None
        K [N m] per joint; None (default): ``F + η`` from :func:`sliding_gain` over
        ``uncertainty`` and the envelope ``rate_bound``, ``accel_bound``.
    phi : pair of float or None
        φ [rad/s], the layer's half width per joint; None (default): ``K / K_D`` with
        ``K_D = (kd / 2) M^_jj`` (M^ at q2 = 0), so that inside the layer the law is
        the adaptive law's PD on s, ``K sat(s/φ) = K_D s``
        (:func:`controllers.adaptive.adaptive_gains`).
    (``kp`` sets λ = sqrt(kp); the rest as :class:`~controllers.ctc.ComputedTorque`)
    """

    eta: float | Sequence[float] = DEFAULT_ETA
    gain: Sequence[float] | None = None
    phi: float | Sequence[float] | None = None
    uncertainty: Uncertainty = DEFAULT_UNCERTAINTY
    rate_bound: float | Sequence[float] = DEFAULT_RATE_BOUND
    accel_bound: float | Sequence[float] = DEFAULT_ACCEL_BOUND

    def __post_init__(self) -> None:
        super().__post_init__()
        self.eta = pair("eta", self.eta)
        if self.gain is None:
            self.gain = _gain(
                self.model, self.eta, pair("rate_bound", self.rate_bound),
                pair("accel_bound", self.accel_bound), *_key(self.uncertainty),
            )  # fmt: skip
        self.gain = pair("gain", self.gain)
        self.lam = (math.sqrt(self.kp[0]), math.sqrt(self.kp[1]))
        if self.phi is None:
            d1, d2 = straight_inertia(self.model)
            k_d = (self.kd[0] / 2 * d1, self.kd[1] / 2 * d2)
            if min(k_d) <= 0:
                raise ValueError("SlidingMode: phi = None needs kd > 0 (phi = K / K_D)")
            self.phi = (self.gain[0] / k_d[0], self.gain[1] / k_d[1])
        self.phi = pair("phi", self.phi, positive=True)
        self.a_model = tuple(parameters(self.model).tolist())

    def sliding(self, t: float, q: Sequence[float], qd: Sequence[float]):
        """``(s1, s2, row1, row2)``: the sliding variables and the regressor's rows."""
        a1, a2, e1, e2, de1, de2 = self.errors(t, q, qd)
        l1, l2 = self.lam
        s1, s2 = de1 + l1 * e1, de2 + l2 * e2
        w1, w2 = qd
        rows = regressor_rows(q[0], q[1], w1, w2, w1 + s1, w2 + s2, a1 + l1 * de1, a2 + l2 * de2)
        return s1, s2, *rows

    def __call__(self, t: float, q: Sequence[float], qd: Sequence[float]) -> tuple[float, float]:
        s1, s2, row1, row2 = self.sliding(t, q, qd)
        a = self.a_model
        (k1, k2), (p1, p2), (lim1, lim2) = self.gain, self.phi, self.torque_limit
        raw1 = sum(y * x for y, x in zip(row1, a, strict=True)) + k1 * sat(s1 / p1)
        raw2 = sum(y * x for y, x in zip(row2, a, strict=True)) + k2 * sat(s2 / p2)
        return saturate(raw1, lim1), saturate(raw2, lim2)
