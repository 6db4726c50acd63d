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

from twolink.controllers.ctc import ComputedTorque

MODES = ("add", "replace")


@dataclass
class FuzzyComputedTorque(ComputedTorque):
    """Computed torque with a fuzzy PD correction per joint.

    Parameters
    ----------
    engine : Mamdani engine
        ``engine(e, de) -> u`` on normalised universes, vectorised; the same rule base
        serves both joints.
    ke, kde : float
        Input scaling: the engine sees ``ke * e`` [1/rad] and ``kde * de`` [s/rad].
    ku : float
        Output scaling [rad/s^2]: the correction is ``ku * u``.
    mode : {"add", "replace"}
        Whether the fuzzy term adds to the PD term or replaces it.
    (other parameters as :class:`~controllers.ctc.ComputedTorque`)
    """

    engine: Any = None
    ke: float = 1.0
    kde: float = 1.0
    ku: float = 4.0
    mode: str = "add"

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.engine is None:
            raise ValueError("FuzzyComputedTorque needs an engine")
        for name in ("ke", "kde", "ku"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
        if self.mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {self.mode!r}")

    def __call__(self, t: float, q: Sequence[float], qd: Sequence[float]) -> tuple[float, float]:
        v1, v2, e1, e2, de1, de2 = self.errors(t, q, qd)
        if self.mode == "add":
            v1 += self.kp[0] * e1 + self.kd[0] * de1
            v2 += self.kp[1] * e2 + self.kd[1] * de2
        ke, kde = self.ke, self.kde
        u1, u2 = self.engine.evaluate_floats((ke * e1, ke * e2), (kde * de1, kde * de2))
        return self.torque(q, qd, v1 + self.ku * u1, v2 + self.ku * u2)
