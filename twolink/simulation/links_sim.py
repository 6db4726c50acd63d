"""Links that bend (:mod:`twolink.arm.links`) in a scenario: its ``[arm.links]`` table,
the closed loop on them, and the measures at the tip.

The loop is :func:`twolink.simulation.sim.simulate`'s: zero-order hold at
``control_dt``, the same divergence bounds. A controller reads the hub angles θ1, θ2
as ``controller(t, q, qd)``, as on the rigid arm; one whose ``needs_links`` is true is
called ``controller(t, q, qd, bends, bend_rates)`` with the hinge angles and rates
(2, N) too. The run keeps the tip and the hinge angles at each control instant.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from twolink.arm.links import MAX_SEGMENTS, FlexibleLinks, LinkPlant, rigid_tip
from twolink.arm.params import ArmParams
from twolink.controllers.base import Controller
from twolink.foundation import steplog
from twolink.simulation.sim import (
    STATUS_DIVERGED,
    STATUS_OK,
    Bounds,
    Trajectory,
    _trajectory,
    control_steps,
    state_message,
    torque_message,
)

if TYPE_CHECKING:
    from twolink.simulation.config import Scenario


@dataclass(frozen=True, eq=False)
class LinkRun:
    """A run of the flexible-link arm: the hub trajectory and, at the same instants, the
    tip (N, 2) [m], each link's hinge angles (N, 2, segments) [rad] and the points of the
    bent arm (N, 2 segments + 3, 2) [m]: hubs, hinges and tip (:attr:`LinkPlant.points`)."""

    trajectory: Trajectory
    tip: np.ndarray
    bends: np.ndarray
    points: np.ndarray | None = None

    def rigid_tip(self, p: ArmParams) -> np.ndarray:
        """Where the rigid arm ``p``'s tip would be at the recorded hub angles."""
        return rigid_tip(p, self.trajectory.q)

    def reference_tip(self, p: ArmParams) -> np.ndarray:
        """Where the rigid arm ``p``'s tip is at the reference's hub angles."""
        return rigid_tip(p, self.trajectory.q_ref)


def simulate_links(
    plant: LinkPlant,
    controller: Controller,
    duration: float,
    control_dt: float = 1e-3,
    q0=(0.0, 0.0),
    qd0=(0.0, 0.0),
    bounds: Bounds = Bounds(),  # noqa: B008 - frozen, as simulate()'s
) -> LinkRun:
    """Run ``controller`` against the flexible-link ``plant`` from its links' rest shape
    (hubs at ``q0``, ``qd0``; straight without gravity); ``control_dt`` a whole number of
    the plant's steps (round it with :func:`control_timestep`)."""
    n, substeps = control_steps(duration, control_dt, plant.dt)
    plant.reset(q0, qd0)
    controller.reset()
    links_aware = bool(getattr(controller, "needs_links", False))
    rows, tips, bends, points = [], [], [], []

    def keep() -> None:
        tips.append(plant.tip)
        bends.append(plant.bends)
        points.append(plant.points)

    status, message = STATUS_OK, ""
    for k in range(n + 1):
        t = k * control_dt
        (q1, q2), (w1, w2) = plant.q, plant.qd
        # NaN fails every comparison, so this also catches non-finite states (as simulate's).
        if not (
            abs(q1) < bounds.angle
            and abs(q2) < bounds.angle
            and abs(w1) < bounds.rate
            and abs(w2) < bounds.rate
        ):
            status, message = STATUS_DIVERGED, state_message(t, q1, q2, w1, w2)
            if not rows:
                rows.append((t, q1, q2, w1, w2, math.nan, math.nan))
                keep()
            break
        if links_aware:
            tau = controller(t, (q1, q2), (w1, w2), plant.bends, plant.bend_rates)
        else:
            tau = controller(t, (q1, q2), (w1, w2))
        tau1, tau2 = float(tau[0]), float(tau[1])
        rows.append((t, q1, q2, w1, w2, tau1, tau2))
        keep()
        if not (abs(tau1) < bounds.torque and abs(tau2) < bounds.torque):
            status, message = STATUS_DIVERGED, torque_message(t, tau1, tau2)
            break
        if k == n:
            break
        for _ in range(substeps):
            plant.step(tau1, tau2)
    traj = _trajectory(rows, [], status, message, controller)
    return LinkRun(traj, np.array(tips).reshape(-1, 2), np.array(bends), np.array(points))


