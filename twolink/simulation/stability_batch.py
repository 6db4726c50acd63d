"""The closed-loop linearisation of many runs at once: :func:`linearise_many` gives every
run the answer :func:`twolink.simulation.stability.linearise` gives it alone, with the
loops' map Φ evaluated for all of them on one MuJoCo model and the controllers' batch laws.

Alone, a linearisation is ~150 evaluations of Φ, each a Python call of the controller and
a MuJoCo step of a single arm (~25 µs each: ~4 ms a run, more than its simulation). Here
every run is an arm of one batch model (:func:`twolink.arm.plant.add_arm`, as the batch
engine builds its arms; a model with few runs holds several copies of each, ``SLOTS``),
under its controller's batch law (``controllers/batch.py``, equal to the single laws to
the bit, ``tests/test_batch_limits.py``), whose own state (CTC-I's integrators, feedback
linearisation's held torque) is set from each point and read back as the single path sets
and reads the controller's attributes. A round evaluates Φ at every run's Newton point and
its 2n perturbations (or, once its search has converged, its 2n finer one-sided ones),
one point of every arm per step of the model. The arithmetic on the results (the
residual, the differences, the Newton step, the tests for a jump and a kink, the
eigenvalues) is the single path's, in the same order; a run searches from its second
start (``near``) only where the first fails, as alone. When fewer than a third of a
model's runs are still searching, the model is rebuilt with those alone, more copies of
each (a step costs ~0.2 ms whatever its arms: the fewer steps a round, the better).

The answer equals the single path's to the bit: MuJoCo steps an arm of a batch as it does
alone where the arm is at its model's gravity (``docs/batch.md``), so runs of different g
get models of their own (one tilted into a model of another g agrees to rounding only,
~2e-9 in σ once the differences amplify it, measured). Laws without a batch form, and any model
that cannot be built, take the single path, run by run (``tests/test_stability_batch.py``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
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

__all__ = ["linearise_many"]

MAX_ARMS = 600  # runs per model: building one grows faster than linearly with its arms
SHRINK = 3  # a model is rebuilt when fewer than a third of its runs are still searched
SLOTS = 128  # arms a model is given at least, where it has few runs (copies of each)
NO_REST = "no rest state found near the target"


def _batchable() -> dict[type, tuple[str, ...]]:
    """The controller classes whose batch law this module drives, with their own state."""
    from twolink.controllers.adaptive import AdaptiveComputedTorque
    from twolink.controllers.baselines import FuzzyPD, IntegralComputedTorque, PDGravity
    from twolink.controllers.ctc import ComputedTorque
    from twolink.controllers.flexible import (
        CompositeControl,
        FlexibleFeedbackLinearisation,
        MotorPD,
    )
    from twolink.controllers.flexible_robust import IntegralFlexibleFeedbackLinearisation
    from twolink.controllers.fuzzy_ctc import FuzzyComputedTorque
    from twolink.controllers.observer import DisturbanceObserverCTC
    from twolink.controllers.sliding import SlidingMode

    return {
        AdaptiveComputedTorque: ("a_hat",),
        SlidingMode: (),
        DisturbanceObserverCTC: ("integral",),
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
    """One run to linearise and its search: from its first start, then (where that
    fails) from its second, as alone; then its finer differences and its answer."""

    index: int
    scenario: Any
    controller: Any  # the caller's (the batch law is built from it)
    near: Any
    setup: Setup
    arm: Any  # twolink.simulation.batch.Arm
    start: int = 0  # the start searched from
    x: Any = None  # the search's point
    steps: int = 0  # Newton steps taken from this start
    phase: str = "newton"  # then "finer" (converged), then "done"
    base: Any = None  # Φ(x) at the rest state
    central: Any = None  # its central differences
    one_sided: Any = None  # and one-sided ones ({1: forward, -1: backward})
    answer: Any = None  # the Linearisation (or the exception raised computing it)

    def fail(self) -> None:
        """This start's search failed: the next start, or no rest state."""
        self.start += 1
        self.steps = 0
        if self.start < len(self.setup.starts):
            self.x = self.setup.starts[self.start].copy()
        else:
            self.phase, self.answer = "done", Linearisation(math.nan, NO_REST)


