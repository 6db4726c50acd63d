"""The flexible-link arm (twolink/arm/links.py) against beam theory and an assumed-modes
model (docs/flexible_links.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from twolink.arm.assumed_modes import AssumedModesArm, clamped_free_beta_l
from twolink.arm.dynamics import inverse_dynamics
from twolink.arm.links import (
    CLAMPED_FREE_BETA_L,
    FlexibleLinks,
    LinkBeam,
    LinkLayout,
    build_links_model,
    linear_modes,
    rigid_tip,
    single_link_model,
    stable_timestep,
    static_tip_deflection,
    tip_position,
)
from twolink.arm.plant import mujoco

BEAM = LinkBeam(damping_ratio=0.0)  # E I = 100 N m², 1 kg/m, 1 m
SEGMENTS = (4, 8, 16, 32)


def _scale(beam: LinkBeam) -> float:
    return math.sqrt(beam.ei / (beam.rho_a * beam.length**4))


def _modes(beam: LinkBeam, n: int, clamped: bool = True):
    dt = stable_timestep(FlexibleLinks(beam, beam, n), 0.1)
    return linear_modes(single_link_model(beam, n, clamped=clamped, timestep=dt))


def _first_root(f, upper: float) -> float:
    xs = np.linspace(1e-3, upper, 4000)
    v = f(xs)
    i = np.nonzero(np.sign(v[:-1]) != np.sign(v[1:]))[0][0]
    return brentq(f, xs[i], xs[i + 1])


def tip_mass_beta_l(mu: float) -> float:
    """First root of 1 + cos cosh + μ βL (cos sinh − sin cosh) = 0, μ = M / (ρ A L)."""
    return _first_root(
        lambda b: (
            1 + np.cos(b) * np.cosh(b) + mu * b * (np.cos(b) * np.sinh(b) - np.sin(b) * np.cosh(b))
        ),
        2.0,
    )


def hub_beta_l(r: float) -> float:
    """First root of r λ³ (1 + cos cosh) + sin cosh − cos sinh = 0, r = J / (ρ A L³)."""
    return _first_root(
        lambda b: (
            r * b**3 * (1 + np.cos(b) * np.cosh(b))
            + np.sin(b) * np.cosh(b)
            - np.cos(b) * np.sinh(b)
        ),
        4.0,
    )


def test_clamped_free_roots_are_the_euler_bernoulli_values():
    assert np.allclose(clamped_free_beta_l(3), CLAMPED_FREE_BETA_L, atol=1e-9)
    assert np.allclose(CLAMPED_FREE_BETA_L, (1.8751, 4.6941, 7.8548), atol=5e-5)


def test_clamped_frequencies_converge_at_second_order():
    """First three frequencies from MuJoCo's linearisation against (βL)² sqrt(EI/ρAL⁴):
    errors below 1.5 %, 5.3 %, 7.5 % at N = 4 and falling 4x per doubling of N."""
    exact = np.array([BEAM.clamped_frequency(m) for m in (1, 2, 3)])
    errors = np.array([_modes(BEAM, n)[0][:3] / exact - 1 for n in SEGMENTS])
    assert np.all(errors > 0)  # the lumped chain is stiffer than the beam
    assert np.all(errors[-1] < [3e-4, 1e-3, 1.5e-3])  # N = 32
    order = np.log2(errors[:-1] / errors[1:])
    assert np.all(order[1:] > 1.95) and np.all(order[1:] < 2.1)


def test_frequency_of_the_first_mode_at_n16_within_a_tenth_of_a_percent():
    w = _modes(BEAM, 16)[0][0]
    assert abs(w / (1.8751040687**2 * _scale(BEAM)) - 1) < 1e-3


def test_static_tip_deflection_is_the_beam_value_with_the_midpoint_rule_error():
    """δ = P L³ / (3 E I) (1 − 1 / (4 N²)): the hinges at the elements' middles are the
    midpoint rule for ∫ (L − x)² dx, whose error is exactly L ℓ² / 12."""
    p = 1e-3  # N: small, so the deflection is linear to 1e-10
    beam = LinkBeam(ei=50.0, rho_a=2.0, length=0.8)
    for n in SEGMENTS:
        exact = p * beam.length**3 / (3 * beam.ei)
        lumped = static_tip_deflection(beam, n, p)
        assert lumped == pytest.approx(exact * (1 - 1 / (4 * n * n)), rel=1e-6)


@pytest.mark.parametrize("mu", [0.5, 2.0])
def test_first_frequency_with_a_tip_mass(mu):
    beam = LinkBeam(damping_ratio=0.0, tip_mass=mu * BEAM.mass)
    exact = tip_mass_beta_l(mu) ** 2 * _scale(beam)
    errors = [_modes(beam, n)[0][0] / exact - 1 for n in (8, 16, 32)]
    assert 0 < errors[-1] < 2e-4
    assert 1.95 < math.log2(errors[1] / errors[2]) < 2.05  # second order, 16 to 32


def test_tip_mass_equation_has_the_spring_mass_limit():
    # A heavy tip: ω² → 3 E I / (M L³), the cantilever's static stiffness on M.
    mu = 1e4
    assert tip_mass_beta_l(mu) ** 4 == pytest.approx(3 / mu, rel=1e-3)


def test_hub_equation_limits_are_pinned_free_and_clamped_free():
    assert hub_beta_l(0.0) == pytest.approx(3.9266023, abs=1e-6)  # tan λ = tanh λ
    assert hub_beta_l(1e8) == pytest.approx(CLAMPED_FREE_BETA_L[0], abs=1e-6)


@pytest.mark.parametrize("r", [0.05, 0.3, 1.0])
def test_first_frequency_on_a_free_hub(r):
    beam = LinkBeam(damping_ratio=0.0, hub_inertia=r * BEAM.rho_a * BEAM.length**3)
    exact = hub_beta_l(r) ** 2 * _scale(beam)
    errors = [_modes(beam, n, clamped=False)[0][0] / exact - 1 for n in (8, 16, 32)]
    assert 0 < errors[-1] < 3e-4
    assert 1.95 < math.log2(errors[1] / errors[2]) < 2.05  # second order, 16 to 32


def test_damping_ratio_of_the_first_clamped_mode_is_the_materials():
    """Kelvin-Voigt: ζ_1 = ζ (to the lumped frequency's error), ζ_2 / ζ_1 = ω_2 / ω_1."""
    beam = LinkBeam(damping_ratio=0.02)
    w, zeta = _modes(beam, 16)
    assert zeta[0] == pytest.approx(0.02, rel=2e-3)
    assert zeta[1] / zeta[0] == pytest.approx(w[1] / w[0], rel=1e-6)


def test_stable_timestep_bounds_the_fastest_mode():
    for tip in (0.0, 0.5):
        for n in (4, 8, 16):
            beam = LinkBeam(damping_ratio=0.0, tip_mass=tip, hub_inertia=0.01)
            links = FlexibleLinks(beam, beam, n)
            w = linear_modes(build_links_model(links, g=0.0, timestep=1e-6))[0]
            assert w.max() * stable_timestep(links, 1.0) < 2.8


def test_hub_angles_and_layout():
    links = FlexibleLinks(segments=5)
    model = build_links_model(links)
    layout = LinkLayout(5)
    assert model.nq == 12
    assert [model.jnt_qposadr[model.joint(f"theta{i}").id] for i in (1, 2)] == list(layout.hubs)
    assert model.joint("bend1_1").id == 1 and model.joint("bend2_5").id == 11
    # Straight at rest: the tip at (l1 + l2, 0), the rigid arm's.
    data = mujoco.MjData(model)
    data.qpos[list(layout.hubs)] = (0.4, -0.7)
    mujoco.mj_kinematics(model, data)
    p = links.rigid_params()
    assert np.allclose(tip_position(model, data), rigid_tip(p, (0.4, -0.7)), atol=1e-12)
    # The chain's mass is the links' and their tip masses.
    assert model.body_subtreemass[1] == pytest.approx(2.0)


def test_link_parameters_are_checked():
    for bad in ({"ei": 0.0}, {"rho_a": -1.0}, {"tip_mass": -0.1}, {"length": math.nan}):
        with pytest.raises(ValueError):
            LinkBeam(**bad)
    for n in (0, 2.5, True, 10_000):
        with pytest.raises(ValueError):
            FlexibleLinks(segments=n)


def test_energy_is_conserved_in_free_motion_without_damping():
    """MuJoCo's energy (mjENBL_ENERGY: gravity, springs, motion) over 2 s of free fall
    of the two-link arm: drift below 1e-7 of it, and smaller at half the step."""
    beam = LinkBeam(damping_ratio=0.0, hub_inertia=0.01, tip_mass=0.2)
    links = FlexibleLinks(beam, beam, 8)
    drift = []
    for margin in (0.5, 0.25):
        model = build_links_model(links, g=9.81, timestep=stable_timestep(links, margin))
        model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
        data = mujoco.MjData(model)
        hubs = list(LinkLayout(8).hubs)
        data.qpos[hubs[0]] = 0.3
        data.qvel[hubs] = (1.0, -2.0)
        mujoco.mj_forward(model, data)
        e0, worst, bent = data.energy.sum(), 0.0, 0.0
        for _ in range(int(2.0 / model.opt.timestep)):
            mujoco.mj_step(model, data)
            worst = max(worst, abs(data.energy.sum() - e0))
            bent = max(bent, float(np.abs(data.qpos[LinkLayout(8).bends[1]]).max()))
        drift.append(worst / abs(e0))
        assert bent > 1e-3  # the links did bend
    assert drift[0] < 1e-7
    assert drift[1] < drift[0] / 4


def _slow_move(links: FlexibleLinks, modes: tuple[int, ...]):
    """Both models on a 3 s quintic move of the hubs by (1, -0.8) rad, horizontal, under
    the same law (the rigid arm's inverse dynamics plus hub PD), evaluated every physics
    step: the tips' worst distance over the move per number of modes, and MuJoCo's worst
    deflection (its tip off the rigid arm's tip at its hub angles)."""
    p = links.rigid_params(0.0)
    duration, target = 3.0, np.array([1.0, -0.8])

    def law(t, th, thd):
        s = min(t / duration, 1.0)
        q = target * (10 * s**3 - 15 * s**4 + 6 * s**5)
        qd = target * (30 * s**2 - 60 * s**3 + 30 * s**4) / duration
        qdd = target * (60 * s - 180 * s**2 + 120 * s**3) / duration**2
        return inverse_dynamics(p, q, qd, qdd) + 40 * (q - th) + np.array([8.0, 1.0]) * (qd - thd)

    model = build_links_model(links, g=0.0, timestep=stable_timestep(links, 0.5))
    data = mujoco.MjData(model)
    hubs = list(LinkLayout(links.segments).hubs)
    every = round(0.01 / model.opt.timestep)
    times, tips, hub_angles = [], [], []
    for k in range(int(duration / model.opt.timestep)):
        if k % every == 0:
            mujoco.mj_kinematics(model, data)
            times.append(data.time)
            tips.append(tip_position(model, data))
            hub_angles.append(data.qpos[hubs].copy())
        data.ctrl[:] = law(data.time, data.qpos[hubs], data.qvel[hubs])
        mujoco.mj_step(model, data)
    times, tips = np.array(times), np.array(tips)
    gaps = {}
    for m in modes:
        arm = AssumedModesArm(links, 0.0, m)
        n = arm.size
        sol = solve_ivp(
            lambda t, x, arm=arm, n=n: arm.rhs(t, x, law(t, x[:2], x[n : n + 2])),
            (0.0, times[-1]),
            np.zeros(2 * n),
            t_eval=times,
            rtol=1e-9,
            atol=1e-11,
            method="DOP853",
        )
        other = np.array([arm.tip(x[:n]) for x in sol.y.T])
        gaps[m] = float(np.linalg.norm(other - tips, axis=1).max())
    bend = float(np.linalg.norm(tips - rigid_tip(p, np.array(hub_angles)), axis=1).max())
    return gaps, bend


@pytest.mark.slow
def test_assumed_modes_model_agrees_on_a_slow_move():
    beam = LinkBeam(damping_ratio=0.0, hub_inertia=0.02, tip_mass=0.1)
    gaps, bend = _slow_move(FlexibleLinks(beam, beam, 8), (1, 2, 3))
    assert bend > 0.01  # the links bent by more than a centimetre
    assert gaps[3] < gaps[2] < gaps[1]  # each mode per link brings the models closer
    assert gaps[2] < 0.12 * bend  # two modes: within 12 % of the bending
    assert gaps[3] < 0.07 * bend
