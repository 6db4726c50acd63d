"""The arm as MuJoCo sees it: model building (MjSpec) and a small stepping wrapper.

This is the only module that imports :mod:`mujoco` (with Ctrl-C held back:
:mod:`twolink.foundation.interrupts`); :mod:`twolink.simulation.batch` takes it from here.

Frames: the paper's vertical plane (x, y) is MuJoCo's (x, z), so the arm stands up
in the viewer; the paper's gravity along -y is MuJoCo's -z. Each hinge turns about
MuJoCo's -y axis, which makes a positive angle lift the link, as in the paper.

Rigid arm: ``qpos == [theta1, theta2]`` (theta1 from the horizontal, theta2 relative
to link 1), ``ctrl == [tau1, tau2]`` in N m, RK4, no damping, friction, armature,
limits or contacts. (With a Stribeck dip, :meth:`Plant.step` puts the torques in
``qfrc_applied`` beside it, as the batch engine does, and ``ctrl`` is zero.)

Flexible arm (Spong's model): two extra hinges carry motor rotors of inertia J. The
rotors' masses sit on their axes and their kinetic energy comes from their own spin
only (Spong's simplifying assumption), so each rotor is a body on the world at its
joint. A fixed tendon ``phi_i - theta_i`` with stiffness K_i and damping D_i is the
joint spring. ``qpos == [theta1, theta2, phi1, phi2]`` and ``ctrl`` drives the rotors.
"""

from __future__ import annotations

import re
from collections import deque
from dataclasses import dataclass

import numpy as np

from twolink.arm.disturbance import Disturbance
from twolink.arm.dynamics import gravity
from twolink.arm.params import ArmParams, Flexibility, Friction
from twolink.foundation.interrupts import import_mujoco

mujoco = import_mujoco()


# MuJoCo's warnings ("Nan, Inf or huge value in QACC at DOF 2. The simulation is
# unstable.") are printed to stderr and appended to MUJOCO_LOG.TXT in the working folder
# by MuJoCo's own handler: a file outside --out, on every unstable step. twolink takes
# them instead (unless the user has set a handler): each run's record names them, from
# the counters of its own data (:func:`warning_notes`), and the last few texts are kept
# here for whoever asks (``RECENT_WARNINGS``).
RECENT_WARNINGS: deque[str] = deque(maxlen=64)


def _keep_warning(text: str) -> None:
    RECENT_WARNINGS.append(text)


if mujoco.get_mju_user_warning() is None:
    mujoco.set_mju_user_warning(_keep_warning)


def warning_counts(data: mujoco.MjData) -> list[int]:
    """How many times MuJoCo warned of each kind (``mjtWarning``) since ``data`` was reset."""
    return [int(w.number) for w in data.warning]


def warning_notes(data: mujoco.MjData, since: list[int] | None = None) -> list[str]:
    """MuJoCo's warnings counted in ``data`` (since the counts ``since``), in words: what a
    run's record names ("MuJoCo warned: Nan, Inf or huge value in QACC; the simulation is
    unstable"), the same for a single arm and an arm of a batch (whose counts are all its
    arms')."""
    notes = []
    for kind, w in enumerate(data.warning):
        if int(w.number) > (since[kind] if since else 0):
            text = mujoco.mju_warningText(kind, int(w.lastinfo))
            head, _, tail = re.sub(r" at DOF \d+", "", text).rstrip(".").partition(". ")
            notes.append(
                f"MuJoCo warned: {head}" + (f"; {tail[:1].lower()}{tail[1:]}" * bool(tail))
            )
    return notes


ROD_RADIUS = 0.02  # visual and for the rod's (irrelevant) spin inertia about its axis [m]
ROTOR_MASS = 1e-3  # rotors sit on their axes: mass has no effect, MuJoCo needs it > 0 [kg]
HINGE_AXIS = (0.0, -1.0, 0.0)
# MuJoCo's dry friction is a soft constraint: a joint held below breakaway creeps at a rate
# proportional to the torque, (1 - d) / d of what it would be with d = 0.5. The joints use
# the stiffest impedance MuJoCo allows (its mjMAXIMP, 0.9999), flat over the whole range:
# the default (0.9 to 0.95) lets the 1 m arm's joint 1 creep at 1.8e-3 rad/s under 0.99 of
# its breakaway torque, this at 1.7e-6 rad/s (docs/model.md, "Friction").
STICTION_SOLIMP = [0.9999, 0.9999, 0.001, 0.5, 2.0]


