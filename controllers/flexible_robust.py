"""A flexible-joint controller that removes a constant model error when it reads the true
state: feedback linearisation with integral action on the link error. Behind encoders it
fails (60-64 mrad off behind the 50 Hz filtered rate, chatter with the differenced one;
``docs/control.md``, "Each law's limits, as measured"); ``flexible_observed.py`` feeds it
a Kalman filter on the encoder angles for that.

:class:`~controllers.flexible.FlexibleFeedbackLinearisation` (Spong 1987) computes the
links' acceleration and jerk from the measured link and rotor states through the model
(M̂, Ĥ, Ĝ and the joints' K̂, D̂, Ĵ). A wrong model biases them, and the law settles off
the target: 3-8e-2 rad on stiff joints and up to 0.23 rad on the soft arm with the
plant's masses ×1.2, g ×1.1 and its stiffness 20 % below the model's (``docs/control.md``,
"Feedback linearisation with integral action"). Integral action on the link error
removes any such constant bias, whatever its source.

:class:`IntegralFlexibleFeedbackLinearisation` is that law (see its docstring for the
design, the gain rule and the anti-windup), :class:`BatchIntegralFlexibleFeedbackLinearisation`
its batch form.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from twolink.controllers.base import integrate_unless_winding_up
from twolink.controllers.batch import ReferenceTable
from twolink.controllers.flexible import (
    BatchFlexibleFeedbackLinearisation,
    FlexibleFeedbackLinearisation,
    _feedback_linearisation,
    _spring_torques,
)

__all__ = [
    "DEFAULT_INTEGRAL_FRACTION",
    "BatchIntegralFlexibleFeedbackLinearisation",
    "IntegralFlexibleFeedbackLinearisation",
    "integral_polynomial",
]

# ωi / ωn, the integral pole as a fraction of the loop's bandwidth √Kp (the rule in
# IntegralFlexibleFeedbackLinearisation's docstring; docs/control.md measures it).
DEFAULT_INTEGRAL_FRACTION = 0.5


def integral_polynomial(
    coefficients: Sequence[float], pole: float
) -> tuple[float, float, float, float, float]:
    """Coefficients ``(ci, C0, C1, C2, C3)`` of ``(s + pole) (s⁴ + c3 s³ + c2 s² + c1 s + c0)``
    from ``coefficients = (c0, c1, c2, c3)``: the fifth-order error dynamics

        e⁗ + C3 e⃛ + C2 ë + C1 ė + C0 e + ci ∫e = 0

    that the designed fourth-order polynomial gets with the integral of the error as a
    fifth state and one more real pole at ``-pole`` (``pole = 0``: ``ci = 0`` and the
    fourth-order coefficients unchanged)."""
    c0, c1, c2, c3 = coefficients
    return pole * c0, c0 + pole * c1, c1 + pole * c2, c2 + pole * c3, c3 + pole


@dataclass
class IntegralFlexibleFeedbackLinearisation(FlexibleFeedbackLinearisation):
    """Exact feedback linearisation of the flexible-joint arm (Spong 1987) with integral
    action on the link error and anti-windup at the torque limit.

    The law is :class:`~controllers.flexible.FlexibleFeedbackLinearisation`'s with the
    synthetic input ``v`` (the links' commanded fourth derivative) given one more state,
    ``z = ∫ e dt``, ``e = q_d − q``:

        v = q⁗d + C3 (q⃛d − q⃛̂) + C2 (q̈d − q̈̂) + C1 ė + C0 e + ci z

    so that with an exact model each link error obeys
    ``e⁗ + C3 e⃛ + C2 ë + C1 ė + C0 e + ci ∫e = 0``, whose characteristic polynomial is
    the fourth-order design times ``(s + ωi)`` (:func:`integral_polynomial`). A model
    error (masses, gravity, the joints' stiffness) biases the accelerations and jerks the
    law computes through the model, which without ``z`` leaves a steady link error; with
    it every rest state of the closed loop has ``e = 0`` (ż = e), and a constant bias is
    integrated out at the rate ωi.

    Sources: the law is Spong's exact feedback linearisation (M. W. Spong, "Modeling and
    control of elastic joint robots", ASME J. Dyn. Syst. Meas. Control 109(4), 1987;
    De Luca and Book, "Robots with flexible elements", Springer Handbook of
    Robotics, 2nd ed. 2016, ch. 11, §11.1, trajectory tracking by feedback
    linearisation, which needs the model exactly); the integral state added to a
    feedback-linearised system for robust regulation under constant parameter errors is
    integral control as in H. K. Khalil, Nonlinear Systems, 3rd ed. 2002, §12.3
    ("Integral control": augment with ż = e, stabilise the augmented system; at any
    equilibrium e = 0 whatever the constant uncertainty, as long as it stays stable).

    **Gain rule.** The extra pole is real, at ``ωi = integral_fraction · ωn`` per joint
    (ωn = √Kp, the CTC pair's natural frequency), default ``integral_fraction = 0.5``:

    - the designed polynomial ``(s + ωi)(s² + Kd s + Kp)(s² + 2 ζp ωp s + ωp²)`` is
      Hurwitz for every ωi > 0 (a product of Hurwitz factors), and the CTC pair and the
      spring's fast pair stay where :class:`FlexibleFeedbackLinearisation` puts them;
    - ωi sets how fast a bias is removed, ``e^(−ωi t)``: at ωn = 10 and 0.5, ωi = 5 rad/s
      leaves 5e-4 of it 1.5 s after a move (the 3 s run of a 1.5 s move);
    - the price: ``z`` must return to its rest value, so an error transient the integral
      did not cause (a start off the reference) comes back with an undershoot, about
      ``2 · integral_fraction`` of it up to 25-45 % (closed form: 24 % on stiff joints,
      33-36 % on the soft arm at 0.5; 7 % at 0.05). A fraction below 1 keeps the integral
      the design's slowest pole, under the CTC pair that sets the tracking transient.
      ``docs/control.md`` measures 0.25 to 2: all meet the spec at ωn = 10 and above,
      at ωn = 7 it takes about 1, at ωn = 4 none does on the stiff joints;
      ``integral_fraction = 0`` gives the plain law, bit for bit.

    **Anti-windup** (conditional integration, as
    :class:`~controllers.baselines.IntegralComputedTorque`): a joint's integrator holds
    while its torque is at the limit and its error would push it further (the sign of
    the error equals the sign of the unsaturated torque). The integrator starts empty at
    each run (:meth:`reset`); it is integrated by forward Euler at the control period
    from the error measured at each call.

    Parameters
    ----------
    integral_fraction : float
        ωi / √Kp, >= 0 (default :data:`DEFAULT_INTEGRAL_FRACTION`, 0.5); 0 turns the
        integral off.
    (others as :class:`~controllers.flexible.FlexibleFeedbackLinearisation`: ``model``,
    ``reference``, ``kp``, ``kd``, ``torque_limit``, ``joints``, ``control_dt``,
    ``fast_damping``)
    """

    integral_fraction: float = DEFAULT_INTEGRAL_FRACTION
    # its own state, for the stability check's linearisation (twolink.simulation.stability)
    internal_state: ClassVar[tuple[str, ...]] = ("held", "z")

    def __post_init__(self) -> None:
        f = self.integral_fraction
        if (
            isinstance(f, bool)
            or not isinstance(f, int | float)
            or not (math.isfinite(f) and f >= 0)
        ):
            raise ValueError(f"integral_fraction must be a finite number >= 0, got {f!r}")
        self.integral_fraction = float(f)
        super().__post_init__()
        polys = self.integral_polynomials()
        (ci1, c01, c11, c21, c31), (ci2, c02, c12, c22, c32) = polys
        # the kernel's gains (c0, c1, c2, c3 per joint), the fifth-order design's
        self._gains = (c01, c02, c11, c12, c21, c22, c31, c32)
        self.ki = (ci1, ci2)

    def integral_poles(self) -> tuple[float, float]:
        """ωi per joint [rad/s]: ``integral_fraction · √Kp``."""
        return tuple(self.integral_fraction * math.sqrt(kp) for kp in self.kp)  # type: ignore[return-value]

    def integral_polynomials(self) -> tuple[tuple[float, float, float, float, float], ...]:
        """(ci, C0, C1, C2, C3) per joint: the designed fifth-order error dynamics, the
        fourth-order design (:meth:`error_polynomials`) times ``(s + ωi)``."""
        return tuple(
            integral_polynomial(poly, wi)
            for poly, wi in zip(self.error_polynomials(), self.integral_poles(), strict=True)
        )

    def reset(self) -> None:
        """Forget the held torque (see the parent) and empty the integrators."""
        super().reset()
        self.z = (0.0, 0.0)

    def _snap_offset(self) -> tuple[float, float]:
        # ci z enters v as the snap does: added to the reference's snap
        (z1, z2), (ki1, ki2) = self.z, self.ki
        return ki1 * z1, ki2 * z2

    def _after(self, t, q, raw, tau) -> None:
        # the error now, integrated by forward Euler; conditional integration (anti-windup)
        e1 = self.reference.joint1(t)[0] - q[0]
        e2 = self.reference.joint2(t)[0] - q[1]
        (z1, z2), dt = self.z, self.control_dt
        self.z = (
            integrate_unless_winding_up(z1, e1, raw[0], tau[0], dt),
            integrate_unless_winding_up(z2, e2, raw[1], tau[1], dt),
        )


class BatchIntegralFlexibleFeedbackLinearisation(BatchFlexibleFeedbackLinearisation):
    """:class:`IntegralFlexibleFeedbackLinearisation` for N arms: the held torques and the
    integrators are this law's state, (N, 2) each, set at the start of a run. The same
    arithmetic in the same order as the single-arm law (the kernel on per-arm arrays, the
    reference at each instant from :class:`~controllers.batch.ReferenceTable` for the
    integrated error)."""

    def __init__(self, controllers, times):
        super().__init__(controllers, times)
        self.ki = np.array([c.ki for c in controllers])
        self.now = ReferenceTable([c.reference for c in controllers], times)
        self.z = np.zeros((len(controllers), 2))

    def __call__(self, k, q, qd, motor_q, motor_qd) -> np.ndarray:
        if k == 0:
            self.held = np.stack(_spring_torques(self.jt, q.T, qd.T, motor_q.T, motor_qd.T), 1)
            self.z = np.zeros_like(self.z)
        ref = self.reference(k)
        ref[8] = ref[8] + self.ki[:, 0] * self.z[:, 0]  # ci z, added to the snap
        ref[9] = ref[9] + self.ki[:, 1] * self.z[:, 1]
        state = (q[:, 0], q[:, 1], qd[:, 0], qd[:, 1])
        state += (motor_q[:, 0], motor_q[:, 1], motor_qd[:, 0], motor_qd[:, 1])
        raw = np.stack(
            _feedback_linearisation(
                self.model,
                self.jt,
                self.gains,
                self.dt,
                ref,
                state,
                (self.held[:, 0], self.held[:, 1]),
                np.cos,
                np.sin,
            ),
            axis=1,
        )
        tau = np.clip(raw, -self.limit, self.limit)
        self.held = tau
        e = self.now.pos[k, self.now.index] - q
        free = (tau == raw) | ((e > 0) != (raw > 0))  # anti-windup, as the scalar law
        self.z = np.where(free, self.z + e * self.dt[:, None], self.z)
        return tau


IntegralFlexibleFeedbackLinearisation.batch_law = BatchIntegralFlexibleFeedbackLinearisation