def control_timestep(links: FlexibleLinks, control_dt: float, margin: float = 0.5) -> float:
    """The largest physics step at most :func:`twolink.arm.links.stable_timestep` that
    divides ``control_dt`` a whole number of times."""
    from twolink.arm.links import stable_timestep

    return control_dt / math.ceil(control_dt / stable_timestep(links, margin))


@dataclass(frozen=True)
class TipMetrics:
    """Measures at the tip of a flexible-link run.

    Attributes
    ----------
    tip_error : float
        Largest distance from the tip to where the rigid arm's tip is at the reference's
        hub angles, over the whole run [m].
    final_tip_error : float
        That distance at the end of the run [m].
    residual_vibration : float
        Largest deflection (the tip off the rigid arm's tip at the measured hub angles,
        less the links' static sag at the end pose) after the reference has come to rest [m].
    vibration_settling_time : float
        The first time after which the deflection stays within ``band`` of its mean
        over the run's last ``window`` seconds [s]; nan where it swings wider than
        ``band`` in that window too (not settled within the run).
    """

    tip_error: float
    final_tip_error: float
    residual_vibration: float
    vibration_settling_time: float

    def to_dict(self) -> dict[str, float]:
        """Each measure by its key in outputs (:data:`twolink.simulation.vocabulary.TIP_METRICS`,
        unit included: ``tip_error_m``, ...)."""
        from twolink.simulation.vocabulary import TIP_METRICS

        return {m.key: float(getattr(self, m.source)) for m in TIP_METRICS}


def tip_metrics(
    run: LinkRun,
    p: ArmParams,
    rest_time: float,
    band: float = 1e-3,
    window: float = 0.5,
    sag=(0.0, 0.0),
) -> TipMetrics:
    """:class:`TipMetrics` of ``run`` against the rigid arm ``p`` (the laws' model), the
    reference at rest from ``rest_time`` on; ``band`` [m] and ``window`` [s] for the
    settling. The deflection is taken about ``sag`` [m], the links' rest shape at the
    end pose (:func:`rest_sag`): gravity's static bending is not a vibration."""
    t = run.trajectory.t
    off_ref = np.linalg.norm(run.tip - run.reference_tip(p), axis=1)
    deflection = run.tip - run.rigid_tip(p) - np.asarray(sag, dtype=float)
    after = t >= rest_time
    residual = float(np.linalg.norm(deflection[after], axis=1).max()) if after.any() else math.nan
    tail = t >= t[-1] - window
    swing = np.linalg.norm(deflection - deflection[tail].mean(axis=0), axis=1)
    outside = np.nonzero(swing > band)[0]
    if len(outside) == 0:
        settle = float(t[0])
    elif tail[outside[-1]]:
        settle = math.nan
    else:
        settle = float(t[outside[-1] + 1])
    return TipMetrics(float(off_ref.max()), float(off_ref[-1]), residual, settle)


def scenario_tip_metrics(s: Scenario, run: LinkRun) -> TipMetrics:
    """:func:`tip_metrics` of a scenario's run: against the plant's rigid rods (where its
    straight links would put the tip), at rest from the reference's end on
    (:func:`twolink.simulation.outcome.reference_end`), about the links' sag at the
    reference's end pose, the default band and window."""
    from twolink.simulation.outcome import reference_end

    end = (s.reference.joint1.final, s.reference.joint2.final)
    sag = (0.0, 0.0)
    if all(math.isfinite(q) for q in end):
        sag = rest_sag(plant_links(s), s.plant_params, s.plant.payload, end)
    return tip_metrics(run, s.plant_params, reference_end(s.reference), sag=sag)