def build_spec(
    p: ArmParams,
    flexibility: Flexibility | None = None,
    payload: float = 0.0,
    timestep: float = 1e-3,
    friction: Friction | None = None,
) -> mujoco.MjSpec:
    """Build the MJCF model of the arm as an editable :class:`mujoco.MjSpec`.

    Parameters
    ----------
    p : ArmParams
        The plant's parameters.
    flexibility : Flexibility, optional
        Joint compliance (Spong's model); ``None`` for the rigid arm.
    payload : float
        Point mass at the tip of link 2 [kg], >= 0; an uncertainty the controller's
        rod model does not know about.
    timestep : float
        Integration step [s] (RK4).
    friction : Friction, optional
        Joint friction (on the motors' joints; see :func:`add_arm`).
    """
    spec = new_spec(timestep, p.g, "twolink_flexible" if flexibility else "twolink")
    add_arm(spec, p, flexibility, payload, friction=friction)
    if friction is not None:
        solve_arms_apart(spec)
    return spec


SOLVER_TOLERANCE = 1e-15  # the friction solve's: Newton stops at its exact optimum


def new_spec(timestep: float, g: float, name: str = "twolink") -> mujoco.MjSpec:
    """An empty model with the options every arm is simulated under: RK4 at ``timestep``,
    gravity ``g`` along -z, no contacts, no automatic reset."""
    if not (timestep > 0 and np.isfinite(timestep)):
        raise ValueError(f"timestep must be > 0, got {timestep!r}")
    spec = mujoco.MjSpec()
    spec.modelname = name
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.compiler.autolimits = True
    spec.option.timestep = timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
    spec.option.gravity = [0.0, 0.0, -g]
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    # A diverging run must show as NaN to the simulation loop, not silently restart.
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
    return spec


def solve_arms_apart(spec: mujoco.MjSpec) -> None:
    """Set the constraint solver (joint friction's) to solve each arm of a model as if it
    were alone (docs/batch.md, "Independent arms"): Newton per island (one arm each), a cold
    start (MuJoCo picks the warm start for all arms at once) and sparse algebra at every
    size (dense sums differ in the last bit), to ``SOLVER_TOLERANCE``."""
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_WARMSTART
    spec.option.jacobian = mujoco.mjtJacobian.mjJAC_SPARSE
    spec.option.tolerance = SOLVER_TOLERANCE


def add_arm(
    spec: mujoco.MjSpec,
    p: ArmParams,
    flexibility: Flexibility | None = None,
    payload: float = 0.0,
    prefix: str = "",
    model_g: float | None = None,
    visual: bool = True,
    motors: bool = True,
    friction: Friction | None = None,
) -> None:
    """Add one arm to ``spec``: its bodies, joints, springs and motors, every name
    prefixed with ``prefix`` (so several arms can share a model, see
    :mod:`twolink.simulation.batch`).

    ``model_g`` is the gravity of a model shared with arms of other gravities (None: the
    arm's own, ``p.g``). An arm whose ``p.g`` differs stands in a plane tilted about
    MuJoCo's x axis, so that the model's gravity has the component ``p.g`` in the plane
    the arm moves in (``|p.g| <= |model_g|``); the rest points along the hinges, where
    it does no work. ``visual=False`` leaves out the geoms and the tip site, which only
    show the arm (the inertias are explicit) and cost ~5 % of a step; ``motors=False``
    the actuators, for a caller that applies the torques itself as ``qfrc_applied`` at
    the motors' joints (the batch: another ~5 %). ``friction`` puts joint friction on the
    motors' joints (the links' of a rigid arm, the rotors' of a flexible one): MuJoCo's
    dry friction (``frictionloss``) at the breakaway level and its ``damping`` for the
    viscous part; the Stribeck dip is a force the stepping code applies
    (:meth:`twolink.arm.params.Friction.stribeck_relief`).
    """
    if not (payload >= 0 and np.isfinite(payload)):
        raise ValueError(f"payload must be a finite mass >= 0, got {payload!r}")
    tip = _add_links(spec, p, payload, prefix, model_g, visual)
    if visual:
        _add_tip(tip, p, payload, prefix)
    if flexibility is None:
        targets = ("theta1", "theta2")
    else:
        _add_rotors(spec, flexibility, prefix, visual)
        targets = ("phi1", "phi2")
    if friction is not None:
        for i, target in enumerate(targets):
            joint = spec.joint(f"{prefix}{target}")
            joint.frictionloss = friction.breakaway[i]
            joint.solimp_friction = STICTION_SOLIMP
            joint.damping = [friction.viscous[i], 0.0, 0.0]  # linear term only
    if not motors:
        return
    for i, target in enumerate(targets, start=1):
        act = spec.add_actuator(name=f"{prefix}tau{i}", target=f"{prefix}{target}")
        act.trntype = mujoco.mjtTrn.mjTRN_JOINT
        act.set_to_motor()


