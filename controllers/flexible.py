"""Controllers for Spong's flexible-joint arm: they read the motor (rotor) states too.

Spong's model (``docs/model.md``): each link is driven by a rotor of inertia J through a
torsional spring K and damper D,

    M(q) q̈ + H(q, q̇) + G(q) = K (φ − q) + D (φ̇ − q̇),     J φ̈ + K (φ − q) + D (φ̇ − q̇) = τ.

Three laws from the flexible-joint literature (``docs/control.md``, "Flexible-joint
controllers", has each law, its source and its stiffness bound):

- :class:`MotorPD`: PD on the motor angles with gravity compensation at the set point
  (Tomei 1991; De Luca, Siciliano and Zollo 2005), stable when the joints are stiffer
  than gravity's gradient (:meth:`MotorPD.stiffness_bound`);
- :class:`CompositeControl`: singular-perturbation composite control (Spong 1987): the
  rigid computed torque of the K → ∞ model (the arm with rotor inertia J) plus a fast
  damping term on the spring's deflection rate;
- :class:`FlexibleFeedbackLinearisation`: exact feedback linearisation of the flexible
  model (Spong 1987), which makes each link error obey a designed fourth-order linear
  equation; it needs the reference's jerk and snap (``Septic`` gives them continuous).

The interface: these controllers set ``needs_motor = True`` and are called as
``controller(t, q, qd, motor_q, motor_qd)``; the simulation loop
(:func:`twolink.simulation.sim.simulate`) and the batch engine
(:mod:`twolink.simulation.batch`) pass the
rotor angles and rates to such a controller, and refuse to run one on a rigid arm. Rigid
controllers keep their three-argument call. Each controller models the links with its
``model`` (the nominal arm, as every controller) and the joints with ``joints`` (a
:class:`~twolink.arm.params.Flexibility`, in scenarios the plant's own: identified joints).

Every law is written once, component by component, as a kernel that runs on floats (the
1 kHz single-arm path, ``math``) and on per-arm arrays (the batch forms, ``numpy``), the
same arithmetic in the same order, as :func:`twolink.arm.dynamics.terms` does.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from twolink.arm.dynamics import derivative_terms, gravity_gradient_bound, terms
from twolink.arm.params import Flexibility
from twolink.controllers.base import saturate
from twolink.controllers.baselines import straight_inertia
from twolink.controllers.batch import ReferenceTable, _Models
from twolink.controllers.ctc import ComputedTorque
from twolink.foundation.references import ArmReference

__all__ = [
    "DEFAULT_FAST_DAMPING",
    "BatchCompositeControl",
    "BatchFlexibleFeedbackLinearisation",
    "BatchMotorPD",
    "CompositeControl",
    "FlexibleFeedbackLinearisation",
    "MotorPD",
    "StiffnessBound",
    "error_polynomial",
    "fast_damping_gain",
    "motor_pd_bound",
    "spring_frequency",
]

# Damping ratio of the composite control's fast (spring) mode: 0.7, the usual choice for a
# mode one wants quiet quickly without overshoot to speak of.
DEFAULT_FAST_DAMPING = 0.7


# ----------------------------------------------------------------------------- kernels


@dataclass(frozen=True)
class _Joints:
    """Joint stiffness, damping and rotor inertia per joint: floats, or per-arm arrays."""

    k1: Any
    k2: Any
    d1: Any
    d2: Any
    j1: Any
    j2: Any

    @classmethod
    def of(cls, f: Flexibility) -> _Joints:
        return cls(f.k[0], f.k[1], f.d[0], f.d[1], f.j[0], f.j[1])

    @classmethod
    def stack(cls, joints: Sequence[Flexibility]) -> _Joints:
        return cls(
            *(np.array([getattr(f, name)[i] for f in joints]) for name in "kdj" for i in (0, 1))
        )


def _motor_pd(p, jt, gains, r1, r2, v1, v2, th1, th2, nu1, nu2, cos, sin):
    """Tomei's law: ``τ = Dm (Kp (φd − φ) + Kd (φ̇d − φ̇)) + Ĝ(q_d)``, ``φd = q_d + K⁻¹ Ĝ(q_d)``."""
    dm1, dm2, kp1, kp2, kd1, kd2 = gains
    gb = p.m2 * p.l2 * p.g / 2
    ga = (p.m1 / 2 + p.m2) * p.l1 * p.g
    r12, v12 = r1 + r2, v1 + v2
    g2 = gb * cos(r12)
    g1 = ga * cos(r1) + g2
    dg2 = -gb * sin(r12) * v12  # d/dt of Ĝ(q_d(t)), for the motor's rate reference
    dg1 = -ga * sin(r1) * v1 + dg2
    phi1, phi2 = r1 + g1 / jt.k1, r2 + g2 / jt.k2
    rate1, rate2 = v1 + dg1 / jt.k1, v2 + dg2 / jt.k2
    return (
        dm1 * (kp1 * (phi1 - th1) + kd1 * (rate1 - nu1)) + g1,
        dm2 * (kp2 * (phi2 - th2) + kd2 * (rate2 - nu2)) + g2,
    )


