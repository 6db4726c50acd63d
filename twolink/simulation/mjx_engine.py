"""The batch engine on MuJoCo's accelerator backend, MJX (MuJoCo in JAX): the same runs as
:func:`twolink.simulation.batch.simulate_batch`, on a GPU where JAX has one, else on the
CPU (slowly; what CI checks it on).

``pip install "twolink[mjx]"`` installs it. Each arm is its own single-arm MjModel, put on
the device and stacked along a batch axis (the arms differ in masses, lengths, gravity and
payload, never in structure), and ``mjx.step`` runs vmapped over them; the control loop is
one ``jax.lax.scan`` over the control instants, compiled once per batch shape. The batch
laws (CTC, CTC-I, PD-G, the fuzzy CTCs through the exact closed-form engine, the lookup
table or the continuous inference, fuzzy-PD) and the sensor are the numpy engine's own
code, run on ``jax.numpy`` (``controllers/batch.py``, :mod:`twolink.simulation.sensor`).
The bounds, the per-arm durations, the freezing of stopped arms and the records are the
CPU engine's, so the result is a :class:`~twolink.simulation.batch.BatchResult` that
measures and writes as any other.

Precision: float64 by default (JAX's ``jax_enable_x64``), so that a run agrees with the CPU
engine to rounding (tests/test_mjx.py holds a robustness sweep's metrics to 1e-6
relative); ``precision="float32"`` halves memory and is several times faster on a GPU,
at the error stated in docs/batch.md ("The accelerator backend").

Not on this backend (a ValueError says so): flexible joints and their laws, controllers
without a batch form written for it (custom ones, arm by arm on the CPU engine), the
Mamdani engine's general path (non-triangular terms, bisector or mean of maximum).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np

from twolink.arm.plant import add_arm, new_spec
from twolink.controllers.base import Controller
from twolink.simulation.batch import Arm, BatchPlant, BatchResult
from twolink.simulation.sensor import (
    Sensor,
    initial_rate_state,
    measured_angles,
    measured_rates,
)
from twolink.simulation.sim import (
    STATUS_DIVERGED,
    STATUS_OK,
    Bounds,
    state_message,
    torque_message,
)

__all__ = ["PRECISIONS", "arm_model", "available", "prepare_batch_mjx", "simulate_batch_mjx"]

PRECISIONS = ("float64", "float32")


# What importing MJX prints to stdout about its optional Warp backend (GPU kernels twolink
# does not use), once per module that tries it: not a fault of the user's, not said.
_WARP_NOTES = ("Failed to import warp:", "Failed to import mujoco_warp:")


def _import_mjx() -> Any:
    """``mujoco.mjx``, imported without its notes on Warp (:data:`_WARP_NOTES`); anything
    else it prints is printed as it was."""
    import contextlib
    import io

    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        from mujoco import mjx
    for line in printed.getvalue().splitlines():
        if not line.startswith(_WARP_NOTES):
            print(line)
    return mjx


def available() -> bool:
    """Whether MJX and JAX are installed."""
    try:
        import jax  # noqa: F401

        _import_mjx()
    except ImportError:
        return False
    return True


def _jax(precision: str = "float64"):
    try:
        import jax

        mjx = _import_mjx()
    except ImportError as exc:
        raise ValueError(
            f'the mjx backend needs MJX and JAX: pip install "twolink[mjx]" (missing: {exc.name})'
        ) from None
    # JAX's 64-bit mode is a global switch, read when a loop is traced: on for float64,
    # off for float32 (MJX's own constants then follow in float32).
    jax.config.update("jax_enable_x64", precision == "float64")
    return jax, jax.numpy, mjx


def arm_model(arm: Arm, timestep: float, model_g: float | None = None) -> Any:
    """An arm's own MjModel, as a one-arm :class:`BatchPlant` under gravity ``model_g``
    builds it (without the rest of the plant: 2 ms an arm instead of 5): the CPU engine's
    rule, so that an arm off ``model_g`` is tilted as there (None: the arm's own g, no
    tilt); a ValueError where MuJoCo refuses it."""
    g = arm.params.g if model_g is None else model_g
    spec = new_spec(timestep, g, "twolink_batch")
    add_arm(spec, arm.params, arm.flexibility, arm.payload, prefix="arm0_", model_g=g,
            visual=False, motors=False)  # fmt: skip
    try:
        return spec.compile()
    except ValueError as exc:
        why = " ".join(str(exc).split()).removeprefix("Error: ")
        raise ValueError(f"MuJoCo cannot build this batch of arms: {why}") from None


def _batched_model(models: list[Any], mjx: Any, jax: Any, jnp: Any) -> tuple[Any, Any]:
    """One MJX model for arms of one structure: the first arm's, with every field in which
    the arms differ (masses, inertias, lengths, gravity, ... read off their MjModels) an
    array along a leading arm axis; and the vmap axes of its fields (0 for those, None for
    the shared ones). One put_model and one array per differing field, where a put_model
    per arm and a stack of every field took minutes for 10^4 arms."""
    first = models[0]
    shared = mjx.put_model(first)
    fields: dict[str, Any] = {}
    for name in (f.name for f in dataclasses.fields(shared)):
        if name.startswith("_") or not hasattr(first, name):
            continue
        value = getattr(first, name)
        if not isinstance(value, np.ndarray) or value.dtype.kind not in "fiub":
            continue
        stacked = np.stack([getattr(m, name) for m in models])
        if stacked.shape[1:] != value.shape:
            raise ValueError("the mjx backend needs arms of one structure")
        if not (stacked == value).all():
            fields[name] = jnp.asarray(stacked)
    opt = {}
    for name in ("gravity", "timestep"):
        stacked = np.stack([np.asarray(getattr(m.opt, name)) for m in models])
        if not (stacked == stacked[0]).all():
            opt[name] = jnp.asarray(stacked)
    none = jax.tree_util.tree_map(lambda _: None, shared)
    axes = none.replace(**dict.fromkeys(fields, 0))
    model = shared.replace(**fields)
    if opt:
        model = model.replace(opt=shared.opt.replace(**opt))
        axes = axes.replace(opt=none.opt.replace(**dict.fromkeys(opt, 0)))
    return model, axes


def simulate_batch_mjx(*args: Any, **kwargs: Any) -> BatchResult:
    """:func:`twolink.simulation.batch.simulate_batch` on MJX, for rigid arms: arm i is
    ``arms[i]`` (a MuJoCo model of its own, step ``timestep``) under ``controllers[i]``
    for ``durations[i]`` s; the other arguments are simulate_batch's, and ``precision``.
    The arguments of :func:`prepare_batch_mjx`."""
    run, carry, finish = prepare_batch_mjx(*args, **kwargs)
    return finish(run(carry))


def prepare_batch_mjx(
    arms: Sequence[Arm],
    timestep: float,
    controllers: Sequence[Controller],
    durations: Sequence[float],
    control_dt: float = 1e-3,
    q0: np.ndarray | None = None,
    qd0: np.ndarray | None = None,
    bounds: Bounds | None = None,
    noise: Sequence[np.ndarray | None] | None = None,
    sensor: Sensor | None = None,
    precision: str = "float64",
    models: Sequence[Any] | None = None,
    model_g: float | None = None,
) -> tuple[Any, Any, Any]:
    """The run of :func:`simulate_batch_mjx` before it starts: ``(run, carry, finish)``,
    ``finish(run(carry))`` its BatchResult; ``run`` is compiled at its first call (the
    benchmarks time the second). ``models``: the arms' :func:`arm_model`, if at hand;
    ``model_g``: the gravity the arms are tilted against, as on the CPU engine (None: each
    arm its own)."""
    from twolink.simulation.batch import schedule

    if precision not in PRECISIONS:
        raise ValueError(f"precision must be one of {list(PRECISIONS)}, got {precision!r}")
    if any(a.friction is not None for a in arms):
        # MJX has no dry friction (frictionloss) in the MuJoCo this project pins, and the
        # Stribeck dip is applied by the CPU engines' stepping: refused before JAX compiles.
        raise ValueError("the mjx backend runs no joint friction ([plant.friction]); use cpu")
    if any(a.disturbance is not None for a in arms):
        raise ValueError("the mjx backend applies no [disturbance]; use cpu")
    jax, jnp, mjx = _jax(precision)
    n_arms = len(arms)
    if len(controllers) != n_arms or len(durations) != n_arms:
        raise ValueError(f"need one controller and one duration per arm ({n_arms})")
    if any(a.flexibility is not None for a in arms):
        raise ValueError("the mjx backend runs rigid arms only (no [plant.flexibility])")
    dtype = jnp.float64 if precision == "float64" else jnp.float32
    models = [arm_model(a, timestep, model_g) for a in arms] if models is None else models
    first = BatchPlant(arms[:1], timestep, model_g)  # a single arm's addresses
    steps, substeps, times, q0, qd0, noise_all = schedule(
        n_arms, first.dt, durations, control_dt, q0, qd0, noise
    )
    laws = _laws(controllers, times, jnp, dtype)
    reader = _reader(sensor, control_dt)
    cast = _caster(jax, jnp, dtype)
    model, model_axes = _batched_model(models, mjx, jax, jnp)
    data = _initial_data(first, q0, qd0, n_arms, mjx, jax, jnp, cast)
    bounds = bounds or Bounds()
    loop = _Loop(
        jax, jnp, laws, reader, None if noise_all is None else jnp.asarray(noise_all, dtype),
        jnp.asarray(steps), bounds, first, substeps,
        jax.vmap(mjx.step, in_axes=(model_axes, 0)), cast(model),
    )  # fmt: skip
    carry0 = loop.initial(data, n_arms)
    run = jax.jit(lambda c: jax.lax.scan(loop.body, c, jnp.arange(len(times))))

    def finish(out: Any) -> BatchResult:
        return _result(out, times, bounds.angle, bounds.rate, controllers)

    return run, carry0, finish


def _laws(controllers: Sequence[Controller], times: np.ndarray, jnp: Any, dtype: Any) -> list:
    """The controllers reset and their batch laws on ``jax.numpy``, ``(arms, law)``; a law
    without a form for it is a ValueError."""
    from twolink.controllers.batch import batch_laws, on_namespace

    for c in controllers:
        c.reset()
    laws = []
    for idx, law in batch_laws(controllers, times):
        try:
            laws.append((idx, on_namespace(law, jnp, dtype)))
        except TypeError as exc:
            raise ValueError(f"the mjx backend cannot run this controller: {exc}") from None
    return laws


def _reader(sensor: Sensor | None, control_dt: float) -> Any:
    """The sensor's batch reader (None for the true state); a delay is a ValueError."""
    if sensor is None or sensor.ideal:
        return None
    reader = sensor.reader(control_dt, None, batch=True)
    if sensor.delay_samples:
        raise ValueError("the mjx backend has no sensor delay (delay_samples = 0)")
    return reader


