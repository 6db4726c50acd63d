"""The field's laws against their theory: the regressor (twolink/arm/regressor.py),
Slotine-Li adaptive CTC, sliding mode with a boundary layer and CTC with a disturbance
observer (controllers/adaptive.py, sliding.py, observer.py), each on MuJoCo's plant; and
their batch forms against the single-arm laws.

Each check names the mutant it kills in its docstring (docs/control.md lists them).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from twolink.arm import dynamics
from twolink.arm.disturbance import Disturbance, TorqueStep
from twolink.arm.params import ArmParams
from twolink.arm.plant import Plant
from twolink.arm.regressor import parameter_box, parameters, regressor
from twolink.controllers.adaptive import DEFAULT_GAMMA, AdaptiveComputedTorque, lyapunov
from twolink.controllers.observer import DisturbanceObserverCTC
from twolink.controllers.sliding import SlidingMode
from twolink.controllers.uncertainty import DEFAULT_UNCERTAINTY, Uncertainty, sliding_gain
from twolink.foundation.references import ArmReference, make_reference
from twolink.simulation.config import ConfigError, load_scenario
from twolink.simulation.experiment import run_scenario, run_scenarios

MODEL = ArmParams()
PLANT = MODEL.scaled(m1=0.9, m2=1.2)  # inside the declared set, with the payload below
PAYLOAD = 0.2
MULTISINE = ArmReference(
    make_reference("multisine", amplitude=0.1, frequency_hz=0.2, harmonics=3),
    make_reference("multisine", amplitude=-0.12, frequency_hz=0.31, harmonics=3),
)
STEP = ArmReference(make_reference("step", final=1.0), make_reference("step", final=0.5))


def random_states(rng, n=200):
    return (rng.uniform(-4, 4, (n, 2)) for _ in range(4))


# ----------------------------------------------------------------------- the regressor


def test_the_regressor_is_m_c_g_of_the_analytic_model():
    """Y a = M qddr + C qdr + G with qdr != qd (the Christoffel C of twolink.arm.dynamics),
    on random arms and states. Kills: a wrong entry or sign of Y (e.g. a3's C term)."""
    rng = np.random.default_rng(0)
    for _ in range(5):
        p = ArmParams(*rng.uniform(0.2, 3.0, 4), g=rng.uniform(0, 20))
        q, qd, qdr, qddr = random_states(rng)
        want = (
            (dynamics.mass_matrix(p, q) @ qddr[..., None])[..., 0]
            + (dynamics.coriolis_matrix(p, q, qd) @ qdr[..., None])[..., 0]
            + dynamics.gravity(p, q)
        )
        got = regressor(q, qd, qdr, qddr) @ parameters(p)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())


def test_the_regressor_with_a_payload_is_mujocos_inverse_dynamics():
    """With a tip payload (lumped into link 2 by the plant) Y(q, qd, qd, qdd) a is
    MuJoCo's inverse dynamics. Kills: a payload term of ``parameters`` left out or at l2/2."""
    rng = np.random.default_rng(1)
    for payload in (0.0, 0.2, 1.5):
        p = ArmParams(*rng.uniform(0.3, 2.0, 4), g=9.81)
        plant = Plant.build(p, None, payload, 1e-3)
        a = parameters(p, payload)
        for q, qd, qdd in zip(*(rng.uniform(-3, 3, (20, 2)) for _ in range(3)), strict=True):
            plant.set_state(q, qd)
            want = plant.inverse(qdd)
            got = regressor(q, qd, qd, qdd) @ a
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-10 * np.abs(want).max())


