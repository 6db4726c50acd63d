"""An independent model of the flexible-link arm: assumed modes, in numpy (no MuJoCo).

The model of De Luca and Siciliano ("Closed-form dynamic model of planar multilink
lightweight robots", IEEE Trans. SMC 21(4), 1991): each link's deflection in its own
frame is w_i(x, t) = Σ_k φ_ik(x) δ_ik(t), with φ_ik the clamped-free beam's mode shapes;
link 2's base turns with link 1's tip slope w_1'(L_1). The equations come from the
virtual power of every mass point: M(q) q̈ + Σ m Jᵀ (J̇ q̇) + D q̇ + K δ = G + B τ,
with q = (θ1, θ2, δ_1..., δ_2...). The mass integrals are Gauss-Legendre sums over
each link; K_kk = E I ∫ φ_k''² dx; D = η K (Kelvin-Voigt, η = 2 ζ / ω_1, as
:mod:`twolink.arm.links`). A hub's inertia spins with its joint's own rate (the motor's
rotor through its gear); tip masses are points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from twolink.arm.links import FlexibleLinks, LinkBeam

QUADRATURE_POINTS = 24  # Gauss-Legendre nodes per link: exact for these smooth shapes


def clamped_free_beta_l(count: int) -> np.ndarray:
    """The first ``count`` roots of 1 + cos(βL) cosh(βL) = 0 (brentq, near (n - 1/2) π)."""

    def f(b):
        return 1.0 + np.cos(b) * np.cosh(b)

    return np.array(
        [brentq(f, (n - 0.5) * np.pi - 1.0, (n - 0.5) * np.pi + 1.0) for n in range(1, count + 1)]
    )


def mode_shapes(beam: LinkBeam, count: int, x: np.ndarray) -> tuple[np.ndarray, ...]:
    """(φ, φ', φ'') of the first ``count`` clamped-free modes at ``x`` (count, len(x)),
    normalised to ∫ φ² dx = L."""
    beta = clamped_free_beta_l(count)[:, None] / beam.length
    bl = beta * beam.length
    sigma = (np.cosh(bl) + np.cos(bl)) / (np.sinh(bl) + np.sin(bl))
    bx = beta * np.asarray(x, dtype=float)[None, :]
    phi = np.cosh(bx) - np.cos(bx) - sigma * (np.sinh(bx) - np.sin(bx))
    d1 = beta * (np.sinh(bx) + np.sin(bx) - sigma * (np.cosh(bx) - np.cos(bx)))
    d2 = beta**2 * (np.cosh(bx) + np.cos(bx) - sigma * (np.sinh(bx) + np.sin(bx)))
    # ∫_0^L φ² dx = L for this form of the clamped-free shape (Blevins, table 8-1).
    return phi, d1, d2


@dataclass(frozen=True)
class _Link:
    beam: LinkBeam
    x: np.ndarray  # quadrature nodes [m]
    w: np.ndarray  # their weights times ρ A [kg]
    phi: np.ndarray  # (modes, nodes)
    tip_phi: np.ndarray  # (modes,)
    tip_slope: np.ndarray  # (modes,)
    k: np.ndarray  # (modes,) modal stiffness E I ∫ φ''² [N m]


def _link(beam: LinkBeam, modes: int) -> _Link:
    nodes, weights = np.polynomial.legendre.leggauss(QUADRATURE_POINTS)
    x = (nodes + 1.0) * beam.length / 2
    w = weights * beam.length / 2
    phi, _, d2 = mode_shapes(beam, modes, x)
    tip, slope, _ = mode_shapes(beam, modes, np.array([beam.length]))
    k = beam.ei * (d2**2 @ w)
    return _Link(beam, x, w * beam.rho_a, phi, tip[:, 0], slope[:, 0], k)


def _rot(a: np.ndarray) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s], [s, c]])


_S = np.array([[0.0, -1.0], [1.0, 0.0]])  # d/da R(a) = R(a) S


class AssumedModesArm:
    """The two-link flexible arm with ``modes`` clamped-free modes per link (1 or 2).

    ``q`` = (θ1, θ2, δ_1 (modes), δ_2 (modes)); :meth:`rhs` is the state derivative of
    (q, q̇) under hub torques τ; :meth:`tip` the tip in the paper's plane.
    """

    def __init__(self, links: FlexibleLinks, g: float = 0.0, modes: int = 2) -> None:
        self.n = modes
        self.g = g
        self.links = (_link(links.link1, modes), _link(links.link2, modes))
        self.size = 2 + 2 * modes
        k = np.concatenate([lk.k for lk in self.links])
        eta = np.repeat([2.0 * b.damping_ratio / b.clamped_frequency() for b in links.links], modes)
        self.k = np.concatenate([[0.0, 0.0], k])
        self.d = np.concatenate([[0.0, 0.0], eta * k])

    def _points(self, q, qd):
        """Every mass point's (mass, Jacobian (P, 2, size), velocity-product accel (P, 2))
        and the hubs' (inertia, angle Jacobian, 0) terms."""
        n = self.n
        l1, l2 = self.links
        d1, d2 = q[2 : 2 + n], q[2 + n :]
        dd1, dd2 = qd[2 : 2 + n], qd[2 + n :]
        a1 = q[0]
        r1 = _rot(a1)
        w1 = d1 @ l1.phi
        wd1 = dd1 @ l1.phi
        u1 = np.stack([l1.x, w1], -1)  # (P, 2) in link 1's frame
        jac1 = np.zeros((len(l1.x), 2, self.size))
        jac1[:, :, 0] = u1 @ (r1 @ _S).T
        jac1[:, :, 2 : 2 + n] = (r1 @ np.array([[0.0], [1.0]]))[None, :, :] * l1.phi.T[:, None, :]
        ud1 = np.stack([np.zeros_like(wd1), wd1], -1)
        acc1 = -(u1 @ r1.T) * qd[0] ** 2 + 2 * qd[0] * (ud1 @ (r1 @ _S).T)
        # Link 1's tip
        ut = np.array([l1.beam.length, d1 @ l1.tip_phi])
        udt = np.array([0.0, dd1 @ l1.tip_phi])
        jt = np.zeros((2, self.size))
        jt[:, 0] = r1 @ _S @ ut
        jt[:, 2 : 2 + n] = r1 @ np.array([[0.0], [1.0]]) * l1.tip_phi[None, :]
        acct = -(r1 @ ut) * qd[0] ** 2 + 2 * qd[0] * (r1 @ _S @ udt)
        # Link 2: its base at link 1's tip, turned by θ1 + w_1'(L_1) + θ2.
        ga = np.zeros(self.size)
        ga[0], ga[1] = 1.0, 1.0
        ga[2 : 2 + n] = l1.tip_slope
        a2 = a1 + d1 @ l1.tip_slope + q[1]
        ad2 = ga @ qd
        r2 = _rot(a2)
        w2 = d2 @ l2.phi
        wd2 = dd2 @ l2.phi
        u2 = np.stack([l2.x, w2], -1)
        jac2 = np.zeros((len(l2.x), 2, self.size))
        jac2 += jt[None]
        jac2 += (u2 @ (r2 @ _S).T)[:, :, None] * ga[None, None, :]
        jac2[:, :, 2 + n :] += (r2 @ np.array([[0.0], [1.0]]))[None, :, :] * l2.phi.T[:, None, :]
        ud2 = np.stack([np.zeros_like(wd2), wd2], -1)
        acc2 = acct[None] - (u2 @ r2.T) * ad2**2 + 2 * ad2 * (ud2 @ (r2 @ _S).T)
        # Link 2's tip
        ut2 = np.array([l2.beam.length, d2 @ l2.tip_phi])
        udt2 = np.array([0.0, dd2 @ l2.tip_phi])
        jt2 = jt + np.outer(r2 @ _S @ ut2, ga)
        jt2[:, 2 + n :] += r2 @ np.array([[0.0], [1.0]]) * l2.tip_phi[None, :]
        acct2 = acct - (r2 @ ut2) * ad2**2 + 2 * ad2 * (r2 @ _S @ udt2)
        masses = np.concatenate([l1.w, l2.w, [l1.beam.tip_mass, l2.beam.tip_mass]])
        jac = np.concatenate([jac1, jac2, jt[None], jt2[None]])
        acc = np.concatenate([acc1, acc2, acct[None], acct2[None]])
        e1, e2 = np.eye(self.size)[:2]  # the rotors spin with the hub joints' own rates
        hubs = ((l1.beam.hub_inertia, e1), (l2.beam.hub_inertia, e2))
        return masses, jac, acc, hubs, jt2, r2 @ ut2 + r1 @ ut

    def mass_matrix(self, q) -> np.ndarray:
        masses, jac, _, hubs, *_ = self._points(np.asarray(q, float), np.zeros(self.size))
        m = np.einsum("p,pai,paj->ij", masses, jac, jac)
        for inertia, ga in hubs:
            m += inertia * np.outer(ga, ga)
        return m

    def accel(self, q, qd, tau) -> np.ndarray:
        """q̈ under hub torques ``tau`` (θ1's and θ2's)."""
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        masses, jac, acc, hubs, *_ = self._points(q, qd)
        m = np.einsum("p,pai,paj->ij", masses, jac, jac)
        for inertia, ga in hubs:
            m += inertia * np.outer(ga, ga)
        gravity = np.zeros(2)
        gravity[1] = -self.g
        force = np.einsum("p,pai,pa->i", masses, jac, gravity[None, :] - acc)
        force[:2] += tau
        force -= self.k * q + self.d * qd
        return np.linalg.solve(m, force)

    def rhs(self, t, state, tau) -> np.ndarray:
        q, qd = state[: self.size], state[self.size :]
        return np.concatenate([qd, self.accel(q, qd, tau)])

    def tip(self, q) -> np.ndarray:
        """Link 2's tip in the paper's plane (x, y) [m]."""
        return self._points(np.asarray(q, float), np.zeros(self.size))[-1]

    def energy(self, q, qd) -> float:
        """Kinetic + elastic energy [J]: the whole energy of an arm built with ``g = 0``."""
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        kinetic = 0.5 * qd @ self.mass_matrix(q) @ qd
        return float(kinetic + 0.5 * self.k @ q**2)