def rest_sag(links: FlexibleLinks, p: ArmParams, payload: float, q) -> np.ndarray:
    """The tip off the rigid rods ``p``'s tip [m] when the links rest at hub angles ``q``
    under ``p.g`` (:func:`twolink.arm.links.rest_shape`): their static sag, zero without
    gravity."""
    if p.g == 0.0:
        return np.zeros(2)
    plant = LinkPlant.build(links, p.g, payload)
    plant.reset(q)
    return plant.tip - rigid_tip(p, q)


def run_links(s: Scenario, controller: Controller) -> LinkRun:
    """A scenario with ``[arm.links]``: its plant's links (:func:`plant_links`,
    its gravity and payload) from their rest shape at ``q0``, ``qd0``, a physics step
    that divides ``control_dt`` (:func:`control_timestep`, at most ``timestep``)."""
    links = plant_links(s)
    plant = LinkPlant.build(links, s.plant_params.g, s.plant.payload, timestep=links_timestep(s))
    return simulate_links(plant, controller, s.duration, s.control_dt, s.q0, s.qd0)


def links_law(s: Scenario, common: dict[str, Any]) -> Controller:
    """A scenario's law of links that bend (``[controller] kind`` in
    :data:`twolink.simulation.field_keys.LINK_KINDS`), modelled on its nominal
    ``[arm.links]``: ``two_time_scale`` is :class:`TwoTimeScaleControl` with the
    controller's ``ks``. ``common``: the model, reference, gains and torque limit."""
    from twolink.controllers.flexible_links import TwoTimeScaleControl

    return TwoTimeScaleControl(**common | {"model": s.links}, ks=s.controller.ks, g=s.arm.g)


def links_timestep(s: Scenario) -> float:
    """The physics step of a scenario's bending links: :func:`control_timestep`, at most
    the scenario's ``timestep``, a whole fraction of ``control_dt`` either way."""
    dt = control_timestep(plant_links(s), s.control_dt)
    if dt > s.timestep:
        dt = s.control_dt / math.ceil(s.control_dt / s.timestep - 1e-9)
    return dt


LINKS_BATCH = 64  # arms per model: past it a batch saves nothing (bench_flexible_links.py)


def iter_links_scenarios(
    scenarios: Sequence[Scenario],
    controllers: Sequence[Controller],
    members: Sequence[int],
    whole: bool = False,
):
    """``(i, trajectory)`` of the scenarios ``members`` (all with ``[arm.links]``), run in
    batches (:func:`simulate_links_batch`) of the arms that share a physics step, control
    period, gravity and duration (at most :data:`LINKS_BATCH` arms a model): each equals
    :func:`run_links`'s trajectory (its whole :class:`LinkRun` where ``whole``)."""
    groups: dict[tuple[float, float, float, float], list[int]] = {}
    for i in members:
        s = scenarios[i]
        key = (links_timestep(s), s.control_dt, s.plant_params.g, s.duration)
        groups.setdefault(key, []).append(i)
    batches = [
        (key, members[start : start + LINKS_BATCH])
        for key, members in groups.items()
        for start in range(0, len(members), LINKS_BATCH)
    ]
    for (dt, control_dt, g, duration), batch in batches:
        arms = [(plant_links(scenarios[i]), scenarios[i].plant.payload) for i in batch]
        runs = simulate_links_batch(
            arms,
            [controllers[i] for i in batch],
            duration,
            control_dt,
            dt,
            g,
            q0=[scenarios[i].q0 for i in batch],
            qd0=[scenarios[i].qd0 for i in batch],
        )
        for i, run in zip(batch, runs, strict=True):
            yield i, run if whole else run.trajectory


# ----------------------------------------------------------------------------- [arm.links]