def _composite(p, jt, gains, ref, q1, q2, w1, w2, nu1, nu2, cos, sin):
    """Spong's composite law: ``τ = (M̂ + J) v + Ĥ + Ĝ + Kv (q̇ − φ̇)``, ``v`` the CTC's."""
    kp1, kp2, kd1, kd2, kv1, kv2 = gains
    r1, r2, rv1, rv2, ra1, ra2 = ref
    m11, m12, m22, b1, b2 = terms(p, q1, q2, w1, w2, cos=cos, sin=sin)
    v1 = ra1 + kd1 * (rv1 - w1) + kp1 * (r1 - q1)
    v2 = ra2 + kd2 * (rv2 - w2) + kp2 * (r2 - q2)
    return (
        (m11 + jt.j1) * v1 + m12 * v2 + b1 + kv1 * (w1 - nu1),
        m12 * v1 + (m22 + jt.j2) * v2 + b2 + kv2 * (w2 - nu2),
    )


def _feedback_linearisation(p, jt, gains, dt, ref, state, held, cos, sin):
    """Spong's exact feedback linearisation, extended to the damped spring.

    With u = K δ + D δ̇ (δ = φ − q) the torque the springs put on the links, the link
    equation M q̈ + n = u differentiated twice gives

        M q⁗ = c + F τ + D J⁻¹ τ̇

    (c and F functions of the state; M̈, ṅ, n̈ from :func:`derivative_terms`). For D = 0 it
    is Spong's relation M q⁗ = c + K J⁻¹ τ, solved for τ. For D > 0 the torque also enters
    through its rate, and τ becomes the state of a first-order filter (time constant
    ~D/K, the stable zero dynamics of the damped joint), integrated by implicit Euler over
    the control period from the torque ``held`` since the last call. Setting q⁗ = v, the
    designed fourth-order error dynamics, and solving the 2x2 system gives τ.

    Sampled: the torque is held for the period ``dt`` that follows, so the law is evaluated
    at the state predicted ``dt / 2`` ahead (second-order Taylor under the held torque),
    with the reference given at that time: the hold's half-period delay compensated. On
    stiff joints the law cancels large, fast spring torques to leave small differences,
    and without this step its error at 1 kHz is first order in dt with a large constant
    (docs/control.md, "Flexible-joint controllers").
    """
    c0_1, c0_2, c1_1, c1_2, c2_1, c2_2, c3_1, c3_2 = gains
    r1, r2, r1d, r2d, r1dd, r2dd, r1ddd, r2ddd, r1s, r2s = ref
    q1, q2, w1, w2, th1, th2, nu1, nu2 = state
    tp1, tp2 = held
    k1, k2, d1, d2, j1, j2 = jt.k1, jt.k2, jt.d1, jt.d2, jt.j1, jt.j2
    # The torque will be held over the next period: evaluate the law half a period ahead
    # (the state predicted under the held torque; the reference is given there too).
    m11, m12, m22, b1, b2 = terms(p, q1, q2, w1, w2, cos=cos, sin=sin)
    det = m11 * m22 - m12 * m12
    u1 = k1 * (th1 - q1) + d1 * (nu1 - w1)
    u2 = k2 * (th2 - q2) + d2 * (nu2 - w2)
    a1 = (m22 * (u1 - b1) - m12 * (u2 - b2)) / det
    a2 = (m11 * (u2 - b2) - m12 * (u1 - b1)) / det
    f1, f2 = (tp1 - u1) / j1, (tp2 - u2) / j2
    h = dt / 2
    q1, q2 = q1 + h * (w1 + h * a1 / 2), q2 + h * (w2 + h * a2 / 2)
    th1, th2 = th1 + h * (nu1 + h * f1 / 2), th2 + h * (nu2 + h * f2 / 2)
    w1, w2, nu1, nu2 = w1 + h * a1, w2 + h * a2, nu1 + h * f1, nu2 + h * f2
    m11, m12, m22, b1, b2 = terms(p, q1, q2, w1, w2, cos=cos, sin=sin)
    det = m11 * m22 - m12 * m12
    i11, i12, i22 = m22 / det, -m12 / det, m11 / det
    # spring and damper torque on the links, and the links' acceleration
    de1, de2 = nu1 - w1, nu2 - w2
    u1 = k1 * (th1 - q1) + d1 * de1
    u2 = k2 * (th2 - q2) + d2 * de2
    f1, f2 = u1 - b1, u2 - b2
    a1, a2 = i11 * f1 + i12 * f2, i12 * f1 + i22 * f2
    dm11, dm12, ddm11, ddm12, dn1, dn2, rn1, rn2, n11, n12, n21 = derivative_terms(
        p, q1, q2, w1, w2, a1, a2, cos=cos, sin=sin
    )
    # the links' jerk is q3 = q30 + B τ, B = M⁻¹ D J⁻¹; u̇ = ud0 + D J⁻¹ τ
    ud1 = k1 * de1 + d1 * (-u1 / j1 - a1)
    ud2 = k2 * de2 + d2 * (-u2 / j2 - a2)
    g1 = ud1 - dn1 - (dm11 * a1 + dm12 * a2)
    g2 = ud2 - dn2 - dm12 * a1
    q31, q32 = i11 * g1 + i12 * g2, i12 * g1 + i22 * g2
    e1, e2 = d1 / j1, d2 / j2
    b11, b12, b21, b22 = i11 * e1, i12 * e2, i12 * e1, i22 * e2
    jerk1 = q31 + b11 * tp1 + b12 * tp2  # under the torque held now
    jerk2 = q32 + b21 * tp1 + b22 * tp2
    # the designed error dynamics: q⁗ = v
    v1 = r1s + c3_1 * (r1ddd - jerk1) + c2_1 * (r1dd - a1) + c1_1 * (r1d - w1) + c0_1 * (r1 - q1)
    v2 = r2s + c3_2 * (r2ddd - jerk2) + c2_2 * (r2dd - a2) + c1_2 * (r2d - w2) + c0_2 * (r2 - q2)
    # c: every term of M q⁗ without τ (n̈ at the jerk q30)
    ndd1 = rn1 + n11 * q31 + n12 * q32
    ndd2 = rn2 + n21 * q31
    mc1 = (
        -k1 * u1 / j1
        - k1 * a1
        - e1 * ud1
        - d1 * q31
        - 2 * (dm11 * q31 + dm12 * q32)
        - ndd1
        - (ddm11 * a1 + ddm12 * a2)
    )
    mc2 = -k2 * u2 / j2 - k2 * a2 - e2 * ud2 - d2 * q32 - 2 * dm12 * q31 - ndd2 - ddm12 * a1
    # F = diag(K/J − (D/J)²) − W B, W = D + ∂H/∂q̇ + 2 Ṁ
    w11, w12, w21 = d1 + n11 + 2 * dm11, n12 + 2 * dm12, n21 + 2 * dm12
    h1, h2 = e1 / dt, e2 / dt  # D J⁻¹ τ̇ by implicit Euler
    f11 = k1 / j1 - e1 * e1 - (w11 * b11 + w12 * b21) + h1
    f12 = -(w11 * b12 + w12 * b22)
    f21 = -(w21 * b11 + d2 * b21)
    f22 = k2 / j2 - e2 * e2 - (w21 * b12 + d2 * b22) + h2
    rhs1 = m11 * v1 + m12 * v2 - mc1 + h1 * tp1
    rhs2 = m12 * v1 + m22 * v2 - mc2 + h2 * tp2
    det_f = f11 * f22 - f12 * f21
    return (f22 * rhs1 - f12 * rhs2) / det_f, (f11 * rhs2 - f21 * rhs1) / det_f


