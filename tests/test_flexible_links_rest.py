"""Links that bend start at rest under gravity (twolink.arm.links.rest_shape): their sag
against beam theory, an arm held still stays still, and the tip's residual vibration is
taken about the sag, not about straight links (docs/flexible_links.md, "At rest under
gravity")."""

from __future__ import annotations

import math

import numpy as np
import pytest

from twolink.arm.links import FlexibleLinks, LinkBeam, LinkPlant, rest_shape, single_link_model
from twolink.arm.plant import mujoco
from twolink.foundation.references import ArmReference, make_reference
from twolink.simulation.links_sim import control_timestep, rest_sag, simulate_links, tip_metrics

G = 9.81


def _clamped_sag(beam: LinkBeam, n: int) -> tuple[float, float]:
    """The clamped link's tip height at rest under gravity, and the largest qacc there."""
    model = single_link_model(beam, n, g=G)
    data = mujoco.MjData(model)
    rest_shape(model, data, np.arange(model.nv))
    mujoco.mj_forward(model, data)
    return float(data.site_xpos[model.site("tip").id][2]), float(np.abs(data.qacc).max())


@pytest.mark.parametrize("tip_mass", [0.0, 0.3])
def test_the_sag_of_a_clamped_link_is_the_beams_with_the_midpoint_rules_error(tip_mass):
    """Euler-Bernoulli: w = ρ A g L⁴ / (8 E I) + M g L³ / (3 E I). The lumped chain's
    error falls as 1 / N² (the midpoint rule), and the rest is a true rest (qacc = 0)."""
    beam = LinkBeam(ei=1000.0, rho_a=1.0, length=1.0, tip_mass=tip_mass)
    theory = -(beam.rho_a * G / 8 + tip_mass * G / 3) * beam.length**3 / beam.ei
    errors = []
    for n in (4, 8, 16, 32):
        height, qacc = _clamped_sag(beam, n)
        assert qacc < 1e-9
        errors.append(abs(height / theory - 1))
    assert errors[-1] < 5e-4
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(orders - 2) < 0.05), orders


class _Hold:
    """A law that gives the hubs, at every instant, the torque that holds the rest shape."""

    def __init__(self, plant: LinkPlant) -> None:
        mujoco.mj_forward(plant.model, plant.data)
        self.tau = plant.data.qfrc_bias[plant.hubs].copy()
        q1, q2 = plant.q
        self.reference = ArmReference(
            make_reference("step", final=q1, initial=q1),
            make_reference("step", final=q2, initial=q2),
        )

    def reset(self) -> None:
        pass

    def __call__(self, t, q, qd):
        return self.tau


_holder = _Hold


LINKS = FlexibleLinks(
    LinkBeam(ei=800.0, hub_inertia=0.05), LinkBeam(ei=800.0, hub_inertia=0.05), segments=4
)


def test_an_arm_held_at_its_rest_shape_stays_at_rest():
    """Hubs at (0.3, -0.4), held by their static torques: the links neither swing nor
    drift. Started straight (the old start), the same arm swings by millimetres."""
    plant = LinkPlant.build(LINKS, g=G, timestep=control_timestep(LINKS, 1e-3))
    q0 = (0.3, -0.4)
    plant.reset(q0)
    sag = plant.bends.copy()
    assert np.abs(sag).max() > 1e-3  # it does sag
    holder = _holder(plant)
    run = simulate_links(plant, holder, 0.3, 1e-3, q0=q0)
    assert np.abs(run.bends - sag).max() < 1e-9
    assert np.abs(run.trajectory.q - q0).max() < 1e-9

    straight = LinkPlant.build(LINKS, g=G, timestep=control_timestep(LINKS, 1e-3))
    straight.reset(q0)
    straight.data.qpos[:] = 0.0
    straight.data.qpos[straight.hubs] = q0
    for _ in range(int(0.1 / straight.dt)):
        straight.step(*holder(0, q0, (0, 0)))
    assert np.abs(straight.bends - sag).max() > 1e-3


def test_the_residual_vibration_of_an_arm_at_rest_is_zero_not_its_sag():
    """The tip of an arm held at rest under gravity sits its sag below the rigid tip; the
    residual vibration is measured about that sag, so it is 0, while the tip error (the
    tip off where the rigid rods would put it) is the sag itself."""
    p = LINKS.rigid_params(G)
    q0 = (0.0, 0.0)
    plant = LinkPlant.build(LINKS, g=G, timestep=control_timestep(LINKS, 1e-3))
    plant.reset(q0)
    run = simulate_links(plant, _holder(plant), 0.3, 1e-3, q0=q0)
    sag = rest_sag(LINKS, p, 0.0, q0)
    assert np.linalg.norm(sag) > 5e-3
    measures = tip_metrics(run, p, rest_time=0.0, sag=sag)
    assert measures.residual_vibration < 1e-9
    assert measures.tip_error == pytest.approx(np.linalg.norm(sag), rel=1e-9)
    assert tip_metrics(run, p, rest_time=0.0).residual_vibration == pytest.approx(
        np.linalg.norm(sag), rel=1e-9
    )  # about straight links it would read the sag


def test_without_gravity_the_rest_shape_is_straight_and_the_sag_zero():
    plant = LinkPlant.build(LINKS, g=0.0)
    plant.reset((0.3, -0.4))
    assert not plant.bends.any()
    assert not rest_sag(LINKS, LINKS.rigid_params(0.0), 0.5, (0.3, -0.4)).any()


def test_links_too_soft_to_hold_themselves_up_are_refused():
    soft = LinkBeam(ei=0.05, tip_mass=0.5)
    plant = LinkPlant.build(FlexibleLinks(soft, soft, segments=4), g=G, timestep=1e-4)
    with pytest.raises(ValueError, match="too soft to hold themselves up"):
        plant.reset((0.0, 0.0))
    assert math.isfinite(plant.dt)
