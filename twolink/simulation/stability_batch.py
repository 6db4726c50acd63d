"""The closed-loop linearisation of many runs at once: :func:`linearise_many` gives every
run the answer :func:`twolink.simulation.stability.linearise` gives it alone, with the
loops' map Φ evaluated for all of them on one MuJoCo model and the controllers' batch laws.

Alone, a linearisation is ~150 evaluations of Φ, each a Python call of the controller and
a MuJoCo step of a single arm (~25 µs each: ~4 ms a run, more than its simulation). Here
every run's Newton search for its rest state is a *lane*, one from the target and one from
the run's last state (``near``) where it has one, both searched at once (alone the second
starts only where the first fails: the answer is the first's where it converges, so it is
the same). A lane is one arm of a batch model (:func:`twolink.arm.plant.add_arm`, as the
batch engine builds its arms); each round evaluates Φ at a lane's point and its 2n
perturbations as 2n + 1 steps of that model, one point of every lane per step, with the
controllers' batch laws (``controllers/batch.py``, equal to the single laws to the bit,
``tests/test_batch_limits.py``), whose own state (CTC-I's integrators, feedback
linearisation's held torque) is set from the point and read back as the single path sets
and reads the controller's attributes. The arithmetic on the results (the residual, the
differences, the Newton step, the tests for a jump and a kink, the eigenvalues) is the
single path's, in the same order; a lane that converges takes one more round for its
finer one-sided differences, and leaves the model. When fewer than half of a model's
lanes still search, the model is rebuilt with those alone (a model's cost per step grows
with its arms).

The answer equals the single path's to the bit where MuJoCo steps an arm of a batch as it
does alone: every arm at the model's gravity (a model takes the largest |g| of its arms,
and an arm at another g is tilted, agreeing to rounding, ``docs/batch.md``); an arm off it
agrees to ~1e-10 in σ. Laws without a batch form, and any model that cannot be built, take
the single path, arm by arm (``tests/test_stability_batch.py``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from twolink.simulation.stability import (
    EPSILON,
    NEWTON_STEPS,
    REST_TOLERANCE,
    Linearisation,
    Setup,
    judge,
    linearise,
    prepare,
)

__all__ = ["MAX_LANES", "linearise_many"]

MAX_LANES = 160  # lanes per model: building one grows faster than linearly with its arms
NO_REST = "no rest state found near the target"


def _batchable() -> dict[type, tuple[str, ...]]:
    """The controller classes whose batch law this module drives, with their own state."""
    from twolink.controllers.baselines import FuzzyPD, IntegralComputedTorque, PDGravity
    from twolink.controllers.ctc import ComputedTorque
    from twolink.controllers.flexible import (
        CompositeControl,
        FlexibleFeedbackLinearisation,
        MotorPD,
    )
    from twolink.controllers.flexible_robust import IntegralFlexibleFeedbackLinearisation
    from twolink.controllers.fuzzy_ctc import FuzzyComputedTorque

    return {
        ComputedTorque: (),
        PDGravity: (),
        FuzzyComputedTorque: (),
        FuzzyPD: (),
        IntegralComputedTorque: ("z",),
        MotorPD: (),
        CompositeControl: (),
        FlexibleFeedbackLinearisation: ("held",),
        IntegralFlexibleFeedbackLinearisation: ("held", "z"),
    }


@dataclass(eq=False)
class _Run:
    """One run to linearise: its setup, its batch arm and the answer once known."""

    index: int
    scenario: Any
    controller: Any  # the caller's (the batch law is built from it)
    setup: Setup
    arm: Any  # twolink.simulation.batch.Arm
    lanes: list[_Lane] = field(default_factory=list)


@dataclass(eq=False)
class _Lane:
    """One Newton search of a run, from one of its starts."""

    run: _Run
    start: int
    x: np.ndarray
    steps: int = 0  # Newton steps taken
    phase: str = "newton"  # then "finer" (converged) or "failed" / "done"
    base: Any = None  # Φ(x) at the rest state
    central: Any = None  # its central differences
    one_sided: Any = None  # and one-sided ones ({1: forward, -1: backward})
    answer: Any = None  # the Linearisation (or the exception raised computing it)


def linearise_many(
    items: Sequence[tuple[Any, Any, Any]], eps: float = EPSILON
) -> list[Linearisation | Exception]:
    """:func:`~twolink.simulation.stability.linearise` of many runs: ``items`` are
    ``(scenario, controller, near)`` (``near`` as there, or None), and the answers come
    in their order; a run whose linearisation raises gets its exception."""
    from twolink.simulation.experiment import _arm

    out: list[Linearisation | Exception] = [Linearisation(math.nan)] * len(items)
    kinds = _batchable()
    groups: dict[tuple[Any, ...], list[_Run]] = {}
    for i, (s, c, near) in enumerate(items):
        try:
            flexible = s.plant.flexibility is not None
            nq = 4 if flexible else 2
            setup = prepare(s, c, near, flexible, nq, s.timestep)
            if isinstance(setup, Linearisation):
                out[i] = setup
                continue
            if kinds.get(type(c), None) != setup.fields or (setup.needs_motor and not flexible):
                out[i] = linearise(s, _plant(s), c, eps, near)  # no batch form: alone
                continue
            run = _Run(i, s, c, setup, _arm(s))
        except Exception as exc:  # this run's error, as alone
            out[i] = exc
            continue
        key = (s.timestep, setup.substeps, setup.t_hold, nq, setup.n, s.control_dt)
        groups.setdefault(key, []).append(run)
    for runs in groups.values():
        per_model = max(1, MAX_LANES // 2)
        for lo in range(0, len(runs), per_model):
            block = runs[lo : lo + per_model]
            try:
                _search(block, eps)
                for run in block:
                    out[run.index] = _answer(run)
            except Exception:  # e.g. MuJoCo refuses the model: each run alone
                for run in block:
                    try:
                        out[run.index] = _alone(run, eps)
                    except Exception as exc:
                        out[run.index] = exc
    return out


def _plant(s: Any) -> Any:
    from twolink.simulation.experiment import build_plant

    return build_plant(s)


def _alone(run: _Run, eps: float) -> Linearisation:
    """The single path's answer for a run (its ``near`` is its second start's state)."""
    s, setup = run.scenario, run.setup
    near = None
    if len(setup.starts) > 1:
        x = setup.starts[1]
        near = (x[:2], x[2:4] if setup.nq == 4 else ())
    return linearise(s, _plant(s), run.controller, eps, near)


def _answer(run: _Run) -> Linearisation | Exception:
    """The first start's answer where its search converged, else the second's."""
    for lane in run.lanes:
        if lane.phase == "done":
            return lane.answer
    return Linearisation(math.nan, NO_REST)


def _search(runs: list[_Run], eps: float) -> None:
    """Every run's Newton searches, its finer differences and its answer (on its lanes)."""
    for run in runs:
        run.lanes = [_Lane(run, k, x.copy()) for k, x in enumerate(run.setup.starts)]
    model = None
    while live := [lane for run in runs for lane in _live(run)]:
        if model is None or len(live) < len(model.lanes) // 2:
            model = _Model(live)  # fewer arms step faster
        _round(model, live, eps)