def _spring_torques(jt, q, qd, motor_q, motor_qd):
    """``K (φ − q) + D (φ̇ − q̇)`` per joint: the torque on the rotors that holds them still
    against the springs, taken as the torque held before a run's first call (at rest with
    the springs relaxed: zero; holding the arm up: the gravity torque)."""
    return (
        jt.k1 * (motor_q[0] - q[0]) + jt.d1 * (motor_qd[0] - qd[0]),
        jt.k2 * (motor_q[1] - q[1]) + jt.d2 * (motor_qd[1] - qd[1]),
    )


# ----------------------------------------------------------------------------- controllers


@dataclass
class _FlexibleJointController(ComputedTorque):
    """What the three laws share: the rigid model, the joints' model, the gains (as CTC's),
    a torque limit, and the motor-reading call."""

    joints: Flexibility | None = None

    needs_motor: ClassVar[bool] = True

    def __post_init__(self) -> None:
        super().__post_init__()
        if not isinstance(self.joints, Flexibility):
            raise ValueError(
                f"{type(self).__name__} reads the motors of flexible joints: it needs their "
                f"model (joints = Flexibility(...)), got {self.joints!r}"
            )
        self._jt = _Joints.of(self.joints)

    def with_joints(self, joints: Flexibility) -> _FlexibleJointController:
        """A copy modelling other joints (a sweep's drawn stiffness)."""
        return dataclasses.replace(self, joints=joints)

    def _saturated(self, tau1: float, tau2: float) -> tuple[float, float]:
        lim1, lim2 = self.torque_limit
        return saturate(tau1, lim1), saturate(tau2, lim2)