def read_links(arm_table, arm: ArmParams) -> FlexibleLinks | None:
    """``[arm]``'s sub-table ``links`` (None where it has none), then ``[arm]`` done: the
    bending links of ``arm``'s rods (their ρ A = m / l, L = l)."""
    if "links" not in arm_table.data:
        arm_table.done()
        return None
    links = _links(arm_table.table("links"), arm)
    arm_table.done()
    return links


def _links(t, arm: ArmParams) -> FlexibleLinks:
    segments = t.integer("segments", 8)
    if not 1 <= segments <= MAX_SEGMENTS:
        t.fail("segments", f"must be in 1..{MAX_SEGMENTS}, got {segments}")
    links = FlexibleLinks.from_arm(
        arm,
        ei=t.pair("ei", (100.0, 100.0), positive=True),
        hub_inertia=t.pair("hub_inertia", (0.0, 0.0), minimum=0.0),
        tip_mass=t.pair("tip_mass", (0.0, 0.0), minimum=0.0),
        damping_ratio=t.pair("damping_ratio", (0.01, 0.01), minimum=0.0),
        segments=segments,
    )
    t.done()
    return links


def links_dict(links: FlexibleLinks) -> dict[str, Any]:
    """``[arm.links]`` as plain data (its keys; ρ A and L are ``[arm]``'s)."""
    names = ("ei", "hub_inertia", "tip_mass", "damping_ratio")
    return {"segments": links.segments} | {
        name: [getattr(b, name) for b in links.links] for name in names
    }


def check_links(top, scenario, flexible_kinds: tuple[str, ...]):
    """``scenario`` back, where its bending links (if any) are runnable; else the error that
    names the key: such a run starts straight, sees the truth, with a law of the hub angles."""
    if scenario.links is None:
        if "ei" in scenario.plant.scale:
            top.fail(
                "plant.scale.ei", "scales the bending links ([arm.links]), and this arm has none"
            )
        return scenario
    for key, there in (
        ("plant.flexibility", scenario.plant.flexibility is not None),
        ("plant.friction", scenario.plant.friction is not None),
        ("disturbance", scenario.disturbance is not None),
        ("sensor", not scenario.sensor.ideal),
    ):
        if there:
            top.fail("arm.links", f"links that bend run without [{key}]")
    if scenario.controller.kind in flexible_kinds:
        top.fail("controller.kind", "links that bend: a law of the hub angles")
    return scenario


def plant_links(s) -> FlexibleLinks | None:
    """The simulated arm's bending links: ``[arm.links]`` on the rods of the scenario's
    ``plant_params`` (ρ A = m / l, L = l), each E I times ``[plant.scale]`` ``ei``; None
    where the links are rigid."""
    if s.links is None:
        return None
    links = s.links.with_arm(s.plant_params)
    factor = s.plant.scale.get("ei", 1.0)
    if factor == 1.0:
        return links
    stiffer = [replace(b, ei=b.ei * factor) for b in links.links]
    return replace(links, link1=stiffer[0], link2=stiffer[1])


# ------------------------------------------------------------------------- the batch engine