def test_mdot_minus_2c_is_skew():
    """dM/dt - 2C is skew for the regressor's own M and C (read off Y column by column),
    dM/dt by central differences along qd. Kills: the factorisation C' = [[-2h w2, -h w2],
    [h w1, 0]], which gives the same C qd but is not skew."""
    rng = np.random.default_rng(2)
    a = parameters(PLANT, PAYLOAD)
    zero = np.zeros(2)
    eye = np.eye(2)
    for q, qd in zip(*(rng.uniform(-3, 3, (30, 2)) for _ in range(2)), strict=True):

        def mass(x):
            return (
                np.stack([regressor(x, zero, zero, eye[j]) @ a for j in range(2)], 1)
                - (regressor(x, zero, zero, zero) @ a)[:, None]
            )

        g = regressor(q, qd, zero, zero) @ a
        c = np.stack([regressor(q, qd, eye[j], zero) @ a - g for j in range(2)], 1)
        h = 1e-6
        mdot = (mass(q + h * qd) - mass(q - h * qd)) / (2 * h)
        n = mdot - 2 * c
        assert np.abs(n + n.T).max() < 1e-8, n
        assert np.abs(mass(q) - mass(q).T).max() < 1e-14


def test_the_parameter_box_holds_every_arm_of_the_declared_set():
    """Corners and random draws of the declared ranges have a inside the box, and its
    corners are attained. Kills: the box from the model alone (low = high)."""
    low, high = DEFAULT_UNCERTAINTY.box(MODEL)
    rng = np.random.default_rng(3)
    f = DEFAULT_UNCERTAINTY.factors
    for _ in range(200):
        p = MODEL.scaled(**{k: rng.uniform(*v) for k, v in f.items()})
        a = parameters(p, rng.uniform(*DEFAULT_UNCERTAINTY.payload))
        assert np.all(low <= a) and np.all(a <= high)
    hi = MODEL.scaled(**{k: v[1] for k, v in f.items()})
    np.testing.assert_array_equal(high, parameters(hi, 0.2))
    with pytest.raises(ValueError, match="unknown"):
        parameter_box(MODEL, {"m3": (1, 2)})


# -------------------------------------------------------------------- Slotine-Li


def adaptive_run(reference, gamma, dt=1e-3, duration=10.0, sign=1.0, limit=math.inf):
    """A closed loop of the adaptive law on PLANT (its payload included) at control and
    physics step ``dt``, recording V, s^T K_D s, the estimates and the errors."""
    plant = Plant.build(PLANT, None, PAYLOAD, dt)
    c = AdaptiveComputedTorque(
        model=MODEL, reference=reference, gamma=gamma, control_dt=dt, torque_limit=limit
    )
    a = parameters(PLANT, PAYLOAD)
    out = {k: [] for k in ("V", "D", "a_hat", "e", "tau")}
    for k in range(round(duration / dt) + 1):
        t = k * dt
        q, qd = plant.q.copy(), plant.qd.copy()
        v, d = lyapunov(c, t, q, qd, plant.mass_matrix(), a)
        out["V"].append(v)
        out["D"].append(d)
        out["a_hat"].append(c.a_hat)
        out["e"].append(np.subtract(reference(t)[0], q))
        tau = c(t, tuple(q), tuple(qd))
        out["tau"].append(tau)
        plant.step(*tau)
    res = {k: np.array(v) for k, v in out.items()}
    res["a"], res["low"], res["high"] = a, np.array(c.low), np.array(c.high)
    return res


LYAPUNOV_GAMMA = tuple(0.03 * x for x in DEFAULT_GAMMA)  # slow enough to leave the box alone


