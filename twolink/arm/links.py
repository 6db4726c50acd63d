"""Links that bend: each link a chain of rigid segments joined by spring hinges (MjSpec).

The lumped model is the rigid finite element method (Wittbrodt, Adamiec-Wójcik and
Wojciech, *Dynamics of Flexible Multibody Systems*, Springer 2006). A link of length L is
cut into N elements of length ℓ = L / N. A spring hinge sits at the middle of each
element, at x_j = (j - 1/2) ℓ, with stiffness k = E I / ℓ: the element's bending
compliance ℓ / (E I), lumped at its centre. The rigid pieces run from one hinge to the
next (length ℓ); the first and the last are half pieces (ℓ / 2). Each piece carries its
own mass ρ A times its length, at its centre, with a slender rod's inertia m ℓ² / 12
about that centre. The hub's inertia is the motor's rotor reflected through its gear
(n² J_r): MuJoCo's armature on the hub joint, kinetic energy ½ J θ̇_i² in the joint's
own rate (for θ2, relative to link 1), as Spong's rotors. The tip mass is a point mass
at the end of the last half piece.

Damping is Kelvin-Voigt (a bending moment E I (κ + η κ̇)): each hinge gets the damping
c = η k. The material's ratio ζ sets η = 2 ζ / ω₁, with ω₁ the link's first clamped-free
frequency (the bare beam), so that mode has the damping ratio ζ; mode n gets ζ ω_n / ω₁.

Joint order (MuJoCo's, depth first): θ1, the N hinges of link 1, θ2, the N hinges of
link 2. :attr:`LinkLayout.hubs` gives the hub angles' addresses: the arm's θ1, θ2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from twolink.arm.params import ArmParams, _check_finite
from twolink.arm.plant import HINGE_AXIS, ROD_RADIUS, mujoco, new_spec

# βL of the clamped-free Euler-Bernoulli beam's first modes: the roots of 1 + cos cosh = 0.
CLAMPED_FREE_BETA_L = (1.8751040687, 4.6940911330, 7.8547574382)
MAX_SEGMENTS = 256  # a chain this fine costs ~500 hinges per arm; beyond is a mistake
POINT_INERTIA = 1e-12  # kg m²: the spin of a segment about its own axis (MuJoCo needs > 0)


@dataclass(frozen=True)
class LinkBeam:
    """One flexible link: a uniform Euler-Bernoulli beam on a hub, in SI units.

    Parameters
    ----------
    ei : float
        Bending stiffness E I [N m²], > 0.
    rho_a : float
        Mass per length ρ A [kg/m], > 0.
    length : float
        Length L [m], > 0.
    hub_inertia : float
        The hub motor's rotor inertia reflected through its gear, n² J_r [kg m²], >= 0:
        the hub joint's armature (it spins with the joint's own rate).
    tip_mass : float
        Point mass at the link's end [kg], >= 0: the next motor, or a payload.
    damping_ratio : float
        The material's damping ratio ζ of the first clamped-free mode, >= 0.

    The defaults are a light laboratory link: 1 m, 1 kg, E I = 100 N m² (first
    clamped-free mode 5.6 Hz), 1 % damping.
    """

    ei: float = 100.0
    rho_a: float = 1.0
    length: float = 1.0
    hub_inertia: float = 0.0
    tip_mass: float = 0.0
    damping_ratio: float = 0.01

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            positive = f.name in ("ei", "rho_a", "length")
            _check_finite("LinkBeam", f.name, value, positive=positive)
            if value < 0:
                raise ValueError(f"LinkBeam.{f.name} must be >= 0, got {value!r}")
            object.__setattr__(self, f.name, float(value))

    @property
    def mass(self) -> float:
        """The beam's own mass ρ A L [kg] (hub and tip mass not included)."""
        return self.rho_a * self.length

    def clamped_frequency(self, mode: int = 1) -> float:
        """ω_n = (β_n L)² sqrt(E I / (ρ A L⁴)) of the bare clamped-free beam [rad/s],
        ``mode`` 1 to 3."""
        beta_l = CLAMPED_FREE_BETA_L[mode - 1]
        return beta_l**2 * math.sqrt(self.ei / (self.rho_a * self.length**4))

    def hinge(self, segments: int) -> tuple[float, float]:
        """(stiffness k = E I / ℓ [N m/rad], damping c = η k [N m s/rad]) of each hinge."""
        k = self.ei * segments / self.length
        return k, 2.0 * self.damping_ratio / self.clamped_frequency() * k


