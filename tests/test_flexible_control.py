"""Controllers of flexible joints (controllers/flexible.py) against theory.

- The analytic time derivatives of M and n = H + G that feedback linearisation needs:
  against finite differences, complex-step differentiation and a symbolic derivation
  from the Lagrangian (sympy).
- Feedback linearisation with an exact model: each link error follows the designed
  fourth-order equation (closed form by the matrix exponential), first order in dt;
  with the septic reference the soft arm (K = 20 N m/rad) tracks within 1e-3 rad; with
  the quintic, the jerk steps at its ends cause the error their closed form predicts.
- The motor PD converges to the set point on random arms above its stiffness bound, and
  below it the soft arm settles at another equilibrium.
- The composite control approaches rigid CTC's designed response as K grows.
- Rigid CTC's instability at light joint damping, from the linearised closed loop's
  eigenvalues, confirmed in MuJoCo.
- The plumbing: batch forms equal the single-arm path, sweeps give each sample's joints,
  rigid plants and references without jerk are refused, the twist flag.
"""

from __future__ import annotations

import cmath
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import brentq, fsolve

from twolink.arm import dynamics
from twolink.arm.params import TWIST_LIMIT, ArmParams, Flexibility
from twolink.arm.plant import Plant
from twolink.arm.validation import random_arm
from twolink.controllers.baselines import straight_inertia
from twolink.controllers.ctc import ComputedTorque
from twolink.controllers.flexible import (
    CompositeControl,
    FlexibleFeedbackLinearisation,
    MotorPD,
    error_polynomial,
    motor_pd_bound,
    spring_frequency,
)
from twolink.foundation.references import ArmReference, Quintic, Septic, Step
from twolink.simulation.config import ConfigError, load_scenario, merge
from twolink.simulation.experiment import build_controller, measure, run_scenario, run_scenarios
from twolink.simulation.sim import simulate

BASE = Path(__file__).resolve().parents[1] / "runs" / "paper" / "base.toml"
ARM = ArmParams()
SOFT = Flexibility.from_damping_ratio((20.0, 20.0), (0.05, 0.05), 0.02)  # the soft arm
KP, KD = 100.0, 20.0  # ωn = 10 rad/s, ζ = 1
MOVE = {"septic": Septic, "quintic": Quintic}


def move(kind: str = "septic") -> ArmReference:
    """θ1: 0 -> 1 rad and θ2: 0 -> 0.5 rad, rest to rest in 2 s."""
    return ArmReference(MOVE[kind](0.0, 1.0, 2.0), MOVE[kind](0.0, 0.5, 2.0))


def holding(flex: Flexibility, q0=(0.0, 0.0)) -> tuple[float, float]:
    """Rotor angles that hold the arm still at q0 (springs twisted by G/K)."""
    return tuple(dynamics.holding_motor_angles(ARM, flex.k, np.array(q0)).tolist())


def companion(coefficients) -> np.ndarray:
    """The state matrix of e⁗ + c3 e⃛ + c2 ë + c1 ė + c0 e = 0, from (c0, c1, c2, c3)."""
    c0, c1, c2, c3 = coefficients
    return np.array([[0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1], [-c0, -c1, -c2, -c3]], float)