def _caster(jax: Any, jnp: Any, dtype: Any) -> Any:
    """A function that casts every floating array of a tree to ``dtype``."""

    def cast(tree: Any) -> Any:
        def leaf(x: Any) -> Any:
            if hasattr(x, "dtype") and jnp.issubdtype(x.dtype, jnp.floating):
                return jnp.asarray(x, dtype)
            return x

        return jax.tree_util.tree_map(leaf, tree)

    return cast


def _initial_data(
    first: BatchPlant, q0: Any, qd0: Any, n_arms: int, mjx: Any, jax: Any, jnp: Any, cast: Any
) -> Any:
    """Every arm's data from the first arm's, its own angles and rates set: mjx.step
    computes everything else from them (as mj_forward did on the CPU)."""
    qa, va = first.q_index[0], first.v_index[0]
    first.reset(q0[:1], qd0[:1])
    one = mjx.put_data(first.model, first.data)
    data = jax.tree_util.tree_map(lambda x: jnp.broadcast_to(x, (n_arms, *x.shape)), one)
    return cast(data.replace(
        qpos=jnp.broadcast_to(data.qpos[0], data.qpos.shape).at[:, qa].set(q0),
        qvel=jnp.broadcast_to(data.qvel[0], data.qvel.shape).at[:, va].set(qd0),
    ))  # fmt: skip


