"""A law of the flexible-link literature that damps the links through the hub motors:
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

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from twolink.arm.dynamics import gravity
from twolink.arm.params import ArmParams
from twolink.controllers.base import pair, saturate
from twolink.foundation.references import ArmReference


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
        self.kp = pair("kp", self.kp)
        self.kd = pair("kd", self.kd)
        self.ks = pair("ks", self.ks)
        self.root_stiffness = pair("root_stiffness", self.root_stiffness, positive=True)
        self.torque_limit = pair("torque_limit", self.torque_limit, positive=True, allow_inf=True)

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
