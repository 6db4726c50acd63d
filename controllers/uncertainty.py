"""The model error the robust and adaptive laws are designed for: declared ranges of the
plant around the controller's model, and the bounds the laws read from them.

:data:`DEFAULT_UNCERTAINTY` is the claims studies' declared plant set
(``runs/sweeps/robustness.toml`` and ``runs/sweeps/lab.toml``): masses x [0.7, 1.3],
lengths and gravity x [0.9, 1.1], a tip payload of 0 to 0.2 kg, and dry friction up to
the lab arm's largest breakaway torque (2 N m x 1.5 and 0.5 N m x 1.5). Pure numpy.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from twolink.arm.params import ArmParams
from twolink.arm.regressor import parameter_box, parameters
from twolink.controllers.base import pair

__all__ = ["DEFAULT_UNCERTAINTY", "Uncertainty", "sliding_gain"]

QUANTITIES = ("m1", "m2", "l1", "l2", "g")


@dataclass(frozen=True)
class Uncertainty:
    """Declared ranges of the plant around the model.

    Parameters
    ----------
    factors : dict
        ``(low, high)`` factors on the model's ``m1, m2, l1, l2, g`` (missing: exact).
    payload : pair of float
        The tip payload's range [kg] (the model has none).
    friction : pair of float
        The largest friction torque per joint [N m] (dry, breakaway included), and any
        other torque the plant adds that the model lacks.
    viscous : pair of float
        The largest viscous friction per joint [N m s/rad].
    """

    factors: dict = field(
        default_factory=lambda: {
            "m1": (0.7, 1.3),
            "m2": (0.7, 1.3),
            "l1": (0.9, 1.1),
            "l2": (0.9, 1.1),
            "g": (0.9, 1.1),
        }
    )
    payload: tuple[float, float] = (0.0, 0.2)
    friction: tuple[float, float] = (3.0, 0.75)
    viscous: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        for name, (lo, hi) in self.factors.items():
            if name not in QUANTITIES:
                raise ValueError(f"Uncertainty.factors: unknown quantity {name!r}")
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
                raise ValueError(f"Uncertainty.factors[{name!r}] must be 0 < low <= high")
        lo, hi = self.payload
        if not (math.isfinite(hi) and 0 <= lo <= hi):
            raise ValueError(f"Uncertainty.payload must be 0 <= low <= high, got {self.payload}")
        object.__setattr__(self, "friction", pair("Uncertainty.friction", self.friction))
        object.__setattr__(self, "viscous", pair("Uncertainty.viscous", self.viscous))

    def box(self, model: ArmParams) -> tuple[np.ndarray, np.ndarray]:
        """The box of the regressor's parameters ``a`` over these ranges
        (:func:`twolink.arm.regressor.parameter_box`)."""
        return parameter_box(model, self.factors, self.payload)

    def corners(self, model: ArmParams) -> list[tuple[ArmParams, float]]:
        """Every corner of the ranges, and the model itself: ``(arm, payload)`` pairs."""
        names = list(self.factors)
        out = [(model, 0.0)]
        for picks in itertools.product((0, 1), repeat=len(names) + 1):
            scale = {n: self.factors[n][k] for n, k in zip(names, picks[:-1], strict=True)}
            out.append((model.scaled(**scale), self.payload[picks[-1]]))
        return out


DEFAULT_UNCERTAINTY = Uncertainty()


def _model_terms(p: ArmParams, payload: float, q: np.ndarray):
    """M, the Coriolis factor h (C's entries are h times rates) and G of the arm ``p``
    with a point ``payload`` at the tip (the plant's), through the regressor's
    parameters: M11 = a1 + a2 + 2 a3 c2, M12 = a2 + a3 c2, M22 = a2, h = a3 s2."""
    a1, a2, a3, a4, a5 = parameters(p, payload)
    c2, s2 = np.cos(q[..., 1]), np.sin(q[..., 1])
    c1, c12 = np.cos(q[..., 0]), np.cos(q[..., 0] + q[..., 1])
    m11, m12, m22 = a1 + a2 + 2 * a3 * c2, a2 + a3 * c2, a2 + 0 * c2
    m = np.stack([np.stack([m11, m12], -1), np.stack([m12, m22], -1)], -2)
    return m, a3 * s2, np.stack([a4 * c1 + a5 * c12, a5 * c12], -1)


def sliding_gain(
    model: ArmParams,
    eta: float | Sequence[float],
    rate_bound: float | Sequence[float],
    accel_bound: float | Sequence[float],
    uncertainty: Uncertainty = DEFAULT_UNCERTAINTY,
    grid: int = 24,
) -> tuple[tuple[float, float], np.ndarray]:
    """The switching gain K [N m] per joint of :class:`~controllers.sliding.SlidingMode`:
    ``K = F + eta``, F the model-error bound.

    The law applies ``tau = M^ qddr + C^ qdr + G^ + K sat(s / phi)``. On a plant of the
    declared set the torque it lacks is ``Delta = (M - M^) qddr + (C - C^) qdr + G - G^
    + f`` (f: friction), and with ``|Delta_i| <= F_i`` the sliding condition
    ``d/dt (s^T M s / 2) <= -sum eta_i |s_i|`` holds outside the layer (Slotine & Li,
    *Applied Nonlinear Control*, 1991, sec. 7.4; the skew ``dM/dt - 2C`` cancels the rest).

    F is the maximum of |Delta_i| over the corners of the ranges (and the model), a grid
    of ``grid`` x ``grid`` poses (q1, q2) and the envelope ``|qd_i|, |qdr_i| <=
    rate_bound_i``, ``|qddr_i| <= accel_bound_i``: exact over the envelope (Delta is
    multilinear in the rates and affine in qddr, so its extremes are at the envelope's
    corners), sampled over poses and parameters. Returns ``(K, F)``.
    """
    eta, w, b = pair("eta", eta), pair("rate_bound", rate_bound), pair("accel_bound", accel_bound)
    angles = np.linspace(-math.pi, math.pi, grid, endpoint=False)
    q1, q2 = np.meshgrid(angles, angles, indexing="ij")
    q = np.stack([q1.ravel(), q2.ravel()], -1)
    m_hat, h_hat, g_hat = _model_terms(model, 0.0, q)
    signs = list(itertools.product((-1.0, 1.0), repeat=4))
    friction = np.add(uncertainty.friction, np.multiply(uncertainty.viscous, w))
    f_max = np.zeros(2)
    for p, payload in uncertainty.corners(model):
        m, h, g = _model_terms(p, payload, q)
        dm, dh, dg = np.abs(m - m_hat), h - h_hat, g - g_hat
        inertia = dm @ np.array(b)  # the qddr term at its worst sign
        for s1, s2, s3, s4 in signs:
            w1, w2, r1, r2 = s1 * w[0], s2 * w[1], s3 * w[0], s4 * w[1]
            coriolis_error = np.stack([-dh * (w2 * r1 + (w1 + w2) * r2), dh * w1 * r1], -1)
            worst = np.abs(coriolis_error + dg) + inertia + friction
            f_max = np.maximum(f_max, worst.max(axis=0))
    k = f_max + np.array(eta)
    return (float(k[0]), float(k[1])), f_max
