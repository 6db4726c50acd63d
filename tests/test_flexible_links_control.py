"""The link-damping law (controllers/flexible_links.py) on the flexible-link arm, judged
by MuJoCo's own linearisation of the closed loop."""

from __future__ import annotations

import numpy as np
import pytest

from twolink.arm.links import FlexibleLinks, LinkBeam, build_links_model, linear_modes
from twolink.arm.links import law_gain as links_law_gain
from twolink.controllers.flexible_links import StrainRateFeedback
from twolink.foundation.references import ArmReference, Step

N = 8
LINKS = FlexibleLinks(
    LinkBeam(ei=1000.0, hub_inertia=0.4, tip_mass=0.5),
    LinkBeam(ei=1000.0, hub_inertia=0.08, tip_mass=0.1),
    N,
)


def law_gain(law, nv: int) -> np.ndarray:
    """:func:`twolink.arm.links.law_gain` on this file's N segments."""
    return links_law_gain(law, N, nv)


def closed_loop(ks: float):
    p = LINKS.rigid_params(0.0)
    law = StrainRateFeedback(
        p, ArmReference(Step(final=0.0), Step(final=0.0)), [b.hinge(N)[0] for b in LINKS.links]
    )
    law.ks = (ks, ks)  # the sign mutant below needs a negative gain, which pair() refuses
    model = build_links_model(LINKS, g=0.0, timestep=1e-5, visual=False)
    return linear_modes(model, feedback=law_gain(law, model.nv))


def test_strain_rate_feedback_damps_the_link_modes():
    """Joint PD alone (ks = 0) against ks = 0.01 s: the modes near 29 and 73 Hz (the links
    bending against the hubs) go from ζ = 0.17 and 0.044 to 0.70 and 0.078."""
    w0, z0 = closed_loop(0.0)
    w1, z1 = closed_loop(0.01)
    assert np.all(z0 > 0) and np.all(z1 > 0)  # both loops are stable
    assert w0[2] / (2 * np.pi) == pytest.approx(29.4, abs=0.1)
    assert w0[3] / (2 * np.pi) == pytest.approx(73.3, abs=0.1)
    assert z0[2] == pytest.approx(0.169, abs=2e-3) and z1[2] == pytest.approx(0.698, abs=2e-3)
    assert z0[3] == pytest.approx(0.044, abs=1e-3) and z1[3] == pytest.approx(0.078, abs=1e-3)


def test_strain_rate_feedback_of_the_wrong_sign_destabilises():
    _, z = closed_loop(-0.01)
    assert z.min() < 0


def test_gains_are_checked():
    ref = ArmReference(Step(final=0.0), Step(final=0.0))
    p = LINKS.rigid_params(0.0)
    with pytest.raises(ValueError):
        StrainRateFeedback(p, ref, [1.0, 1.0], ks=-0.01)
    with pytest.raises(ValueError):
        StrainRateFeedback(p, ref, [0.0, 1.0])


def test_the_loop_hands_the_law_the_hinge_rates():
    """Through simulate_links the law sees the hinges: ks changes the torques."""
    from twolink.arm.links import LinkPlant
    from twolink.foundation.references import Quintic
    from twolink.simulation.links_sim import control_timestep, simulate_links

    p = LINKS.rigid_params(0.0)
    ref = ArmReference(Quintic(final=0.5, duration=0.3), Quintic(final=0.2, duration=0.3))
    k = [b.hinge(N)[0] for b in LINKS.links]
    plant = LinkPlant.build(LINKS, g=0.0, timestep=control_timestep(LINKS, 1e-3))
    runs = [simulate_links(plant, StrainRateFeedback(p, ref, k, ks=ks), 0.3) for ks in (0, 0.01)]
    assert all(r.trajectory.ok for r in runs)
    assert np.abs(runs[0].trajectory.tau - runs[1].trajectory.tau).max() > 1e-3
    # The first torque after rest: PD on the reference only (the hinges start at rest).
    assert np.allclose(runs[1].trajectory.tau[0], 0.0)


@pytest.mark.slow
def test_on_a_move_the_residual_deflection_is_the_hubs_not_the_strains():
    """docs/flexible_links.md: after a 1 s move of (1, 0.5) rad at 1 kHz, PD leaves 24 mm
    of deflection, the strain term does not shrink it, the paper's CTC leaves 4.9 mm."""
    from twolink.arm.links import LinkPlant
    from twolink.controllers.ctc import ComputedTorque
    from twolink.foundation.references import Quintic
    from twolink.simulation.links_sim import control_timestep, simulate_links, tip_metrics

    p = LINKS.rigid_params(0.0)
    ref = ArmReference(Quintic(final=1.0, duration=1.0), Quintic(final=0.5, duration=1.0))
    k = [b.hinge(N)[0] for b in LINKS.links]
    plant = LinkPlant.build(LINKS, g=0.0, timestep=control_timestep(LINKS, 1e-3))
    laws = (StrainRateFeedback(p, ref, k, ks=0.0), StrainRateFeedback(p, ref, k, ks=0.01))
    pd, srf = (tip_metrics(simulate_links(plant, c, 3.0), p, 1.0) for c in laws)
    ctc = tip_metrics(simulate_links(plant, ComputedTorque(p, ref), 3.0), p, 1.0)
    assert pd.residual_vibration == pytest.approx(0.0238, abs=5e-4)
    assert srf.residual_vibration >= pd.residual_vibration
    assert ctc.residual_vibration == pytest.approx(0.0049, abs=2e-4)