def _live(run: _Run) -> list[_Lane]:
    """The lanes of a run still to evaluate: the second start's only until the first has
    converged (the answer is then the first's, as alone)."""
    first = run.lanes[0]
    if first.phase in ("finer", "done"):
        return [first] if first.phase == "finer" else []
    return [lane for lane in run.lanes if lane.phase in ("newton", "finer")]


def _round(model: _Model, live: list[_Lane], eps: float) -> None:
    """Evaluate Φ at every live lane's points (its Newton point and its 2n central
    perturbations, or its 2n finer one-sided ones) and move each lane on."""
    n = model.setup.n
    slot = {id(lane): k for k, lane in enumerate(model.lanes)}
    points = np.zeros((len(model.lanes), 2 * n + 1, n))  # a slot out of use rests at 0
    newton = [lane for lane in live if lane.phase == "newton"]
    finer = [lane for lane in live if lane.phase == "finer"]
    for lanes, step in ((newton, eps), (finer, eps / 8)):
        if not lanes:
            continue
        rows = [slot[id(lane)] for lane in lanes]
        x = np.array([lane.x for lane in lanes])[:, None, :]
        dx = np.eye(n) * step  # row i: the single path's dx of x_i
        points[rows, 0] = x[:, 0]
        if step == eps:  # the central differences' points, as alone
            points[rows, 1 : 1 + n] = x + dx
            points[rows, 1 + n :] = x - dx
        else:  # the one-sided differences' (x + side dx)
            points[rows, 1 : 1 + n] = x + 1 * dx
            points[rows, 1 + n :] = x + -1 * dx
    values = model.advance(points, 0 if newton else 1)  # Φ(x) of a finer lane is known
    for lane in finer:
        _finish(lane, values[slot[id(lane)]], n, eps)
    if newton:
        _newton_steps(newton, values[[slot[id(lane)] for lane in newton]], n, eps)


