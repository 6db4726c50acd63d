"""Computed-torque control (feedback linearisation) with the controller's own model.

    tau = M^(q) (qdd_d + Kd de + Kp e) + H^(q, qd) + G^(q),   e = q_d - q

The hats are the controller's model parameters, which may differ from the plant's
("uncertainty"). With a perfect model each joint's error obeys
e'' + Kd e' + Kp e = 0.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from twolink.arm.dynamics import terms
from twolink.arm.params import ArmParams
from twolink.controllers.base import pair, saturate
from twolink.foundation.references import ArmReference

# Defaults: the shipped design, runs/paper/base.toml's [controller] (the gain study's
# rule, docs/control.md "Choosing the gains"): ωn = 15 rad/s, ζ = 1, and the paper's
# 60 / 15 N·m actuators. Every controller builds on this class, so any two built with
# their defaults compare fairly (docs/control.md "Defaults"; tests/test_defaults.py
# checks these against base.toml).
DEFAULT_KP = 225.0  # 1/s²: ωn²
DEFAULT_KD = 30.0  # 1/s: 2 ζ ωn
DEFAULT_TORQUE_LIMIT = (60.0, 15.0)  # N·m per joint


@dataclass
class ComputedTorque:
    """Computed-torque controller.

    Parameters
    ----------
    model : ArmParams
        The controller's model of the arm (M^, H^, G^).
    reference : ArmReference
        What to track.
    kp, kd : float or pair of float
        Proportional [1/s^2] and derivative [1/s] gains, per joint, >= 0.
    torque_limit : float or pair of float
        Actuator saturation [N m] per joint; ``inf`` for none.

    The defaults are the shipped design (:data:`DEFAULT_KP`, :data:`DEFAULT_KD`,
    :data:`DEFAULT_TORQUE_LIMIT`), as for every controller.
    """

    model: ArmParams
    reference: ArmReference
    kp: float | Sequence[float] = DEFAULT_KP
    kd: float | Sequence[float] = DEFAULT_KD
    torque_limit: float | Sequence[float] = DEFAULT_TORQUE_LIMIT

    def __post_init__(self) -> None:
        self.kp = pair("kp", self.kp)
        self.kd = pair("kd", self.kd)
        self.torque_limit = pair("torque_limit", self.torque_limit, positive=True, allow_inf=True)

    def reset(self) -> None:
        """No internal state."""

    def errors(self, t: float, q: Sequence[float], qd: Sequence[float]):
        """Desired accelerations and errors at ``t``: ``(a1, a2, e1, e2, de1, de2)``."""
        q1, q2 = q
        w1, w2 = qd
        r1, v1, a1 = self.reference.joint1(t)
        r2, v2, a2 = self.reference.joint2(t)
        return a1, a2, r1 - q1, r2 - q2, v1 - w1, v2 - w2

    def unsaturated(self, q: Sequence[float], qd: Sequence[float], v1: float, v2: float):
        """``M^(q) v + H^ + G^``: the inner, linearising loop, before the actuator limit."""
        m11, m12, m22, b1, b2 = terms(self.model, q[0], q[1], qd[0], qd[1])
        return m11 * v1 + m12 * v2 + b1, m12 * v1 + m22 * v2 + b2

    def torque(self, q: Sequence[float], qd: Sequence[float], v1: float, v2: float):
        """:meth:`unsaturated`, saturated."""
        raw1, raw2 = self.unsaturated(q, qd, v1, v2)
        lim1, lim2 = self.torque_limit
        return saturate(raw1, lim1), saturate(raw2, lim2)

    def __call__(self, t: float, q: Sequence[float], qd: Sequence[float]) -> tuple[float, float]:
        a1, a2, e1, e2, de1, de2 = self.errors(t, q, qd)
        kp1, kp2 = self.kp
        kd1, kd2 = self.kd
        return self.torque(q, qd, a1 + kd1 * de1 + kp1 * e1, a2 + kd2 * de2 + kp2 * e2)
