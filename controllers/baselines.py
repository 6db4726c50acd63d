"""The baselines a reviewer asks for beside CTC and FCM-CTC (docs/control.md).

- :class:`PDGravity`: PD with gravity compensation (Takegaki & Arimoto 1981),
  ``tau = D (Kp e + Kd de) + G^(q)``: the model only for gravity.
- :class:`IntegralComputedTorque`: CTC with integral action and anti-windup,
  ``tau = M^(q) (qdd_d + Kd de + Kp e + Ki z) + H^ + G^``, ``z = integral of e``: removes a
  constant model mismatch (e.g. a wrong weight) that plain CTC leaves as an error.
- :class:`FuzzyPD`: the fuzzy PD term alone, no model, ``tau = D ku f(ke e, kde de)``:
  what the fuzzy part contributes without computed torque.

``D = diag(M^11, M^22)`` at q2 = 0 (the model's inertia, arm straight) turns the gains of
the CTC family (1/s^2, 1/s, rad/s^2) into torques, so one set of numbers means the same
stiffness near the straight arm for every controller. Errors are e = q_d - q, as in CTC.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

from twolink.arm.dynamics import terms
from twolink.arm.params import ArmParams
from twolink.controllers.base import integrate_unless_winding_up, pair, saturate
from twolink.controllers.ctc import ComputedTorque

# Integral gain [1/s^3], the shipped design's (runs/paper/base.toml): ki = 0.25 ωn³ at
# ωn = 15 rad/s. s^3 + Kd s^2 + Kp s + Ki is Hurwitz for Ki < Kd Kp (6750 with the default
# Kp = 225, Kd = 30); docs/control.md says why a quarter of ωn³.
DEFAULT_KI = 843.75


def straight_inertia(model: ArmParams) -> tuple[float, float]:
    """``(M^11, M^22)`` at q2 = 0: the torque scaling D of the baselines."""
    m11, _, m22, _, _ = terms(model, 0.0, 0.0, 0.0, 0.0)
    return m11, m22


@dataclass
class PDGravity(ComputedTorque):
    """PD with gravity compensation: ``tau = D (Kp e + Kd de) + G^(q)``, saturated.

    No feedforward and no inertia model: for a set point and an exact G^ the arm
    converges to it from anywhere (a Lyapunov argument: Takegaki & Arimoto 1981); a wrong
    G^ leaves the error where ``D Kp e = G(q) - G^(q)``. Parameters as
    :class:`~controllers.ctc.ComputedTorque`.
    """

    def __post_init__(self) -> None:
        super().__post_init__()
        self.scale = straight_inertia(self.model)

    def __call__(self, t: float, q: Sequence[float], qd: Sequence[float]) -> tuple[float, float]:
        _, _, e1, e2, de1, de2 = self.errors(t, q, qd)
        _, _, _, g1, g2 = terms(self.model, q[0], q[1], 0.0, 0.0)
        (kp1, kp2), (kd1, kd2), (d1, d2) = self.kp, self.kd, self.scale
        lim1, lim2 = self.torque_limit
        return (
            saturate(d1 * (kp1 * e1 + kd1 * de1) + g1, lim1),
            saturate(d2 * (kp2 * e2 + kd2 * de2) + g2, lim2),
        )


@dataclass
class IntegralComputedTorque(ComputedTorque):
    """CTC with integral action: ``v = qdd_d + Kd de + Kp e + Ki z``, ``z_{k+1} = z_k + e_k dt``.

    With an exact model each joint's error obeys e''' + Kd e'' + Kp e' + Ki e = 0 (to
    O(dt) for the sampled integrator). Anti-windup by conditional integration: a joint's
    integrator holds while its torque is saturated and its error pushes further into the
    saturation, so it cannot wind up while the actuator is at its limit.

    Parameters
    ----------
    ki : float or pair of float
        Integral gain [1/s^3], >= 0.
    control_dt : float
        The control period [s], the integrator's step.
    (other parameters as :class:`~controllers.ctc.ComputedTorque`)
    """

    ki: float | Sequence[float] = DEFAULT_KI
    control_dt: float = 1e-3
    # its own state, for the stability check's linearisation (twolink.simulation.stability)
    internal_state: ClassVar[tuple[str, ...]] = ("z",)

    def __post_init__(self) -> None:
        super().__post_init__()
        self.ki = pair("ki", self.ki)
        if not (math.isfinite(self.control_dt) and self.control_dt > 0):
            raise ValueError(f"control_dt must be > 0, got {self.control_dt!r}")
        self.reset()

    def reset(self) -> None:
        """Empty the integrators."""
        self.z = (0.0, 0.0)

    def __call__(self, t: float, q: Sequence[float], qd: Sequence[float]) -> tuple[float, float]:
        a1, a2, e1, e2, de1, de2 = self.errors(t, q, qd)
        (kp1, kp2), (kd1, kd2), (ki1, ki2) = self.kp, self.kd, self.ki
        z1, z2 = self.z
        v1 = a1 + kd1 * de1 + kp1 * e1 + ki1 * z1
        v2 = a2 + kd2 * de2 + kp2 * e2 + ki2 * z2
        raw1, raw2 = self.unsaturated(q, qd, v1, v2)
        lim1, lim2 = self.torque_limit
        tau1, tau2 = saturate(raw1, lim1), saturate(raw2, lim2)
        dt = self.control_dt
        self.z = (
            integrate_unless_winding_up(z1, e1, raw1, tau1, dt),
            integrate_unless_winding_up(z2, e2, raw2, tau2, dt),
        )
        return tau1, tau2


@dataclass
class FuzzyPD(ComputedTorque):
    """The fuzzy PD term alone: ``tau = D ku f(ke e, kde de)``, saturated; no model terms.

    Parameters
    ----------
    engine : Mamdani engine
        ``engine(e, de) -> u`` on normalised universes (the same rule base for both joints).
    ke, kde, ku : float or None
        Scalings as in :class:`~controllers.fuzzy_ctc.FuzzyComputedTorque`; ``None`` (the
        default): tied to ``kp`` and the torque limits, as a scenario's ``"auto"``.
    (``kp`` sets the scaling only; ``kd`` is not used; other parameters as ComputedTorque)
    """

    engine: Any = None
    ke: float | None = None
    kde: float | None = None
    ku: float | None = None

    def __post_init__(self) -> None:
        from twolink.controllers.fuzzy_ctc import fill_scaling

        super().__post_init__()
        if self.engine is None:
            raise ValueError("FuzzyPD needs an engine")
        fill_scaling(self)
        self.scale = straight_inertia(self.model)

    def __call__(self, t: float, q: Sequence[float], qd: Sequence[float]) -> tuple[float, float]:
        _, _, e1, e2, de1, de2 = self.errors(t, q, qd)
        ke, kde, ku = self.ke, self.kde, self.ku
        u1, u2 = self.engine.evaluate_floats((ke * e1, ke * e2), (kde * de1, kde * de2))
        (d1, d2), (lim1, lim2) = self.scale, self.torque_limit
        return saturate(d1 * (ku * u1), lim1), saturate(d2 * (ku * u2), lim2)


__all__ = [
    "DEFAULT_KI",
    "FuzzyPD",
    "IntegralComputedTorque",
    "PDGravity",
    "straight_inertia",
]