class LinkBatch:
    """Many flexible-link arms in one MuJoCo model, stepped in lockstep: the batch engine
    (:mod:`twolink.simulation.batch`) for links that bend. Arm i's names carry the prefix
    ``arm{i}_``; its hub and hinge addresses come from its joints' names (the arms may
    have different N). The arms are separate trees without contacts, so each moves as
    alone. Torques enter as applied forces at the hubs, as the single arm's gear-1
    motors add them."""

    def __init__(
        self, arms: Sequence[tuple[FlexibleLinks, float]], g: float, timestep: float
    ) -> None:
        from twolink.arm.links import add_links_arm
        from twolink.arm.plant import mujoco, new_spec

        if not arms:
            raise ValueError("a batch needs at least one arm")
        spec = new_spec(timestep, g, "twolink_links_batch")
        for i, (links, payload) in enumerate(arms):
            add_links_arm(spec, links, payload, prefix=f"arm{i}_", visual=False, motors=False)
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        self.dt = float(self.model.opt.timestep)
        self.segments = [links.segments for links, _ in arms]
        m = self.model
        self.hubs = np.array([[m.joint(f"arm{i}_theta{k}").dofadr[0] for k in (1, 2)]
                              for i in range(len(arms))])  # fmt: skip
        self.bends = [
            np.array(
                [
                    [m.joint(f"arm{i}_bend{k}_{j}").dofadr[0] for j in range(1, n + 1)]
                    for k in (1, 2)
                ]
            )  # fmt: skip
            for i, n in enumerate(self.segments)
        ]
        # Each arm's bodies in tree order (hubs, hinges) and its tip site: its points.
        self.bodies = [
            np.array([m.body(f"arm{i}_link{k}_{j}").id for k in (1, 2) for j in range(n + 1)])
            for i, n in enumerate(self.segments)
        ]
        self.tips = np.array([m.site(f"arm{i}_tip").id for i in range(len(arms))])
        # every dof of arm i (to freeze it): its hubs and hinges
        self.dofs = [np.concatenate([self.hubs[i], b.ravel()]) for i, b in enumerate(self.bends)]

    def reset(self, q0: np.ndarray, qd0: np.ndarray) -> None:
        """Time 0, arm i's hubs at ``q0[i]``, ``qd0[i]``, its links in their rest shape
        there (:func:`twolink.arm.links.rest_shape`). (qpos and qvel share addresses:
        hinge joints only.)"""
        from twolink.arm.links import rest_shape
        from twolink.arm.plant import mujoco

        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[self.hubs] = q0
        rest_shape(self.model, self.data, np.concatenate([b.ravel() for b in self.bends]))
        self.data.qvel[self.hubs] = qd0
        mujoco.mj_forward(self.model, self.data)

    def freeze(self, i: int) -> None:
        """Hold arm i straight at rest at zero with no torque."""
        self.data.qpos[self.dofs[i]] = 0.0
        self.data.qvel[self.dofs[i]] = 0.0
        self.data.qfrc_applied[self.hubs[i]] = 0.0