@dataclass(frozen=True)
class StiffnessBound:
    """The motor PD's stiffness condition: ``lambda_min > alpha``.

    Attributes
    ----------
    alpha : float
        max over q of ‖∂Ĝ/∂q‖ [N m/rad] (:func:`twolink.arm.dynamics.gravity_gradient_bound`).
    lambda_min : float
        Smallest eigenvalue of ``[[K, −K], [−K, K + Kp]]`` [N m/rad], over both joints.
    """

    alpha: float
    lambda_min: float

    @property
    def met(self) -> bool:
        return self.lambda_min > self.alpha

    @property
    def margin(self) -> float:
        """``lambda_min / alpha``: above 1 the bound is met."""
        return self.lambda_min / self.alpha if self.alpha > 0 else math.inf


def motor_pd_bound(model, k: Sequence[float], kp_motor: Sequence[float]) -> StiffnessBound:
    """Tomei's condition for motor stiffness ``kp_motor`` [N m/rad] on joints ``k``.

    The potential of the closed loop (gravity, springs, the PD's spring on the motors) is
    convex with its one minimum at the set point when the Hessian
    ``∂²U_g/∂q² ⊕ 0 + [[K, −K], [−K, K + Kp]]`` is positive definite; since
    ``‖∂²U_g/∂q²‖ = ‖∂G/∂q‖ ≤ α``, ``λmin([[K, −K], [−K, K + Kp]]) > α`` suffices (Tomei
    1991). K and Kp are diagonal, so the matrix splits into one 2x2 block per joint with
    ``λmin = (2k + kp − sqrt(4k² + kp²)) / 2`` < k: the joints must be stiffer than α.
    """
    lam = min(
        (2 * ki + pi - math.sqrt(4 * ki * ki + pi * pi)) / 2
        for ki, pi in zip(k, kp_motor, strict=True)
    )
    return StiffnessBound(gravity_gradient_bound(model), lam)