def test_slotine_li_v_does_not_increase_and_dissipates_s_kd_s():
    """With the exact structure, no saturation and the projection idle, V = s^T M s / 2 +
    ã^T Γ^-1 ã / 2 has dV/dt = -s^T K_D s: V's increments are O(dt²) (a quarter at half
    the step) and V(T) - V(0) + ∫ s^T K_D s dt is O(dt) (halves). Kills: the adaptation's
    sign flipped (V grows by ~V(0))."""
    runs = {dt: adaptive_run(MULTISINE, LYAPUNOV_GAMMA, dt) for dt in (1e-3, 5e-4)}
    worst, balance = {}, {}
    for dt, r in runs.items():
        assert np.all(r["a_hat"] > r["low"]) and np.all(r["a_hat"] < r["high"])  # idle
        v = r["V"]
        worst[dt] = np.diff(v).max()
        balance[dt] = abs(v[-1] - v[0] + np.sum(r["D"][:-1]) * dt)
        assert v[-1] < 0.05 * v[0]
        assert worst[dt] < 1e-5 * v[0]
    assert worst[5e-4] < 0.35 * worst[1e-3]
    assert balance[1e-3] < 1e-3 * runs[1e-3]["V"][0]
    assert balance[5e-4] < 0.6 * balance[1e-3]


def test_slotine_li_learns_the_plant_on_a_multisine_and_not_on_a_step():
    """On the persistently exciting multi-sine the error goes to zero and every estimate
    to the plant's parameter (within 1 %); on a held step the error goes to zero too but
    the inertias stay wrong (only gravity at the target is learnt, Y(q*, 0, 0, 0) ã = 0).
    Kills: the adaptation's sign flipped (the error does not vanish)."""
    sine = adaptive_run(MULTISINE, DEFAULT_GAMMA, duration=20.0)
    step = adaptive_run(STEP, DEFAULT_GAMMA, duration=10.0)
    a = sine["a"]
    assert np.abs(sine["e"][-2000:]).max() < 5e-4
    assert np.all(np.abs(sine["a_hat"][-1] - a) < 0.01 * a), sine["a_hat"][-1] / a
    assert np.abs(step["e"][-1000:]).max() < 2e-3
    inertia = np.abs(step["a_hat"][-1, :3] - a[:3]) / a[:3]
    assert inertia.max() > 0.2, inertia
    # what a rest state learns: gravity at the target
    q = np.array([1.0, 0.5])
    y = regressor(q, np.zeros(2), np.zeros(2), np.zeros(2))
    g_err = y @ (step["a_hat"][-1] - a)
    assert np.abs(g_err).max() < 0.02 * np.abs(y @ a).max()


def test_the_projection_keeps_the_estimates_in_the_box():
    """A plant outside the declared set (a 1.5 kg payload) drives the estimates into the
    box's faces, and they stay there. Kills: the projection removed (â leaves the box)."""
    plant = Plant.build(PLANT, None, 1.5, 1e-3)
    c = AdaptiveComputedTorque(model=MODEL, reference=MULTISINE, torque_limit=math.inf)
    touched = np.zeros(5, bool)
    for k in range(4000):
        tau = c(k * 1e-3, tuple(plant.q), tuple(plant.qd))
        a = np.array(c.a_hat)
        assert np.all(a >= c.low) and np.all(a <= c.high)
        touched |= (a == c.low) | (a == c.high)
        plant.step(*tau)
    assert touched.any()


def test_the_projection_never_moves_the_estimate_away_from_the_truth():
    """Clipping to a box that holds a (diagonal Γ) never increases ã^T Γ^-1 ã: the
    property the Lyapunov proof needs of the projection."""
    rng = np.random.default_rng(4)
    low, high = DEFAULT_UNCERTAINTY.box(MODEL)
    g = np.array(DEFAULT_GAMMA)
    for _ in range(1000):
        a = rng.uniform(low, high)
        x = rng.uniform(low - 2 * (high - low), high + 2 * (high - low))
        clipped = np.clip(x, low, high)
        assert np.sum((clipped - a) ** 2 / g) <= np.sum((x - a) ** 2 / g) + 1e-15