class _Loop:
    """One control instant of every arm (:meth:`body`, what ``jax.lax.scan`` runs): the
    bounds, the sensor, the laws, the stops and the plant's steps, as the CPU engine's."""

    def __init__(
        self, jax, jnp, laws, reader, noise_j, steps_j, bounds, first, substeps, step_arms, model
    ) -> None:  # fmt: skip
        self.jax, self.jnp, self.laws, self.reader, self.noise_j = jax, jnp, laws, reader, noise_j
        self.steps_j, self.substeps, self.step_arms, self.model = (
            steps_j,
            substeps,
            step_arms,
            model,
        )
        self.qmax, self.wmax, self.tmax = bounds.angle, bounds.rate, bounds.torque
        self.qa, self.va, self.fa = first.q_index[0], first.v_index[0], first.force_index[0]

    def initial(self, data: Any, n_arms: int) -> tuple:
        """The carry at instant 0: data, the laws' states, the rate filter's state, and
        per arm whether it runs, its samples kept and why it stopped (1 state, 2 torque)."""
        jnp, reader = self.jnp, self.reader
        q_start = data.qpos[:, self.qa]
        rate_state0 = None
        if reader is not None:
            rate_state0 = initial_rate_state(reader, jnp.zeros_like(q_start), jnp)
        return (
            data,
            tuple(law.initial() for _, law in self.laws),
            rate_state0,
            jnp.ones(n_arms, bool),
            jnp.zeros(n_arms, jnp.int32),
            jnp.zeros(n_arms, jnp.int32),
        )

    def sense(self, k: Any, escaped: Any, q: Any, qd: Any, rate_state: Any) -> tuple:
        """What the laws see at instant k (arms that left their bounds read as zero)."""
        jax, jnp, reader, noise_j = self.jax, self.jnp, self.reader, self.noise_j
        zero = jnp.zeros_like(q)
        seen_q = jnp.where(escaped[:, None], zero, q)
        seen_qd = jnp.where(escaped[:, None], zero, qd)
        rates = seen_qd
        if reader is not None:
            x = seen_q if noise_j is None else seen_q + noise_j[k]
            x = measured_angles(reader, x, jnp)
            first = initial_rate_state(reader, x, jnp)
            if first is not None:
                rate_state = jax.tree_util.tree_map(
                    lambda a, b: jnp.where(k == 0, a, b), first, rate_state
                )
            rates, rate_state = measured_rates(reader, x, seen_qd, rate_state)
            seen_q = x
        elif noise_j is not None:
            seen_q = seen_q + noise_j[k]
        return seen_q, rates, rate_state

    def body(self, carry: Any, k: Any) -> tuple[Any, Any]:
        jnp = self.jnp
        data, states, rate_state, active, length, code = carry
        q, qd = data.qpos[:, self.qa], data.qvel[:, self.va]
        inside = jnp.all(jnp.abs(q) < self.qmax, axis=1) & jnp.all(jnp.abs(qd) < self.wmax, axis=1)
        escaped = active & ~inside
        length = jnp.where(escaped, jnp.maximum(k, 1), length).astype(length.dtype)
        code = jnp.where(escaped, 1, code)
        active = active & ~escaped
        seen_q, rates, rate_state = self.sense(k, escaped, q, qd, rate_state)
        tau = jnp.zeros_like(q)
        new_states = []
        for (idx, law), state in zip(self.laws, states, strict=True):
            part, state = law.step(k, seen_q[idx], rates[idx], state)
            tau = tau.at[idx].set(part)
            new_states.append(state)
        stopped_value = jnp.where(k == 0, jnp.nan, 0.0)
        tau = jnp.where(active[:, None], tau, stopped_value)
        runaway = active & ~jnp.all(jnp.abs(tau) < self.tmax, axis=1)
        code = jnp.where(runaway, 2, code)
        done = active & (runaway | (self.steps_j == k))
        length = jnp.where(done, k + 1, length).astype(length.dtype)
        active = active & ~done
        record = (q, qd, tau)
        applied = jnp.where(active[:, None], tau, 0.0)
        keep = active[:, None]
        qpos = jnp.where(keep, data.qpos, 0.0)
        qvel = jnp.where(keep, data.qvel, 0.0)
        force = jnp.zeros_like(data.qfrc_applied).at[:, self.fa].set(applied)
        data = data.replace(qpos=qpos, qvel=qvel, qfrc_applied=force)
        for _ in range(self.substeps):
            data = self.step_arms(self.model, data)
        return (data, tuple(new_states), rate_state, active, length, code), record