@dataclass
class MotorPD(_FlexibleJointController):
    """PD on the motor angles with gravity compensation (Tomei 1991):

        τ = Dm (Kp (φd − φ) + Kd (φ̇d − φ̇)) + Ĝ(q_d),     φd = q_d + K⁻¹ Ĝ(q_d)

    φd is the motor angle that holds the link at q_d against gravity through the spring;
    ``Dm = diag(M̂11 + J1, M̂22 + J2)`` at θ2 = 0 turns the CTC-family gains (1/s², 1/s) into
    torques, as the baselines' D does. For a set point, exact Ĝ and K, the arm converges to
    it from anywhere when :meth:`stiffness_bound` is met (a Lyapunov argument). A moving
    reference is followed as a moving set point (φ̇d its rate): no feedforward of the
    inertia, so it lags a fast move. Reads only the motors and Ĝ at the reference: the
    collocated law, which a light spring damping cannot destabilise.
    """

    def __post_init__(self) -> None:
        super().__post_init__()
        s1, s2 = straight_inertia(self.model)
        self.scale = (s1 + self.joints.j[0], s2 + self.joints.j[1])
        (kp1, kp2), (kd1, kd2) = self.kp, self.kd
        self._gains = (*self.scale, kp1, kp2, kd1, kd2)

    def stiffness_bound(self) -> StiffnessBound:
        """Tomei's condition for these gains and joints (:func:`motor_pd_bound`)."""
        kp_motor = [d * kp for d, kp in zip(self.scale, self.kp, strict=True)]
        return motor_pd_bound(self.model, self.joints.k, kp_motor)

    def __call__(self, t, q, qd, motor_q, motor_qd) -> tuple[float, float]:
        r1, v1, _ = self.reference.joint1(t)
        r2, v2, _ = self.reference.joint2(t)
        return self._saturated(
            *_motor_pd(
                self.model,
                self._jt,
                self._gains,
                r1,
                r2,
                v1,
                v2,
                motor_q[0],
                motor_q[1],
                motor_qd[0],
                motor_qd[1],
                math.cos,
                math.sin,
            )
        )


def spring_frequency(model, joints: Flexibility) -> tuple[float, float]:
    """ωf per joint [rad/s]: the frequency of the spring's (fast) mode with the links'
    slow motion frozen, ``sqrt(K (1/J + μ))``, μ = (M̂⁻¹)ii at θ2 = 0 (the rotor and the
    link swinging against each other on the spring)."""
    m11, m12, m22, _, _ = terms(model, 0.0, 0.0, 0.0, 0.0)
    det = m11 * m22 - m12 * m12
    return tuple(  # type: ignore[return-value]
        math.sqrt(k * (1 / j + mu))
        for k, j, mu in zip(joints.k, joints.j, (m22 / det, m11 / det), strict=True)
    )


def fast_damping_gain(model, joints: Flexibility, zeta: float) -> tuple[float, float]:
    """The composite control's Kv per joint [N m s/rad]: the gain that gives the fast
    (spring) mode the damping ratio ``zeta``.

    With the links' slow motion frozen, joint i's deflection δ obeys
    ``δ̈ ≈ −(1/J + μ) (K δ + D δ̇) − (Kv / J) δ̇`` (μ = (M̂⁻¹)ii at θ2 = 0): a mode of
    frequency ``ωf = sqrt(K (1/J + μ))`` (:func:`spring_frequency`), whose damping ratio is
    ``zeta`` when ``Kv = J (2 zeta ωf − (1/J + μ) D)`` (0 where the joint's own damping
    already gives more).
    """
    out = []
    for wf, k, d, j in zip(spring_frequency(model, joints), joints.k, joints.d, joints.j,
                           strict=True):  # fmt: skip
        inv = wf * wf / k  # 1/J + μ
        out.append(max(0.0, j * (2 * zeta * wf - inv * d)))
    return out[0], out[1]


