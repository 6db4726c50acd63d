"""Analytic rigid-body dynamics of the two-link arm: the paper's model, errata fixed.

    tau = M(q) qdd + H(q, qd) + G(q)

q = [theta1, theta2]: theta1 from the horizontal, theta2 relative to link 1; gravity
along -y. Derivation and the list of the paper's errata: ``docs/model.md``.

Every function broadcasts over leading batch axes: ``q`` of shape (..., 2) gives
``M`` of shape (..., 2, 2) and vectors of shape (..., 2). Pure numpy, no MuJoCo.

:func:`terms` is the scalar kernel the controllers call at 1 kHz; it returns plain
floats because numpy's per-call overhead on 2-vectors would dominate the loop. A
test proves it equal to the vectorised functions.
"""

from __future__ import annotations

import math

import numpy as np

from twolink.params import ArmParams


def _split(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    x = np.asarray(x, dtype=float)
    if x.shape[-1:] != (2,):
        raise ValueError(f"expected a trailing axis of length 2, got shape {x.shape}")
    return x[..., 0], x[..., 1]


def mass_matrix(p: ArmParams, q: np.ndarray) -> np.ndarray:
    """Inertia matrix M(q), shape (..., 2, 2): symmetric positive definite."""
    _, q2 = _split(q)
    c2 = np.cos(q2)
    a = p.m2 * p.l1 * p.l2
    m11 = (p.m1 / 3 + p.m2) * p.l1**2 + p.m2 * p.l2**2 / 3 + a * c2
    m12 = p.m2 * p.l2**2 / 3 + a * c2 / 2
    m22 = np.broadcast_to(p.m2 * p.l2**2 / 3, c2.shape)
    return np.stack([np.stack([m11, m12], -1), np.stack([m12, m22], -1)], -2)


def coriolis(p: ArmParams, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Coriolis and centrifugal torques, the paper's H(q, qd), shape (..., 2)."""
    _, q2 = _split(q)
    w1, w2 = _split(qd)
    h = p.m2 * p.l1 * p.l2 * np.sin(q2) / 2
    return np.stack(np.broadcast_arrays(-h * (2 * w1 * w2 + w2**2), h * w1**2), -1)


def coriolis_matrix(p: ArmParams, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Coriolis matrix C(q, qd) from Christoffel symbols: H = C qd, dM/dt - 2C skew."""
    _, q2 = _split(q)
    w1, w2 = _split(qd)
    h = p.m2 * p.l1 * p.l2 * np.sin(q2) / 2
    c11, c12, c21, c22 = np.broadcast_arrays(-h * w2, -h * (w1 + w2), h * w1, 0.0 * h)
    return np.stack([np.stack([c11, c12], -1), np.stack([c21, c22], -1)], -2)


def gravity(p: ArmParams, q: np.ndarray) -> np.ndarray:
    """Gravity torques G(q), shape (..., 2)."""
    q1, q2 = _split(q)
    g2 = p.m2 * p.l2 * np.cos(q1 + q2) * p.g / 2
    g1 = (p.m1 / 2 + p.m2) * p.l1 * np.cos(q1) * p.g + g2
    return np.stack([g1, g2], -1)


def inverse_dynamics(p: ArmParams, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """Joint torques that produce accelerations ``qdd`` at state (q, qd)."""
    qdd = np.asarray(qdd, dtype=float)
    m = mass_matrix(p, q)
    return (m @ qdd[..., None])[..., 0] + coriolis(p, q, qd) + gravity(p, q)


def forward_dynamics(p: ArmParams, q: np.ndarray, qd: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Joint accelerations produced by torques ``tau`` at state (q, qd)."""
    rhs = np.asarray(tau, dtype=float) - coriolis(p, q, qd) - gravity(p, q)
    m = mass_matrix(p, q)
    rhs = np.broadcast_to(rhs, m.shape[:-1])
    return np.linalg.solve(m, rhs[..., None])[..., 0]


def energy(p: ArmParams, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Kinetic and potential energy [J]; potential is zero with both links horizontal."""
    qd = np.asarray(qd, dtype=float)
    m = mass_matrix(p, q)
    kinetic = 0.5 * np.einsum("...i,...ij,...j->...", qd, m, qd)
    q1, q2 = _split(q)
    y1 = p.l1 * np.sin(q1) / 2
    y2 = p.l1 * np.sin(q1) + p.l2 * np.sin(q1 + q2) / 2
    potential = p.g * (p.m1 * y1 + p.m2 * y2)
    return kinetic, potential


def terms(
    p: ArmParams, q1: float, q2: float, w1: float, w2: float, cos=math.cos, sin=math.sin
) -> tuple[float, float, float, float, float]:
    """Scalar fast path: (M11, M12, M22, H1 + G1, H2 + G2) as Python floats.

    With ``cos=np.cos, sin=np.sin`` the same arithmetic, in the same order, runs on
    arrays: the batch controllers' path (``p``'s fields may then be arrays too), equal
    to this one arm by arm."""
    c2 = cos(q2)
    a = p.m2 * p.l1 * p.l2
    m22 = p.m2 * p.l2 * p.l2 / 3
    m12 = m22 + a * c2 / 2
    m11 = (p.m1 / 3 + p.m2) * p.l1 * p.l1 + m22 + a * c2
    h = a * sin(q2) / 2
    g2 = p.m2 * p.l2 * cos(q1 + q2) * p.g / 2
    g1 = (p.m1 / 2 + p.m2) * p.l1 * cos(q1) * p.g + g2
    return m11, m12, m22, g1 - h * (2 * w1 * w2 + w2 * w2), g2 + h * w1 * w1
