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

from twolink.arm.params import ArmParams


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


# --------------------------------------------------------------------------- derivatives
# Time derivatives of M and of n = H + G along a motion (q, qd, qdd, qddd): what feedback
# linearisation of the flexible-joint arm needs (controllers/flexible.py). Checked against
# finite differences, complex-step differentiation and, where sympy is installed, a
# symbolic derivation from the Lagrangian (tests/test_flexible_control.py).


def derivative_terms(
    p: ArmParams,
    q1: float,
    q2: float,
    w1: float,
    w2: float,
    a1: float,
    a2: float,
    cos=math.cos,
    sin=math.sin,
) -> tuple[float, ...]:
    """Scalar kernel of the time derivatives of M and n = H + G at (q, qd = w, qdd = a).

    Returns ``(dM11, dM12, ddM11, ddM12, dn1, dn2, r1, r2, N11, N12, N21)``: Ṁ and M̈
    (Ṁ22 = M̈22 = 0; M is symmetric), ṅ, and n̈ split as ``n̈ = r + N q⃛`` with
    ``N = ∂H/∂q̇`` (N22 = 0), so that the jerk q⃛ (which depends on the torque in the
    flexible arm) enters linearly. Like :func:`terms`, the same arithmetic runs on arrays
    with ``cos=np.cos, sin=np.sin``.
    """
    c2, s2 = cos(q2), sin(q2)
    a = p.m2 * p.l1 * p.l2
    # M11 = const + a c2, M12 = const + a c2 / 2
    dm11 = -a * s2 * w2
    ddm11 = -a * (c2 * w2 * w2 + s2 * a2)
    # H1 = -h P, H2 = h Q with h = a s2 / 2, P = 2 w1 w2 + w2^2, Q = w1^2
    h = a * s2 / 2
    dh = a * c2 * w2 / 2
    ddh = a * (c2 * a2 - s2 * w2 * w2) / 2
    pp = 2 * w1 * w2 + w2 * w2
    dp = 2 * (a1 * w2 + w1 * a2 + w2 * a2)
    qq = w1 * w1
    dq = 2 * w1 * a1
    # G2 = gb cos(q1 + q2), G1 = ga cos(q1) + G2
    gb = p.m2 * p.l2 * p.g / 2
    ga = (p.m1 / 2 + p.m2) * p.l1 * p.g
    c1, s1 = cos(q1), sin(q1)
    c12, s12 = cos(q1 + q2), sin(q1 + q2)
    w12, a12 = w1 + w2, a1 + a2
    dg2 = -gb * s12 * w12
    ddg2 = -gb * (c12 * w12 * w12 + s12 * a12)
    dg1 = -ga * s1 * w1 + dg2
    ddg1 = -ga * (c1 * w1 * w1 + s1 * a1) + ddg2
    dn1 = -(dh * pp + h * dp) + dg1
    dn2 = dh * qq + h * dq + dg2
    # second derivatives without their jerk terms (those are N q⃛)
    r1 = -(ddh * pp + 2 * dh * dp + h * (4 * a1 * a2 + 2 * a2 * a2)) + ddg1
    r2 = ddh * qq + 2 * dh * dq + h * 2 * a1 * a1 + ddg2
    return dm11, dm11 / 2, ddm11, ddm11 / 2, dn1, dn2, r1, r2, -2 * h * w2, -2 * h * w12, 2 * h * w1