@dataclass
class CompositeControl(_FlexibleJointController):
    """Singular-perturbation composite control (Spong 1987):

        τ = τs + τf,   τs = (M̂(q) + J) (q̈d + Kd ė + Kp e) + Ĥ + Ĝ,   τf = Kv (q̇ − φ̇)

    τs is the computed torque of the reduced (slow) model, the arm with rotor inertia J
    that the flexible arm becomes as K → ∞; τf damps the fast spring mode, Kv from
    ``fast_damping`` (its damping ratio, :func:`fast_damping_gain`). Valid while the
    spring's mode is much faster than the loop: :meth:`separation` (ωf / ωn) well above 1.
    As K grows, τf → 0 and the link follows CTC's designed error dynamics.

    Parameters
    ----------
    fast_damping : float
        Damping ratio given to the spring's fast mode, >= 0 (default 0.7).
    (others as :class:`~controllers.ctc.ComputedTorque`, plus ``joints``)
    """

    fast_damping: float = DEFAULT_FAST_DAMPING

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (math.isfinite(self.fast_damping) and self.fast_damping >= 0):
            raise ValueError(f"fast_damping must be >= 0, got {self.fast_damping!r}")
        self.kv = fast_damping_gain(self.model, self.joints, self.fast_damping)
        (kp1, kp2), (kd1, kd2) = self.kp, self.kd
        self._gains = (kp1, kp2, kd1, kd2, *self.kv)

    def separation(self) -> tuple[float, float]:
        """ωf / ωn per joint: the spring mode's frequency (:func:`spring_frequency`) over
        the loop's (√Kp)."""
        return tuple(  # type: ignore[return-value]
            wf / math.sqrt(kp) if kp > 0 else math.inf
            for wf, kp in zip(spring_frequency(self.model, self.joints), self.kp, strict=True)
        )

    def __call__(self, t, q, qd, motor_q, motor_qd) -> tuple[float, float]:
        r1, v1, a1 = self.reference.joint1(t)
        r2, v2, a2 = self.reference.joint2(t)
        return self._saturated(
            *_composite(
                self.model,
                self._jt,
                self._gains,
                (r1, r2, v1, v2, a1, a2),
                q[0],
                q[1],
                qd[0],
                qd[1],
                motor_qd[0],
                motor_qd[1],
                math.cos,
                math.sin,
            )
        )


def error_polynomial(
    kp: float, kd: float, fast: tuple[float, float] | None = None
) -> tuple[float, float, float, float]:
    """Coefficients (c0, c1, c2, c3) of the feedback linearisation's error dynamics
    ``e⁗ + c3 e⃛ + c2 ë + c1 ė + c0 e = 0``: CTC's ``s² + Kd s + Kp`` times a second pair.

    ``fast = (ωp, ζp)``: the second pair is ``s² + 2 ζp ωp s + ωp²`` (the default design,
    :class:`FlexibleFeedbackLinearisation`, puts it at the spring's own frequency). Without
    ``fast``: CTC's polynomial squared, its poles each twice ((s + 10)⁴ at ωn = 10, ζ = 1),
    which asks the law to slow the spring's mode down to the loop's bandwidth: see
    ``docs/control.md``, "Why not CTC's poles twice"."""
    if fast is None:
        a1, a0 = kd, kp
    else:
        wp, zp = fast
        a1, a0 = 2 * zp * wp, wp * wp
    return kp * a0, kd * a0 + kp * a1, kp + a0 + kd * a1, kd + a1


