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


def available() -> bool:
    """Whether MJX and JAX are installed."""
    try:
        import jax  # noqa: F401
        from mujoco import mjx  # noqa: F401
    except ImportError:
        return False
    return True


def _jax(precision: str = "float64"):
    try:
        import jax
        from mujoco import mjx
    except ImportError as exc:
        raise ValueError(
            f'the mjx backend needs MJX and JAX: pip install "twolink[mjx]" (missing: {exc.name})'
        ) from None
    # JAX's 64-bit mode is a global switch, read when a loop is traced: on for float64,
    # off for float32 (MJX's own constants then follow in float32).
    jax.config.update("jax_enable_x64", precision == "float64")
    return jax, jax.numpy, mjx


def arm_model(arm: Arm, timestep: float) -> Any:
    """An arm's own MjModel, as a one-arm :class:`BatchPlant` builds it (without the rest
    of the plant: 2 ms an arm instead of 5); a ValueError where MuJoCo refuses it."""
    g = arm.params.g
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
) -> tuple[Any, Any, Any]:
    """The run of :func:`simulate_batch_mjx` before it starts: ``(run, carry, finish)``,
    ``finish(run(carry))`` its BatchResult; ``run`` is compiled at its first call (the
    benchmarks time the second). ``models``: the arms' :func:`arm_model`, if at hand."""
    from twolink.controllers.batch import batch_laws, on_namespace
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
    models = [arm_model(a, timestep) for a in arms] if models is None else models
    first = BatchPlant(arms[:1], timestep)  # a single arm's addresses
    dt = first.dt
    steps, substeps, times, q0, qd0, noise_all = schedule(
        n_arms, dt, durations, control_dt, q0, qd0, noise
    )
    n_max = len(times) - 1
    for c in controllers:
        c.reset()
    laws = []
    for idx, law in batch_laws(controllers, times):
        try:
            laws.append((idx, on_namespace(law, jnp, dtype)))
        except TypeError as exc:
            raise ValueError(f"the mjx backend cannot run this controller: {exc}") from None
    reader = None
    if sensor is not None and not sensor.ideal:
        reader = sensor.reader(control_dt, None, batch=True)
        if sensor.delay_samples:
            raise ValueError("the mjx backend has no sensor delay (delay_samples = 0)")

    def cast(tree: Any) -> Any:
        def leaf(x: Any) -> Any:
            if hasattr(x, "dtype") and jnp.issubdtype(x.dtype, jnp.floating):
                return jnp.asarray(x, dtype)
            return x

        return jax.tree_util.tree_map(leaf, tree)

    model, model_axes = _batched_model(models, mjx, jax, jnp)
    model = cast(model)
    qa, va = first.q_index[0], first.v_index[0]
    first.reset(q0[:1], qd0[:1])
    one = mjx.put_data(first.model, first.data)
    # Every arm's data from the first arm's, its own angles and rates set: mjx.step
    # computes everything else from them (as mj_forward did on the CPU).
    data = jax.tree_util.tree_map(lambda x: jnp.broadcast_to(x, (n_arms, *x.shape)), one)
    data = cast(data.replace(
        qpos=jnp.broadcast_to(data.qpos[0], data.qpos.shape).at[:, qa].set(q0),
        qvel=jnp.broadcast_to(data.qvel[0], data.qvel.shape).at[:, va].set(qd0),
    ))  # fmt: skip
    fa = first.force_index[0]
    bounds = bounds or Bounds()
    qmax, wmax, tmax = bounds.angle, bounds.rate, bounds.torque
    step_arms = jax.vmap(mjx.step, in_axes=(model_axes, 0))
    steps_j = jnp.asarray(steps)
    noise_j = None if noise_all is None else jnp.asarray(noise_all, dtype)

    def body(carry: Any, k: Any) -> tuple[Any, Any]:
        data, states, rate_state, active, length, code = carry
        q, qd = data.qpos[:, qa], data.qvel[:, va]
        inside = jnp.all(jnp.abs(q) < qmax, axis=1) & jnp.all(jnp.abs(qd) < wmax, axis=1)
        escaped = active & ~inside
        length = jnp.where(escaped, jnp.maximum(k, 1), length).astype(length.dtype)
        code = jnp.where(escaped, 1, code)
        active = active & ~escaped
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
        tau = jnp.zeros_like(q)
        new_states = []
        for (idx, law), state in zip(laws, states, strict=True):
            part, state = law.step(k, seen_q[idx], rates[idx], state)
            tau = tau.at[idx].set(part)
            new_states.append(state)
        stopped_value = jnp.where(k == 0, jnp.nan, 0.0)
        tau = jnp.where(active[:, None], tau, stopped_value)
        runaway = active & ~jnp.all(jnp.abs(tau) < tmax, axis=1)
        code = jnp.where(runaway, 2, code)
        done = active & (runaway | (steps_j == k))
        length = jnp.where(done, k + 1, length).astype(length.dtype)
        active = active & ~done
        record = (q, qd, tau)
        applied = jnp.where(active[:, None], tau, 0.0)
        keep = active[:, None]
        qpos = jnp.where(keep, data.qpos, 0.0)
        qvel = jnp.where(keep, data.qvel, 0.0)
        force = jnp.zeros_like(data.qfrc_applied).at[:, fa].set(applied)
        data = data.replace(qpos=qpos, qvel=qvel, qfrc_applied=force)
        for _ in range(substeps):
            data = step_arms(model, data)
        return (data, tuple(new_states), rate_state, active, length, code), record

    q_start = data.qpos[:, qa]
    rate_state0 = None
    if reader is not None:
        rate_state0 = initial_rate_state(reader, jnp.zeros_like(q_start), jnp)
    carry0 = (
        data,
        tuple(law.initial() for _, law in laws),
        rate_state0,
        jnp.ones(n_arms, bool),
        jnp.zeros(n_arms, jnp.int32),
        jnp.zeros(n_arms, jnp.int32),
    )
    run = jax.jit(lambda c: jax.lax.scan(body, c, jnp.arange(n_max + 1)))

    def finish(out: Any) -> BatchResult:
        return _result(out, times, qmax, wmax, controllers)

    return run, carry0, finish


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
