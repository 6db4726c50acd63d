"""What leaves the tip swinging after a move on bending links, and what stops it: the
rigid-body model of the arm (twolink.arm.links.FlexibleLinks.rigid_body_terms), the
two-time-scale law on it and a zero-vibration shaper of the reference
(controllers/flexible_links.py)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from test_flexible_links_control import LINKS, N, law_gain

from twolink.arm.dynamics import terms
from twolink.arm.links import FlexibleLinks, LinkBeam, LinkLayout, build_links_model, linear_modes
from twolink.controllers.flexible_links import TwoTimeScaleControl, ZVShaped, zv_shaped
from twolink.foundation.references import ArmReference, Quintic, Step


def test_rigid_body_terms_are_mujocos_with_the_links_straight():
    """Held straight, the arm's hub dynamics are MuJoCo's: the hub rows of its mass
    matrix (mj_fullM) and of its bias forces, gravity included, with hubs and tip masses."""
    links = FlexibleLinks(
        LinkBeam(ei=1e3, rho_a=0.8, length=1.2, hub_inertia=0.4, tip_mass=0.5),
        LinkBeam(ei=1e3, length=0.7, hub_inertia=0.08, tip_mass=0.1),
        N,
    )
    model = build_links_model(links, g=9.81, timestep=1e-4, visual=False)
    data = mujoco.MjData(model)
    hubs = list(LinkLayout(N).hubs)
    full = np.zeros((model.nv, model.nv))
    for q1, q2, w1, w2 in np.random.default_rng(1).uniform(-2, 2, (4, 4)):
        data.qpos[:], data.qvel[:] = 0.0, 0.0
        data.qpos[hubs], data.qvel[hubs] = (q1, q2), (w1, w2)
        mujoco.mj_forward(model, data)
        mujoco.mj_fullM(model, data, full)
        m = full[np.ix_(hubs, hubs)]
        expected = (m[0, 0], m[0, 1], m[1, 1], *data.qfrc_bias[hubs])
        assert links.rigid_body_terms(q1, q2, w1, w2, 9.81) == pytest.approx(expected, rel=1e-9)
    # Without hubs and tip masses: the rods of twolink.arm.dynamics.
    bare = FlexibleLinks(LinkBeam(), LinkBeam(length=0.5), 4)
    assert bare.rigid_body_terms(0.3, 0.7, 0.2, -1.0, 9.81) == pytest.approx(
        terms(bare.rigid_params(9.81), 0.3, 0.7, 0.2, -1.0), rel=1e-12
    )


def _step_response(t, f, z):
    """A unit step through the mode (f [Hz], ζ) with unit static gain, exactly."""
    w = 2 * math.pi * f
    wd = w * math.sqrt(1 - z * z)
    t = np.maximum(t, 0.0)
    y = 1 - np.exp(-z * w * t) * (np.cos(wd * t) + z * w / wd * np.sin(wd * t))
    return np.where(t > 0, y, 0.0)


@pytest.mark.parametrize("z", [0.0, 0.1, 0.4])
def test_a_zv_shaped_step_leaves_its_mode_at_rest(z):
    """The shaper's staircase drives the mode (f, ζ) to rest at the second impulse: the
    exact response equals 1 from Δ on; with the delay 10 % off it swings."""
    f = 3.0
    shaped = ZVShaped(Step(final=1.0), f, z)
    a1, a2 = shaped.amplitudes
    assert a1 + a2 == pytest.approx(1.0) and shaped.final == 1.0
    t = np.linspace(0, 3, 3001)
    assert np.allclose(shaped.sample(t)[0], a1 * (t >= 0) + a2 * (t >= shaped.delay))
    after = t >= shaped.delay
    y = a1 * _step_response(t, f, z) + a2 * _step_response(t - shaped.delay, f, z)
    assert np.abs(y[after] - 1).max() < 1e-12
    off = a1 * _step_response(t, f, z) + a2 * _step_response(t - 1.1 * shaped.delay, f, z)
    assert np.abs(off[t >= 1.1 * shaped.delay] - 1).max() > 0.05 * a2
    with pytest.raises(ValueError):
        ZVShaped(Step(final=1.0), f, 1.0)


def _loop_mode(ks: float):
    """The two-time-scale loop's linearised modes at rest (no gravity)."""
    law = TwoTimeScaleControl(LINKS, ArmReference(Step(final=0.0), Step(final=0.0)), ks=ks)
    model = build_links_model(LINKS, g=0.0, timestep=1e-5, visual=False)
    w, z = linear_modes(model, feedback=law_gain(law, model.nv))
    return w / (2 * np.pi), z


def test_the_loops_slow_mode_is_the_hubs_and_strain_rate_does_not_damp_it():
    """Computed torque on the rigid-body model puts the hubs at ωn = 15 rad/s (2.4 Hz),
    critically damped; the links split that pair into 2.73 Hz (ζ 0.86) and 3.37 Hz
    (ζ 0.40). Strain-rate feedback damps the 30 Hz bending mode (ζ 0.10 to 0.63) but
    lowers the 3.37 Hz mode's ζ to 0.34."""
    f0, z0 = _loop_mode(0.0)
    f1, z1 = _loop_mode(0.01)
    assert f0[:3] == pytest.approx([2.726, 3.367, 30.285], abs=2e-3)
    assert z0[:3] == pytest.approx([0.863, 0.404, 0.103], abs=2e-3)
    assert f1[2] == pytest.approx(27.943, abs=2e-3) and z1[2] == pytest.approx(0.627, abs=2e-3)
    assert f1[:2] == pytest.approx([3.012, 3.148], abs=2e-3)
    assert z1[:2] == pytest.approx([0.894, 0.337], abs=2e-3)


