"""The batch engine for links that bend (twolink.simulation.links_sim.simulate_links_batch)
against the single-arm run, arm by arm."""

from __future__ import annotations

import numpy as np
import pytest

from twolink.arm.links import FlexibleLinks, LinkBeam, LinkPlant
from twolink.controllers.ctc import ComputedTorque
from twolink.controllers.flexible_links import StrainRateFeedback, TwoTimeScaleControl
from twolink.foundation.references import ArmReference, Quintic
from twolink.simulation.links_sim import control_timestep, simulate_links, simulate_links_batch

REF = ArmReference(Quintic(final=0.8, duration=0.3), Quintic(final=-0.4, duration=0.3))
ARMS = [
    (FlexibleLinks(LinkBeam(ei=1e3, hub_inertia=0.4, tip_mass=0.5), LinkBeam(ei=1e3), 4), 0.0),
    (
        FlexibleLinks(
            LinkBeam(ei=2e3, hub_inertia=0.2), LinkBeam(ei=5e2, hub_inertia=0.08, tip_mass=0.1), 6
        ),
        0.3,
    ),
    (FlexibleLinks(LinkBeam(ei=1e3, hub_inertia=0.4), LinkBeam(ei=1e3, hub_inertia=0.08), 4), 0.0),
]
DT = min(control_timestep(links, 1e-3) for links, _ in ARMS)


def _laws():
    links0, links1, links2 = (a for a, _ in ARMS)
    k2 = [b.hinge(4)[0] for b in links2.links]
    return [
        ComputedTorque(links0.rigid_params(0.0), REF),
        TwoTimeScaleControl(links1, REF, ks=0.01),
        StrainRateFeedback(links2.rigid_params(0.0), REF, k2, ks=0.01),
    ]


def test_each_arm_of_a_batch_runs_as_alone():
    """Same torques, hub angles, hinge angles and bent points as the single-arm run, to
    rounding, whatever the other arms (N = 4 and 6, payloads, laws that read the hinges)."""
    q0 = np.array([[0.1, 0.2], [0.0, -0.3], [0.5, 0.0]])
    runs = simulate_links_batch(ARMS, _laws(), 0.4, 1e-3, DT, g=9.81, q0=q0)
    for i, ((links, payload), law) in enumerate(zip(ARMS, _laws(), strict=True)):
        plant = LinkPlant.build(links, 9.81, payload, timestep=DT)
        alone = simulate_links(plant, law, 0.4, 1e-3, q0=q0[i])
        got = runs[i]
        assert got.trajectory.ok and len(got.trajectory.t) == len(alone.trajectory.t)
        for a, b in (
            (got.trajectory.tau, alone.trajectory.tau),
            (got.trajectory.q, alone.trajectory.q),
        ):
            assert np.array_equal(a, b)
        assert np.array_equal(got.bends, alone.bends)
        assert np.array_equal(got.points, alone.points)
        assert np.array_equal(got.tip, alone.tip)
    assert np.abs(runs[0].trajectory.tau - runs[2].trajectory.tau).max() > 1e-2  # they differ


def test_an_arm_that_diverges_stops_alone():
    """An arm whose torque leaves the bounds stops there as alone; its neighbours run on."""
    from twolink.simulation.sim import Bounds

    laws = _laws()
    laws[1] = TwoTimeScaleControl(ARMS[1][0], REF, ks=0.01, kp=1e5, kd=1e3)
    bounds = Bounds(torque=200.0)
    runs = simulate_links_batch(ARMS, laws, 0.4, 1e-3, DT, g=0.0, bounds=bounds)
    plant = LinkPlant.build(ARMS[1][0], 0.0, ARMS[1][1], timestep=DT)
    alone = simulate_links(plant, laws[1], 0.4, 1e-3, bounds=bounds)
    assert not alone.trajectory.ok and not runs[1].trajectory.ok
    assert runs[1].trajectory.message == alone.trajectory.message
    assert len(runs[1].trajectory.t) == len(alone.trajectory.t)
    for i in (0, 2):
        assert runs[i].trajectory.ok
        plant = LinkPlant.build(ARMS[i][0], 0.0, ARMS[i][1], timestep=DT)
        single = simulate_links(plant, _laws()[i], 0.4, 1e-3)
        assert np.allclose(runs[i].trajectory.q, single.trajectory.q, rtol=0, atol=1e-9)
    with pytest.raises(ValueError):
        simulate_links_batch([], [], 0.1, 1e-3, DT)