@dataclass(frozen=True)
class FlexibleLinks:
    """Both links of a flexible-link arm and the number of elements N per link.

    ``FlexibleLinks()`` is two default :class:`LinkBeam` links of N = 8 elements.
    :meth:`rigid_params` is the rigid arm a controller models it with.
    """

    link1: LinkBeam = LinkBeam()
    link2: LinkBeam = LinkBeam()
    segments: int = 8

    def __post_init__(self) -> None:
        n = self.segments
        if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_SEGMENTS:
            raise ValueError(f"FlexibleLinks.segments must be an integer in 1..{MAX_SEGMENTS}")
        for name in ("link1", "link2"):
            if not isinstance(getattr(self, name), LinkBeam):
                raise ValueError(f"FlexibleLinks.{name} must be a LinkBeam")

    @property
    def links(self) -> tuple[LinkBeam, LinkBeam]:
        return self.link1, self.link2

    @classmethod
    def from_arm(
        cls,
        p: ArmParams,
        ei: tuple[float, float],
        hub_inertia: tuple[float, float] = (0.0, 0.0),
        tip_mass: tuple[float, float] = (0.0, 0.0),
        damping_ratio: tuple[float, float] = (0.01, 0.01),
        segments: int = 8,
    ) -> FlexibleLinks:
        """The links of the rigid arm ``p`` made to bend: ρ A = m / l and L = l per link,
        with the given E I, hubs, tip masses and damping ratios (pairs, link 1 first)."""
        beams = [
            LinkBeam(ei[i], m / length, length, hub_inertia[i], tip_mass[i], damping_ratio[i])
            for i, (m, length) in enumerate(((p.m1, p.l1), (p.m2, p.l2)))
        ]
        return cls(beams[0], beams[1], segments)

    def with_arm(self, p: ArmParams) -> FlexibleLinks:
        """These links on the rods of ``p`` (ρ A = m / l, L = l), the rest kept."""
        return FlexibleLinks.from_arm(
            p,
            tuple(b.ei for b in self.links),
            tuple(b.hub_inertia for b in self.links),
            tuple(b.tip_mass for b in self.links),
            tuple(b.damping_ratio for b in self.links),
            self.segments,
        )

    def rigid_params(self, g: float = 9.81) -> ArmParams:
        """The rigid arm of the same rods (m_i = ρ A L, l_i = L): what the paper's laws
        model; hubs and tip masses are not in it."""
        l1, l2 = self.links
        return ArmParams(m1=l1.mass, m2=l2.mass, l1=l1.length, l2=l2.length, g=g)

    def rigid_body_terms(
        self, q1: float, q2: float, w1: float, w2: float, g: float = 0.0
    ) -> tuple[float, float, float, float, float]:
        """The arm with its links held straight, hubs and tip masses included, as
        :func:`twolink.arm.dynamics.terms` gives the rods alone: (M11, M12, M22, H1 + G1,
        H2 + G2). A hub's inertia is its joint's armature (M_ii only); each link is its
        rod (m L² / 3 about the hub, centre at L / 2) and a point mass at its end."""
        b1, b2 = self.links
        m2 = b2.mass + b2.tip_mass
        first1 = b1.mass * b1.length / 2 + b1.tip_mass * b1.length  # m c about the hub
        first2 = b2.mass * b2.length / 2 + b2.tip_mass * b2.length
        inertia1 = (b1.mass / 3 + b1.tip_mass) * b1.length**2
        inertia2 = (b2.mass / 3 + b2.tip_mass) * b2.length**2
        a = b1.length * first2
        c2 = math.cos(q2)
        m22 = inertia2
        m12 = m22 + a * c2
        m11 = inertia1 + m2 * b1.length**2 + m22 + 2 * a * c2 + b1.hub_inertia
        h = a * math.sin(q2)
        g2 = first2 * math.cos(q1 + q2) * g
        g1 = (first1 + m2 * b1.length) * math.cos(q1) * g + g2
        return m11, m12, m22 + b2.hub_inertia, g1 - h * (2 * w1 * w2 + w2 * w2), g2 + h * w1 * w1