def _newton_steps(lanes: list[_Lane], v: np.ndarray, n: int, eps: float) -> None:
    """One step of each lane's search (``rest_state`` of the single path) from Φ at its
    point and its perturbations, ``v`` (lanes, 2n + 1, n)."""
    x = np.array([lane.x for lane in lanes])
    residual = v[:, 0] - x
    plus, minus = v[:, 1 : 1 + n], v[:, 1 + n :]
    central = ((plus - minus) / (2 * eps)).transpose(0, 2, 1)  # column i: along x_i
    finite = np.isfinite(residual).all(axis=1)
    with np.errstate(invalid="ignore"):
        rest = finite & (np.abs(residual).max(axis=1) < REST_TOLERANCE)
    move = np.flatnonzero(finite & ~rest)
    try:
        delta = np.linalg.solve(central[move] - np.eye(n), residual[move][..., None])[..., 0]
    except np.linalg.LinAlgError:  # some are singular: each alone, as the single path
        delta = None
    for k, lane in enumerate(lanes):
        if not finite[k]:
            lane.phase = "failed"
        elif rest[k]:
            lane.phase = "finer"
            lane.base = v[k, 0]
            lane.central = central[k]
            lane.one_sided = {  # at the same points as the central differences
                1: ((plus[k] - lane.base) / (1 * eps)).T,
                -1: ((minus[k] - lane.base) / (-1 * eps)).T,
            }
    for j, k in enumerate(move):
        lane = lanes[k]
        if delta is not None:
            lane.x = x[k] - delta[j]
        else:
            try:
                lane.x = x[k] - np.linalg.solve(central[k] - np.eye(n), residual[k])
            except np.linalg.LinAlgError:
                lane.phase = "failed"
                continue
        lane.steps += 1
        if lane.steps == NEWTON_STEPS:
            lane.phase = "failed"


def _finish(lane: _Lane, v: np.ndarray, n: int, eps: float) -> None:
    """The answer of a converged lane from Φ at its finer points ``v`` (row 0 unused)."""
    finer = {
        1: ((v[1 : 1 + n] - lane.base) / (1 * (eps / 8))).T,
        -1: ((v[1 + n :] - lane.base) / (-1 * (eps / 8))).T,
    }
    try:
        lane.answer = judge(lane.central, lane.one_sided, finer, lane.run.scenario.control_dt)
    except Exception as exc:  # as alone: the run's error
        lane.answer = exc
    lane.phase = "done"