def test_the_estimate_is_held_while_the_torque_is_at_its_limit():
    """No wind-up: at every instant a joint's torque is at its limit, â is unchanged.
    Kills: adapting through saturation."""
    r = adaptive_run(STEP, DEFAULT_GAMMA, duration=2.0, limit=(40.0, 12.0))
    at_limit = np.any(np.abs(r["tau"]) == (40.0, 12.0), axis=1)
    assert at_limit.sum() > 50
    moved = np.any(np.diff(r["a_hat"], axis=0) != 0, axis=1)
    assert not np.any(moved & at_limit[:-1])
    assert moved[~at_limit[:-1]].any()


# ------------------------------------------------------------------- sliding mode

SLIDING_ETA = (2.0, 1.0)  # N m
SLIDING_REFERENCE = ArmReference(
    make_reference("quintic", initial=0.0, final=0.6, duration=2.0),
    make_reference("quintic", initial=0.0, final=-0.4, duration=2.0),
)


def sliding_law(**kw):
    return SlidingMode(
        model=MODEL, reference=SLIDING_REFERENCE, eta=SLIDING_ETA, torque_limit=math.inf, **kw
    )


def test_the_switching_term_is_k_sat_s_over_phi():
    """The law minus its model terms is K sat(s / φ): K s / φ inside the layer, ±K on
    and beyond its edge. Kills: a wrong layer width (e.g. sat(s / (φ λ)))."""
    c = sliding_law(phi=(0.05, 0.08))
    lam, (k1, k2), (p1, p2) = c.lam, c.gain, c.phi
    for frac in (-3.0, -1.0, -0.5, 0.0, 0.25, 1.0, 2.0):
        # at t = 0 the reference is at rest at 0: s = λ e (qd = 0), so q sets s
        q, qd = (-frac * p1 / lam[0], -frac * p2 / lam[1]), (0.0, 0.0)
        s1, s2, row1, row2 = c.sliding(0.0, q, qd)
        model = (np.dot(row1, c.a_model), np.dot(row2, c.a_model))
        tau = c(0.0, q, qd)
        want = (k1 * max(-1, min(1, frac)), k2 * max(-1, min(1, frac)))
        np.testing.assert_allclose(np.subtract(tau, model), want, rtol=1e-12, atol=1e-12)
        assert math.isclose(s1, frac * p1, rel_tol=1e-12, abs_tol=1e-15)
        assert math.isclose(s2, frac * p2, rel_tol=1e-12, abs_tol=1e-15)


@pytest.mark.parametrize("q0", [(0.25, -0.5), (-0.3, 0.6)])
def test_sliding_mode_reaches_the_layer_in_time_and_keeps_the_error_within_phi_over_lambda(q0):
    """From s(0) outside the layer, on a plant of the declared set (masses, lengths, g,
    payload, dry friction), with the default layer (K / φ = λ M^_jj, the balance of
    the layer's bandwidth with the loop's; a thinner one chatters at 1 kHz):

    - while every |s_i| > φ_i, d/dt sqrt(s^T M s) <= -η_min / sqrt(μ) (μ: the largest
      eigenvalue of M), so the layer is first reached by sqrt(s0^T M0 s0 μ) / η_min;
    - every joint is then inside and stays, and thereafter |e_i| <= φ_i / λ_i.

    The theorem's premise is checked along the run: |Δ_i| + the friction bound <= F_i.
    Kills: a wrong layer width in the law (the error leaves φ/λ, or s the layer)."""
    from twolink.arm.params import Friction

    c = sliding_law()
    k_minus_eta = np.subtract(c.gain, SLIDING_ETA)
    plant_params = MODEL.scaled(m1=1.25, m2=0.75, l1=1.05, l2=0.95, g=1.08)
    dt = 1e-3
    plant = Plant.build(plant_params, None, 0.15, dt, Friction(coulomb=(1.5, 0.4)))
    plant.reset(q0, (0.0, 0.0))
    a_err = parameters(plant_params, 0.15) - parameters(MODEL)
    lam, phi = np.array(c.lam), np.array(c.phi)
    s_log, e_log, mu = [], [], 0.0
    m0 = plant.mass_matrix()
    for k in range(3001):
        t = k * dt
        q, qd = tuple(plant.q), tuple(plant.qd)
        s1, s2, row1, row2 = c.sliding(t, q, qd)
        delta = np.array([row1, row2]) @ a_err
        assert np.all(np.abs(delta) + DEFAULT_UNCERTAINTY.friction <= k_minus_eta)
        s_log.append((s1, s2))
        e_log.append(np.subtract(c.reference(t)[0], q))
        mu = max(mu, float(np.linalg.eigvalsh(plant.mass_matrix()).max()))
        plant.step(*c(t, q, qd))
    s, e = np.abs(np.array(s_log)), np.abs(np.array(e_log))
    s0 = np.array(s_log[0])
    assert np.all(s[0] > phi)
    first = np.argmax((s <= phi).any(axis=1)) * dt
    assert first <= math.sqrt(s0 @ m0 @ s0 * mu) / min(SLIDING_ETA), first
    inside = np.all(s <= phi, axis=1)
    k_in = int(np.argmax(inside))
    assert inside[k_in:].all()
    settled = k_in + round(5 / lam.min() / dt)  # e(t) -> within φ/λ as e^(-λ t)
    assert np.all(e[settled:] <= phi / lam), (e[settled:].max(0), phi / lam)


