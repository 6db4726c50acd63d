"""The batch engine: many arms in one MuJoCo model, stepped in lockstep.

N arms, rigid or flexible, each with its own masses, lengths, payload, flexibility and
gravity, are built into one MjModel (:func:`twolink.arm.plant.add_arm` with a name prefix per
arm) and advanced by one ``mj_step`` per physics step. The arms are separate kinematic
trees with no contacts, so MuJoCo's (block-diagonal) dynamics keep them independent:
each arm moves as it does alone in its own model (``tests/test_batch.py``).

Gravity is one option per model: the one its caller fixes (``model_g``: a sweep's comes
from its definition, so an arm's run never depends on the other arms of its batch), else
the largest in magnitude of the arms'; an arm whose g
differs moves in a plane tilted about the horizontal x axis by the angle whose cosine is
``g / g_model`` (:func:`twolink.arm.plant.incline`): the model's gravity then has exactly the
component g in the arm's plane, and the rest lies along its hinges, where it does no
work. Arms at the model's g are bit-identical to the single-arm path and the others
agree to rounding; the tilt costs nothing per step (the gravity compensation this
replaced cost ~30 % of MuJoCo's step).

:func:`simulate_batch` is :func:`twolink.simulation.sim.simulate` for N arms: the same zero-order
hold, the same bounds and the same records, per arm. An arm that leaves its bounds stops
there as "diverged", exactly as alone, and is then frozen (held at rest at zero, torque
zero) so that it cannot disturb the others; MuJoCo's automatic reset is off, so a NaN in
one arm never resets the rest. An arm whose run is over is frozen the same way.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from twolink.arm.disturbance import Disturbance
from twolink.arm.params import ArmParams, Flexibility, Friction, squared_rate
from twolink.arm.plant import (
    add_arm,
    holding_motor_q,
    lump_point_mass,
    mujoco,
    new_spec,
    solve_arms_apart,
    warning_counts,
    warning_notes,
)
from twolink.controllers.base import Controller
from twolink.foundation import steplog
from twolink.simulation.sensor import Sensor
from twolink.simulation.sim import (
    STATUS_DIVERGED,
    STATUS_OK,
    Bounds,
    Trajectory,
    control_steps,
    state_message,
    torque_message,
)

__all__ = ["Arm", "BatchPlant", "BatchResult", "record_bytes", "simulate_batch"]


@dataclass(frozen=True)
class Arm:
    """One arm of a batch: what :meth:`twolink.arm.plant.Plant.build` takes."""

    params: ArmParams
    flexibility: Flexibility | None = None
    payload: float = 0.0
    friction: Friction | None = None
    disturbance: Disturbance | None = None


def model_gravity(gs: Sequence[float]) -> float:
    """The model's gravity for arms with gravities ``gs``: the one of largest magnitude
    (the first of those), so that every arm's share ``g / g_model`` of it is a cosine
    (:func:`twolink.arm.plant.incline`); a tilt can take gravity away, not add it."""
    return max(gs, key=abs, default=0.0)


def batch_model(
    arms: Sequence[Arm],
    timestep: float,
    name: str = "twolink_batch",
    model_g: float | None = None,
):
    """One MuJoCo model of ``arms``, ``arm{i}_`` their names' prefixes, under the gravity
    ``model_g`` (None: :func:`model_gravity` of the arms; the batch engine's, and the batch
    linearisation's). An arm's tilt, and so its run to the last bit, depends on its own g
    and ``model_g`` only: a caller that fixes ``model_g`` for all its arms gets the same run
    of an arm whatever batch it lands in. An arm of larger |g| than ``model_g`` is a
    ValueError (no tilt adds gravity)."""
    g_model = model_gravity([a.params.g for a in arms]) if model_g is None else model_g
    spec = new_spec(timestep, g_model, name)
    if any(a.friction is not None for a in arms):
        solve_arms_apart(spec)  # friction's solver sees each arm alone
    for i, a in enumerate(arms):
        # No geoms (nothing renders a batch) and no actuators (see force_index): each
        # costs ~5 % of a step.
        add_arm(
            spec,
            a.params,
            a.flexibility,
            a.payload,
            prefix=f"arm{i}_",
            model_g=g_model,
            visual=False,
            motors=False,
            friction=a.friction,
        )
    try:
        return spec.compile()
    except ValueError as exc:
        why = " ".join(str(exc).split()).removeprefix("Error: ")
        raise ValueError(f"MuJoCo cannot build this batch of arms: {why}") from None


class BatchPlant:
    """N arms in one MuJoCo model (its gravity ``model_g``: :func:`batch_model`).
    ``q_index``/``v_index``: (N, 2) addresses of each arm's link angles in
    ``qpos``/``qvel``, and ``force_index`` the (N, 2) ``qfrc_applied`` addresses its
    torques are written to (its motors' joints)."""

    def __init__(
        self, arms: Sequence[Arm], timestep: float = 1e-3, model_g: float | None = None
    ) -> None:
        if not arms:
            raise ValueError("a batch needs at least one arm")
        self.model = batch_model(arms, timestep, model_g=model_g)
        self.data = mujoco.MjData(self.model)
        self.dt = float(self.model.opt.timestep)
        self.arms = list(arms)
        self.n_arms = len(arms)
        self.flexible = np.array([a.flexibility is not None for a in arms])

        def joint(i: int, name: str):
            return self.model.joint(f"arm{i}_{name}")

        links = [(joint(i, "theta1"), joint(i, "theta2")) for i in range(len(arms))]
        self.q_index = np.array([[j.qposadr[0] for j in pair] for pair in links])
        self.v_index = np.array([[j.dofadr[0] for j in pair] for pair in links])
        # Rotor addresses; a rigid arm's point at its links (read, never used).
        motors = [
            (joint(i, "phi1"), joint(i, "phi2")) if flex else pair
            for i, (flex, pair) in enumerate(zip(self.flexible, links, strict=True))
        ]
        self.motor_index = np.array([[j.qposadr[0] for j in pair] for pair in motors])
        self.motor_v_index = np.array([[j.dofadr[0] for j in pair] for pair in motors])
        # Each arm's spring stiffness (inf for a rigid arm: no twist), from the model.
        self.stiffness = np.array(
            [
                [
                    self.model.tendon_stiffness[self.model.tendon(f"arm{i}_spring{k}").id]
                    for k in (1, 2)
                ]
                if flex
                else [np.inf, np.inf]
                for i, flex in enumerate(self.flexible)
            ]
        )
        # The torques enter as applied forces on the motors' joints (``qfrc_applied``),
        # which is exactly what the single arm's gear-1 motors add (no control limits:
        # qfrc_actuator = ctrl); the batch model has no actuators, whose transmission
        # MuJoCo would compute four times a step for nothing. (Sums are unchanged: MuJoCo
        # adds applied, then actuator forces, and one of the two is zero either way.)
        self.force_index = self.motor_v_index
        self.disturbed = [(i, a.disturbance) for i, a in enumerate(arms) if a.disturbance]
        # Arms with equal disturbances, rigid or flexible, in groups: each group's torque
        # is evaluated once per physics step (a sweep's arms usually share one).
        groups: dict[tuple[Disturbance, bool], list[int]] = {}
        for i, d in self.disturbed:
            groups.setdefault((d, bool(self.flexible[i])), []).append(i)
        self._disturbance_groups = [
            (d, flexible, idx, self.v_index[idx]) for (d, flexible), idx in groups.items()
        ]
        self._built = tuple(  # the masses as built: a payload picked up is put down at reset
            a.copy() for a in (self.model.body_mass, self.model.body_ipos, self.model.body_inertia)
        )
        # The Stribeck dip of the arms' friction (Plant.step's, per arm): None where no arm
        # has one, else its (N, 2) excess F_s - F_c (zero for the arms without) and v_s.
        self.stribeck = None
        if any(a.friction is not None and a.friction.stribeck for a in arms):
            none = Friction()
            frictions = [a.friction or none for a in arms]
            self.stribeck = (
                np.array([np.subtract(f.breakaway, f.coulomb) for f in frictions]),
                np.array([[f.stribeck_velocity] * 2 for f in frictions]),
            )

    def apply(self, tau: np.ndarray) -> None:
        """``qfrc_applied`` for the next physics step (where an arm has a Stribeck dip or
        a disturbance): the torques ``tau`` (N, 2) at the motors' joints plus each arm's
        dip there, and each arm's disturbance on its links (as Plant.step)."""
        force = self.data.qfrc_applied
        force[self.force_index] = tau if self.stribeck is None else tau + self.stribeck_relief()
        t = self.data.time
        for d, flexible, arms, links in self._disturbance_groups:
            if d.picks_up(t, self.dt):
                for i in arms:
                    body = self.model.body(f"arm{i}_link2").id
                    lump_point_mass(self.model, body, d.pickup.mass, self.arms[i].params.l2)
            torque = d.torque(t, self.dt)  # (2,): the same on every arm of the group
            if flexible:  # a flexible arm's links carry nothing else
                force[links] = torque
            else:
                force[links] += torque

    def stribeck_relief(self) -> np.ndarray:
        """The Stribeck forces (N, 2) at the motors' joints now:
        :meth:`twolink.arm.params.Friction.stribeck_relief` of each arm's rates."""
        excess, vs = self.stribeck
        v = self.data.qvel[self.force_index]
        return excess * -np.expm1(-squared_rate(v, vs)) * np.sign(v)

    def reset(self, q0: np.ndarray, qd0: np.ndarray, holding: np.ndarray | None = None) -> None:
        """Every arm at (q0, qd0), time 0, its rotors at the links (springs relaxed) or,
        for the flexible arms where ``holding`` is true, twisted to hold the arm at rest at
        q0 by its own gravity and payload: :func:`twolink.arm.plant.holding_motor_q`, the
        angles a single arm's run starts with
        (:func:`twolink.simulation.experiment.start_motor_q`)."""
        if not np.array_equal(self.model.body_mass, self._built[0]):
            for now, built in zip(
                (self.model.body_mass, self.model.body_ipos, self.model.body_inertia),
                self._built,
                strict=True,
            ):
                now[:] = built
            mujoco.mj_setConst(self.model, mujoco.MjData(self.model))
        mujoco.mj_resetData(self.model, self.data)
        motor_q0 = np.array(q0, dtype=float)
        held = np.zeros(self.n_arms, bool) if holding is None else holding & self.flexible
        for i in np.flatnonzero(held):
            a = self.arms[i]
            motor_q0[i] = holding_motor_q(a.params, a.flexibility, q0[i], a.payload)
        for index, value in ((self.motor_index, motor_q0), (self.q_index, q0)):
            self.data.qpos[index] = value
        for index, value in ((self.motor_v_index, qd0), (self.v_index, qd0)):
            self.data.qvel[index] = value
        mujoco.mj_forward(self.model, self.data)

    def freeze(self, arms: np.ndarray) -> None:
        """Hold ``arms`` (indices) at rest at zero with no torque."""
        for q_index, v_index in (
            (self.q_index, self.v_index),
            (self.motor_index, self.motor_v_index),
        ):
            self.data.qpos[q_index[arms]] = 0.0
            self.data.qvel[v_index[arms]] = 0.0
        self.data.qfrc_applied[self.force_index[arms]] = 0.0


def record_bytes(steps: int, flexible: bool = False) -> int:
    """Memory one arm's records take for ``steps`` control periods (what bounds a batch)."""
    return (steps + 1) * (8 if flexible else 6) * 8


@dataclass(frozen=True, eq=False)
class BatchResult:
    """The records of a batch; :meth:`trajectory` gives arm i's as a Trajectory."""

    times: np.ndarray
    q: np.ndarray  # (steps + 1, N, 2)
    qd: np.ndarray
    tau: np.ndarray
    motor_q: np.ndarray | None
    length: np.ndarray  # (N,) samples kept per arm
    status: list[str]
    message: list[str]
    controllers: Sequence[Controller]
    flexible: np.ndarray
    warnings: tuple[tuple[str, ...], ...] = ()  # per arm: MuJoCo's warnings, in words

    def trajectory(self, i: int) -> Trajectory:
        """Arm i's run, as :func:`twolink.simulation.sim.simulate` returns it."""
        n = int(self.length[i])
        t = self.times[:n].copy()
        q_ref, qd_ref, qdd_ref = self.controllers[i].reference.sample(t)
        motor = self.motor_q[:n, i].copy() if self.flexible[i] else np.empty((0, 2))
        return Trajectory(
            t=t,
            q=self.q[:n, i].copy(),
            qd=self.qd[:n, i].copy(),
            q_ref=q_ref.reshape(-1, 2),
            qd_ref=qd_ref.reshape(-1, 2),
            qdd_ref=qdd_ref.reshape(-1, 2),
            tau=self.tau[:n, i].copy(),
            motor_q=motor,
            status=self.status[i],
            message=self.message[i],
            warnings=self.warnings[i] if self.warnings else (),
        )


# An arm running away may overflow its law's arithmetic (w² of a rotor at 1e160 rad/s)
# before its torque leaves the bounds: expected, not printed; the arm's record says so
# (diverged, its torque message showing the non-finite torque).
@np.errstate(over="ignore", invalid="ignore", divide="ignore")
def simulate_batch(
    plant: BatchPlant,
    controllers: Sequence[Controller],
    durations: Sequence[float],
    control_dt: float = 1e-3,
    q0: np.ndarray | None = None,
    qd0: np.ndarray | None = None,
    bounds: Bounds | None = None,
    noise: Sequence[np.ndarray | None] | None = None,
    holding: np.ndarray | None = None,
    sensor: Sensor | None = None,
) -> BatchResult:
    """Run arm i of ``plant`` under ``controllers[i]`` for ``durations[i]`` seconds.

    The arguments are those of :func:`twolink.simulation.sim.simulate`, one per arm (a controller
    that reads the motors, ``needs_motor``, gets each arm's rotor states): ``q0`` and
    ``qd0`` of shape (N, 2) (default zeros), ``noise[i]`` of shape (steps_i + 1, 2) or
    None; ``holding`` (N,) bool: flexible arms that start with their springs holding them at
    rest (:meth:`BatchPlant.reset`); ``sensor``: what every arm's controller sees (one
    sensor for the batch; :mod:`twolink.simulation.sensor`). Every arm shares the plant's
    timestep and ``control_dt``.
    """
    n_arms = plant.n_arms
    if len(controllers) != n_arms or len(durations) != n_arms:
        raise ValueError(f"need one controller and one duration per arm ({n_arms})")
    steps, substeps, times, q0, qd0, noise_all = schedule(
        n_arms, plant.dt, durations, control_dt, q0, qd0, noise
    )
    laws, motor_laws = _laws(plant, controllers, times)
    reader, motor_reader, noise_all = _readers(sensor, control_dt, noise_all, any(motor_laws))
    plant.reset(q0, qd0, None if holding is None else np.asarray(holding, bool))
    run = _Run(plant, len(times) - 1, bounds or Bounds())
    qpos, qvel = plant.data.qpos, plant.data.qvel
    q_index, v_index = plant.q_index, plant.v_index
    any_flexible, any_motor = bool(plant.flexible.any()), any(motor_laws)
    applied = plant.stribeck is not None or bool(plant.disturbed)
    qmax, wmax, tmax = run.bounds.angle, run.bounds.rate, run.bounds.torque
    active, tau = run.active, run.tau
    ends = set(steps.tolist())  # instants where some arm's run is over
    started, advanced = time.time(), len(times)  # control periods stepped (the step log's)
    for k in range(len(times)):
        t = float(times[k])
        q, qd = qpos[q_index], qvel[v_index]
        run.q[k], run.qd[k] = q, qd
        if any_flexible:
            run.motor[k] = qpos[plant.motor_index]
        # NaN fails every comparison, so this also catches non-finite states. (Frozen
        # arms rest at zero, inside the bounds.)
        if not (np.abs(q).max() < qmax and np.abs(qd).max() < wmax):
            run.escape(k, t, q, qd)
        seen, rates = q, qd
        if reader is not None:
            seen, rates = reader(k, q, qd)
        elif noise_all is not None:
            seen = q + noise_all[k]
        if any_motor:  # the rotors, for the laws of flexible joints
            mq, mqd = qpos[plant.motor_index], qvel[plant.motor_v_index]
            mq[~active] = mqd[~active] = 0.0
            if motor_reader is not None:
                mq, mqd = motor_reader(k, mq, mqd)
        for (idx, law), motor in zip(laws, motor_laws, strict=True):
            if motor:
                tau[idx] = law(k, seen[idx], rates[idx], mq[idx], mqd[idx])
            else:
                tau[idx] = law(k, seen[idx], rates[idx])
        stopped = not active.all()
        if stopped:
            tau[~active] = np.nan if k == 0 else 0.0
        run.tau_record[k] = tau
        if not np.abs(tau).max() < tmax or k in ends:
            if not run.stop(k, t, steps):
                advanced = k
                break
            stopped = True
        if stopped:
            plant.freeze(np.flatnonzero(~active))
            tau[~active] = 0.0
        _advance(plant, tau, substeps, applied)
    return _logged(run.result(times, controllers), started, advanced, substeps)


def _logged(result: BatchResult, started: float, advanced: int, substeps: int) -> BatchResult:
    """``result``, written to the step log where it is on (:mod:`twolink.foundation.steplog`)."""
    if not steplog.enabled():
        return result
    digests = [
        steplog.arm_digest(result.q[:n, i], result.tau[:n, i])
        for i, n in enumerate(result.length.tolist())
    ]
    steplog.record("batch", started, advanced * substeps, result.length, substeps, digests)
    return result


def _advance(plant: BatchPlant, tau: np.ndarray, substeps: int, applied: bool) -> None:
    """Hold the torques ``tau`` over one control period of ``substeps`` physics steps
    (with each arm's Stribeck dip and disturbance, as Plant.step, where ``applied``)."""
    model, data = plant.model, plant.data
    data.qfrc_applied[plant.force_index] = tau
    for _ in range(substeps):
        if applied:  # as Plant.step: held over the step, from its start
            plant.apply(tau)
        mujoco.mj_step(model, data)


def _readers(
    sensor: Sensor | None, control_dt: float, noise_all: np.ndarray | None, motors: bool
) -> tuple[Any, Any, np.ndarray | None]:
    """What the laws see through ``sensor``: the links' reader (the noise in it), the
    rotors' (where a law reads them), and the noise left to add (None once read)."""
    if sensor is None or sensor.ideal:
        return None, None, noise_all
    reader = sensor.reader(control_dt, noise_all, batch=True)
    return reader, sensor.reader(control_dt, batch=True) if motors else None, None


def _laws(
    plant: BatchPlant, controllers: Sequence[Controller], times: np.ndarray
) -> tuple[list[tuple[Any, Any]], list[bool]]:
    """The controllers reset and their batch laws, ``(arms, law)``, and which of them read
    the rotors; a law of flexible joints on a rigid arm is a ValueError."""
    from twolink.controllers.batch import batch_laws

    n_arms = plant.n_arms
    for c in controllers:
        c.reset()
    laws = batch_laws(controllers, times)
    motor_laws = [bool(getattr(law, "needs_motor", False)) for _, law in laws]
    # A law over every arm in order (a sweep chunk of one kind, the benchmarks) reads and
    # writes whole arrays: three fancy-index copies a step fewer.
    laws = [
        (slice(None) if np.array_equal(idx, np.arange(n_arms)) else idx, law) for idx, law in laws
    ]
    rigid = [i for i, c in enumerate(controllers) if getattr(c, "needs_motor", False)]
    rigid = [i for i in rigid if not plant.flexible[i]]
    if rigid:
        raise ValueError(
            f"arm {rigid[0]}'s controller ({type(controllers[rigid[0]]).__name__}) reads the "
            "motor states of flexible joints; that arm is rigid"
        )
    return laws, motor_laws


class _Run:
    """The records of a batch run and its arms' fates (:func:`simulate_batch`'s loop)."""

    def __init__(self, plant: BatchPlant, n_max: int, bounds: Bounds) -> None:
        n_arms = plant.n_arms
        self.plant, self.bounds = plant, bounds
        self.q = np.empty((n_max + 1, n_arms, 2))
        self.qd = np.empty_like(self.q)
        self.tau_record = np.empty_like(self.q)
        self.motor = np.empty_like(self.q) if plant.flexible.any() else None
        self.length = np.zeros(n_arms, dtype=int)
        self.status = [STATUS_OK] * n_arms
        self.message = [""] * n_arms
        self.active = np.ones(n_arms, dtype=bool)
        self.tau = np.zeros((n_arms, 2))
        self.counts = warning_counts(plant.data)  # MuJoCo's warnings so far (none: reset)
        self.warned: list[list[str]] = [[] for _ in range(n_arms)]

    def escape(self, k: int, t: float, q: np.ndarray, qd: np.ndarray) -> None:
        """Stop the active arms whose state left its bounds at instant k ("diverged", their
        one state kept if at once); ``q`` and ``qd`` are zeroed there for the laws."""
        qmax, wmax, active = self.bounds.angle, self.bounds.rate, self.active
        escaped = active & ~((np.abs(q) < qmax).all(axis=1) & (np.abs(qd) < wmax).all(axis=1))
        # MuJoCo warns of a non-finite or huge state in the steps before (its counts
        # are the batch's): the arms that left their bounds now are the ones it meant
        notes, self.counts = _new_warnings(self.plant.data, self.counts)
        for i in np.flatnonzero(escaped):
            self.status[i] = STATUS_DIVERGED
            self.message[i] = state_message(t, *q[i], *qd[i])
            self.warned[i] += notes
        self.length[escaped] = k if k else 1  # at once: keep the one state, with no torque
        active &= ~escaped
        q[escaped] = qd[escaped] = 0.0  # the laws see finite numbers

    def stop(self, k: int, t: float, steps: np.ndarray) -> bool:
        """Stop the active arms whose torque is out of bounds (kept: the state measured and
        the torque asked for, not applied) or whose run ends at instant k; whether any
        arm is still active."""
        tau, active = self.tau, self.active
        runaway = active & ~(np.abs(tau) < self.bounds.torque).all(axis=1)
        for i in np.flatnonzero(runaway):
            self.status[i] = STATUS_DIVERGED
            self.message[i] = torque_message(t, *tau[i])
        done = active & (runaway | (steps == k))
        self.length[done] = k + 1
        active &= ~done
        return bool(active.any())

    def result(self, times: np.ndarray, controllers: Sequence[Controller]) -> BatchResult:
        """The BatchResult; MuJoCo's warnings after the last escape go to the arm of the
        last warning's degree of freedom."""
        plant, warned = self.plant, self.warned
        notes, _ = _new_warnings(plant.data, self.counts)
        if notes:
            dof = max(int(w.lastinfo) for w in plant.data.warning)
            arm = np.flatnonzero(
                (plant.v_index == dof).any(1) | (plant.motor_v_index == dof).any(1)
            )
            for i in arm[:1] if len(arm) else range(plant.n_arms):
                warned[i] += notes
        return BatchResult(
            times,
            self.q,
            self.qd,
            self.tau_record,
            self.motor,
            self.length,
            self.status,
            self.message,
            controllers,
            plant.flexible,
            tuple(tuple(w) for w in warned),
        )


def _new_warnings(data, counts: list[int]) -> tuple[list[str], list[int]]:
    """MuJoCo's warnings since ``counts``, in words without their batch-wide counts, and
    the counts now."""
    return warning_notes(data, counts), warning_counts(data)


def schedule(
    n_arms: int,
    dt: float,
    durations: Sequence[float],
    control_dt: float,
    q0: np.ndarray | None,
    qd0: np.ndarray | None,
    noise: Sequence[np.ndarray | None] | None,
) -> tuple[np.ndarray, int, np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """What a batch run of ``n_arms`` steps through, on either engine: each arm's control
    periods, the plant steps per period, the control instants of the longest run, the
    initial states (default zeros) and the noise stacked as (steps + 1, N, 2) (None
    where no arm has any)."""
    steps = np.array([control_steps(d, control_dt, dt)[0] for d in durations])
    substeps = control_steps(durations[0], control_dt, dt)[1]
    n_max = int(steps.max())
    q0 = np.zeros((n_arms, 2)) if q0 is None else np.asarray(q0, dtype=float)
    qd0 = np.zeros((n_arms, 2)) if qd0 is None else np.asarray(qd0, dtype=float)
    noisy = noise is not None and any(n is not None for n in noise)
    noise_all = _stack_noise(noise, steps, n_max) if noisy else None
    return steps, substeps, np.arange(n_max + 1) * control_dt, q0, qd0, noise_all


def _stack_noise(noise: Sequence[np.ndarray | None], steps: np.ndarray, n_max: int) -> np.ndarray:
    """Per-arm noise as one (n_max + 1, N, 2) array; zeros where an arm has none."""
    out = np.zeros((n_max + 1, len(steps), 2))
    for i, (rows, n) in enumerate(zip(noise, steps, strict=True)):
        if rows is None:
            continue
        if np.shape(rows) != (n + 1, 2):
            raise ValueError(f"noise of arm {i} must have shape {(n + 1, 2)}, got {np.shape(rows)}")
        out[: n + 1, i] = rows
    return out