def mass_matrix_derivatives(
    p: ArmParams, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """dM/dt and d²M/dt² along a motion with rates ``qd`` and accelerations ``qdd``, each of
    shape (..., 2, 2)."""
    (q1, q2), (w1, w2), (a1, a2) = _split(q), _split(qd), _split(qdd)
    d = derivative_terms(p, q1, q2, w1, w2, a1, a2, cos=np.cos, sin=np.sin)
    shape = np.broadcast_shapes(*(np.shape(x) for x in (q1, w1, a1)))
    zero = np.zeros(shape)

    def matrix(m11, m12):
        m11, m12 = np.broadcast_to(m11, shape), np.broadcast_to(m12, shape)
        return np.stack([np.stack([m11, m12], -1), np.stack([m12, zero], -1)], -2)

    return matrix(d[0], d[1]), matrix(d[2], d[3])


def bias_derivatives(
    p: ArmParams, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, qddd: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """d/dt and d²/dt² of n = H + G (Coriolis, centrifugal and gravity torques) along a
    motion with rates ``qd``, accelerations ``qdd`` and jerks ``qddd``, each (..., 2)."""
    (q1, q2), (w1, w2), (a1, a2), (j1, j2) = (_split(x) for x in (q, qd, qdd, qddd))
    d = derivative_terms(p, q1, q2, w1, w2, a1, a2, cos=np.cos, sin=np.sin)
    dn1, dn2, r1, r2, n11, n12, n21 = d[4:]
    dn = np.stack(np.broadcast_arrays(dn1, dn2), -1)
    ddn = np.stack(np.broadcast_arrays(r1 + n11 * j1 + n12 * j2, r2 + n21 * j1), -1)
    return dn, ddn


def gravity_gradient(p: ArmParams, q: np.ndarray) -> np.ndarray:
    """∂G/∂q, shape (..., 2, 2) (symmetric: G is the gradient of the potential energy)."""
    q1, q2 = _split(q)
    gb = p.m2 * p.l2 * p.g / 2
    ga = (p.m1 / 2 + p.m2) * p.l1 * p.g
    d22 = -gb * np.sin(q1 + q2)
    d11 = -ga * np.sin(q1) + d22
    return np.stack([np.stack([d11, d22], -1), np.stack([d22, d22], -1)], -2)


def gravity_gradient_bound(p: ArmParams) -> float:
    """α = max over q of ‖∂G/∂q‖₂ [N m/rad]: how fast gravity's torque can change with the
    angles, the number the motor-side PD's stiffness bound compares with.

    ∂G/∂q is affine in (sin q1, sin(q1 + q2)), which range independently over [-1, 1],
    and a norm is convex, so the maximum is at a corner of that square (exact, no search).
    """
    gb = p.m2 * p.l2 * p.g / 2
    ga = (p.m1 / 2 + p.m2) * p.l1 * p.g
    corners = [
        np.array([[ga * x + gb * y, gb * y], [gb * y, gb * y]]) for x in (1, -1) for y in (1, -1)
    ]
    return float(max(np.abs(np.linalg.eigvalsh(m)).max() for m in corners))


def flexible_forward_dynamics(
    p: ArmParams,
    k: np.ndarray,
    d: np.ndarray,
    j: np.ndarray,
    q: np.ndarray,
    qd: np.ndarray,
    phi: np.ndarray,
    phid: np.ndarray,
    tau: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Spong's flexible-joint arm: link and rotor accelerations (q̈, φ̈), each (..., 2).

        M(q) q̈ + H + G = K (φ − q) + D (φ̇ − q̇),     J φ̈ + K (φ − q) + D (φ̇ − q̇) = τ

    ``k``, ``d``, ``j``: per-joint stiffness, damping and rotor inertia (pairs). The analytic
    model of what :func:`twolink.arm.plant.build_model` simulates with a ``Flexibility``.
    """
    k, d, j = (np.asarray(x, dtype=float) for x in (k, d, j))
    spring = k * (np.asarray(phi) - np.asarray(q)) + d * (np.asarray(phid) - np.asarray(qd))
    return forward_dynamics(p, q, qd, spring), (np.asarray(tau, dtype=float) - spring) / j


def holding_motor_angles(p: ArmParams, k: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Rotor angles that hold the flexible arm still at ``q``: φ = q + K⁻¹ G(q), each
    spring twisted by the gravity torque it carries."""
    return np.asarray(q, dtype=float) + gravity(p, q) / np.asarray(k, dtype=float)