def test_the_gain_bound_is_the_largest_model_error_of_its_envelope():
    """F is the largest |Δ_i| + the friction bound over the ranges' corners, the pose grid
    and the envelope's corners (Δ through the regressor here, an independent path), and
    random states of the envelope stay within it. Kills: the friction left out of F."""
    k, f = sliding_gain(MODEL, 0.0, 1.5, 3.0, grid=12)
    assert k == tuple(f)
    angles = np.linspace(-math.pi, math.pi, 12, endpoint=False)
    q = np.stack(np.meshgrid(angles, angles, indexing="ij"), -1).reshape(-1, 1, 2)
    corners = np.array(list(itertools.product((-1.0, 1.0), repeat=6)))  # w, r, b signs
    w, r, b = corners[:, 0:2] * 1.5, corners[:, 2:4] * 1.5, corners[:, 4:6] * 3.0
    worst = np.zeros(2)
    rng = np.random.default_rng(5)
    a_hat = parameters(MODEL)
    for p, payload in DEFAULT_UNCERTAINTY.corners(MODEL):
        delta = regressor(q, w, r, b) @ (parameters(p, payload) - a_hat)
        worst = np.maximum(worst, np.abs(delta).max(axis=(0, 1)))
        x = rng.uniform(-1, 1, (4, 300, 2))
        qr = rng.uniform(-math.pi, math.pi, (300, 2))
        inside = regressor(qr, 1.5 * x[0], 1.5 * x[1], 3.0 * x[2]) @ (
            parameters(p, payload) - a_hat
        )
        assert np.all(np.abs(inside) + DEFAULT_UNCERTAINTY.friction <= f * (1 + 1e-12))
    np.testing.assert_allclose(f, worst + DEFAULT_UNCERTAINTY.friction, rtol=1e-12)


# -------------------------------------------------------------- disturbance observer


def observer_run(law, load=2.0, duration=1.5, at=0.5):
    """Hold the arm at (0.5, 0.3) on the exact plant; a load step on joint 1 at ``at``."""
    hold = ArmReference(make_reference("step", final=0.5), make_reference("step", final=0.3))
    c = law(model=MODEL, reference=hold)
    dist = Disturbance(steps=(TorqueStep(joint=1, time=at, size=load),))
    plant = Plant.build(MODEL, None, 0.0, 1e-3, None, dist)
    plant.reset((0.5, 0.3), (0.0, 0.0))
    t, e, d = [], [], []
    for k in range(round(duration / 1e-3) + 1):
        q, qd = tuple(plant.q), tuple(plant.qd)
        tau = c(k * 1e-3, q, qd)
        t.append(k * 1e-3)
        e.append(np.subtract((0.5, 0.3), q))
        if isinstance(c, DisturbanceObserverCTC):
            p = c.model
            from twolink.controllers.observer import momentum_terms

            d.append(c.estimate(*momentum_terms(p, *q, *qd)[:2]))
        plant.step(*tau)
    return np.array(t), np.array(e), np.array(d)