@dataclass(frozen=True)
class LinkLayout:
    """Where a flexible-link arm's states sit in MuJoCo's ``qpos`` (= ``qvel``)."""

    segments: int

    @property
    def hubs(self) -> tuple[int, int]:
        """Addresses of θ1 and θ2."""
        return 0, self.segments + 1

    @property
    def bends(self) -> tuple[slice, slice]:
        """Addresses of each link's N hinge angles."""
        n = self.segments
        return slice(1, n + 1), slice(n + 2, 2 * n + 2)


def pieces(beam: LinkBeam, segments: int) -> list[tuple[float, float]]:
    """(start x, length) of the link's rigid pieces along it: a half piece, N - 1 whole
    ones, a half piece (N + 1 in all)."""
    ell = beam.length / segments
    starts = [0.0] + [(j - 0.5) * ell for j in range(1, segments + 1)]
    lengths = [ell / 2] + [ell] * (segments - 1) + [ell / 2]
    return list(zip(starts, lengths, strict=True))


def _piece_inertial(body, beam: LinkBeam, length: float, extra_inertia: float, tip: float):
    """A rigid piece's mass, centre and inertia: a slender rod of ``length`` about its
    centre, plus ``extra_inertia`` (the hub) and a point mass ``tip`` at its end."""
    m = beam.rho_a * length
    com, inertia = length / 2, m * length**2 / 12
    if tip > 0:
        total = m + tip
        c = (m * com + tip * length) / total
        inertia += m * (com - c) ** 2 + tip * (length - c) ** 2
        m, com = total, c
    inertia += extra_inertia
    body.explicitinertial = True
    body.mass = m
    body.ipos = [com, 0, 0]
    body.inertia = [POINT_INERTIA, inertia, inertia]


def add_link(
    parent,
    beam: LinkBeam,
    segments: int,
    index: int,
    pos=(0.0, 0.0, 0.0),
    prefix: str = "",
    hub_joint: bool = True,
    visual: bool = True,
):
    """Add one flexible link under ``parent`` at ``pos``: its hub piece (with the hub
    joint ``theta{index}`` unless ``hub_joint`` is false: a link clamped to ``parent``),
    then the N spring hinges ``bend{index}_{j}`` and their pieces. Returns the last
    piece, whose end (x = its length) is the link's tip."""
    k, c = beam.hinge(segments)
    body = parent
    x0 = 0.0
    for j, (start, length) in enumerate(pieces(beam, segments)):
        at = list(pos) if j == 0 else [start - x0, 0.0, 0.0]
        body = body.add_body(name=f"{prefix}link{index}_{j}", pos=at)
        last = j == segments
        _piece_inertial(body, beam, length, 0.0, beam.tip_mass if last else 0.0)
        if j == 0 and hub_joint:
            body.add_joint(
                name=f"{prefix}theta{index}",
                type=mujoco.mjtJoint.mjJNT_HINGE,
                axis=HINGE_AXIS,
                armature=beam.hub_inertia,
            )
        elif j > 0:
            body.add_joint(
                name=f"{prefix}bend{index}_{j}",
                type=mujoco.mjtJoint.mjJNT_HINGE,
                axis=HINGE_AXIS,
                stiffness=k,
                damping=c,
            )
        if visual:
            body.add_geom(
                type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                fromto=[0, 0, 0, length, 0, 0],
                size=[ROD_RADIUS / 2, 0, 0],
                rgba=[0.2, 0.45, 0.8, 1] if index == 1 else [0.85, 0.45, 0.2, 1],
            )
        x0 = start
    return body


def build_links_spec(
    links: FlexibleLinks,
    g: float = 9.81,
    payload: float = 0.0,
    timestep: float = 1e-4,
    visual: bool = True,
    motors: bool = True,
) -> mujoco.MjSpec:
    """The flexible-link arm as an :class:`mujoco.MjSpec`: link 2's hub on link 1's tip,
    ``payload`` [kg] added to link 2's tip mass, motors ``tau1``, ``tau2`` on the hubs,
    a site ``tip`` at link 2's end. RK4 at ``timestep`` (the hinges are stiff: see
    :func:`stable_timestep`)."""
    spec = new_spec(timestep, g, "twolink_flexible_links")
    add_links_arm(spec, links, payload, visual=visual, motors=motors)
    return spec