class _LinkRecord:
    """Every arm's points and hinge angles at each control instant, kept in preallocated
    arrays (one gather per instant for all arms, not one per arm), then cut per arm."""

    def __init__(self, batch: LinkBatch, instants: int) -> None:
        self.batch = batch
        self.bodies = np.concatenate(batch.bodies)
        self.bend_dofs = np.concatenate([b.ravel() for b in batch.bends])
        self.body_at = np.cumsum([0, *(len(b) for b in batch.bodies)])
        self.bend_at = np.cumsum([0, *(b.size for b in batch.bends)])
        n_arms = len(batch.bodies)
        self.body_points = np.empty((instants, len(self.bodies), 2))
        self.tip_points = np.empty((instants, n_arms, 2))
        self.bends = np.empty((instants, len(self.bend_dofs)))
        self.rows = np.empty((instants, n_arms, 7))

    def keep(self, k: int) -> None:
        """The state of every arm at instant k (after the kinematics)."""
        data = self.batch.data
        self.body_points[k] = data.xpos[self.bodies][:, [0, 2]]
        self.tip_points[k] = data.site_xpos[self.batch.tips][:, [0, 2]]
        self.bends[k] = data.qpos[self.bend_dofs]

    def arm(self, i: int, length: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Arm i's first ``length`` instants: its rows (t, q, qd, tau), hinge angles
        (length, 2, N) and points (length, 2 N + 3, 2)."""
        bodies = self.body_points[:length, self.body_at[i] : self.body_at[i + 1]]
        points = np.concatenate([bodies, self.tip_points[:length, i : i + 1]], axis=1)
        bends = self.bends[:length, self.bend_at[i] : self.bend_at[i + 1]]
        shape = (length, *self.batch.bends[i].shape)
        return self.rows[:length, i], bends.reshape(shape).copy(), points


def simulate_links_batch(
    arms: Sequence[tuple[FlexibleLinks, float]],
    controllers: Sequence[Controller],
    duration: float,
    control_dt: float,
    timestep: float,
    g: float = 0.0,
    q0=None,
    qd0=None,
    bounds: Bounds = Bounds(),  # noqa: B008 - frozen, as simulate()'s
) -> list[LinkRun]:
    """:func:`simulate_links` for many arms ``(links, payload)`` at once, arm i under
    ``controllers[i]``, all at one ``timestep`` and gravity ``g``, from hubs at ``q0[i]``,
    ``qd0[i]`` (default 0). An arm that leaves its bounds stops there as "diverged", as
    alone, and is then frozen; the others run on."""
    from twolink.arm.plant import mujoco

    batch = LinkBatch(arms, g, timestep)
    n_arms = len(arms)
    q0 = np.zeros((n_arms, 2)) if q0 is None else np.asarray(q0, dtype=float)
    qd0 = np.zeros((n_arms, 2)) if qd0 is None else np.asarray(qd0, dtype=float)
    n, substeps = control_steps(duration, control_dt, batch.dt)
    batch.reset(q0, qd0)
    for c in controllers:
        c.reset()
    aware = [bool(getattr(c, "needs_links", False)) for c in controllers]
    started, advanced = time.time(), 0
    record = _LinkRecord(batch, n + 1)
    lengths = np.zeros(n_arms, dtype=int)  # instants kept per arm
    ended = [(STATUS_OK, "")] * n_arms
    active = list(range(n_arms))
    data = batch.data
    for k in range(n + 1):
        t = k * control_dt
        mujoco.mj_kinematics(batch.model, data)
        record.keep(k)
        q, qd = data.qpos[batch.hubs], data.qvel[batch.hubs]
        # the single arm's test for all arms at once (NaN fails it)
        within = (np.abs(q) < bounds.angle).all(axis=1) & (np.abs(qd) < bounds.rate).all(axis=1)
        for i in list(active):
            q1, q2, w1, w2 = float(q[i, 0]), float(q[i, 1]), float(qd[i, 0]), float(qd[i, 1])
            stop = None
            if not within[i]:
                stop = (STATUS_DIVERGED, state_message(t, q1, q2, w1, w2))
                if k == 0:  # nothing kept yet: this state, without a torque
                    record.rows[k, i] = (t, q1, q2, w1, w2, math.nan, math.nan)
                    lengths[i] = 1
            else:
                if aware[i]:
                    bends, rates = data.qpos[batch.bends[i]], data.qvel[batch.bends[i]]
                    tau = controllers[i](t, (q1, q2), (w1, w2), bends, rates)
                else:
                    tau = controllers[i](t, (q1, q2), (w1, w2))
                tau1, tau2 = float(tau[0]), float(tau[1])
                record.rows[k, i] = (t, q1, q2, w1, w2, tau1, tau2)
                lengths[i] = k + 1
                data.qfrc_applied[batch.hubs[i]] = (tau1, tau2)
                if not (abs(tau1) < bounds.torque and abs(tau2) < bounds.torque):
                    stop = (STATUS_DIVERGED, torque_message(t, tau1, tau2))
            if stop is not None:
                ended[i] = stop
                active.remove(i)
                batch.freeze(i)
        if k == n or not active:
            break
        for _ in range(substeps):
            mujoco.mj_step(batch.model, data)
        advanced += 1
    runs = []
    for i in range(n_arms):
        rows, bends, points = record.arm(i, lengths[i])
        traj = _trajectory(rows, [], ended[i][0], ended[i][1], controllers[i])
        runs.append(LinkRun(traj, points[:, -1].copy(), bends, points))
    if steplog.enabled():  # the batch in the step log, as the rigid batch engine's
        digests = [steplog.arm_digest(r.trajectory.q, r.trajectory.tau) for r in runs]
        steplog.record("links", started, advanced * substeps, lengths, substeps, digests)
    return runs
