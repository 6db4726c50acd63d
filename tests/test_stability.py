"""Every law in the stability check (issue 37): each controller is linearised at its rest
state with its own state (integrators, a held torque) and its fuzzy term; a law that jumps
there has no linearisation, a kink is judged by its worse side; and no run is "met spec"
where its linearisation is unstable (the two flexible-map cells where FCM-CTC was)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from twolink import sweep as sw
from twolink.controllers.ctc import ComputedTorque
from twolink.foundation.overrides import merge
from twolink.simulation.config import load_scenario, scenario_from_dict
from twolink.simulation.experiment import build_controller, build_plant, measure, run_scenario
from twolink.simulation.outcome import classify_run, reasons
from twolink.simulation.stability import closed_loop_growth, linearise

REPO = Path(__file__).resolve().parents[1]
MAP = REPO / "runs" / "sweeps" / "flexible_map.toml"
STEP = REPO / "runs" / "paper" / "theta1_step.toml"
QUINTIC = {
    "joint1": {"kind": "quintic", "final": 1.0, "duration": 1.0},
    "joint2": {"kind": "quintic", "final": 0.5, "duration": 1.0},
}


def map_cell(controller: str, k: float, wn: float):
    """The flexible map's scenario of one cell, as its sweep builds it."""
    plan = sw.load_sweep(MAP)
    values = {"k": k, "zeta_joint": 0.02, "wn": wn}
    data = plan.sample_data(values, 0)
    data = merge(data, {"controller": plan.controller_data(controller, values)["controller"]})
    return scenario_from_dict(data, str(plan.file))


@pytest.mark.parametrize(("k", "wn", "sigma"), [(2000.0, 4.0, 1.44), (1e4, 7.0, 1.61)])
def test_fcm_ctc_is_linearised_with_its_fuzzy_term_and_is_not_met_spec_where_unstable(k, wn, sigma):
    # Near the target no rule of the designed base fires: FCM-CTC's linearisation is
    # CTC's, unstable; before issue 37 it had none (NaN) and its calm 3 s run "met spec".
    ctc, fcm = map_cell("CTC", k, wn), map_cell("FCM-CTC", k, wn)
    growth_ctc = closed_loop_growth(ctc, build_plant(ctc), build_controller(ctc))
    growth_fcm = closed_loop_growth(fcm, build_plant(fcm), build_controller(fcm))
    assert growth_ctc == pytest.approx(sigma, abs=0.01)
    assert growth_fcm == pytest.approx(growth_ctc, abs=1e-6)
    metrics = measure(fcm, run_scenario(fcm))
    assert metrics.linear_growth[0] == pytest.approx(sigma, abs=0.01)
    assert classify_run(fcm, metrics) == "off target"
    assert any("linearised" in r for r in reasons(fcm, metrics))


def rigid(kind: str, **controller) -> object:
    return load_scenario(
        STEP,
        {"duration": 2.0, "controller": {"kind": kind, **controller}, "reference": QUINTIC},
    )


def test_ctc_with_integral_action_is_linearised_with_its_integrators():
    # With the exact model each joint's error obeys e''' + Kd e'' + Kp e' + Ki e = 0: the
    # loop's growth is the largest real part of that polynomial's roots (sampled at 1 kHz:
    # within 0.05 s⁻¹). Without its integrators in the state there is no such answer.
    kp, kd, ki = 100.0, 12.0, 200.0
    s = rigid("ctc_integral", kp=kp, kd=kd, ki=ki)
    expected = max(np.roots([1.0, kd, kp, ki]).real)
    assert closed_loop_growth(s, build_plant(s), build_controller(s)) == pytest.approx(
        expected, abs=0.05
    )


def test_flexible_feedback_linearisation_is_linearised_with_its_held_torque():
    # Exact model: the link error follows the designed quartic (error_polynomials), whose
    # slowest root is CTC's pair at −Kd/2 ± j... (ζ = 0.5 here, away from a double root).
    s = map_cell("flexible-FL", 1e4, 7.0)
    s = merge(s.to_dict(), {"controller": {"kp": 49.0, "kd": 7.0}})
    s = scenario_from_dict(s, str(MAP))
    controller = build_controller(s)
    expected = max(max(np.roots([1.0, c3, c2, c1, c0]).real)
                   for c0, c1, c2, c3 in controller.error_polynomials())  # fmt: skip
    lin = linearise(s, build_plant(s), controller)
    assert lin.sigma == pytest.approx(expected, abs=0.05)
    assert lin.note == ""  # smooth: no kink claimed


@dataclass
class Kinked(ComputedTorque):
    """CTC plus ``c |e1|`` (a kink at e1 = 0) or ``c sign(e1)`` (a jump) in joint 1's
    acceleration: at the target the loop rests where the law is not differentiable."""

    c: float = 0.0
    jump: bool = False

    def __call__(self, t, q, qd):
        a1, a2, e1, e2, de1, de2 = self.errors(t, q, qd)
        (kp1, kp2), (kd1, kd2) = self.kp, self.kd
        extra = self.c * (math.copysign(1.0, e1) if self.jump and e1 else abs(e1))
        return self.torque(q, qd, a1 + kd1 * de1 + kp1 * e1 + extra, a2 + kd2 * de2 + kp2 * e2)


def test_a_kink_is_judged_by_its_worse_side_and_a_jump_has_no_linearisation():
    s = rigid("ctc", kp=100.0, kd=12.0)
    base = dict(model=s.arm, reference=s.reference, kp=(100.0, 100.0), kd=(12.0, 12.0),
                torque_limit=(math.inf, math.inf))  # fmt: skip
    smooth = linearise(s, build_plant(s), Kinked(**base))
    assert smooth.sigma < 0 and smooth.note == ""
    # Kp − c < 0 on the e1 < 0 side: a negative stiffness there, unstable; the central
    # difference (Kp on average) alone would call it stable.
    kink = linearise(s, build_plant(s), Kinked(**base, c=150.0))
    assert kink.sigma > 0 and "kink" in kink.note
    # a small kink that both sides survive stays stable, still said to be a kink
    mild = linearise(s, build_plant(s), Kinked(**base, c=20.0))
    assert mild.sigma < 0 and "kink" in mild.note
    jump = linearise(s, build_plant(s), Kinked(**base, c=1.0, jump=True))
    assert math.isnan(jump.sigma) and "jumps" in jump.note


def test_every_law_on_the_rigid_arm_gets_a_growth_rate_or_a_reason():
    # The stability check no longer skips laws by kind: each shipped law on the rigid
    # arm (exact model) is stable there, or says why it has no linearisation.
    for kind in ("ctc", "ctc_integral", "pd_gravity", "fcm_ctc", "fuzzy_ctc", "fuzzy_pd"):
        extra = {"rule_base": "designed"} if kind == "fcm_ctc" else {}
        s = rigid(kind, **extra)
        lin = linearise(s, build_plant(s), build_controller(s))
        assert lin.sigma < 0 or (math.isnan(lin.sigma) and lin.note), (kind, lin)
