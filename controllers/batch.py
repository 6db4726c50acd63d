"""Batch forms of the controllers: one law computing the torques of many arms at once.

A batch law is built from the arms' own controllers (the scalar objects the single-arm
loop calls) and, at control instant ``k``, maps the measured states of its arms, arrays
of shape (N, 2), to their torques (N, 2). It runs the scalar law's arithmetic in the
same order on arrays, so arm i's torque equals its controller's bit for bit, except
where numpy's SIMD ``cos``/``sin`` round differently from ``math`` (machines with
AVX-512) and for the fuzzy term, whose numpy path agrees with the pure-Python one to
1e-12 (``controllers/fuzzy/engine.py``). ``tests/test_batch.py`` holds them to that.

Arms are grouped by :func:`batch_laws`: all controllers of one class form one law (their
models, gains and limits become per-arm arrays), fuzzy ones one law per engine (and
mode); any other controller is called arm by arm (correct, not fast).

The laws of CTC, CTC-I, PD-G, fuzzy-PD and the fuzzy CTCs are written once for two array
backends: their arithmetic takes its functions from the namespace ``self.xp`` (numpy
here; ``jax.numpy`` on MuJoCo's accelerator backend, :mod:`twolink.simulation.mjx`, via
:func:`on_namespace`), and their state (CTC-I's integrators) is passed in and returned by
:meth:`BatchComputedTorque.step` rather than kept, so that a compiled loop can carry it.
Called as ``law(k, q, qd)`` (numpy), a law keeps its state itself.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from twolink.arm.dynamics import terms
from twolink.arm.regressor import regressor_rows
from twolink.controllers.adaptive import AdaptiveComputedTorque
from twolink.controllers.base import Controller
from twolink.controllers.baselines import FuzzyPD, IntegralComputedTorque, PDGravity
from twolink.controllers.ctc import ComputedTorque
from twolink.controllers.fuzzy import kernels
from twolink.controllers.fuzzy_ctc import FuzzyComputedTorque
from twolink.controllers.observer import DisturbanceObserverCTC, momentum_terms
from twolink.controllers.sliding import SlidingMode
from twolink.foundation.references import ArmReference

__all__ = [
    "BatchAdaptiveComputedTorque",
    "BatchComputedTorque",
    "BatchDisturbanceObserverCTC",
    "BatchFuzzyComputedTorque",
    "BatchFuzzyPD",
    "BatchIntegralComputedTorque",
    "BatchPDGravity",
    "BatchSlidingMode",
    "ReferenceTable",
    "batch_laws",
    "batched",
]


class ReferenceTable:
    """The references of many arms sampled once on the control grid ``times``.

    Equal references are stored once: memory (len(times), unique, 2) per signal. Where all
    arms share one reference (a sweep's chunk), :meth:`at` answers with broadcast views,
    copying nothing.
    """

    xp: Any = np

    def __init__(self, references: Sequence[ArmReference], times: np.ndarray) -> None:
        unique: dict[ArmReference, int] = {}
        self.index = np.array([unique.setdefault(r, len(unique)) for r in references])
        self.shared = len(unique) == 1
        samples = [ref.sample(times) for ref in unique]
        self.pos, self.vel, self.acc = (
            np.stack([s[signal] for s in samples], axis=1) for signal in range(3)
        )

    def at(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Desired positions, velocities and accelerations at instant k, each (N, 2)."""
        i = self.index
        if self.shared:
            shape = (i.shape[0], 2)
            return tuple(
                self.xp.broadcast_to(x[k, 0], shape) for x in (self.pos, self.vel, self.acc)
            )
        return self.pos[k, i], self.vel[k, i], self.acc[k, i]


@dataclass(frozen=True)
class _Models:
    """The controllers' arm models as per-arm arrays (what :func:`terms` reads)."""

    m1: np.ndarray
    m2: np.ndarray
    l1: np.ndarray
    l2: np.ndarray
    g: np.ndarray

    @classmethod
    def stack(cls, controllers: Sequence[ComputedTorque]) -> _Models:
        return cls(
            *(np.array([getattr(c.model, f) for c in controllers]) for f in "m1 m2 l1 l2 g".split())
        )


def _fuzzy_scalings(controllers: Sequence[Any]) -> tuple[np.ndarray, ...]:
    """Per-arm (ke, kde, ku) of fuzzy controllers, each as an (N, 1) column."""
    return tuple(np.array([[getattr(c, f)] for c in controllers]) for f in ("ke", "kde", "ku"))


class BatchComputedTorque:
    """:class:`~controllers.ctc.ComputedTorque` for N arms, each with its own model,
    gains, limits and reference.

    ``law.step(k, q, qd, state)`` is :meth:`finish` of the reference errors and model terms
    it computes itself, and returns the torques and the law's next state (:meth:`initial`
    at the start of a run; None for the laws without one); ``law(k, q, qd)`` does the
    same keeping the state itself. :class:`_SharedTerms` computes the errors and terms
    once for the laws of several kinds and calls their :meth:`finish` on slices."""

    xp: Any = np  # the array namespace of the arithmetic (see the module's docstring)

    def __init__(self, controllers: Sequence[ComputedTorque], times: np.ndarray) -> None:
        self.reference = ReferenceTable([c.reference for c in controllers], times)
        self.model = _Models.stack(controllers)
        self.kp = np.array([c.kp for c in controllers])
        self.kd = np.array([c.kd for c in controllers])
        self.limit = np.array([c.torque_limit for c in controllers])
        self.state = self.initial()

    def initial(self) -> Any:
        """The law's state at the start of a run (None: it has none)."""
        return None

    def __call__(self, k: int, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        tau, self.state = self.step(k, q, qd, self.state)
        return tau

    def step(self, k: int, q, qd, state: Any) -> tuple[Any, Any]:
        """The torques at instant k and the next state."""
        return self.finish(k, *self.errors(k, q, qd), self.terms(q, qd), state)

    def errors(self, k: int, q: np.ndarray, qd: np.ndarray):
        """Desired accelerations, errors and error rates at instant k, each (N, 2)."""
        r, v, a = self.reference.at(k)
        return a, r - q, v - qd

    def terms(self, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, ...]:
        """The model's ``(M11, M12, M22, H1 + G1, H2 + G2)`` at (q, qd), each (N,)."""
        xp = self.xp
        return terms(self.model, q[:, 0], q[:, 1], qd[:, 0], qd[:, 1], cos=xp.cos, sin=xp.sin)

    def unsaturated(self, m: tuple[np.ndarray, ...], v: np.ndarray) -> np.ndarray:
        """``M^(q) v + H^ + G^`` from the model terms ``m`` (the scalar ``unsaturated``)."""
        m11, m12, m22, b1, b2 = m
        v1, v2 = v[:, 0], v[:, 1]
        return self.xp.stack([m11 * v1 + m12 * v2 + b1, m12 * v1 + m22 * v2 + b2], axis=1)

    def torque(self, m: tuple[np.ndarray, ...], v: np.ndarray) -> np.ndarray:
        """:meth:`unsaturated`, saturated."""
        return self.xp.clip(self.unsaturated(m, v), -self.limit, self.limit)

    def finish(self, k: int, a, e, de, m, state: Any) -> tuple[Any, Any]:
        """The torques from the desired accelerations, errors and model terms, and the
        next state."""
        return self.torque(m, a + self.kd * de + self.kp * e), state


class BatchFuzzyComputedTorque(BatchComputedTorque):
    """:class:`~controllers.fuzzy_ctc.FuzzyComputedTorque` for N arms sharing one engine
    and mode (scalings per arm)."""

    def __init__(self, controllers: Sequence[FuzzyComputedTorque], times: np.ndarray) -> None:
        super().__init__(controllers, times)
        self.engine = controllers[0].engine
        self.add = controllers[0].mode == "add"
        self.ke, self.kde, self.ku = _fuzzy_scalings(controllers)

    def finish(self, k: int, a, e, de, m, state: Any) -> tuple[Any, Any]:
        v = a + (self.kp * e + self.kd * de) if self.add else a
        u = _evaluate(self.engine, self.ke * e, self.kde * de, self.xp)
        return self.torque(m, v + self.ku * u), state


class BatchPDGravity(BatchComputedTorque):
    """:class:`~controllers.baselines.PDGravity` for N arms."""

    def __init__(self, controllers: Sequence[PDGravity], times: np.ndarray) -> None:
        super().__init__(controllers, times)
        self.scale = np.array([c.scale for c in controllers])

    def step(self, k: int, q, qd, state: Any) -> tuple[Any, Any]:
        xp = self.xp
        _, e, de = self.errors(k, q, qd)
        zero = xp.zeros_like(q[:, 0])
        _, _, _, g1, g2 = terms(self.model, q[:, 0], q[:, 1], zero, zero, cos=xp.cos, sin=xp.sin)
        tau = self.scale * (self.kp * e + self.kd * de) + xp.stack([g1, g2], axis=1)
        return xp.clip(tau, -self.limit, self.limit), state


class BatchIntegralComputedTorque(BatchComputedTorque):
    """:class:`~controllers.baselines.IntegralComputedTorque` for N arms: its integrators
    are this law's state, (N, 2), empty at the start of a run."""

    def __init__(self, controllers: Sequence[IntegralComputedTorque], times: np.ndarray) -> None:
        self.ki = np.array([c.ki for c in controllers])
        self.dt = np.array([[c.control_dt] for c in controllers])
        super().__init__(controllers, times)

    def initial(self) -> Any:
        return self.xp.zeros((len(self.ki), 2))

    def finish(self, k: int, a, e, de, m, state: Any) -> tuple[Any, Any]:
        xp, z = self.xp, state
        v = a + self.kd * de + self.kp * e + self.ki * z
        raw = self.unsaturated(m, v)
        tau = xp.clip(raw, -self.limit, self.limit)
        free = (tau == raw) | ((e > 0) != (raw > 0))  # anti-windup, as the scalar law
        return tau, xp.where(free, z + e * self.dt, z)


def _dot(rows: tuple, a) -> Any:
    """``sum(y * x for y, x in zip(rows, a.T))`` in the scalar laws' order (0 + first
    term, then each next one), per arm: a (N, 5)."""
    out = 0
    for i, y in enumerate(rows):
        out = out + y * a[:, i]
    return out


class _SlidingTerms(BatchComputedTorque):
    """What the Slotine-Li style laws share: the sliding variable s = de + Λ e and the
    regressor's rows at (q, qd, qdr = qd + s, qddr = qdd_d + Λ de), per arm."""

    def sliding(self, k: int, q, qd):
        a, e, de = self.errors(k, q, qd)
        s = de + self.lam * e
        r, b = qd + s, a + self.lam * de
        xp = self.xp
        row1, row2 = regressor_rows(
            q[:, 0], q[:, 1], qd[:, 0], qd[:, 1], r[:, 0], r[:, 1], b[:, 0], b[:, 1],
            cos=xp.cos, sin=xp.sin,
        )  # fmt: skip
        return s, row1, row2


class BatchAdaptiveComputedTorque(_SlidingTerms):
    """:class:`~controllers.adaptive.AdaptiveComputedTorque` for N arms: the estimates
    ``â`` are this law's state, (N, 5), the models' parameters at the start of a run."""

    def __init__(self, controllers: Sequence[AdaptiveComputedTorque], times: np.ndarray) -> None:
        self.a0 = np.array([c.a_nominal for c in controllers])
        super().__init__(controllers, times)
        self.lam = np.array([c.lam for c in controllers])
        self.k_d = np.array([c.k_d for c in controllers])
        self.gamma = np.array([c.gamma for c in controllers])
        self.low = np.array([c.low for c in controllers])
        self.high = np.array([c.high for c in controllers])
        self.dt = np.array([[c.control_dt] for c in controllers])

    def initial(self) -> Any:
        return self.xp.asarray(self.a0).copy() if self.xp is np else self.xp.asarray(self.a0)

    def step(self, k: int, q, qd, state: Any) -> tuple[Any, Any]:
        xp, a = self.xp, state
        s, row1, row2 = self.sliding(k, q, qd)
        raw = xp.stack([_dot(row1, a), _dot(row2, a)], axis=1) + self.k_d * s
        tau = xp.clip(raw, -self.limit, self.limit)
        y1 = xp.stack(xp.broadcast_arrays(*row1), axis=1)
        y2 = xp.stack(xp.broadcast_arrays(*row2), axis=1)
        step = a + self.dt * self.gamma * (y1 * s[:, :1] + y2 * s[:, 1:])
        new = xp.minimum(xp.maximum(step, self.low), self.high)
        free = xp.all(tau == raw, axis=1)[:, None]  # held while saturated, as the scalar law
        return tau, xp.where(free, new, a)


class BatchSlidingMode(_SlidingTerms):
    """:class:`~controllers.sliding.SlidingMode` for N arms (no state)."""

    def __init__(self, controllers: Sequence[SlidingMode], times: np.ndarray) -> None:
        super().__init__(controllers, times)
        self.lam = np.array([c.lam for c in controllers])
        self.a = np.array([c.a_model for c in controllers])
        self.gain = np.array([c.gain for c in controllers])
        self.phi = np.array([c.phi for c in controllers])

    def step(self, k: int, q, qd, state: Any) -> tuple[Any, Any]:
        xp = self.xp
        s, row1, row2 = self.sliding(k, q, qd)
        switch = self.gain * xp.clip(s / self.phi, -1.0, 1.0)
        raw = xp.stack([_dot(row1, self.a), _dot(row2, self.a)], axis=1) + switch
        return xp.clip(raw, -self.limit, self.limit), state


class BatchDisturbanceObserverCTC(BatchComputedTorque):
    """:class:`~controllers.observer.DisturbanceObserverCTC` for N arms: the observers'
    integrals are this law's state, (N, 2); NaN (the start of a run) is set to the first
    momentum, as the scalar law's None."""

    def __init__(self, controllers: Sequence[DisturbanceObserverCTC], times: np.ndarray) -> None:
        self.n_arms = len(controllers)
        super().__init__(controllers, times)
        self.observer_time = np.array([[c.observer_time] for c in controllers])
        self.dt = np.array([[c.control_dt] for c in controllers])

    def initial(self) -> Any:
        return self.xp.full((self.n_arms, 2), np.nan)

    def step(self, k: int, q, qd, state: Any) -> tuple[Any, Any]:
        xp = self.xp
        a, e, de = self.errors(k, q, qd)
        p1, p2, c1, c2, m11, m12, m22, n1, n2 = momentum_terms(
            self.model, q[:, 0], q[:, 1], qd[:, 0], qd[:, 1], cos=xp.cos, sin=xp.sin
        )
        p = xp.stack([p1, p2], axis=1)
        integral = xp.where(xp.isnan(state), p, state)
        d = (p - integral) / self.observer_time
        v = a + self.kd * de + self.kp * e
        v1, v2 = v[:, 0], v[:, 1]
        raw = xp.stack([m11 * v1 + m12 * v2 + n1, m12 * v1 + m22 * v2 + n2], axis=1) - d
        tau = xp.clip(raw, -self.limit, self.limit)
        drift = xp.stack(xp.broadcast_arrays(c1, c2), axis=1)
        return tau, integral + self.dt * (tau + drift + d)


class _SharedTerms:
    """Computed-torque laws of several kinds (CTC, CTC-I, fuzzy CTC) as one law: the
    reference errors and the model terms of all their arms are computed once per instant,
    on arms ordered law by law, and each law finishes its own contiguous slice. Per arm the
    arithmetic is the law's own (element-wise operations on longer arrays give the same
    numbers); what is saved is numpy's fixed cost per call, paid once instead of per law."""

    def __init__(
        self, parts: Sequence[tuple[BatchComputedTorque, Sequence[Any]]], times: np.ndarray
    ) -> None:
        controllers = [c for _, group in parts for c in group]
        self.reference = ReferenceTable([c.reference for c in controllers], times)
        self.model = _Models.stack(controllers)
        bounds = np.cumsum([0, *(len(group) for _, group in parts)])
        self.parts = [
            (slice(int(lo), int(hi)), law)
            for (law, _), lo, hi in zip(parts, bounds[:-1], bounds[1:], strict=True)
        ]

        self.state = self.initial()

    xp: Any = np
    errors = BatchComputedTorque.errors
    terms = BatchComputedTorque.terms
    __call__ = BatchComputedTorque.__call__

    def initial(self) -> Any:
        return tuple(law.initial() for _, law in self.parts)

    def step(self, k: int, q, qd, state: Any) -> tuple[Any, Any]:
        a, e, de = self.errors(k, q, qd)
        m = self.terms(q, qd)
        out, states = [], []
        for (sl, law), part in zip(self.parts, state, strict=True):
            tau, part = law.finish(k, a[sl], e[sl], de[sl], tuple(x[sl] for x in m), part)
            out.append(tau)
            states.append(part)
        return self.xp.concatenate(out, axis=0), tuple(states)


class BatchFuzzyPD(BatchComputedTorque):
    """:class:`~controllers.baselines.FuzzyPD` for N arms sharing one engine."""

    def __init__(self, controllers: Sequence[FuzzyPD], times: np.ndarray) -> None:
        super().__init__(controllers, times)
        self.engine = controllers[0].engine
        self.scale = np.array([c.scale for c in controllers])
        self.ke, self.kde, self.ku = _fuzzy_scalings(controllers)

    def step(self, k: int, q, qd, state: Any) -> tuple[Any, Any]:
        _, e, de = self.errors(k, q, qd)
        u = _evaluate(self.engine, self.ke * e, self.kde * de, self.xp)
        return self.xp.clip(self.scale * (self.ku * u), -self.limit, self.limit), state


def _evaluate(engine: Any, e, de, xp: Any):
    """The fuzzy term: on numpy the engine's compiled kernel (``evaluate_compiled``,
    controllers/fuzzy/kernels.py) for more than ``MIN_INPUTS`` inputs, else its numpy
    batch path; on another backend its array-namespace form (``evaluate_xp``)."""
    if xp is not np:
        return engine.evaluate_xp(e, de, xp)
    compiled = getattr(engine, "evaluate_compiled", None)
    if compiled is not None and e.size > kernels.MIN_INPUTS:
        return compiled(e, de)
    return engine.evaluate_batch(e, de)


def on_namespace(law: Any, xp: Any, dtype: Any = None) -> Any:
    """A copy of a batch law whose arithmetic runs on the array namespace ``xp`` (e.g.
    ``jax.numpy``): its arrays become ``xp`` arrays, its state starts afresh. Only the
    laws written for it (see the module's docstring) can be moved; any other raises
    TypeError. ``dtype``: the floating type of its arrays (default: float64)."""
    if not isinstance(law, (BatchComputedTorque, _SharedTerms)):
        raise TypeError(f"{type(law).__name__} runs on numpy only")
    return _moved(law, xp, dtype)


def _moved(obj: Any, xp: Any, dtype: Any = None) -> Any:
    import copy

    if isinstance(obj, np.ndarray):
        return xp.asarray(obj, dtype=dtype if dtype is not None and obj.dtype.kind == "f" else None)
    if isinstance(obj, (list, tuple)):
        return type(obj)(_moved(x, xp, dtype) for x in obj)
    if isinstance(obj, slice | int | float | bool | type(None)):
        return obj
    if isinstance(obj, _Models):
        return _Models(*(xp.asarray(getattr(obj, f), dtype=dtype) for f in "m1 m2 l1 l2 g".split()))
    if isinstance(obj, (ReferenceTable, BatchComputedTorque, _SharedTerms)):
        new = copy.copy(obj)
        for name, value in vars(obj).items():
            if name not in ("engine", "index", "state"):
                setattr(new, name, _moved(value, xp, dtype))
        new.xp = xp
        if hasattr(new, "initial"):
            new.state = new.initial()
        return new
    return obj


class _ArmByArm:
    """Any other controller, called once per arm (the scalar loop's call, unbatched). A
    controller that reads the motors (``needs_motor``) gets them, as in the scalar loop."""

    def __init__(self, controllers: Sequence[Controller], times: np.ndarray) -> None:
        self.controllers = list(controllers)
        self.times = times
        self.motor = [bool(getattr(c, "needs_motor", False)) for c in self.controllers]
        self.needs_motor = any(self.motor)

    def __call__(
        self,
        k: int,
        q: np.ndarray,
        qd: np.ndarray,
        motor_q: np.ndarray | None = None,
        motor_qd: np.ndarray | None = None,
    ) -> np.ndarray:
        t = float(self.times[k])
        out = []
        for i, (c, qi, wi) in enumerate(zip(self.controllers, q, qd, strict=True)):
            if self.motor[i]:
                m, md = tuple(motor_q[i].tolist()), tuple(motor_qd[i].tolist())
                out.append(c(t, tuple(qi.tolist()), tuple(wi.tolist()), m, md))
            else:
                out.append(c(t, tuple(qi.tolist()), tuple(wi.tolist())))
        return np.array(out, dtype=float).reshape(-1, 2)


def batched(c: Controller) -> bool:
    """Whether :func:`batch_laws` gives ``c`` a batch law, which keeps each arm's state in
    its own row. False: ``c`` is called arm by arm, so every arm needs its own object."""
    return _group_key(c)[0] is not _ArmByArm


def _group_key(c: Controller) -> tuple[Any, ...]:
    kind = type(c)
    if kind is FuzzyComputedTorque:
        return (kind, id(c.engine), c.mode)
    if kind is FuzzyPD:
        return (kind, id(c.engine))
    if kind in _LAWS or "batch_law" in vars(kind):  # a class may bring its own batch form
        return (kind,)
    return (_ArmByArm,)


# The kinds whose laws share one evaluation of the reference errors and model terms.
_SHARED_TERMS = (ComputedTorque, IntegralComputedTorque, FuzzyComputedTorque)

_LAWS: dict[type, type] = {
    ComputedTorque: BatchComputedTorque,
    FuzzyComputedTorque: BatchFuzzyComputedTorque,
    PDGravity: BatchPDGravity,
    IntegralComputedTorque: BatchIntegralComputedTorque,
    FuzzyPD: BatchFuzzyPD,
    AdaptiveComputedTorque: BatchAdaptiveComputedTorque,
    SlidingMode: BatchSlidingMode,
    DisturbanceObserverCTC: BatchDisturbanceObserverCTC,
    _ArmByArm: _ArmByArm,
}


def batch_laws(
    controllers: Sequence[Controller], times: np.ndarray
) -> list[tuple[np.ndarray, Any]]:
    """Group the arms' controllers into as few batch laws as possible.

    Returns ``(arm indices, law)`` pairs: ``law(k, q[idx], qd[idx])`` gives those arms'
    torques at ``times[k]`` (``law(k, q, qd, motor_q, motor_qd)`` for a law whose
    ``needs_motor`` is true: the flexible-joint controllers, ``controllers/flexible.py``,
    whose classes name their batch form as ``batch_law``). Fuzzy controllers are batched
    together when they share an engine object (the experiment layer builds one engine
    per rule base).
    """
    groups: dict[tuple[Any, ...], list[int]] = {}
    for i, c in enumerate(controllers):
        groups.setdefault(_group_key(c), []).append(i)
    laws, shared = [], []
    for key, idx in groups.items():
        law = _LAWS.get(key[0]) or vars(key[0])["batch_law"]
        members = [controllers[i] for i in idx]
        if key[0] in _SHARED_TERMS:
            shared.append((idx, law(members, times), members))
        else:
            laws.append((np.array(idx), law(members, times)))
    if len(shared) == 1:
        idx, law, _ = shared[0]
        laws.append((np.array(idx), law))
    elif shared:
        order = np.array([i for idx, _, _ in shared for i in idx])
        laws.append((order, _SharedTerms([(law, members) for _, law, members in shared], times)))
    return laws