def closed_form(c: FlexibleFeedbackLinearisation, e0: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Each joint's error under its designed dynamics from (e, ė, ë, e⃛) = e0[j], at t."""
    a = [companion(poly) for poly in c.error_polynomials()]
    return np.array([[(expm(a[j] * x) @ e0[j])[0] for j in range(2)] for x in t])


# The two designs of the error polynomial: CTC's pair times a fast pair at the spring's
# own frequency (the default), and CTC's pair squared (fast_damping=None).
DESIGNS = {"fast pair": 0.7, "squared": None}


def test_error_polynomial_has_ctcs_poles_and_the_fast_pair():
    kp, kd, wp, zp = 4.0, 4.0, 300.0, 0.7
    roots = np.roots([1.0, *error_polynomial(kp, kd, (wp, zp))[::-1]])
    expected = np.r_[np.roots([1, kd, kp]), np.roots([1, 2 * zp * wp, wp * wp])]
    assert np.allclose(np.sort_complex(roots), np.sort_complex(expected), rtol=1e-6)
    assert error_polynomial(kp, kd) == (16.0, 32.0, 24.0, 8.0)  # (s + 2)^4
    # the controller's fast pair is at the spring's mode, or at the loop's ωn if slower
    c = FlexibleFeedbackLinearisation(
        ARM, move(), kp, kd, joints=Flexibility.realistic(), torque_limit=math.inf
    )
    for poly, wf in zip(c.error_polynomials(), spring_frequency(ARM, c.joints), strict=True):
        assert poly == error_polynomial(kp, kd, (wf, 0.7)) and wf > 100
    soft = Flexibility.from_damping_ratio((1.0, 1.0), (0.4, 0.08), 0.02)
    c = FlexibleFeedbackLinearisation(ARM, move(), 900.0, 60.0, joints=soft, torque_limit=math.inf)
    assert c.error_polynomials()[0] == error_polynomial(900.0, 60.0, (30.0, 0.7))


# ----------------------------------------------------------------------------- derivatives


def motion(rng):
    """A random cubic motion through a random state: q(t), and its derivatives at 0."""
    q, w, a, j = (rng.uniform(-2, 2, 2) for _ in range(4))

    def at(t):
        return q + w * t + a * t**2 / 2 + j * t**3 / 6, w + a * t + j * t**2 / 2, a + j * t

    return q, w, a, j, at


def test_derivatives_of_m_and_n_match_central_differences():
    rng = np.random.default_rng(0)
    h = 1e-4  # fourth-order differences: truncation ~h^4, rounding ~eps/h^2
    for _ in range(50):
        p = random_arm(rng)
        q, w, a, j, at = motion(rng)
        md, mdd = dynamics.mass_matrix_derivatives(p, q, w, a)
        nd, ndd = dynamics.bias_derivatives(p, q, w, a, j)

        def m(t, p=p, at=at):
            return dynamics.mass_matrix(p, at(t)[0])

        def n(t, p=p, at=at):
            qt, wt, _ = at(t)
            return dynamics.coriolis(p, qt, wt) + dynamics.gravity(p, qt)

        for f, d1, d2 in ((m, md, mdd), (n, nd, ndd)):
            v = [f(k * h) for k in (-2, -1, 0, 1, 2)]
            fd1 = (v[0] - 8 * v[1] + 8 * v[3] - v[4]) / (12 * h)
            fd2 = (-v[0] + 16 * v[1] - 30 * v[2] + 16 * v[3] - v[4]) / (12 * h * h)
            scale = 1 + np.abs(v[2]).max()
            np.testing.assert_allclose(d1, fd1, rtol=0, atol=1e-7 * scale)
            np.testing.assert_allclose(d2, fd2, rtol=0, atol=1e-5 * scale)


def test_derivatives_of_m_and_n_match_complex_step_differentiation():
    # Exact to rounding: d/dt f(q(t)) = Im f(q(i h)) / h for a tiny h. The first derivatives
    # are checked against terms() (M, H + G); the second against the first's formula.
    rng = np.random.default_rng(1)
    h = 1e-30
    for _ in range(50):
        p = random_arm(rng)
        q, w, a, j, at = motion(rng)
        qc, wc, ac = at(1j * h)
        m11, m12, _, b1, b2 = dynamics.terms(p, *qc, *wc, cos=cmath.cos, sin=cmath.sin)
        dm11, dm12, ddm11, ddm12, dn1, dn2, r1, r2, n11, n12, n21 = dynamics.derivative_terms(
            p, *q, *w, *a
        )
        exact = [m11.imag / h, m12.imag / h, b1.imag / h, b2.imag / h]
        assert np.allclose([dm11, dm12, dn1, dn2], exact, rtol=1e-12, atol=1e-12)
        cd = dynamics.derivative_terms(p, *qc, *wc, *ac, cos=cmath.cos, sin=cmath.sin)
        second = [cd[0].imag / h, cd[1].imag / h, cd[4].imag / h, cd[5].imag / h]
        ndd = [r1 + n11 * j[0] + n12 * j[1], r2 + n21 * j[0]]
        assert np.allclose([ddm11, ddm12, *ndd], second, rtol=1e-12, atol=1e-11)


def test_derivatives_of_m_and_n_match_a_symbolic_derivation_from_the_lagrangian():
    sp = pytest.importorskip("sympy")
    t = sp.Symbol("t")
    m1, m2, l1, l2, g = sp.symbols("m1 m2 l1 l2 g", positive=True)
    q1, q2 = sp.Function("q1")(t), sp.Function("q2")(t)
    # Two uniform rods in the vertical plane, gravity along -y (docs/model.md): the
    # kinetic energy of each centre of mass plus its spin, and the potential energy.
    x1, y1 = l1 / 2 * sp.cos(q1), l1 / 2 * sp.sin(q1)
    x2 = l1 * sp.cos(q1) + l2 / 2 * sp.cos(q1 + q2)
    y2 = l1 * sp.sin(q1) + l2 / 2 * sp.sin(q1 + q2)
    dq1, dq2 = q1.diff(t), q2.diff(t)
    kinetic = (
        m1 / 2 * (x1.diff(t) ** 2 + y1.diff(t) ** 2)
        + m1 * l1**2 / 24 * dq1**2
        + m2 / 2 * (x2.diff(t) ** 2 + y2.diff(t) ** 2)
        + m2 * l2**2 / 24 * (dq1 + dq2) ** 2
    )
    lagrangian = kinetic - g * (m1 * y1 + m2 * y2)
    tau = [
        sp.expand(lagrangian.diff(qd).diff(t) - lagrangian.diff(qi))
        for qi, qd in ((q1, dq1), (q2, dq2))
    ]
    acc = (q1.diff(t, 2), q2.diff(t, 2))
    mass = [[sp.simplify(ti.coeff(ak)) for ak in acc] for ti in tau]
    bias = [
        sp.simplify(ti - sum(mass[i][k] * acc[k] for k in range(2))) for i, ti in enumerate(tau)
    ]
    # derivatives in time, then the motion's values substituted for q, q', q'', q'''
    symbols = sp.symbols("a0:8")
    names = [
        f(t).diff(t, k) if k else f(t)
        for k in range(4)
        for f in (sp.Function("q1"), sp.Function("q2"))
    ]
    replace = dict(zip(reversed(names), reversed(symbols), strict=True))

    def compiled(expr):
        return sp.lambdify((m1, m2, l1, l2, g, *symbols), expr.subs(replace), "math")

    checks = [
        (compiled(mass[0][0].diff(t)), lambda md, mdd, nd, ndd: md[0, 0]),
        (compiled(mass[0][1].diff(t)), lambda md, mdd, nd, ndd: md[0, 1]),
        (compiled(mass[0][0].diff(t, 2)), lambda md, mdd, nd, ndd: mdd[0, 0]),
        (compiled(mass[0][1].diff(t, 2)), lambda md, mdd, nd, ndd: mdd[0, 1]),
        (compiled(bias[0].diff(t)), lambda md, mdd, nd, ndd: nd[0]),
        (compiled(bias[1].diff(t)), lambda md, mdd, nd, ndd: nd[1]),
        (compiled(bias[0].diff(t, 2)), lambda md, mdd, nd, ndd: ndd[0]),
        (compiled(bias[1].diff(t, 2)), lambda md, mdd, nd, ndd: ndd[1]),
    ]
    rng = np.random.default_rng(2)
    for _ in range(20):
        p = random_arm(rng)
        q, w, a, j, _ = motion(rng)
        ours = (
            *dynamics.mass_matrix_derivatives(p, q, w, a),
            *dynamics.bias_derivatives(p, q, w, a, j),
        )
        values = (p.m1, p.m2, p.l1, p.l2, p.g, *q, *w, *a, *j)
        for f, pick in checks:
            expected = f(*values)
            assert pick(*ours) == pytest.approx(expected, rel=1e-10, abs=1e-10)


def test_flexible_dynamics_and_gravity_gradient_match_mujoco_and_differences():
    rng = np.random.default_rng(3)
    for _ in range(20):
        p = random_arm(rng)
        flex = Flexibility(
            *(tuple(rng.uniform(lo, hi, 2)) for lo, hi in ((5, 5e3), (0, 2), (0.01, 1)))
        )
        x = rng.uniform(-2, 2, 8)
        tau = rng.uniform(-10, 10, 2)
        plant = Plant.build(p, flex)
        plant.set_state(x[[0, 1, 4, 5]], x[[2, 3, 6, 7]])
        qdd, phidd = dynamics.flexible_forward_dynamics(
            p, flex.k, flex.d, flex.j, x[:2], x[2:4], x[4:6], x[6:], tau
        )
        np.testing.assert_allclose(plant.forward(tau), np.r_[qdd, phidd], rtol=1e-9, atol=1e-9)
        h = 1e-6
        grad = np.column_stack(
            [
                (dynamics.gravity(p, x[:2] + h * e) - dynamics.gravity(p, x[:2] - h * e)) / (2 * h)
                for e in np.eye(2)
            ]
        )
        np.testing.assert_allclose(dynamics.gravity_gradient(p, x[:2]), grad, atol=1e-7)
    # the bound is the largest norm of the gradient: a dense grid never exceeds it, and
    # reaches it at its corner (sin q1 = sin(q1 + q2) = 1)
    grid = np.stack(np.meshgrid(np.linspace(-np.pi, np.pi, 61), np.linspace(-np.pi, np.pi, 61)), -1)
    norms = np.linalg.norm(dynamics.gravity_gradient(ARM, grid.reshape(-1, 2)), ord=2, axis=(1, 2))
    alpha = dynamics.gravity_gradient_bound(ARM)
    assert norms.max() <= alpha * (1 + 1e-12) and norms.max() == pytest.approx(alpha, rel=1e-3)
    assert alpha == pytest.approx(21.105, abs=1e-3)


# ----------------------------------------------------------------------------- references


def test_septic_is_a_rest_to_rest_move_with_continuous_jerk():
    ref = Septic(initial=0.5, final=-1.0, duration=1.7, t0=0.4)
    d = ref.final - ref.initial
    eps = 1e-12
    for t_end in (0.4, 2.1):
        before, after = ref.derivatives(t_end - eps, 4), ref.derivatives(t_end, 4)
        np.testing.assert_allclose(before[:4], after[:4], atol=1e-9)  # q, v, a, jerk continuous
        assert abs(after[1]) + abs(after[2]) + abs(after[3]) < 1e-9  # at rest at both ends
    assert ref.derivatives(0.4, 4)[4] == pytest.approx(840 * d / 1.7**4)  # the snap steps
    assert ref.derivatives(1.25, 0)[0] == pytest.approx(-0.25)  # halfway, by symmetry
    t = np.linspace(-0.5, 3.0, 3501)
    rows = ref.sample_derivatives(t, 4)
    np.testing.assert_array_equal(rows, np.array([ref.derivatives(float(x), 4) for x in t]).T)
    np.testing.assert_array_equal(ref.sample(t), rows[:3])
    # each derivative is the difference quotient of the one before (off the two ends)
    inside = np.linspace(0.45, 2.05, 50)
    h = 1e-6
    for k in range(4):
        fd = ref.sample_derivatives(inside + h, 4)[k] - ref.sample_derivatives(inside - h, 4)[k]
        np.testing.assert_allclose(
            fd / (2 * h), ref.sample_derivatives(inside, 4)[k + 1], rtol=1e-6, atol=1e-4
        )


@pytest.mark.parametrize(
    "ref",
    [
        Step(0.2, -1.3, 0.5),
        Quintic(0.5, -1.0, 1.7, 0.4),
        Septic(0.5, -1.0, 1.7, 0.4),
    ],
    ids=["step", "quintic", "septic"],
)
def test_every_reference_gives_its_derivatives_up_to_the_snap(ref):
    t = np.linspace(-1.0, 3.0, 401)
    for n in range(5):
        rows = ref.sample_derivatives(t, n)
        assert rows.shape == (n + 1, t.size)
        scalar = np.array([ref.derivatives(float(x), n) for x in t]).T
        np.testing.assert_array_equal(rows, scalar)
        np.testing.assert_array_equal(rows[: min(n + 1, 3)], ref.sample(t)[: n + 1])
    with pytest.raises(ValueError, match="order"):
        ref.derivatives(0.0, 5)


def test_quintic_jerk_jumps_at_its_ends():
    ref = Quintic(0.0, 1.0, 2.0)
    assert ref.derivatives(-1e-9, 3)[3] == 0.0
    assert ref.derivatives(0.0, 3)[3] == pytest.approx(60 / 2.0**3)  # 7.5 rad/s^3


# ------------------------------------------------------------------- feedback linearisation


def _initial_error(p, flex, ref, q0) -> np.ndarray:
    """(e, ė, ë, e⃛) at t = 0 per joint, for an arm at rest at q0 with relaxed springs: the
    links' acceleration and jerk from the analytic model (the jerk by a central difference
    along the motion under the torque held at the start, zero)."""
    x0 = np.r_[q0, 0.0, 0.0, q0, 0.0, 0.0]

    def acc(x):
        return dynamics.flexible_forward_dynamics(
            p, flex.k, flex.d, flex.j, x[:2], x[2:4], x[4:6], x[6:], np.zeros(2)
        )

    def rate(x):
        qdd, phidd = acc(x)
        return np.r_[x[2:4], qdd, x[6:], phidd]

    h = 1e-6
    jerk = (acc(x0 + h * rate(x0))[0] - acc(x0 - h * rate(x0))[0]) / (2 * h)
    r = np.array([ref.joint1.derivatives(0.0, 3), ref.joint2.derivatives(0.0, 3)])
    return np.stack([r[:, 0] - q0, r[:, 1], r[:, 2] - acc(x0)[0], r[:, 3] - jerk], axis=1)


@pytest.mark.parametrize("design", DESIGNS)
@pytest.mark.parametrize("zeta", [0.0, 0.02], ids=["undamped", "lightly damped"])
def test_feedback_linearisation_gives_the_designed_fourth_order_error_dynamics(zeta, design):
    # The soft arm starts at rest with relaxed springs, so the links drop under gravity:
    # the error starts with ë(0) = M⁻¹ G and then obeys e⁗ + c3 e⃛ + c2 ë + c1 ė + c0 e = 0.
    flex = Flexibility.from_damping_ratio(SOFT.k, SOFT.j, zeta)
    ref = move("septic")
    e0 = _initial_error(ARM, flex, ref, np.zeros(2))
    deviation = []
    for dt in (1e-3, 5e-4):
        c = FlexibleFeedbackLinearisation(
            ARM,
            ref,
            KP,
            KD,
            joints=flex,
            control_dt=dt,
            fast_damping=DESIGNS[design],
            torque_limit=math.inf,
        )
        traj = simulate(Plant.build(ARM, flex, timestep=dt), c, 2.5, control_dt=dt)
        assert traj.ok
        k = np.arange(0, len(traj.t), round(1e-2 / dt))
        closed = closed_form(c, e0, traj.t[k])
        deviation.append(np.abs(traj.e[k] - closed).max())
        assert np.abs(closed).max() > 0.02  # a transient worth following
    # The law is evaluated half a period ahead, which makes the zero-order hold's error
    # O(dt²) (2.2e-5 rad at 1 ms, squared design); with damping, the torque's filter
    # (implicit Euler) is O(dt) (1.9e-4 rad). Halving dt divides the deviation by 4, or by 2.
    assert deviation[0] < (1e-4 if zeta == 0 else 1e-3)
    order = 2 if zeta == 0 else 1
    assert 0.9 * 2**order < deviation[0] / deviation[1] < 1.1 * 2**order


def test_feedback_linearisation_at_a_low_bandwidth_on_stiff_joints():
    # The map's cell that failed: realistic joints (k = 1e4 and 3e3, J = 0.4 and 0.08,
    # ζ = 0.02), ωn = 2, the map's septic move in 1.5 s from relaxed springs, 1 kHz.
    # The default design follows its closed form; CTC's polynomial squared, (s + 2)⁴,
    # asks the sampled law to bring the spring's mode (ωf = 205 and 280 rad/s) down to
    # 2 rad/s and cannot: it leaves its closed form by tenths of a radian, and by less at
    # a faster control rate (docs/control.md, "Why not CTC's poles twice").
    flex = Flexibility.realistic()
    ref = ArmReference(Septic(0.0, 1.0, 1.5), Septic(0.0, 0.5, 1.5))
    e0 = _initial_error(ARM, flex, ref, np.zeros(2))
    for dt, tol in ((1e-3, 1e-3), (5e-4, 3e-4)):
        c = FlexibleFeedbackLinearisation(
            ARM, ref, 4.0, 4.0, joints=flex, control_dt=dt, torque_limit=math.inf
        )
        traj = simulate(Plant.build(ARM, flex, timestep=dt), c, 3.0, control_dt=dt)
        k = np.arange(0, len(traj.t), round(1e-2 / dt))
        closed = closed_form(c, e0, traj.t[k])
        assert traj.ok and np.abs(traj.e[k] - closed).max() < tol
        assert 0.01 < np.abs(closed).max() < 0.02  # the drop from relaxed springs
    # From rest holding itself up, it tracks the move within 1e-3 rad.
    c = FlexibleFeedbackLinearisation(ARM, ref, 4.0, 4.0, joints=flex, torque_limit=math.inf)
    traj = simulate(Plant.build(ARM, flex), c, 3.0, motor_q0=holding(flex))
    assert traj.ok and np.abs(traj.e).max() < 1e-3
    # The squared design: its closed form swings joint 2 by 4 rad from relaxed springs
    # (ë(0) = M⁻¹ G recovered at 2 rad/s), and the sampled law leaves even that.
    squared = [
        FlexibleFeedbackLinearisation(
            ARM, ref, 4.0, 4.0, joints=flex, control_dt=dt, fast_damping=None, torque_limit=math.inf
        )
        for dt in (1e-3, 5e-4)
    ]
    off = []
    for c in squared:
        dt = c.control_dt
        traj = simulate(Plant.build(ARM, flex, timestep=dt), c, 3.0, control_dt=dt)
        k = np.arange(0, len(traj.t), round(1e-2 / dt))
        closed = closed_form(c, e0, traj.t[k])
        assert np.abs(closed[:, 1]).max() > 4.0
        off.append(np.abs(traj.e[k] - closed).max())
    assert off[0] > 0.2 and off[1] < off[0] / 5


@pytest.mark.parametrize("zeta", [0.0, 0.02, 0.05])
def test_feedback_linearisation_tracks_the_septic_move_on_the_soft_arm_within_1e_3(zeta):
    flex = Flexibility.from_damping_ratio(SOFT.k, SOFT.j, zeta)
    c = FlexibleFeedbackLinearisation(
        ARM, move("septic"), KP, KD, joints=flex, torque_limit=math.inf
    )
    traj = simulate(Plant.build(ARM, flex), c, 4.0, motor_q0=holding(flex))
    assert traj.ok and np.abs(traj.e).max() < 1e-3
    assert np.abs(traj.e[-1]).max() < 1e-8


@pytest.mark.parametrize("design", DESIGNS)
def test_the_quintics_jerk_steps_cause_the_error_their_closed_form_predicts(design):
    # The arm's jerk is continuous; the quintic's jumps by Δ = 60 d / T³ at t = 0 and back
    # at t = T, so e⃛ jumps by Δ there and the error is Δ (φ(t) − φ(t − T)), φ the
    # response of the error dynamics to e⃛(0) = 1 (the inverse Laplace transform of
    # 1 / p(s)). Its peak for (s + ωn)⁴ is (3/ωn)³ e⁻³ / 6 ≈ 0.224 / ωn³: 1.68e-3 rad for
    # the 1 rad move in 2 s. With the fast pair (at ωp = ωf = 20.8 and 26.0 rad/s on this
    # arm) the jump is taken up by the fast pair and φ ≈ t e^(−ωn t) / ωp², whose peak is
    # 1 / (e ωn ωp²): 8.0e-5 and 5.4e-5 (6.0e-4 and 2.0e-4 rad), 2.8 and 4.2 times less.
    c = FlexibleFeedbackLinearisation(
        ARM,
        move("quintic"),
        KP,
        KD,
        joints=SOFT,
        fast_damping=DESIGNS[design],
        torque_limit=math.inf,
    )
    traj = simulate(Plant.build(ARM, SOFT), c, 4.0, motor_q0=holding(SOFT))
    peaks = {}
    for j, d in ((0, 1.0), (1, 0.5)):
        a = companion(c.error_polynomials()[j])

        def phi(t, a=a):
            return np.where(t > 0, [(expm(a * max(x, 0.0)) @ [0, 0, 0, 1.0])[0] for x in t], 0)

        jump = 60 * d / 2.0**3
        predicted = jump * (phi(traj.t) - phi(traj.t - 2.0))
        peaks[j] = np.abs(predicted).max() / jump
        # the residual is the sampled law's own error, all that the septic move leaves
        # (<= 6.6e-5 rad on either joint of this arm at dt = 1 ms)
        assert np.abs(traj.e[:, j] - predicted).max() < 1e-4
        assert np.abs(traj.e[:, j]).max() > 0.9 * np.abs(predicted).max() > 3e-4 * d
    if design == "squared":
        assert peaks[0] == peaks[1] == pytest.approx(0.2240 / 10.0**3, rel=1e-3)
    else:
        for j, wp in enumerate(spring_frequency(ARM, SOFT)):
            assert peaks[j] == pytest.approx(1 / (math.e * 10.0 * wp * wp), rel=0.1)


def test_feedback_linearisation_refuses_a_reference_without_derivatives():
    class Bare:  # a JointReference without derivatives(t, n)
        final = 1.0

        def __call__(self, t):
            return (1.0, 0.0, 0.0)

        def sample(self, t):
            return np.zeros((3, np.size(t)))

    ref = ArmReference(Bare(), Step(0.0, 0.5))
    with pytest.raises(ValueError, match="jerk and snap.*joint1"):
        FlexibleFeedbackLinearisation(ARM, ref, KP, KD, joints=SOFT, torque_limit=math.inf)


# ----------------------------------------------------------------------------- motor PD


def test_motor_pd_converges_to_the_set_point_on_random_arms_above_its_stiffness_bound():
    rng = np.random.default_rng(5)
    for _ in range(10):
        p = ArmParams(*rng.uniform(0.5, 2.0, 2), *rng.uniform(0.5, 1.5, 2), 9.81)
        alpha = dynamics.gravity_gradient_bound(p)
        k = alpha * np.exp(rng.uniform(np.log(3), np.log(30), 2))
        j = rng.uniform(0.05, 0.5, 2)
        flex = Flexibility.from_damping_ratio(tuple(k), tuple(j), 0.02)
        # motor stiffness for λmin = 1.5 α: kp_motor = λ (2k − λ) / (k − λ)
        lam = 1.5 * alpha
        kp = lam * (2 * k - lam) / (k - lam) / (np.array(straight_inertia(p)) + j)
        target = rng.uniform(-1, 1, 2)
        c = MotorPD(
            p,
            ArmReference(Step(0.0, target[0]), Step(0.0, target[1])),
            tuple(kp),
            tuple(2 * np.sqrt(kp)),
            joints=flex,
            torque_limit=math.inf,
        )
        bound = c.stiffness_bound()
        assert bound.met and bound.margin == pytest.approx(1.5)
        traj = simulate(Plant.build(p, flex), c, 10.0)  # from rest, springs relaxed
        assert traj.ok and np.abs(traj.e[-1]).max() < 1e-4
        # the rotors end where the law puts them: the set point plus the springs' twist
        np.testing.assert_allclose(
            traj.motor_q[-1], target + dynamics.gravity(p, target) / k, atol=1e-4
        )


def _motor_pd_equilibria(c: MotorPD, target) -> list[np.ndarray]:
    """Every rest state (q, φ) of the motor PD's closed loop found by fsolve from a grid of
    starts: springs hold the links (K (φ − q) = G(q)) and the law holds the rotors."""
    k, target = np.array(c.joints.k), np.asarray(target)
    g_r = dynamics.gravity(ARM, target)
    phi_d, kp_motor = target + g_r / k, np.array(c.scale) * np.array(c.kp)

    def residual(x):
        q, phi = x[:2], x[2:]
        spring = k * (phi - q)
        return np.r_[spring - dynamics.gravity(ARM, q), kp_motor * (phi_d - phi) + g_r - spring]

    found: list[np.ndarray] = []
    for q1 in np.linspace(-np.pi, np.pi, 9):
        for q2 in np.linspace(-np.pi, np.pi, 9):
            x, _, ok, _ = fsolve(residual, np.r_[q1, q2, q1, q2], full_output=True, xtol=1e-12)
            if ok == 1 and not any(np.allclose(x, y, atol=1e-6) for y in found):
                found.append(x)
    return found


def test_motor_pd_bound_and_what_happens_below_it():
    # λmin of [[k, −k], [−k, k + kp]] is below k, so no motor gain rescues joints softer
    # than α = 21.1 N m/rad (the default arm); the soft arm (K = 20) is.
    assert motor_pd_bound(ARM, (20.0, 20.0), (1e9, 1e9)).met is False
    assert motor_pd_bound(ARM, (500.0, 500.0), (1e3, 1e3)).met
    target = (1.0, 0.5)
    stiff = Flexibility.from_damping_ratio((100.0, 100.0), SOFT.j, 0.02)
    gains = ((100.0, 300.0), (20.0, 35.0))  # joint 2's motor stiffness must exceed 2 α
    above = MotorPD(ARM, move(), *gains, joints=stiff)
    below = MotorPD(ARM, move(), *gains, joints=SOFT)
    assert above.stiffness_bound().met and not below.stiffness_bound().met
    # Above the bound the closed loop's potential is convex: one rest state, the set
    # point. Below it gravity's gradient beats the springs: the set point and two more.
    [only] = _motor_pd_equilibria(above, target)
    np.testing.assert_allclose(only[:2], target, atol=1e-9)
    states = _motor_pd_equilibria(below, target)
    assert len(states) == 3 and any(np.allclose(x[:2], target) for x in states)
    # and the soft arm swings between them, still far from settled 6 s after the move
    traj = simulate(Plant.build(ARM, SOFT), below, 8.0, motor_q0=holding(SOFT))
    assert traj.ok and np.abs(traj.e[6000:]).max() > 0.3
    traj = simulate(Plant.build(ARM, stiff), above, 15.0, motor_q0=holding(stiff))
    assert traj.ok and np.abs(traj.e[-1]).max() < 1e-3


# ----------------------------------------------------------------------------- composite


def test_composite_control_approaches_rigid_ctc_as_the_joints_stiffen():
    # Rigid CTC's designed response: ë + Kd ė + Kp e = 0 from e(0) = −q0. The composite
    # control's links follow it as K grows (its slow law is CTC of the K → ∞ model).
    q0 = np.array([0.2, -0.1])
    a = np.array([[0.0, 1.0], [-KP, -KD]])
    deviation = []
    for k in (1e2, 1e3, 1e4):
        flex = Flexibility.from_damping_ratio((k, k), (0.05, 0.05), 0.02)
        c = CompositeControl(ARM, move("septic"), KP, KD, joints=flex, torque_limit=math.inf)
        traj = simulate(Plant.build(ARM, flex), c, 3.0, q0=tuple(q0), motor_q0=holding(flex, q0))
        assert traj.ok
        closed = np.array([[(expm(a * t) @ [-q, 0.0])[0] for q in q0] for t in traj.t[::10]])
        deviation.append(np.abs(traj.e[::10] - closed).max())
        assert min(c.separation()) > 4  # the spring's mode well above the loop's 10 rad/s
    assert deviation[0] > 2.5 * deviation[1] > 2.5**2 * deviation[2]
    assert deviation[2] < 2e-3  # near the zero-order hold's O(dt) floor of CTC itself


# ----------------------------------------------------------------------------- rigid CTC


def _ctc_closed_loop_eigenvalues(flex: Flexibility, kp: float, kd: float) -> np.ndarray:
    """Eigenvalues of rigid CTC on the flexible arm (analytic model, continuous time),
    linearised by central differences at the set point q* = (1, 0.5) held still."""
    q_star = np.array([1.0, 0.5])

    def f(x):
        q, qd, phi, phid = x[:2], x[2:4], x[4:6], x[6:]
        v = kp * (q_star - q) - kd * qd
        tau = dynamics.inverse_dynamics(ARM, q, qd, v)
        qdd, phidd = dynamics.flexible_forward_dynamics(
            ARM, flex.k, flex.d, flex.j, q, qd, phi, phid, tau
        )
        return np.r_[qd, qdd, phid, phidd]

    x0 = np.r_[q_star, 0, 0, dynamics.holding_motor_angles(ARM, flex.k, q_star), 0, 0]
    assert np.abs(f(x0)).max() < 1e-9  # an equilibrium
    h = 1e-6
    jac = np.column_stack([(f(x0 + h * e) - f(x0 - h * e)) / (2 * h) for e in np.eye(8)])
    return np.linalg.eigvals(jac)


def test_rigid_ctc_is_unstable_at_light_joint_damping_and_the_linearisation_says_why():
    # The reproduction's gains (ωn = 15, ζ = 1) on K = 500 N m/rad, J = 0.05 kg m².
    kp, kd, j = 225.0, 30.0, 0.05

    def max_real(d):
        return _ctc_closed_loop_eigenvalues(
            Flexibility((500.0,) * 2, (d, d), (j, j)), kp, kd
        ).real.max()

    light, heavy = max_real(0.05), max_real(2.0)
    assert light > 10 and heavy < -5  # a spring mode near 103 rad/s grows, or decays
    # Why: one joint, link inertia M, rotor J, torque τ = −M (Kp q + Kd q̇):
    #   J M s⁴ + D (J + M) s³ + (K (J + M) + M Kd D) s² + M (Kp D + Kd K) s + M Kp K,
    # Hurwitz (Routh) only for D above ≈ J Kd M² / (J + M)²: CTC's derivative action,
    # applied through the rotor, takes damping J Kd from the spring mode, and the joint's
    # own D must pay it back. With D = 0 it is unstable at any K.
    d_crit = brentq(max_real, 0.05, 2.0)
    m11 = dynamics.mass_matrix(ARM, np.array([1.0, 0.5]))[0, 0]
    assert d_crit == pytest.approx(j * kd * m11**2 / (j + m11) ** 2, rel=0.1)
    assert (
        max_real(0.0) > 0
        and _ctc_closed_loop_eigenvalues(
            Flexibility((1e4,) * 2, (0.0, 0.0), (j, j)), kp, kd
        ).real.max()
        > 0
    )
    # MuJoCo agrees: a small push off the set point dies out at D = 2, runs away at 0.05
    ref = ArmReference(Step(1.0, 1.0), Step(0.5, 0.5))
    for d, grows in ((0.05, True), (2.0, False)):
        flex = Flexibility((500.0,) * 2, (d, d), (j, j))
        push = tuple(np.array(holding(flex, (1.0, 0.5))) + 1e-4)
        traj = simulate(
            Plant.build(ARM, flex),
            ComputedTorque(ARM, ref, kp, kd, torque_limit=math.inf),
            3.0,
            q0=(1.0, 0.5),
            motor_q0=push,
        )
        assert (traj.status == "diverged") is grows
        if not grows:
            assert np.abs(traj.e[-1]).max() < 1e-9


def test_the_soft_arm_under_each_controller():
    # The comparison: K = 20, J = 0.05, ζ = 0.02; the 1 rad (and 0.5 rad) move
    # in 2 s at ωn = 10, from rest holding itself up.
    results = {}
    for name, c in {
        "ctc": ComputedTorque(ARM, move(), KP, KD, torque_limit=math.inf),
        "motor_pd": MotorPD(ARM, move(), KP, KD, joints=SOFT, torque_limit=math.inf),
        "composite": CompositeControl(ARM, move(), KP, KD, joints=SOFT, torque_limit=math.inf),
        "flexible_fl": FlexibleFeedbackLinearisation(
            ARM, move(), KP, KD, joints=SOFT, torque_limit=math.inf
        ),
    }.items():
        traj = simulate(Plant.build(ARM, SOFT), c, 4.0, motor_q0=holding(SOFT))
        results[name] = (traj.status, np.abs(traj.e).max())
    assert results["ctc"][0] == "diverged"
    assert results["motor_pd"][0] == "ok" and results["motor_pd"][1] > 0.5  # below its bound
    assert results["composite"][0] == "ok" and results["composite"][1] < 0.05
    assert results["flexible_fl"][0] == "ok" and results["flexible_fl"][1] < 1e-3


# ----------------------------------------------------------------------------- plumbing


FLEX = {"flexibility": {"k": [500.0, 300.0], "d": [0.2, 0.1], "j": [0.05, 0.08]}}


def scenario(**overrides):
    base = {
        "duration": 1.0,
        "plant": FLEX,
        "reference": {
            "joint1": {"kind": "septic", "final": 1.0, "duration": 0.8},
            "joint2": {"kind": "quintic", "final": 0.5, "duration": 0.8},
        },
        "controller": {"kp": 100.0, "kd": 20.0},
    }
    return load_scenario("runs/paper/theta1_step.toml", merge(base, overrides))


@pytest.mark.parametrize("kind", ["motor_pd", "composite", "flexible_fl"])
def test_batch_form_equals_the_single_arm_path(kind):
    ctrl = {"controller": {"kind": kind}}
    scenarios = [
        scenario(**ctrl),
        scenario(
            **merge(ctrl, {"plant": {"scale": {"m2": 1.2}}, "sensor": {"noise_std_rad": 0.002}}),
            seed=3,
        ),
        scenario(**merge(ctrl, {"controller": {"torque_limit": [20.0, 4.0]}})),
        scenario(plant={"flexibility": {"k": 2e3}}, controller={"kind": kind, "kp": 25.0}),
        scenario(),  # a rigid-model CTC on a flexible arm in the same batch
        load_scenario("runs/paper/theta1_step.toml", {"duration": 1.0}),  # a rigid arm
    ]
    for s, batch in zip(scenarios, run_scenarios(scenarios), strict=True):
        single = run_scenario(s)
        assert batch.status == single.status == "ok"
        for name in ("q", "qd", "motor_q", "tau"):
            np.testing.assert_allclose(
                getattr(batch, name), getattr(single, name), rtol=0, atol=1e-10, err_msg=name
            )


def test_custom_motor_reading_controllers_run_arm_by_arm():
    class Wrapped:  # not a known class: the batch engine calls it arm by arm
        needs_motor = True

        def __init__(self, inner):
            self.inner, self.reference = inner, inner.reference

        def reset(self):
            self.inner.reset()

        def __call__(self, t, q, qd, motor_q, motor_qd):
            return self.inner(t, q, qd, motor_q, motor_qd)

    s = scenario(controller={"kind": "flexible_fl"})
    single = run_scenario(s)
    [batch] = run_scenarios([s], [Wrapped(build_controller(s))])
    np.testing.assert_allclose(batch.q, single.q, rtol=0, atol=1e-12)


def test_a_motor_reading_controller_needs_a_flexible_plant():
    with pytest.raises(ConfigError, match="controller.kind: 'motor_pd' reads the motors"):
        load_scenario("runs/paper/theta1_step.toml", {"controller": {"kind": "motor_pd"}})
    c = MotorPD(ARM, move(), KP, KD, joints=SOFT, torque_limit=math.inf)
    with pytest.raises(ValueError, match="rigid"):
        simulate(Plant.build(ARM), c, 0.1)
    with pytest.raises(ValueError, match="needs their model"):
        MotorPD(ARM, move(), KP, KD, torque_limit=math.inf)


def test_a_sweep_gives_each_sample_its_own_joints(tmp_path):
    from twolink import sweep as sw

    path = tmp_path / "sweep.toml"
    path.write_text(
        f"""
scenario = "{BASE.as_posix()}"
samples = 2
chunk_size = 2
[overrides]
duration = 0.5
[overrides.plant.flexibility]
d = 0.1
j = 0.05
[reference.joint1]
kind = "septic"
final = 1.0
duration = 0.4
[parameters]
k = {{ dist = "grid", values = [50.0, 5000.0] }}
[controllers.FL]
kind = "flexible_fl"
kp = 100.0
kd = 20.0
"""
    )
    plan = sw.load_sweep(path)
    rows = sw.run_chunk(plan, 0).rows
    for row, k in zip(rows, (50.0, 5000.0), strict=True):
        assert row[-2] == "ok", row[-1]
        s = load_scenario(
            BASE,
            merge(
                {"controller": {"kind": "flexible_fl", "kp": 100.0, "kd": 20.0}},
                {
                    "duration": 0.5,
                    "plant": {"flexibility": {"k": k, "d": 0.1, "j": 0.05}},
                    "reference": {"joint1": {"kind": "septic", "final": 1.0, "duration": 0.4}},
                },
            ),
        )
        expected = measure(s, run_scenario(s))
        column = plan.columns.index("joint1_max_error_rad")
        assert row[column] == pytest.approx(expected.errors.max_abs[0], rel=1e-9)


def test_spring_twist_is_measured_and_flagged_beyond_its_limit():
    s = scenario(controller={"kind": "flexible_fl"})
    m = measure(s, traj := run_scenario(s))
    assert m.max_twist == tuple(np.abs(traj.motor_q - traj.q).max(axis=0))
    assert max(m.max_twist) < TWIST_LIMIT and m.warnings == []
    soft = scenario(plant={"flexibility": {"k": 20.0}}, controller={"kind": "flexible_fl"})
    m = measure(soft, run_scenario(soft))
    assert m.max_twist[0] > TWIST_LIMIT and "joint 1 spring twisted" in m.warnings[0]
    d = m.to_dict("FL")
    assert d["max_twist_rad"] == list(m.max_twist) and d["warnings"] == m.warnings
    rigid = load_scenario("runs/paper/theta1_step.toml", {"duration": 0.2})
    m = measure(rigid, run_scenario(rigid))
    assert all(math.isnan(x) for x in m.max_twist) and m.warnings == []


def test_realistic_joints():
    f = Flexibility.realistic()
    assert f.damping_ratio == pytest.approx((0.02, 0.02))
    assert f.k == (1.0e4, 3.0e3) and f.j == (0.4, 0.08)
    # stiff enough for the motor PD's bound, and a static twist far inside the limit
    assert min(f.k) > 10 * dynamics.gravity_gradient_bound(ARM)
    assert (np.abs(dynamics.gravity(ARM, np.zeros(2))) / f.k).max() < TWIST_LIMIT / 50
    assert Flexibility.realistic(0.05).damping_ratio == pytest.approx((0.05, 0.05))