@dataclass
class FlexibleFeedbackLinearisation(_FlexibleJointController):
    """Exact feedback linearisation of the flexible-joint arm (Spong 1987).

    With an exact model, each link error obeys ``e⁗ + c3 e⃛ + c2 ë + c1 ė + c0 e = 0``
    (:meth:`error_polynomials`) for any K > 0: CTC's ``s² + Kd s + Kp`` (the slow,
    dominant pair: the link error follows CTC's design) times a fast pair
    ``s² + 2 ζp ωp s + ωp²`` at the spring's own frequency ``ωp = max(ωf, √Kp)``
    (:func:`spring_frequency`) with the damping ratio ``fast_damping``, as the composite
    control gives it. The law inverts the spring, so it has no stiffness bound, but its
    torque grows as J/K times the links' snap and it relies on the model of K, J and D.
    The reference must give its jerk and snap (``derivatives(t, 4)``: every built-in
    reference does; a jerk that jumps, as the quintic's at its ends, is an error the loop
    cannot avoid, so use ``Septic``). For D > 0 the law is dynamic: τ is filtered with
    the joint's own time constant D/K (see :func:`_feedback_linearisation`), over
    ``control_dt``.

    Parameters
    ----------
    control_dt : float
        The control period [s], the step of the torque filter when D > 0.
    fast_damping : float or None
        ζp of the fast pair, > 0 (default 0.7). None: no fast pair, CTC's polynomial
        squared, ``(s² + Kd s + Kp)²``, which a sampled law cannot realise on stiff joints
        at a low bandwidth (``docs/control.md``, "Why not CTC's poles twice").
    (others as :class:`~controllers.ctc.ComputedTorque`, plus ``joints``)
    """

    control_dt: float = 1e-3
    fast_damping: float | None = DEFAULT_FAST_DAMPING
    # its own state, for the stability check's linearisation (twolink.simulation.stability)
    internal_state: ClassVar[tuple[str, ...]] = ("held",)

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (math.isfinite(self.control_dt) and self.control_dt > 0):
            raise ValueError(f"control_dt must be > 0, got {self.control_dt!r}")
        if self.fast_damping is not None and not (
            math.isfinite(self.fast_damping) and self.fast_damping > 0
        ):
            raise ValueError(f"fast_damping must be > 0 or None, got {self.fast_damping!r}")
        for name in ("joint1", "joint2"):
            ref = getattr(self.reference, name)
            if not callable(getattr(ref, "derivatives", None)):
                raise ValueError(
                    f"feedback linearisation needs the jerk and snap of the reference; "
                    f"{name} ({type(ref).__name__}) has no derivatives(t, n) method"
                )
        (c01, c11, c21, c31), (c02, c12, c22, c32) = self.error_polynomials()
        self._gains = (c01, c02, c11, c12, c21, c22, c31, c32)
        self.reset()

    def error_polynomials(self) -> tuple[tuple[float, float, float, float], ...]:
        """(c0, c1, c2, c3) per joint: the designed error dynamics (:func:`error_polynomial`)."""
        wf = spring_frequency(self.model, self.joints)
        out = []
        for kp, kd, w in zip(self.kp, self.kd, wf, strict=True):
            fast = None
            if self.fast_damping is not None:
                fast = (max(w, math.sqrt(kp)), self.fast_damping)
            out.append(error_polynomial(kp, kd, fast))
        return tuple(out)

    def reset(self) -> None:
        """Forget the held torque: the first call takes the springs' torque on the rotors
        (:func:`_spring_torques`) as the torque held before the run."""
        self.held = None

    def __call__(self, t, q, qd, motor_q, motor_qd) -> tuple[float, float]:
        ahead = t + self.control_dt / 2  # where the law is evaluated (see the kernel)
        r1, v1, a1, j1, s1 = self.reference.joint1.derivatives(ahead, 4)
        r2, v2, a2, j2, s2 = self.reference.joint2.derivatives(ahead, 4)
        if self.held is None:
            self.held = _spring_torques(self._jt, q, qd, motor_q, motor_qd)
        o1, o2 = self._snap_offset()
        raw = _feedback_linearisation(
            self.model,
            self._jt,
            self._gains,
            self.control_dt,
            (r1, r2, v1, v2, a1, a2, j1, j2, s1 + o1, s2 + o2),
            (q[0], q[1], qd[0], qd[1], motor_q[0], motor_q[1], motor_qd[0], motor_qd[1]),
            self.held,
            math.cos,
            math.sin,
        )
        tau = self._saturated(*raw)
        self.held = tau
        self._after(t, q, raw, tau)
        return tau

    def _snap_offset(self) -> tuple[float, float]:
        """What a subclass adds to the commanded snap (integral action: ``ci z``)."""
        return 0.0, 0.0

    def _after(self, t: float, q, raw: tuple[float, float], tau: tuple[float, float]) -> None:
        """A subclass's update after each call (its integrators)."""


# ----------------------------------------------------------------------------- batch forms