@pytest.mark.slow
def test_a_zv_shaper_at_the_loops_mode_stops_the_tip_swinging():
    """docs/flexible_links.md: a 1 s move of (1, 0.5) rad at 1 kHz under the two-time-scale
    law (ks = 0). Unshaped, the tip swings 5.70 mm after the move and settles within 1 mm
    at 1.276 s; shaped at the loop's mode (3.367 Hz, ζ 0.404, Δ = 162 ms) 0.49 mm after
    the shaped move, settled at 1.038 s. A shaper whose delay is off by half does worse."""
    from twolink.arm.links import LinkPlant
    from twolink.controllers.ctc import ComputedTorque
    from twolink.simulation.links_sim import control_timestep, simulate_links, tip_metrics

    p = LINKS.rigid_params(0.0)
    ref = ArmReference(Quintic(final=1.0, duration=1.0), Quintic(final=0.5, duration=1.0))
    plant = LinkPlant.build(LINKS, g=0.0, timestep=control_timestep(LINKS, 1e-3))

    def measured(reference, rest, law=TwoTimeScaleControl):
        controller = law(LINKS, reference, ks=0.0) if law is TwoTimeScaleControl else law
        run = simulate_links(plant, controller, 2.5)
        hubs.append(np.abs(run.trajectory.e).max())
        return tip_metrics(run, p, rest)

    hubs: list[float] = []
    ctc = measured(ref, 1.0, ComputedTorque(p, ref, torque_limit=np.inf))
    plain = measured(ref, 1.0)
    assert ctc.residual_vibration == pytest.approx(4.90e-3, abs=5e-5)
    assert ctc.vibration_settling_time == pytest.approx(1.205, abs=2e-3)
    assert ctc.tip_error == pytest.approx(42.5e-3, abs=1e-4)
    assert plain.tip_error == pytest.approx(33.9e-3, abs=1e-4)
    assert hubs[0] == pytest.approx(0.0484, abs=5e-4) and hubs[1] < 2.3e-3  # CTC's, ours
    shaped_ref = zv_shaped(ref, 3.367, 0.404)
    delay = shaped_ref.joint1.delay
    assert delay == pytest.approx(0.162, abs=5e-4)
    shaped = measured(shaped_ref, 1.0 + delay)
    assert plain.residual_vibration == pytest.approx(5.70e-3, abs=5e-5)
    assert plain.vibration_settling_time == pytest.approx(1.276, abs=2e-3)
    assert shaped.residual_vibration == pytest.approx(0.49e-3, abs=5e-5)
    assert shaped.vibration_settling_time == pytest.approx(1.038, abs=2e-3)
    assert shaped.tip_error == pytest.approx(28.7e-3, abs=1e-4)
    for scale in (0.5, 1.5):  # the delay's mutants
        wrong = ArmReference(*(ZVShaped(j, 3.367 / scale, 0.404) for j in (ref.joint1, ref.joint2)))
        off = measured(wrong, 1.0 + wrong.joint1.delay)
        assert off.residual_vibration > 3 * shaped.residual_vibration
        assert off.vibration_settling_time > plain.vibration_settling_time


@pytest.mark.slow
def test_on_the_shipped_soft_links_the_shaper_removes_the_swing_at_the_moves_end():
    """docs/flexible_links.md: runs/flexible_links/ctc_soft.toml for 6 s. The loop's
    bending mode is 4.415 Hz, ζ 0.555; shaped there, the two-time-scale law's residual
    falls from 201 to 2.2 mm; the paper's CTC leaves 114 mm and settles at 4.39 s."""
    from twolink.simulation.config import load_scenario, parse_set
    from twolink.simulation.experiment import build_controller
    from twolink.simulation.links_sim import plant_links, run_links, tip_metrics
    from twolink.simulation.outcome import reference_end

    s = load_scenario("flexible_links/ctc_soft", parse_set(["duration=6"]))
    links = plant_links(s)
    gains = dict(kp=s.controller.kp, kd=s.controller.kd)
    still = ArmReference(Step(final=0.0), Step(final=0.0))
    model = build_links_model(links, g=0.0, timestep=1e-5, visual=False)
    import test_flexible_links_control as control

    assert control.N == links.segments  # law_gain's layout
    w, z = linear_modes(
        model, feedback=law_gain(TwoTimeScaleControl(links, still, **gains, ks=0.0), model.nv)
    )
    f = w / (2 * np.pi)
    assert f[:4] == pytest.approx([0.322, 0.363, 4.415, 9.698], abs=2e-3)
    assert z[2] == pytest.approx(0.555, abs=2e-3)

    def measured(controller):
        run = run_links(s, controller)
        return tip_metrics(run, s.plant_params, reference_end(controller.reference))

    ctc = measured(build_controller(s))
    plain = measured(TwoTimeScaleControl(links, s.reference, **gains, ks=0.0))
    shaped = measured(
        TwoTimeScaleControl(links, zv_shaped(s.reference, f[2], z[2]), **gains, ks=0.0)
    )
    strain = measured(TwoTimeScaleControl(links, s.reference, **gains, ks=0.01))
    assert ctc.residual_vibration == pytest.approx(0.114, abs=5e-4)
    assert ctc.vibration_settling_time == pytest.approx(4.39, abs=5e-3)
    assert plain.residual_vibration == pytest.approx(0.2006, abs=5e-4)
    assert plain.vibration_settling_time == pytest.approx(2.28, abs=5e-3)
    assert shaped.residual_vibration == pytest.approx(2.2e-3, abs=5e-5)
    assert shaped.vibration_settling_time == pytest.approx(2.33, abs=5e-3)
    assert strain.residual_vibration == pytest.approx(0.227, abs=5e-4)
    assert strain.vibration_settling_time == pytest.approx(2.43, abs=5e-3)