def _result(out: Any, times: np.ndarray, qmax: float, wmax: float, controllers: Any) -> BatchResult:
    """The BatchResult of a finished scan: records on the host, statuses and messages."""
    (_, _, _, _, length, code), (rec_q, rec_qd, rec_tau) = out
    n_arms = len(controllers)
    rec_q, rec_qd, rec_tau = (np.asarray(x, dtype=float) for x in (rec_q, rec_qd, rec_tau))
    length, code = np.asarray(length), np.asarray(code)
    status, message = [STATUS_OK] * n_arms, [""] * n_arms
    for i in np.flatnonzero(code):
        k = int(length[i]) - 1 if code[i] == 2 else (int(length[i]) if length[i] > 1 else 0)
        if code[i] == 1 and length[i] == 1:
            k = _first_escape(rec_q[:, i], rec_qd[:, i], qmax, wmax)
        status[i] = STATUS_DIVERGED
        t = float(times[k])
        if code[i] == 1:
            message[i] = state_message(t, *rec_q[k, i], *rec_qd[k, i])
        else:
            message[i] = torque_message(t, *rec_tau[k, i])
    return BatchResult(
        times,
        rec_q,
        rec_qd,
        rec_tau,
        None,
        length,
        status,
        message,
        controllers,
        np.zeros(n_arms, bool),
    )


def _first_escape(q: np.ndarray, qd: np.ndarray, qmax: float, wmax: float) -> int:
    """The first instant an arm's recorded state is outside the bounds."""
    inside = (np.abs(q) < qmax).all(axis=1) & (np.abs(qd) < wmax).all(axis=1)
    return int(np.argmin(inside))