# The search evaluates the loop from points far from any rest state, where a law's
# arithmetic may overflow (w² of a runaway): expected, not printed; such a point has no
# finite answer and the search reports "no rest state" (NaN σ, the run's record).
@np.errstate(over="ignore", invalid="ignore", divide="ignore")
def linearise_many(
    items: Sequence[tuple[Any, Any, Any]], eps: float = EPSILON
) -> list[Linearisation | Exception]:
    """:func:`~twolink.simulation.stability.linearise` of many runs: ``items`` are
    ``(scenario, controller, near)`` (``near`` as there, or None), and the answers come
    in their order; a run whose linearisation raises gets its exception."""
    from twolink.simulation.batch import Arm

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
            arm = Arm(s.plant_params, s.plant_joints, s.plant.payload)  # experiment._arm's
            run = _Run(i, s, c, near, setup, arm, x=setup.starts[0].copy())
        except Exception as exc:  # this run's error, as alone
            out[i] = exc
            continue
        # one model per gravity: an arm off its model's g would be tilted, equal only to
        # rounding (~2e-9 in σ, the differences amplifying it), not to the bit
        key = (s.timestep, setup.substeps, setup.t_hold, nq, setup.n, s.control_dt, arm.params.g)
        groups.setdefault(key, []).append(run)
    for runs in groups.values():
        for lo in range(0, len(runs), MAX_ARMS):
            block = runs[lo : lo + MAX_ARMS]
            try:
                _search(block, eps)
                for run in block:
                    out[run.index] = run.answer
            except Exception:  # e.g. MuJoCo refuses the model: each run alone
                for run in block:
                    try:
                        out[run.index] = linearise(
                            run.scenario, _plant(run.scenario), run.controller, eps, run.near
                        )
                    except Exception as exc:
                        out[run.index] = exc
    return out


def _plant(s: Any) -> Any:
    """The scenario's single arm (``experiment.build_plant``'s)."""
    from twolink.arm.plant import Plant

    return Plant.build(s.plant_params, s.plant_joints, s.plant.payload, s.timestep)


def _search(runs: list[_Run], eps: float) -> None:
    """Every run's search, finer differences and answer, a round at a time."""
    model = None
    while live := [run for run in runs if run.phase != "done"]:
        if model is None or len(live) * SHRINK < len(model.runs):
            model = _Model(live)  # fewer arms step faster
        _round(model, live, eps)


def _round(model: _Model, live: list[_Run], eps: float) -> None:
    """Evaluate Φ at every live run's points (its Newton point and its 2n central
    perturbations, or its 2n finer one-sided ones) and move each run on."""
    n = model.setup.n
    points = np.zeros((len(model.runs), 2 * n + 1, n))  # a slot out of use rests at 0
    newton = [run for run in live if run.phase == "newton"]
    finer = [run for run in live if run.phase == "finer"]
    for runs, step in ((newton, eps), (finer, eps / 8)):
        if not runs:
            continue
        rows = [model.slot[id(run)] for run in runs]
        x = np.array([run.x for run in runs])[:, None, :]
        dx = np.eye(n) * step  # row i: the single path's dx of x_i
        points[rows, 0] = x[:, 0]
        if step == eps:  # the central differences' points, as alone
            points[rows, 1 : 1 + n] = x + dx
            points[rows, 1 + n :] = x - dx
        else:  # the one-sided differences' (x + side dx)
            points[rows, 1 : 1 + n] = x + 1 * dx
            points[rows, 1 + n :] = x + -1 * dx
    values = model.advance(points, 0 if newton else 1)  # Φ(x) of a finer run is known
    for run in finer:
        _finish(run, values[model.slot[id(run)]], n, eps)
    if newton:
        _newton_steps(newton, values[[model.slot[id(run)] for run in newton]], n, eps)


def _newton_steps(runs: list[_Run], v: np.ndarray, n: int, eps: float) -> None:
    """One step of each run's search (``rest_state`` of the single path) from Φ at its
    point and its perturbations, ``v`` (runs, 2n + 1, n)."""
    x = np.array([run.x for run in runs])
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
    for k, run in enumerate(runs):
        if not finite[k]:
            run.fail()
        elif rest[k]:
            run.phase = "finer"
            run.base = v[k, 0]
            run.central = central[k]
            run.one_sided = {  # at the same points as the central differences
                1: ((plus[k] - run.base) / (1 * eps)).T,
                -1: ((minus[k] - run.base) / (-1 * eps)).T,
            }
    for j, k in enumerate(move):
        run = runs[k]
        if delta is not None:
            run.x = x[k] - delta[j]
        else:
            try:
                run.x = x[k] - np.linalg.solve(central[k] - np.eye(n), residual[k])
            except np.linalg.LinAlgError:
                run.fail()
                continue
        run.steps += 1
        if run.steps == NEWTON_STEPS:
            run.fail()