def test_the_observer_estimates_a_constant_load_with_its_time_constant():
    """A 2 N m load step on joint 1: the estimate d^_1 follows the discrete observer's
    response 2 (1 - (1 - dt/T)^k) (to 2.5 % of the load: the 1 ms step's integration
    error) and is 63 % there at T (within 10 % of T); d^_2 stays near 0.
    Kills: a wrong observer gain (e.g. 2/T)."""
    t, _, d = observer_run(DisturbanceObserverCTC)
    T = DisturbanceObserverCTC(model=MODEL, reference=STEP).observer_time
    after = t >= 0.5
    tt = t[after] - 0.5
    # the discrete observer's own response, (1 - dt/T)^k, and the continuous one's T
    want = 2.0 * (1 - (1 - 1e-3 / T) ** np.round(tt / 1e-3))
    assert np.abs(d[after, 0] - want).max() < 0.025 * 2.0  # the 1 ms step's O(dt) error
    t63 = tt[np.argmax(d[after, 0] >= 2.0 * (1 - math.exp(-1)))]
    assert abs(t63 - T) < 0.1 * T + 1e-3, (t63, T)
    assert np.abs(d[:, 1]).max() < 0.05 * 2.0
    assert np.abs(d[after, 0][-100:] - 2.0).max() < 1e-6


def test_ctc_with_the_observer_ends_a_load_step_on_target_and_plain_ctc_does_not():
    """CTC-DOB ends the load step with zero steady error; CTC is off by M^-1 d / kp on
    the exact plant. Kills: the estimate added with the wrong sign (twice CTC's error)."""
    from twolink.controllers.ctc import ComputedTorque

    _, e_dob, _ = observer_run(DisturbanceObserverCTC, duration=2.0)
    _, e_ctc, _ = observer_run(ComputedTorque, duration=2.0)
    q_end = np.array([0.5, 0.3]) - e_ctc[-1]  # CTC's own M^(q) kp e = -d at its rest
    want = np.linalg.solve(dynamics.mass_matrix(MODEL, q_end), [-2.0, 0.0]) / 225
    np.testing.assert_allclose(e_ctc[-1], want, rtol=1e-3)
    assert np.abs(e_dob[-200:]).max() < 1e-7
    assert np.abs(e_ctc[-1]).max() > 1e-3


# --------------------------------------------------------------- scenarios and batch

KINDS = {
    "adaptive_ctc": {"kind": "adaptive_ctc", "gamma": [20, 8, 8, 200, 80]},
    "sliding_mode": {"kind": "sliding_mode", "eta": [2.0, 1.0], "phi": [0.4, 0.3]},
    "sliding_mode auto": {"kind": "sliding_mode"},
    "ctc_dob": {"kind": "ctc_dob", "observer_time": 0.02},
}