def test_iter_scenarios_runs_bending_links_as_run_scenario():
    """The batch engine's entry (iter_scenarios) runs [arm.links] scenarios, batched with
    each other, each trajectory equal to run_scenario's; a rigid scenario beside them too."""
    from twolink.simulation.config import scenario_from_dict
    from twolink.simulation.experiment import iter_scenarios, run_scenario

    def data(**links):
        return {
            "duration": 0.4,
            "arm": {"g": 0.0, "links": {"segments": 4, **links}},
            "controller": {"kind": "ctc"},
            "reference": {
                "joint1": {"kind": "quintic", "final": 0.5, "duration": 0.3},
                "joint2": {"kind": "quintic", "final": -0.3, "duration": 0.3},
            },
        }

    rigid = data()
    del rigid["arm"]["links"]
    scenarios = [
        scenario_from_dict(d)
        for d in (
            data(ei=1e3, hub_inertia=[0.4, 0.08]),
            rigid,
            data(ei=1e3, hub_inertia=[0.2, 0.08], tip_mass=0.3),
            data(ei=1e3) | {"plant": {"payload": 0.2}},
        )
    ]
    got = dict(iter_scenarios(scenarios))
    assert sorted(got) == [0, 1, 2, 3]
    for i, s in enumerate(scenarios):
        alone = run_scenario(s)
        assert np.array_equal(got[i].q, alone.q) and np.array_equal(got[i].tau, alone.tau)
    with pytest.raises(ValueError, match="cpu"):
        dict(iter_scenarios(scenarios, backend="mjx"))


def test_an_arm_whose_state_leaves_the_bounds_keeps_what_alone_keeps():
    """Out of bounds at the start: one row (no torque) and that instant's shape; out of
    bounds later: the instants before, none of that one. Each as alone, bit for bit."""
    from twolink.simulation.sim import Bounds

    bounds = Bounds(angle=1.0, rate=8.0)
    q0 = np.array([[0.0, 0.0], [1.5, 0.0], [0.0, 0.0]])  # arm 1 starts beyond 1 rad

    def laws():  # arm 2 moves by 3 rad in 0.3 s: past 8 rad/s and 1 rad
        fast = ArmReference(Quintic(final=3.0, duration=0.3), Quintic(final=0.0, duration=0.3))
        return [*_laws()[:2], ComputedTorque(ARMS[2][0].rigid_params(0.0), fast)]

    runs = simulate_links_batch(ARMS, laws(), 0.4, 1e-3, DT, g=0.0, q0=q0, bounds=bounds)
    for i, law in enumerate(laws()):
        plant = LinkPlant.build(ARMS[i][0], 0.0, ARMS[i][1], timestep=DT)
        alone = simulate_links(plant, law, 0.4, 1e-3, q0=q0[i], bounds=bounds)
        got = runs[i]
        assert got.trajectory.status == alone.trajectory.status
        assert got.trajectory.message == alone.trajectory.message
        for a, b in (
            (got.trajectory.q, alone.trajectory.q),
            (got.trajectory.tau, alone.trajectory.tau),
        ):
            assert np.array_equal(a, b, equal_nan=True)
        assert np.array_equal(got.points, alone.points) and np.array_equal(got.bends, alone.bends)
    assert len(runs[1].trajectory.t) == 1 and np.isnan(runs[1].trajectory.tau).all()
    assert runs[0].trajectory.ok and not runs[2].trajectory.ok
    assert 1 < len(runs[2].trajectory.t) < len(runs[0].trajectory.t)  # it stopped mid-move


def test_a_non_finite_hub_angle_is_a_state_out_of_bounds_in_the_batch_and_alone():
    """NaN fails the bounds as in the rigid engines: the law is never called with it."""
    q0 = np.array([[0.0, 0.0], [0.0, np.nan], [0.0, 0.0]])
    runs = simulate_links_batch(ARMS, _laws(), 0.1, 1e-3, DT, g=0.0, q0=q0)
    plant = LinkPlant.build(ARMS[1][0], 0.0, ARMS[1][1], timestep=DT)
    alone = simulate_links(plant, _laws()[1], 0.1, 1e-3, q0=q0[1])
    for run in (runs[1], alone):
        assert run.trajectory.message.startswith("state out of bounds at t=0.0000 s")
        assert len(run.trajectory.t) == 1 and np.isnan(run.trajectory.tau).all()
    assert runs[0].trajectory.ok and runs[2].trajectory.ok