def add_links_arm(
    spec: mujoco.MjSpec,
    links: FlexibleLinks,
    payload: float = 0.0,
    prefix: str = "",
    visual: bool = True,
    motors: bool = True,
) -> None:
    """Add the flexible-link arm to ``spec`` at the world's origin, every name under
    ``prefix`` (the batch engine's ``arm{i}_``): what :func:`build_links_spec` builds."""
    if not (payload >= 0 and np.isfinite(payload)):
        raise ValueError(f"payload must be a finite mass >= 0, got {payload!r}")
    n = links.segments
    tip1 = add_link(spec.worldbody, links.link1, n, 1, prefix=prefix, visual=visual)
    beam2 = links.link2
    if payload:
        beam2 = LinkBeam(**{**_fields(beam2), "tip_mass": beam2.tip_mass + payload})
    end1 = pieces(links.link1, n)[-1][1]
    tip2 = add_link(tip1, beam2, n, 2, pos=(end1, 0.0, 0.0), prefix=prefix, visual=visual)
    end2 = pieces(beam2, n)[-1][1]
    tip2.add_site(name=f"{prefix}tip", pos=[end2, 0, 0], size=[ROD_RADIUS * 1.5, 0, 0])
    if motors:
        for i in (1, 2):
            act = spec.add_actuator(name=f"{prefix}tau{i}", target=f"{prefix}theta{i}")
            act.trntype = mujoco.mjtTrn.mjTRN_JOINT
            act.set_to_motor()


def _fields(beam: LinkBeam) -> dict[str, float]:
    return {f.name: getattr(beam, f.name) for f in fields(beam)}


def build_links_model(links: FlexibleLinks, g: float = 9.81, payload: float = 0.0, **kw):
    """Compile :func:`build_links_spec`."""
    return build_links_spec(links, g, payload, **kw).compile()


def single_link_model(
    beam: LinkBeam,
    segments: int,
    clamped: bool = True,
    timestep: float = 1e-4,
    g: float = 0.0,
) -> mujoco.MjModel:
    """One link on the world: clamped at its hub (only the N hinges move) or on a free
    hub (the hub joint ``theta1`` too), a site ``tip`` at its end; no gravity unless
    ``g``. What the beam-theory checks run on."""
    spec = new_spec(timestep, g, "flexible_link")
    last = add_link(spec.worldbody, beam, segments, 1, hub_joint=not clamped)
    last.add_site(name="tip", pos=[pieces(beam, segments)[-1][1], 0, 0], size=[0.01, 0, 0])
    return spec.compile()


# The lumped chain's highest mode, over sqrt(k / (ρ A ℓ³ / 12)): 2.57 to 2.65 measured
# (MuJoCo's linearisation, N = 4 to 16, with and without tip masses); a bound above it.
HIGHEST_MODE_FACTOR = 2.7


def stable_timestep(links: FlexibleLinks, margin: float = 0.5) -> float:
    """A timestep that RK4 steps the fastest hinge mode of either link at: ``margin``
    times RK4's limit 2.8 / |s|_max. The mode's ω_max is bounded by
    :data:`HIGHEST_MODE_FACTOR` sqrt(k / (ρ A ℓ³ / 12)) (one piece's inertia on a
    hinge); Kelvin-Voigt damping gives it the ratio ζ_max = ζ ω_max / ω₁, and its
    fastest root |s|_max = ω_max (ζ_max + sqrt(ζ_max² + 1))."""
    n = links.segments
    s = []
    for beam in links.links:
        ell = beam.length / n
        k = beam.ei / ell
        w = HIGHEST_MODE_FACTOR * math.sqrt(k / (beam.rho_a * ell**3 / 12.0))
        zeta = beam.damping_ratio * w / beam.clamped_frequency()
        s.append(w * (zeta + math.sqrt(zeta**2 + 1.0)))
    return margin * 2.8 / max(s)


