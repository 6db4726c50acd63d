"""Laws of the flexible-link literature for links that bend: :class:`StrainRateFeedback`,
:class:`TwoTimeScaleControl` (computed torque on the rigid-body model plus strain rate)
and :func:`zv_shaped`, a zero-vibration shaper of the reference.

:class:`StrainRateFeedback` damps the links through the hub motors:
joint PD with gravity compensation plus root strain-rate feedback (Ge, Lee and Zhu,
"Improving regulation of a single-link flexible manipulator with strain feedback", IEEE
Trans. Robot. Autom. 14(1), 1998; the rate form as in Sun, Mills, Shan and Tso,
Mechatronics 14, 2004)::

    tau_i = G^(q)_i + kp_i e_i + kd_i de_i + ks_i dM_i / dt

M_i is link i's root bending moment, what a strain gauge at the root reads: in the
lumped model the first hinge's spring torque, k_i times its angle. The gain ks [s]
turns the moment's rate into hub torque; its sign is the one that damps (a hub whose
inertia dominates at the links' frequencies then moves with the moment and takes energy
out of the link). The law reads the hub angles and the hinge rates (``needs_links``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from twolink.arm.dynamics import gravity
from twolink.arm.links import FlexibleLinks
from twolink.arm.params import ArmParams
from twolink.controllers.base import pair, saturate
from twolink.controllers.ctc import DEFAULT_KD, DEFAULT_KP
from twolink.foundation.references import ArmReference


def _check_gains(law) -> None:
    """A law's kp, kd, ks (>= 0) and torque limit (> 0, inf allowed) as checked pairs."""
    law.kp = pair("kp", law.kp)
    law.kd = pair("kd", law.kd)
    law.ks = pair("ks", law.ks)
    law.torque_limit = pair("torque_limit", law.torque_limit, positive=True, allow_inf=True)


@dataclass
class StrainRateFeedback:
    """Joint PD + gravity compensation + root strain-rate feedback.

    Parameters
    ----------
    model : ArmParams
        The rigid arm the gravity term models.
    reference : ArmReference
        What the hubs track.
    root_stiffness : pair of float
        Each link's first hinge stiffness k_i [N m/rad]: the gauge's calibration.
    kp, kd : float or pair of float
        Joint gains [N m/rad], [N m s/rad], >= 0.
    ks : float or pair of float
        Strain-rate gain [s], >= 0; 0 is the joint PD alone.
    torque_limit : float or pair of float
        Actuator saturation [N m].
    """

    model: ArmParams
    reference: ArmReference
    root_stiffness: Sequence[float]
    kp: float | Sequence[float] = (200.0, 50.0)
    kd: float | Sequence[float] = (40.0, 10.0)
    ks: float | Sequence[float] = 0.01
    torque_limit: float | Sequence[float] = float("inf")

    needs_links = True

    def __post_init__(self) -> None:
        _check_gains(self)
        self.root_stiffness = pair("root_stiffness", self.root_stiffness, positive=True)

    def reset(self) -> None:
        """No internal state."""

    def __call__(self, t, q, qd, bends: np.ndarray, bend_rates: np.ndarray):
        g = gravity(self.model, np.asarray(q, dtype=float))
        out = []
        for i, joint in enumerate((self.reference.joint1, self.reference.joint2)):
            r, v, _ = joint(t)
            moment_rate = self.root_stiffness[i] * float(bend_rates[i][0])
            tau = g[i] + self.kp[i] * (r - q[i]) + self.kd[i] * (v - qd[i])
            out.append(saturate(tau + self.ks[i] * moment_rate, self.torque_limit[i]))
        return out[0], out[1]