class _Model:
    """The batch model of a set of lanes: one arm per lane, each its run's arm, with the
    batch laws of the lanes' controllers (called at the hold instant)."""

    def __init__(self, lanes: list[_Lane]) -> None:
        import mujoco

        from twolink.arm.plant import add_arm, new_spec
        from twolink.controllers.batch import batch_laws
        from twolink.simulation.batch import model_gravity

        self.lanes = lanes
        runs = [lane.run for lane in lanes]
        setup = runs[0].setup
        arms = [run.arm for run in runs]
        g_model = model_gravity([a.params.g for a in arms])
        spec = new_spec(runs[0].scenario.timestep, g_model, "twolink_linearise")
        for i, a in enumerate(arms):  # as the batch engine builds its arms
            add_arm(
                spec,
                a.params,
                a.flexibility,
                a.payload,
                prefix=f"arm{i}_",
                model_g=g_model,
                visual=False,
                motors=False,
            )
        try:
            self.model = spec.compile()
        except ValueError as exc:
            why = " ".join(str(exc).split()).removeprefix("Error: ")
            raise ValueError(f"MuJoCo cannot build this batch of arms: {why}") from None
        self.data = mujoco.MjData(self.model)
        joint = mujoco.mjtObj.mjOBJ_JOINT

        def ids(names: tuple[str, str]) -> np.ndarray:
            return np.array(
                [
                    [mujoco.mj_name2id(self.model, joint, f"arm{i}_{n}") for n in names]
                    for i in range(len(arms))
                ]
            )

        links = ids(("theta1", "theta2"))
        self.q_index = self.model.jnt_qposadr[links]
        self.v_index = self.model.jnt_dofadr[links]
        self.flexible = setup.nq == 4
        if self.flexible:
            rotors = ids(("phi1", "phi2"))
            self.motor_index = self.model.jnt_qposadr[rotors]
            self.motor_v_index = self.model.jnt_dofadr[rotors]
        self.force_index = self.motor_v_index if self.flexible else self.v_index
        self.setup = setup
        self.times = np.array([setup.t_hold, setup.t_hold])  # called at instant 1: no reset
        self.laws = [
            (idx, law, _StateAdapter(law, [runs[i].setup.fields for i in idx]))
            for idx, law in batch_laws([run.controller for run in runs], self.times)
        ]

    def advance(self, points: np.ndarray, first: int = 0) -> np.ndarray:
        """Φ at ``points`` (lanes, k, n): each lane's k-th point on its arm, one step of
        the model per k from ``first`` on (the rows before it are left empty)."""
        import mujoco

        setup = self.setup
        nq, n_plant, n = setup.nq, setup.n_plant, setup.n
        out = np.empty_like(points)
        model, data = self.model, self.data
        qpos, qvel, force = data.qpos, data.qvel, data.qfrc_applied
        own_width = n - n_plant
        for k in range(first, points.shape[1]):
            x = points[:, k]
            qpos[self.q_index] = x[:, :2]
            qvel[self.v_index] = x[:, nq : nq + 2]
            if self.flexible:
                qpos[self.motor_index] = x[:, 2:4]
                qvel[self.motor_v_index] = x[:, nq + 2 : nq + 4]
            q, qd = x[:, :2], x[:, nq : nq + 2]
            tau = np.empty((len(x), 2))
            own = np.empty((len(x), own_width))
            for idx, law, adapter in self.laws:
                if adapter.motor:
                    args = (q[idx], qd[idx], x[idx, 2:4], x[idx, nq + 2 : nq + 4])
                else:
                    args = (q[idx], qd[idx])
                tau[idx], own[idx] = adapter.call(law, x[idx, n_plant:], args)
            force[self.force_index] = tau
            for _ in range(setup.substeps):
                mujoco.mj_step(model, data)
            res = out[:, k]
            res[:, :2] = qpos[self.q_index]
            res[:, nq : nq + 2] = qvel[self.v_index]
            if self.flexible:
                res[:, 2:4] = qpos[self.motor_index]
                res[:, nq + 2 : nq + 4] = qvel[self.motor_v_index]
            res[:, n_plant:] = own
        return out


class _StateAdapter:
    """Calls one batch law at the hold instant with its arms' own state set from their
    points, and reads it back: what the single path does with the controller's attributes
    (:func:`twolink.simulation.stability.internal_state`). ``fields``: each arm's."""

    def __init__(self, law: Any, fields: list[tuple[str, ...]]) -> None:
        from twolink.controllers import batch as cb
        from twolink.controllers.flexible import BatchFlexibleFeedbackLinearisation
        from twolink.controllers.flexible_robust import (
            BatchIntegralFlexibleFeedbackLinearisation,
        )

        self.motor = bool(getattr(law, "needs_motor", False))
        self.width = 2 * len(fields[0]) if fields else 0
        if isinstance(law, cb._SharedTerms):
            self.kind = "shared"
            self.parts = [
                (sl, isinstance(part, cb.BatchIntegralComputedTorque)) for sl, part in law.parts
            ]
        elif isinstance(law, cb.BatchIntegralComputedTorque):
            self.kind = "integral"
        elif isinstance(law, cb.BatchComputedTorque):
            self.kind = "stateless"
        elif isinstance(law, BatchIntegralFlexibleFeedbackLinearisation):
            self.kind = "held_z"
        elif isinstance(law, BatchFlexibleFeedbackLinearisation):
            self.kind = "held"
        else:
            self.kind = "call"

    def call(self, law: Any, own: np.ndarray, args: tuple) -> tuple[np.ndarray, np.ndarray]:
        """The torques of the law's arms and their own state after the call."""
        if self.kind == "shared":
            state = tuple(own[sl, 0:2] if integral else None for sl, integral in self.parts)
            tau, after = law.step(1, *args, state)
            new = np.empty_like(own)
            for (sl, integral), part in zip(self.parts, after, strict=True):
                if integral:
                    new[sl] = part
            return tau, new
        if self.kind == "integral":
            return law.step(1, *args, own[:, 0:2])
        if self.kind == "stateless":
            return law.step(1, *args, None)[0], own[:, :0]
        if self.kind == "held":
            law.held = own[:, 0:2].copy()
            tau = law(1, *args)
            return tau, law.held
        if self.kind == "held_z":
            law.held, law.z = own[:, 0:2].copy(), own[:, 2:4].copy()
            tau = law(1, *args)
            return tau, np.concatenate([law.held, law.z], axis=1)
        return law(1, *args), own[:, :0]