def tip_position(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """The tip in the paper's plane (x, y) [m] (MuJoCo's x, z), after ``mj_kinematics``."""
    p = data.site("tip").xpos
    return np.array([p[0], p[2]])


def rigid_tip(p: ArmParams, q) -> np.ndarray:
    """Where the tip of the rigid arm of ``p`` is at hub angles ``q`` (..., 2) [m]."""
    q = np.asarray(q, dtype=float)
    a, b = q[..., 0], q[..., 0] + q[..., 1]
    return np.stack([p.l1 * np.cos(a) + p.l2 * np.cos(b), p.l1 * np.sin(a) + p.l2 * np.sin(b)], -1)


def law_gain(law, segments: int, nv: int) -> np.ndarray:
    """A links-aware law's torques as a linear map of MuJoCo's state (δqpos, qvel) at rest,
    (2, 2 nv), read from the law one state at a time (it is linear there without gravity):
    the ``feedback`` of :func:`linear_modes`."""
    layout = LinkLayout(segments)
    hubs = list(layout.hubs)
    gain = np.zeros((2, 2 * nv))
    for col in range(2 * nv):
        x = np.zeros(2 * nv)
        x[col] = 1.0
        qpos, qvel = x[:nv], x[nv:]
        bends = np.stack([qpos[b] for b in layout.bends])
        rates = np.stack([qvel[b] for b in layout.bends])
        gain[:, col] = law(0.0, qpos[hubs], qvel[hubs], bends, rates)
    return gain


def linear_modes(model: mujoco.MjModel, data: mujoco.MjData | None = None, feedback=None):
    """The model's oscillating modes at its state in ``data`` (default: at rest at
    ``qpos0``), from MuJoCo's own linearisation (``mjd_transitionFD``, centred
    differences) of one semi-implicit Euler step with explicit damping: its velocity rows
    are [dt ∂a/∂q, I + dt ∂a/∂v] and [dt ∂a/∂u], which give the continuous system's
    matrices exactly. (MuJoCo does not differentiate RK4 steps; the integrator is
    switched for the call and restored.) ``feedback`` (nu, 2 nv) closes the loop
    ``ctrl = feedback @ (δqpos, qvel)``. Returns (ω_n [rad/s], ζ) of the eigenvalues s
    with Im s > 0, sorted by ω_n = |s|, ζ = -Re s / |s|."""
    if data is None:
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
    nv, nu = model.nv, model.nu
    a = np.zeros((2 * nv, 2 * nv))
    b = np.zeros((2 * nv, nu))
    integrator, flags = model.opt.integrator, model.opt.disableflags
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    model.opt.disableflags = flags | mujoco.mjtDisableBit.mjDSBL_EULERDAMP
    try:
        mujoco.mjd_transitionFD(model, data, 1e-6, 1, a, b if nu else None, None, None)
    finally:
        model.opt.integrator, model.opt.disableflags = integrator, flags
    dt = model.opt.timestep
    system = np.zeros_like(a)
    system[:nv, nv:] = np.eye(nv)
    system[nv:, :nv] = a[nv:, :nv] / dt
    system[nv:, nv:] = (a[nv:, nv:] - np.eye(nv)) / dt
    if feedback is not None:
        system[nv:] += b[nv:] / dt @ np.asarray(feedback, dtype=float)
    s = np.linalg.eigvals(system)
    s = s[s.imag > 1e-9 * np.abs(s).max()]
    order = np.argsort(np.abs(s))
    w = np.abs(s[order])
    return w, -s[order].real / w


def static_tip_deflection(beam: LinkBeam, segments: int, force: float) -> float:
    """The clamped link's tip deflection [m] under a transverse dead load ``force`` [N]
    at its tip, from MuJoCo: the hinge angles where the springs balance the load's
    generalised force (``mj_applyFT`` at the tip site): the fixed point
    q = Jᵀ(q) P / k, a contraction at small loads."""
    model = single_link_model(beam, segments)
    data = mujoco.MjData(model)
    tip = model.site("tip").id
    body = int(model.site_bodyid[tip])
    k = beam.hinge(segments)[0]

    def residual(qpos):
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        data.qfrc_applied[:] = 0.0
        load = np.array([0.0, 0.0, force])  # the paper's +y is MuJoCo's +z
        mujoco.mj_applyFT(
            model, data, load, np.zeros(3), data.site_xpos[tip], body, data.qfrc_applied
        )
        return data.qfrc_applied - k * data.qpos  # spring + load torques per hinge

    q = np.zeros(model.nq)
    for _ in range(50):  # fixed point q = load(q) / k: a contraction for small loads
        q_new = residual(q) / k + q
        if np.max(np.abs(q_new - q)) < 1e-15:
            break
        q = q_new
    residual(q)
    return float(data.site_xpos[tip][2])


REST_ITERATIONS = 60  # of the fixed point below: a contraction; a fixed count keeps batch = alone


def rest_shape(model: mujoco.MjModel, data: mujoco.MjData, bends: np.ndarray) -> None:
    """Set the hinge angles at the addresses ``bends`` to the links' rest shape at the
    hub angles in ``data.qpos``: where each hinge's spring holds the weight beyond it,
    k φ = −G(φ) (gravity's generalised force, MuJoCo's bias at rest). Straight links
    where gravity is off. The fixed point φ ← −G(φ) / k contracts while the springs are
    much stiffer than gravity's pull (about m g L); ValueError where it has not settled."""
    bends = np.asarray(bends).ravel()
    data.qpos[bends] = 0.0
    if not model.opt.gravity.any():
        return
    saved = data.qvel.copy()
    data.qvel[:] = 0.0
    k = model.jnt_stiffness[model.dof_jntid[bends]]
    change = np.inf
    for _ in range(REST_ITERATIONS):
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        mujoco.mj_comVel(model, data)
        mujoco.mj_rne(model, data, 0, data.qfrc_bias)
        new = -data.qfrc_bias[bends] / k
        change = float(np.max(np.abs(new - data.qpos[bends])))
        data.qpos[bends] = new
    data.qvel[:] = saved
    if not change < 1e-9:
        raise ValueError(
            f"the links do not come to rest under gravity (the rest shape moves {change:.3g} "
            "rad in its last iteration): they are too soft to hold themselves up"
        )


@dataclass
class LinkPlant:
    """A flexible-link arm in MuJoCo and its state: hub angles ``q``, ``qd`` (the arm's
    θ1, θ2), hinge angles ``bends`` (2, N), the tip. Torques drive the hubs."""

    model: mujoco.MjModel
    segments: int
    data: mujoco.MjData = None  # type: ignore[assignment]

    def __post_init__(self) -> None:
        if self.data is None:
            self.data = mujoco.MjData(self.model)
        self.layout = LinkLayout(self.segments)
        self.hubs = list(self.layout.hubs)
        self.dt = float(self.model.opt.timestep)
        self._tip = self.model.site("tip").id

    @classmethod
    def build(
        cls,
        links: FlexibleLinks,
        g: float = 9.81,
        payload: float = 0.0,
        timestep: float | None = None,
        visual: bool = False,
    ) -> LinkPlant:
        """The arm at ``timestep`` (default :func:`stable_timestep` at margin 0.5)."""
        dt = stable_timestep(links) if timestep is None else timestep
        model = build_links_model(links, g, payload, timestep=dt, visual=visual)
        return cls(model, links.segments)

    def reset(self, q=(0.0, 0.0), qd=(0.0, 0.0)) -> None:
        """Time 0, the hubs at ``q``, ``qd``, the links in their rest shape there
        (:func:`rest_shape`: straight without gravity)."""
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[self.hubs] = q
        rest_shape(self.model, self.data, np.r_[self.layout.bends[0], self.layout.bends[1]])
        self.data.qvel[self.hubs] = qd
        mujoco.mj_forward(self.model, self.data)

    def step(self, tau1: float, tau2: float) -> None:
        self.data.ctrl[0] = tau1
        self.data.ctrl[1] = tau2
        mujoco.mj_step(self.model, self.data)

    @property
    def q(self) -> np.ndarray:
        return self.data.qpos[self.hubs].copy()

    @property
    def qd(self) -> np.ndarray:
        return self.data.qvel[self.hubs].copy()

    @property
    def bends(self) -> np.ndarray:
        return np.stack([self.data.qpos[b] for b in self.layout.bends])

    @property
    def bend_rates(self) -> np.ndarray:
        return np.stack([self.data.qvel[b] for b in self.layout.bends])

    @property
    def points(self) -> np.ndarray:
        """The hubs, every hinge and the tip in the paper's plane (x, y) [m]: (2 N + 3, 2),
        link 1's hub first, after :attr:`tip` (which runs the kinematics)."""
        p = np.concatenate([self.data.xpos[1:], self.data.site_xpos[self._tip][None]])
        return p[:, [0, 2]]

    @property
    def tip(self) -> np.ndarray:
        """The tip in the paper's plane (x, y) [m] at the current state."""
        mujoco.mj_kinematics(self.model, self.data)
        p = self.data.site_xpos[self._tip]
        return np.array([p[0], p[2]])