@dataclass
class TwoTimeScaleControl:
    """Computed torque on the rigid-body model of the bending arm plus root strain-rate
    feedback: the composite control of the singular perturbation approach (Siciliano and
    Book, "A singular perturbation approach to control of lightweight flexible
    manipulators", Int. J. Robot. Res. 7(4), 1988)::

        tau = M_rb(q) (qdd_d + kd de + kp e) + H_rb(q, qd) + G_rb(q) + ks dM / dt

    The slow part is computed torque on the arm with its links held straight
    (:meth:`twolink.arm.links.FlexibleLinks.rigid_body_terms`: rods, hubs and tip masses);
    it keeps the hubs on the reference, so the hub torques, which bend the links, end
    with the move. The fast part damps the bending left, as in
    :class:`StrainRateFeedback`.

    Parameters
    ----------
    model : FlexibleLinks
        The law's model of the arm: its rigid-body terms and each link's first hinge
        stiffness (the strain gauge's calibration).
    reference : ArmReference
        What the hubs track.
    kp, kd : float or pair of float
        Hub gains [1/s²], [1/s], >= 0, as :class:`ComputedTorque`'s.
    ks : float or pair of float
        Strain-rate gain [s], >= 0; 0 is the rigid-body computed torque alone.
    g : float
        The model's gravity [m/s²].
    torque_limit : float or pair of float
        Actuator saturation [N m].
    """

    model: FlexibleLinks
    reference: ArmReference
    kp: float | Sequence[float] = DEFAULT_KP
    kd: float | Sequence[float] = DEFAULT_KD
    ks: float | Sequence[float] = 0.01
    g: float = 0.0
    torque_limit: float | Sequence[float] = float("inf")

    needs_links = True

    def __post_init__(self) -> None:
        _check_gains(self)
        self.root_stiffness = tuple(b.hinge(self.model.segments)[0] for b in self.model.links)

    def reset(self) -> None:
        """No internal state."""

    def __call__(self, t, q, qd, bends: np.ndarray, bend_rates: np.ndarray):
        (r1, r2), (v1, v2), (a1, a2) = self.reference(t)
        u1 = a1 + self.kd[0] * (v1 - qd[0]) + self.kp[0] * (r1 - q[0])
        u2 = a2 + self.kd[1] * (v2 - qd[1]) + self.kp[1] * (r2 - q[1])
        m11, m12, m22, n1, n2 = self.model.rigid_body_terms(q[0], q[1], qd[0], qd[1], self.g)
        slow = (m11 * u1 + m12 * u2 + n1, m12 * u1 + m22 * u2 + n2)
        out = []
        for i in range(2):
            fast = self.ks[i] * self.root_stiffness[i] * float(bend_rates[i][0])
            out.append(saturate(slow[i] + fast, self.torque_limit[i]))
        return out[0], out[1]


@dataclass(frozen=True)
class ZVShaped:
    """A joint's reference through a zero-vibration input shaper (Singer and Seering,
    "Preshaping command inputs to reduce system vibration", J. Dyn. Syst. Meas. Control
    112(1), 1990): two copies of it, the second delayed by half the mode's damped period::

        r_s(t) = A1 r(t) + A2 r(t - Δ),   Δ = 1 / (2 f sqrt(1 - ζ²)),
        K = exp(-ζ π / sqrt(1 - ζ²)),   A1 = 1 / (1 + K),   A2 = K / (1 + K)

    A linear loop whose mode is (f, ζ) then ends the move with that mode at rest: the
    second copy's swing cancels the first's. The move lasts Δ longer. f and ζ are the
    closed loop's mode, not the open links' (:func:`twolink.arm.links.linear_modes` with
    the law's feedback).

    Parameters
    ----------
    joint : JointReference
        The reference shaped (a move with ``t0`` and ``duration``, or a step).
    frequency : float
        The mode's natural frequency f [Hz], > 0.
    damping_ratio : float
        Its ζ, in [0, 1).
    """

    joint: Any
    frequency: float
    damping_ratio: float

    def __post_init__(self) -> None:
        if not self.frequency > 0 or not 0 <= self.damping_ratio < 1:
            raise ValueError(
                f"ZVShaped needs frequency > 0 and 0 <= damping_ratio < 1, got "
                f"{self.frequency}, {self.damping_ratio}"
            )

    @property
    def delay(self) -> float:
        """Δ [s]: half the mode's damped period."""
        return 0.5 / (self.frequency * math.sqrt(1 - self.damping_ratio**2))

    @property
    def amplitudes(self) -> tuple[float, float]:
        """(A1, A2): they sum to 1, so the shaped reference ends where the joint's does."""
        z = self.damping_ratio
        k = math.exp(-z * math.pi / math.sqrt(1 - z * z))
        return 1 / (1 + k), k / (1 + k)

    @property
    def final(self) -> float:
        return self.joint.final

    @property
    def t0(self) -> float:
        return getattr(self.joint, "t0", 0.0)

    @property
    def duration(self) -> float:
        """The joint's move and the delay: when the shaped reference is at rest."""
        return getattr(self.joint, "duration", 0.0) + self.delay

    def __call__(self, t: float) -> tuple[float, float, float]:
        a1, a2 = self.amplitudes
        first, second = self.joint(t), self.joint(t - self.delay)
        return tuple(a1 * x + a2 * y for x, y in zip(first, second, strict=True))

    def sample(self, t: np.ndarray) -> np.ndarray:
        a1, a2 = self.amplitudes
        t = np.asarray(t, dtype=float)
        return a1 * self.joint.sample(t) + a2 * self.joint.sample(t - self.delay)


def zv_shaped(reference: ArmReference, frequency: float, damping_ratio: float) -> ArmReference:
    """Both joints' references through one :class:`ZVShaped` shaper at the loop's mode."""
    return ArmReference(
        ZVShaped(reference.joint1, frequency, damping_ratio),
        ZVShaped(reference.joint2, frequency, damping_ratio),
    )