def _link_inertia(m: float, length: float, payload: float) -> tuple[float, float, float]:
    """(mass, centre of mass, inertia about it) of a uniform rod with a point mass
    ``payload`` at its tip."""
    # Uniform rod along x: centre of mass at L/2, inertia m L^2/12 about it.
    mass, com, inertia = m, length / 2, m * length**2 / 12
    if payload > 0:
        # The payload, a point mass at the tip, is rigidly part of link 2: one body
        # with the combined mass, centre of mass and (parallel-axis) inertia, which is
        # the same physics as a welded body and cheaper to step.
        mass = m + payload
        com = (m * length / 2 + payload * length) / mass
        inertia += m * (length / 2 - com) ** 2 + payload * (length - com) ** 2
    return mass, com, inertia


def _add_links(
    spec: mujoco.MjSpec,
    p: ArmParams,
    payload: float,
    prefix: str,
    model_g: float | None,
    visual: bool,
):
    """The two links and their hinges; returns link 2's body."""
    parent = spec.worldbody
    for i, (m, length) in enumerate(((p.m1, p.l1), (p.m2, p.l2)), start=1):
        pos = [0, 0, 0] if i == 1 else [p.l1, 0, 0]
        body = parent.add_body(name=f"{prefix}link{i}", pos=pos)
        if i == 1 and model_g is not None and p.g != model_g:
            body.quat = incline(p.g / model_g)
        mass, com, inertia = _link_inertia(m, length, payload if i == 2 else 0.0)
        body.explicitinertial = True
        body.mass = mass
        body.ipos = [com, 0, 0]
        body.inertia = [m * ROD_RADIUS**2 / 2, inertia, inertia]
        body.add_joint(name=f"{prefix}theta{i}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=HINGE_AXIS)
        if visual:
            body.add_geom(
                name=f"{prefix}rod{i}",
                type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                fromto=[0, 0, 0, length, 0, 0],
                size=[ROD_RADIUS, 0, 0],
                rgba=[0.2, 0.45, 0.8, 1] if i == 1 else [0.85, 0.45, 0.2, 1],
            )
        parent = body
    return parent


def _add_tip(link2, p: ArmParams, payload: float, prefix: str) -> None:
    """The tip site and, if any, the payload's ball (shown only: geoms carry no mass)."""
    link2.add_site(name=f"{prefix}tip", pos=[p.l2, 0, 0], size=[ROD_RADIUS * 1.5, 0, 0])
    if payload > 0:
        link2.add_geom(
            name=f"{prefix}payload",
            type=mujoco.mjtGeom.mjGEOM_SPHERE,
            pos=[p.l2, 0, 0],
            size=[0.05, 0, 0],
            rgba=[0.3, 0.3, 0.3, 1],
        )


def _add_rotors(spec: mujoco.MjSpec, flexibility: Flexibility, prefix: str, visual: bool) -> None:
    """Spong's rotors on the world at the joints, and the tendon springs to the links."""
    for i in (1, 2):
        rotor = spec.worldbody.add_body(name=f"{prefix}rotor{i}")
        rotor.explicitinertial = True
        rotor.mass = ROTOR_MASS
        rotor.ipos = [0, 0, 0]
        j = flexibility.j[i - 1]
        rotor.inertia = [j, j, j]  # only the spin about the hinge axis matters
        rotor.add_joint(name=f"{prefix}phi{i}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=HINGE_AXIS)
        if visual:  # a disc behind the arm's plane to show the rotor
            rotor.add_geom(
                name=f"{prefix}rotor{i}",
                type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                fromto=[0, 0.03, 0, 0, 0.06, 0],
                size=[0.06, 0, 0],
                rgba=[0.4, 0.4, 0.4, 1],
            )
        spring = spec.add_tendon(
            name=f"{prefix}spring{i}",
            stiffness=flexibility.k[i - 1],
            damping=flexibility.d[i - 1],
            springlength=[0.0, 0.0],
        )
        spring.wrap_joint(f"{prefix}phi{i}", 1.0)
        spring.wrap_joint(f"{prefix}theta{i}", -1.0)


def lump_point_mass(model: mujoco.MjModel, body: int, mass: float, x: float) -> None:
    """Make a point mass ``mass`` at ``(x, 0, 0)`` in ``body``'s frame part of that body,
    mid-run (a payload picked up): its mass, centre of mass and inertia as :func:`add_arm`
    lumps a payload (parallel axes), then ``mj_setConst`` for what MuJoCo derives from
    them (subtree masses, the inverse weights that scale its constraints' softness)."""
    m0, c0 = float(model.body_mass[body]), float(model.body_ipos[body, 0])
    m = m0 + mass
    c = (m0 * c0 + mass * x) / m
    model.body_mass[body] = m
    model.body_ipos[body, 0] = c
    model.body_inertia[body, 1:] += m0 * (c0 - c) ** 2 + mass * (x - c) ** 2
    mujoco.mj_setConst(model, mujoco.MjData(model))


def incline(ratio: float) -> list[float]:
    """The orientation (quaternion) of an arm's base that tilts the plane it moves in
    about MuJoCo's x axis until the model's gravity has the fraction ``ratio`` (in
    [-1, 1]) of its magnitude in that plane: the cosine of the tilt. Written with the
    half-angle formulas, so the in-plane part MuJoCo computes, 1 - 2 sin²(α/2), is
    ``ratio`` to rounding."""
    if not -1.0 <= ratio <= 1.0:
        raise ValueError(f"an arm's gravity cannot exceed its model's: ratio {ratio!r}")
    return [float(np.sqrt((1 + ratio) / 2)), float(np.sqrt((1 - ratio) / 2)), 0.0, 0.0]


def build_model(
    p: ArmParams,
    flexibility: Flexibility | None = None,
    payload: float = 0.0,
    timestep: float = 1e-3,
    friction: Friction | None = None,
) -> mujoco.MjModel:
    """Compile the arm into a :class:`mujoco.MjModel` (see :func:`build_spec`).

    Raises
    ------
    ValueError
        MuJoCo's compiler refuses the arm (e.g. a mass or inertia below its mjMINVAL),
        in one line that says so.
    """
    try:
        return build_spec(p, flexibility, payload, timestep, friction).compile()
    except ValueError as exc:
        why = " ".join(str(exc).split()).removeprefix("Error: ")
        raise ValueError(f"MuJoCo cannot build this arm ({p}): {why}") from None


def holding_motor_q(
    p: ArmParams, flexibility: Flexibility, q=(0.0, 0.0), payload: float = 0.0
) -> np.ndarray:
    """Rotor angles that hold a flexible arm at rest at ``q``: φ = q + K⁻¹ G(q), each
    spring twisted by the gravity torque its link carries, K (φ − q) = G(q).

    G is the analytic gravity of the simulated arm (:func:`twolink.arm.dynamics.gravity` with
    its own ``p``, g included) plus the tip payload's, m_p g (l1 cos q1 + l2 cos q12,
    l2 cos q12): the point mass that :func:`add_arm` lumps into link 2. MuJoCo's own
    gravity (``qfrc_bias`` at rest) is the independent check (tests/test_holding_start.py).
    """
    q = np.asarray(q, dtype=float)
    load = gravity(p, q)
    if payload:
        tip = p.l2 * np.cos(q[..., 0] + q[..., 1])
        load = load + payload * p.g * np.stack([p.l1 * np.cos(q[..., 0]) + tip, tip], -1)
    return q + load / np.asarray(flexibility.k, dtype=float)


def model_xml(p: ArmParams, flexibility: Flexibility | None = None, payload: float = 0.0) -> str:
    """MJCF text of the model built from ``p`` (what ``models/*.xml`` hold)."""
    return build_spec(p, flexibility, payload).to_xml()


def scene_xml(robot_file: str = "twolink.xml") -> str:
    """A viewing scene (floor, light, camera) that includes the robot's MJCF file."""
    return f"""<mujoco model="twolink scene">
  <include file="{robot_file}"/>
  <statistic center="1 0 0.5" extent="2.5"/>
  <visual>
    <headlight diffuse="0.6 0.6 0.6" ambient="0.3 0.3 0.3" specular="0 0 0"/>
    <global azimuth="90" elevation="-10"/>
  </visual>
  <asset>
    <texture type="skybox" builtin="gradient" rgb1="0.3 0.5 0.7" rgb2="0 0 0" width="512"
             height="3072"/>
    <texture type="2d" name="groundplane" builtin="checker" mark="edge" rgb1="0.2 0.3 0.4"
             rgb2="0.1 0.2 0.3" markrgb="0.8 0.8 0.8" width="300" height="300"/>
    <material name="groundplane" texture="groundplane" texuniform="true" texrepeat="5 5"
              reflectance="0.2"/>
  </asset>
  <worldbody>
    <light pos="0 -3 4" dir="0 1 -1" directional="true"/>
    <geom name="floor" pos="0 0 -2.2" size="0 0 0.05" type="plane" material="groundplane"/>
  </worldbody>
</mujoco>
"""


@dataclass
class Plant:
    """Owns a MuJoCo model and its data: reset, apply torques, step, read the state.

    ``q`` and ``qd`` are the link angles and rates [theta1, theta2]; for the flexible
    arm ``motor_q`` and ``motor_qd`` are the rotor angles and rates.
    """

    model: mujoco.MjModel
    data: mujoco.MjData = None  # type: ignore[assignment]
    friction: Friction | None = None  # the model's; its Stribeck dip is applied in step()
    disturbance: Disturbance | None = None  # torques on the links, applied in step()
    tip: float = 0.0  # link 2's length: where a picked-up payload sits

    def __post_init__(self) -> None:
        if self.data is None:
            self.data = mujoco.MjData(self.model)
        self.flexible = self.model.nq == 4
        self.dt = float(self.model.opt.timestep)
        self._stribeck = self.friction is not None and self.friction.stribeck
        self._friction_dofs = slice(2, 4) if self.flexible else slice(0, 2)
        self._applied = self._stribeck or self.disturbance is not None
        link2 = self.model.body("link2").id
        self._link2 = (link2, self.model.body_mass[link2], *self.model.body_ipos[link2])
        self._link2_inertia = self.model.body_inertia[link2].copy()

    @classmethod
    def build(
        cls,
        p: ArmParams,
        flexibility: Flexibility | None = None,
        payload: float = 0.0,
        timestep: float = 1e-3,
        friction: Friction | None = None,
        disturbance: Disturbance | None = None,
    ) -> Plant:
        model = build_model(p, flexibility, payload, timestep, friction)
        return cls(model, friction=friction, disturbance=disturbance, tip=p.l2)

    def reset(self, q=(0.0, 0.0), qd=(0.0, 0.0), motor_q=None, motor_qd=None) -> None:
        """Set the state and time 0. Rotors default to the link state (springs relaxed);
        :func:`holding_motor_q` gives the ``motor_q`` that holds the arm at rest."""
        self._restore_link2()
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[:2] = q
        self.data.qvel[:2] = qd
        if self.flexible:
            self.data.qpos[2:] = q if motor_q is None else motor_q
            self.data.qvel[2:] = qd if motor_qd is None else motor_qd
        mujoco.mj_forward(self.model, self.data)

    def step(self, tau1: float, tau2: float) -> None:
        """Hold the torques [N m] and advance one timestep."""
        ctrl = self.data.ctrl
        ctrl[0] = tau1
        ctrl[1] = tau2
        if self._applied:  # held over the step, from its start
            applied = self.data.qfrc_applied
            if self._stribeck:  # the torques join the dip, summed as the batch engine does
                dofs = self._friction_dofs
                relief = self.friction.stribeck_relief(self.data.qvel[dofs])
                applied[dofs] = np.array((tau1, tau2)) + relief
                ctrl[:2] = 0.0
            if self.disturbance is not None:
                if not self._stribeck or self.flexible:
                    applied[:2] = 0.0
                applied[:2] += self.disturbance.torque(self.data.time, self.dt)
                if self.disturbance.picks_up(self.data.time, self.dt):
                    mass, tip = self.disturbance.pickup.mass, self.tip
                    lump_point_mass(self.model, self._link2[0], mass, tip)
        mujoco.mj_step(self.model, self.data)

    def _restore_link2(self) -> None:
        """Link 2 as built (a payload picked up in a previous run put down)."""
        body, mass, *ipos = self._link2
        if self.model.body_mass[body] != mass:
            self.model.body_mass[body] = mass
            self.model.body_ipos[body] = ipos
            self.model.body_inertia[body] = self._link2_inertia
            mujoco.mj_setConst(self.model, mujoco.MjData(self.model))

    @property
    def time(self) -> float:
        return float(self.data.time)

    @property
    def q(self) -> np.ndarray:
        return self.data.qpos[:2].copy()

    @property
    def qd(self) -> np.ndarray:
        return self.data.qvel[:2].copy()

    @property
    def motor_q(self) -> np.ndarray | None:
        return self.data.qpos[2:].copy() if self.flexible else None

    @property
    def motor_qd(self) -> np.ndarray | None:
        return self.data.qvel[2:].copy() if self.flexible else None

    # MuJoCo's own dynamics at the current state, for cross-validation.
    def set_state(self, qpos, qvel) -> None:
        """Set the full state and run ``mj_forward`` (no stepping)."""
        self.data.qpos[:] = qpos
        self.data.qvel[:] = qvel
        mujoco.mj_forward(self.model, self.data)

    def mass_matrix(self) -> np.ndarray:
        """Joint-space inertia matrix from ``mj_fullM``."""
        full = np.zeros((self.model.nv, self.model.nv))
        mujoco.mj_fullM(self.model, self.data, full)
        return full

    def bias(self) -> np.ndarray:
        """Coriolis, centrifugal and gravity forces (``qfrc_bias``): H + G."""
        return self.data.qfrc_bias.copy()

    def inverse(self, qacc) -> np.ndarray:
        """Joint forces that produce ``qacc`` at the current state (``mj_inverse``)."""
        self.data.qacc[:] = qacc
        mujoco.mj_inverse(self.model, self.data)
        return self.data.qfrc_inverse.copy()

    def forward(self, tau) -> np.ndarray:
        """Accelerations under actuator torques ``tau`` (``qacc`` after ``mj_forward``)."""
        self.data.ctrl[:] = tau
        mujoco.mj_forward(self.model, self.data)
        return self.data.qacc.copy()

    def energy(self) -> tuple[float, float]:
        """MuJoCo's kinetic and potential energy at the current state [J].

        Computed on demand (``mj_energyPos``/``mj_energyVel``) rather than by enabling
        the energy flag, which would cost every ``mj_step``.
        """
        mujoco.mj_energyPos(self.model, self.data)
        mujoco.mj_energyVel(self.model, self.data)
        return float(self.data.energy[1]), float(self.data.energy[0])