def _finish(run: _Run, v: np.ndarray, n: int, eps: float) -> None:
    """The answer of a converged run from Φ at its finer points ``v`` (row 0 unused)."""
    finer = {
        1: ((v[1 : 1 + n] - run.base) / (1 * (eps / 8))).T,
        -1: ((v[1 + n :] - run.base) / (-1 * (eps / 8))).T,
    }
    try:
        run.answer = judge(run.central, run.one_sided, finer, run.scenario.control_dt)
    except Exception as exc:  # as alone: the run's error
        run.answer = exc
    run.phase = "done"


class _Model:
    """The batch model of a set of runs: ``reps`` arms per run, each the run's arm, with
    the batch laws of the runs' controllers (called at the hold instant). A step
    evaluates ``reps`` of each run's points at once."""

    def __init__(self, runs: list[_Run]) -> None:
        import mujoco

        from twolink.controllers.batch import batch_laws
        from twolink.simulation.batch import batch_model

        self.runs = runs
        self.slot = {id(run): k for k, run in enumerate(runs)}
        setup = runs[0].setup
        # few runs: a copy of each per point, so a round takes fewer steps (a step costs
        # ~0.2 ms whatever its arms, an arm ~1 µs a step and ~0.05 ms to build)
        self.reps = max(1, min(2 * setup.n + 1, SLOTS // len(runs)))
        slots = [run for run in runs for _ in range(self.reps)]
        arms = [run.arm for run in slots]
        self.model = batch_model(arms, runs[0].scenario.timestep, "twolink_linearise")
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
            (idx, law, _StateAdapter(law, [slots[i].setup.fields for i in idx]))
            for idx, law in batch_laws([run.controller for run in slots], self.times)
        ]
        for _, law, _ in self.laws:
            for part in [law, *(part for _, part in getattr(law, "parts", ()))]:
                if _compiles(getattr(part, "engine", None)):
                    part.engine = _Compiled(part.engine)

    def advance(self, points: np.ndarray, first: int = 0) -> np.ndarray:
        """Φ at ``points`` (runs, k, n): each run's k-th point (from ``first`` on; the
        rows before it are left empty) on its arm, ``reps`` of them a step."""
        runs, count, n = points.shape
        reps = self.reps
        steps = -(-(count - first) // reps)
        padded = np.zeros((runs, steps * reps, n))  # a slot out of use rests at 0
        padded[:, : count - first] = points[:, first:]
        # slot (run, r) takes the points r, r + reps, ...: one per step
        layout = padded.reshape(runs, steps, reps, n).transpose(0, 2, 1, 3)
        values = self._steps(layout.reshape(runs * reps, steps, n))
        values = values.reshape(runs, reps, steps, n).transpose(0, 2, 1, 3)
        out = np.empty_like(points)
        out[:, first:] = values.reshape(runs, steps * reps, n)[:, : count - first]
        return out

    def _steps(self, points: np.ndarray) -> np.ndarray:
        """Φ at ``points`` (slots, k, n): one step of the model per k."""
        import mujoco

        setup = self.setup
        nq, n_plant, n = setup.nq, setup.n_plant, setup.n
        out = np.empty_like(points)
        model, data = self.model, self.data
        qpos, qvel, force = data.qpos, data.qvel, data.qfrc_applied
        own_width = n - n_plant
        for k in range(points.shape[1]):
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
        elif isinstance(law, (cb.BatchAdaptiveComputedTorque, cb.BatchDisturbanceObserverCTC)):
            self.kind = "stepped"  # its whole state in and out of step(), any width
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
        if self.kind == "stepped":
            return law.step(1, *args, own)
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


def _compiles(engine: Any) -> bool:
    """Whether ``engine`` is the exact Mamdani engine and its compiled kernel is at hand."""
    from twolink.controllers.fuzzy import kernels
    from twolink.controllers.fuzzy.engine import MamdaniEngine

    return type(engine) is MamdaniEngine and kernels.available()


class _Compiled:
    """A Mamdani engine whose batch call is its compiled kernel at any size: the batch
    laws call the pure-Python path for up to 64 inputs (``kernels.MIN_INPUTS``: a numba
    import spared), the kernel beyond; both equal the single loop's path to the bit
    (``controllers/fuzzy/kernels.py``), the kernel at ~1/20 of the cost."""

    def __init__(self, engine: Any) -> None:
        self.engine = engine
        self.evaluate_batch = self.evaluate_compiled = engine.evaluate_compiled

    def __getattr__(self, name: str) -> Any:
        return getattr(self.engine, name)
