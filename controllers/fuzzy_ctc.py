"""Fuzzy computed-torque control: a Mamdani fuzzy PD term joined with CTC.

The paper does not say how the fuzzy output joins the computed-torque law. We put it
inside the linearising bracket, as an outer loop on the (nominally) linearised arm:

    mode "add" (default):  tau = M^ (qdd_d + Kd de + Kp e + ku f(ke e, kde de)) + H^ + G^
    mode "replace":        tau = M^ (qdd_d + ku f(ke e, kde de)) + H^ + G^

Why "add": the paper's reduced rule base (Table 1) has 5 rules, so most of the (e, de)
plane fires none; there the engine returns zero correction and the CTC term alone
acts, which keeps the loop defined and stable. In "replace" mode a reduced rule base
leaves the arm without feedback wherever no rule fires. Inside the bracket (rather
than as a torque on top) the fuzzy term has the units of acceleration, so the same
scaling gains work for both joints whatever their inertia. See docs/control.md.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from twolink.arm.dynamics import gravity, mass_matrix
from twolink.arm.params import ArmParams
from twolink.controllers.base import pair
from twolink.controllers.ctc import DEFAULT_KD, DEFAULT_KP, DEFAULT_TORQUE_LIMIT, ComputedTorque
from twolink.foundation.references import ArmReference

MODES = ("add", "replace")
DEFAULT_SPAN = 1.0  # rad: E where no joint has a torque limit (the paper's 1 rad moves)


def linear_span(
    arm: ArmParams, kp: Sequence[float], torque_limit: Sequence[float] = (math.inf, math.inf)
) -> float:
    """E, the largest error the PD term answers without saturating the actuator [rad].

    Per joint j, the torque left over the largest static gravity torque, divided by the
    PD term's torque per radian at the largest inertia, M̂jj Kp_j (both at θ = 0, the arm
    straight and horizontal); the smaller of the two joints. A joint with Kp = 0, no
    limit, or a limit that does not exceed gravity's torque (it cannot hold itself,
    whatever the span) gives none; :data:`DEFAULT_SPAN` where neither gives one.
    """
    m = mass_matrix(arm, np.zeros(2))
    g = np.abs(gravity(arm, np.zeros(2))).tolist()
    spans = []
    for j in range(2):
        if not math.isfinite(torque_limit[j]) or not kp[j] > 0:
            continue
        headroom = torque_limit[j] - g[j]
        if headroom > 0:  # else the joint cannot even hold itself: no linear range
            spans.append(float(headroom / (m[j, j] * kp[j])))
    return min(spans, default=DEFAULT_SPAN)


def auto_fuzzy_scaling(
    kp: Sequence[float],
    span: float = DEFAULT_SPAN,
    authority: float = 1.0,
    ke: float | None = None,
    kde: float | None = None,
    ku: float | None = None,
) -> tuple[float, float, float]:
    """The fuzzy scaling tied to the CTC gains (docs/fuzzy.md, "Scaling"); a value given
    (not None) is kept, and the others follow from it.

    With the softer joint's stiffness (the smaller Kp = ωn²; both joints share one
    scaling):

    - ``ke = 1 / span``: an error of ``span`` (E; by default :func:`linear_span`, the
      largest error the PD term answers unsaturated) fills the error universe;
    - ``kde = ke / ωn``: a rate of ωn E, a full-scale error changing on the loop's own
      time scale 1/ωn, fills the rate universe;
    - ``ku = authority · Kp / ke``: the fuzzy term's full scale is ``authority`` times the
      PD term's Kp · E at full-scale error E = 1/ke.

    The damping (Kd) does not enter. Raises ValueError where the softer joint's Kp is 0
    and ``kde`` or ``ku`` is derived.
    """
    kp_s = float(min(kp))
    ke = 1.0 / span if ke is None else ke
    if (kde is None or ku is None) and not kp_s > 0:
        raise ValueError(f"needs kp > 0 on both joints, got kp = {list(kp)}")
    kde = ke / math.sqrt(kp_s) if kde is None else kde
    ku = authority * kp_s / ke if ku is None else ku
    return ke, kde, ku


def fill_scaling(controller: Any, authority: float = 1.0) -> None:
    """Fill a controller's ``ke``, ``kde``, ``ku`` left ``None`` as a scenario's ``"auto"``
    does: :func:`auto_fuzzy_scaling` of its gains with the span :func:`linear_span` of its
    torque limits (the values given are kept and the others follow from them)."""
    given = {name: getattr(controller, name) for name in ("ke", "kde", "ku")}
    if all(v is not None for v in given.values()):
        return
    span = linear_span(controller.model, controller.kp, controller.torque_limit)
    ke, kde, ku = auto_fuzzy_scaling(controller.kp, span, authority, **given)
    controller.ke, controller.kde, controller.ku = ke, kde, ku


@dataclass
class FuzzyComputedTorque(ComputedTorque):
    """Computed torque with a fuzzy PD correction per joint.

    Parameters
    ----------
    engine : Mamdani engine
        ``engine(e, de) -> u`` on normalised universes, vectorised; the same rule base
        serves both joints.
    ke, kde : float or None
        Input scaling: the engine sees ``ke * e`` [1/rad] and ``kde * de`` [s/rad].
    ku : float or None
        Output scaling [rad/s^2]: the correction is ``ku * u``. ``None`` (the default, for
        each of the three): tied to ``kp`` and the torque limits as a scenario's
        ``"auto"`` (:func:`fill_scaling`), so the defaults are the shipped design's.
    mode : {"add", "replace"}
        Whether the fuzzy term adds to the PD term or replaces it.
    (other parameters as :class:`~controllers.ctc.ComputedTorque`)
    """

    engine: Any = None
    ke: float | None = None
    kde: float | None = None
    ku: float | None = None
    mode: str = "add"

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.engine is None:
            raise ValueError("FuzzyComputedTorque needs an engine")
        fill_scaling(self)
        for name in ("ke", "kde", "ku"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
        if self.mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {self.mode!r}")

    @classmethod
    def fcm(
        cls,
        arm: ArmParams,
        reference: ArmReference,
        rule_base: str = "designed",
        *,
        kp: float | Sequence[float] = DEFAULT_KP,
        kd: float | Sequence[float] = DEFAULT_KD,
        torque_limit: float | Sequence[float] = DEFAULT_TORQUE_LIMIT,
        authority: float = 1.0,
        inference: str = "mamdani",
        **kwargs: Any,
    ) -> FuzzyComputedTorque:
        """FCM-CTC as the reproduction builds it: CTC with the ``rule_base`` ("designed",
        "paper", "default", a TOML file or any two-input, one-output ``.fis``) in its
        bracket, scaled by the gains (:func:`auto_fuzzy_scaling` with the span
        :func:`linear_span` of the torque limits; docs/fuzzy.md, "Scaling").
        ``inference="continuous"`` infers the same rules continuously (our extension:
        docs/fuzzy.md, "The relay"). The defaults are the shipped design's, as every
        controller's (:class:`ComputedTorque`: ωn = 15 rad/s, ζ = 1, the paper's
        60 / 15 N·m limits).

        >>> from twolink import ArmParams, ArmReference, FuzzyComputedTorque, Step
        >>> arm, ref = ArmParams(), ArmReference(Step(final=1.0), Step(final=0.0))
        >>> fcm = FuzzyComputedTorque.fcm(arm, ref)
        >>> round(fcm.ke, 2), round(fcm.kde, 3), round(fcm.ku, 2), len(fcm.engine.rules)
        (14.86, 0.991, 15.14, 5)
        """
        from twolink.controllers.fuzzy.continuous import ContinuousEngine
        from twolink.controllers.fuzzy.fis.matlab import rule_base_engine
        from twolink.controllers.fuzzy.rulebase import resolve_rule_base

        if inference not in ("mamdani", "continuous"):
            raise ValueError(f'inference must be "mamdani" or "continuous", got {inference!r}')
        engine = rule_base_engine(resolve_rule_base(rule_base))
        if inference == "continuous":
            engine = ContinuousEngine(engine)
        kp2 = pair("kp", kp)
        limit = pair("torque_limit", torque_limit, allow_inf=True)
        ke, kde, ku = auto_fuzzy_scaling(kp2, linear_span(arm, kp2, limit), authority)
        return cls(
            arm, reference, kp=kp2, kd=kd, torque_limit=limit, engine=engine,
            ke=ke, kde=kde, ku=ku, **kwargs,
        )  # fmt: skip

    def __call__(self, t: float, q: Sequence[float], qd: Sequence[float]) -> tuple[float, float]:
        v1, v2, e1, e2, de1, de2 = self.errors(t, q, qd)
        if self.mode == "add":
            v1 += self.kp[0] * e1 + self.kd[0] * de1
            v2 += self.kp[1] * e2 + self.kd[1] * de2
        ke, kde = self.ke, self.kde
        u1, u2 = self.engine.evaluate_floats((ke * e1, ke * e2), (kde * de1, kde * de2))
        return self.torque(q, qd, v1 + self.ku * u1, v2 + self.ku * u2)