@pytest.mark.parametrize("name", list(KINDS))
def test_batch_laws_equal_the_single_arm_laws(name):
    """Every arm of a batch runs as alone (to 1e-12; to the bit where numpy's cos/sin
    round as libm's), on plants with model error, payload, noise and a load step."""
    base = {
        "duration": 1.5,
        "controller": KINDS[name],
        "reference": {"joint2": {"kind": "quintic", "final": 0.5, "duration": 1.0}},
    }
    over = [
        {},
        {"plant": {"scale": {"m2": 1.3}, "payload": 0.1}, "sensor": {"noise_std_rad": 0.002}},
        {"disturbance": {"step": [{"joint": 1, "time": 0.7, "size": 2.0}]}, "seed": 4},
    ]
    from twolink.simulation.config import merge

    scenarios = [load_scenario("runs/paper/theta1_step.toml", merge(base, o)) for o in over]
    for s, b in zip(scenarios, run_scenarios(scenarios), strict=True):
        a = run_scenario(s)
        assert a.status == b.status == "ok"
        for field in ("q", "qd", "tau"):
            np.testing.assert_allclose(getattr(b, field), getattr(a, field), rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    ("controller", "key"),
    [
        ({"kind": "adaptive_ctc", "gamma": [1, 2]}, "controller.gamma"),
        ({"kind": "adaptive_ctc", "gamma": -1}, "controller.gamma"),
        ({"kind": "sliding_mode", "phi": "wide"}, "controller.phi"),
        ({"kind": "sliding_mode", "phi": 0.0}, "controller.phi"),
        ({"kind": "sliding_mode", "eta": [1, float("nan")]}, "controller.eta"),
        ({"kind": "ctc_dob", "observer_time": 1e-4}, "controller.observer_time"),
        ({"kind": "ctc_dob", "observer_tau": 0.1}, "controller.observer_tau"),
    ],
)
def test_bad_keys_of_the_field_laws_name_the_key_and_the_file(controller, key):
    with pytest.raises(ConfigError) as err:
        load_scenario("runs/paper/theta1_step.toml", {"controller": controller})
    assert str(err.value).startswith(f"runs/paper/theta1_step.toml: {key}:"), str(err.value)


@pytest.mark.parametrize("name", list(KINDS))
def test_a_resolved_config_reads_back_as_itself(name):
    from twolink.simulation.config import scenario_from_dict

    s = load_scenario("runs/paper/theta1_step.toml", {"controller": KINDS[name]})
    again = scenario_from_dict(s.to_dict(), s.source)
    assert again.controller == s.controller
    other = load_scenario("runs/paper/theta1_step.toml").to_dict()["controller"]
    assert not {"gamma", "eta", "phi", "observer_time"} & set(other)  # CTC's digest as was


def test_uncertainty_refuses_bad_ranges():
    with pytest.raises(ValueError, match="unknown quantity"):
        Uncertainty(factors={"mass": (0.9, 1.1)})
    with pytest.raises(ValueError, match="low <= high"):
        Uncertainty(factors={"m1": (1.1, 0.9)})
    with pytest.raises(ValueError, match="payload"):
        Uncertainty(payload=(0.2, 0.1))


def test_the_stability_check_linearises_each_law_with_its_own_state():
    """Each law's loop linearised at its rest state, alone and in the batch search, to
    the bit: ACTC with its five estimates (a neutral mode: three of them do not act at
    rest, so σ = 0, not the rounding's sign), CTC-DOB with its observer. Kills: the
    neutral rule removed (σ of ±1e-8)."""
    from twolink.simulation.experiment import build_controller, build_plant
    from twolink.simulation.stability import linearise
    from twolink.simulation.stability_batch import linearise_many

    over = {
        "reference": {"joint2": {"kind": "quintic", "final": 0.5, "duration": 2.0}},
        "plant": {"scale": {"m1": 1.2, "m2": 1.25, "g": 1.05}, "payload": 0.1},
    }
    items = []
    for kind in ("adaptive_ctc", "sliding_mode", "ctc_dob"):
        s = load_scenario("runs/paper/theta1_step.toml", {**over, "controller": {"kind": kind}})
        items.append((s, build_controller(s), None))
    for (s, c, _), many in zip(items, linearise_many(items), strict=True):
        alone = linearise(s, build_plant(s), c)
        assert many == alone, (s.controller.kind, many, alone)
    adaptive, sliding, observer = (linearise(s, build_plant(s), c) for s, c, _ in items)
    assert adaptive.sigma == 0.0 and "neutral" in adaptive.note
    assert sliding.sigma < -1 and observer.sigma < -1