class _BatchFlexible:
    """What the batch forms share: per-arm models, joints, limits and reference samples up
    to ``order``; called as ``law(k, q, qd, motor_q, motor_qd)`` on (N, 2) arrays."""

    needs_motor = True
    order = 2

    def __init__(self, controllers: Sequence[_FlexibleJointController], times: np.ndarray):
        self.model = _Models.stack(controllers)
        self.jt = _Joints.stack([c.joints for c in controllers])
        self.limit = np.array([c.torque_limit for c in controllers])
        self.gains = tuple(np.array(g) for g in zip(*(c._gains for c in controllers), strict=True))
        refs = [c.reference for c in controllers]
        if self.order <= 2:
            table = ReferenceTable(refs, times)
            self.index, rows = table.index, (table.pos, table.vel, table.acc)
        else:  # feedback linearisation: half a period ahead of each instant
            ahead = [(r, c.control_dt) for r, c in zip(refs, controllers, strict=True)]
            self.index, rows = _sample_derivatives(ahead, times, self.order)
        self.rows = rows  # each (len(times), unique, 2)

    def reference(self, k: int) -> list[np.ndarray]:
        """Per joint and order at instant k: ``[r1, r2, v1, v2, ...]``, each (N,)."""
        out = []
        for row in self.rows:
            at = row[k, self.index]
            out += [at[:, 0], at[:, 1]]
        return out

    def _clip(self, tau1, tau2) -> np.ndarray:
        return np.clip(np.stack([tau1, tau2], axis=1), -self.limit, self.limit)


def _sample_derivatives(refs: Sequence[tuple[ArmReference, float]], times, order: int):
    """Like :class:`~controllers.batch.ReferenceTable`, up to derivative ``order``, each
    reference at ``times + dt / 2`` (pairs of reference and control period dt)."""
    unique: dict[tuple[ArmReference, float], int] = {}
    index = np.array([unique.setdefault(r, len(unique)) for r in refs])
    samples = []
    for r, dt in unique:
        ahead = times + dt / 2
        samples.append(
            (r.joint1.sample_derivatives(ahead, order), r.joint2.sample_derivatives(ahead, order))
        )
    rows = tuple(
        np.stack([np.stack([s1[n], s2[n]], axis=-1) for s1, s2 in samples], axis=1)
        for n in range(order + 1)
    )
    return index, rows


class BatchMotorPD(_BatchFlexible):
    """:class:`MotorPD` for N arms."""

    def __call__(self, k, q, qd, motor_q, motor_qd) -> np.ndarray:
        r1, r2, v1, v2, _, _ = self.reference(k)
        tau = _motor_pd(
            self.model,
            self.jt,
            self.gains,
            r1,
            r2,
            v1,
            v2,
            motor_q[:, 0],
            motor_q[:, 1],
            motor_qd[:, 0],
            motor_qd[:, 1],
            np.cos,
            np.sin,
        )
        return self._clip(*tau)


class BatchCompositeControl(_BatchFlexible):
    """:class:`CompositeControl` for N arms."""

    def __call__(self, k, q, qd, motor_q, motor_qd) -> np.ndarray:
        tau = _composite(
            self.model,
            self.jt,
            self.gains,
            self.reference(k),
            q[:, 0],
            q[:, 1],
            qd[:, 0],
            qd[:, 1],
            motor_qd[:, 0],
            motor_qd[:, 1],
            np.cos,
            np.sin,
        )
        return self._clip(*tau)


class BatchFlexibleFeedbackLinearisation(_BatchFlexible):
    """:class:`FlexibleFeedbackLinearisation` for N arms: the held torques are this law's
    state, (N, 2), zero at the start of a run."""

    order = 4

    def __init__(self, controllers, times):
        super().__init__(controllers, times)
        self.dt = np.array([c.control_dt for c in controllers])
        self.held = np.zeros((len(controllers), 2))  # set at the first instant

    def __call__(self, k, q, qd, motor_q, motor_qd) -> np.ndarray:
        if k == 0:
            self.held = np.stack(_spring_torques(self.jt, q.T, qd.T, motor_q.T, motor_qd.T), 1)
        state = (q[:, 0], q[:, 1], qd[:, 0], qd[:, 1])
        state += (motor_q[:, 0], motor_q[:, 1], motor_qd[:, 0], motor_qd[:, 1])
        tau = _feedback_linearisation(
            self.model,
            self.jt,
            self.gains,
            self.dt,
            self.reference(k),
            state,
            (self.held[:, 0], self.held[:, 1]),
            np.cos,
            np.sin,
        )
        self.held = self._clip(*tau)
        return self.held


MotorPD.batch_law = BatchMotorPD
CompositeControl.batch_law = BatchCompositeControl
FlexibleFeedbackLinearisation.batch_law = BatchFlexibleFeedbackLinearisation
