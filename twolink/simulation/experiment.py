"""From a scenario to results: build the plant and controller, run, measure, write.

This is the glue the CLI, the reproduction and the sweeps share; it holds no physics
and no control law of its own.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from twolink.arm.plant import Plant, holding_motor_q
from twolink.controllers.base import Controller
from twolink.controllers.ctc import ComputedTorque
from twolink.simulation.config import FLEXIBLE_KINDS, LINK_KINDS, Scenario, resolve_rule_base
from twolink.simulation.metrics import (
    column_max,
    error_measures,
    metrics_dict,
    oscillation_amplitude,
    settling_time,
    step_metrics,
    torque_measures,
)
from twolink.simulation.sensor import Sensor
from twolink.simulation.sim import Trajectory, simulate
from twolink.simulation.vocabulary import format_value, joint_values


def build_plant(s: Scenario) -> Plant:
    """The simulated arm: the nominal arm with the scenario's uncertainty."""
    return Plant.build(
        s.plant_params,
        s.plant_joints,
        s.plant.payload,
        s.timestep,
        s.plant.friction,
        s.disturbance,
    )


def build_controller(s: Scenario) -> Controller:
    """The scenario's controller, modelled on the nominal arm."""
    c = s.controller
    common = dict(model=s.arm, reference=s.reference, kp=c.kp, kd=c.kd, torque_limit=c.torque_limit)
    if c.kind == "ctc":
        return ComputedTorque(**common)
    if c.kind in LINK_KINDS:  # they model the links that bend: [arm.links]
        from twolink.simulation.links_sim import links_law

        return links_law(s, common)
    if c.kind in FLEXIBLE_KINDS:  # they model the joints with the plant's own (identified)
        from twolink.controllers import flexible

        joints = s.plant.flexibility
        if c.kind == "motor_pd":
            return flexible.MotorPD(**common, joints=joints)
        if c.kind == "composite":
            return flexible.CompositeControl(**common, joints=joints)
        if c.kind == "flexible_fl_kalman":  # it assumes the scenario's encoders (or 17-bit)
            from twolink.controllers.flexible_observed import (
                DEFAULT_RESOLUTION,
                ObservedIntegralFlexibleFeedbackLinearisation,
            )

            return ObservedIntegralFlexibleFeedbackLinearisation(
                **common,
                joints=joints,
                control_dt=s.control_dt,
                resolution_rad=s.sensor.resolution_rad or DEFAULT_RESOLUTION,
            )
        if c.kind == "flexible_fl_integral":
            from twolink.controllers.flexible_robust import IntegralFlexibleFeedbackLinearisation

            return IntegralFlexibleFeedbackLinearisation(
                **common, joints=joints, control_dt=s.control_dt
            )
        return flexible.FlexibleFeedbackLinearisation(
            **common, joints=joints, control_dt=s.control_dt
        )
    from twolink.controllers import baselines

    if c.kind == "pd_gravity":
        return baselines.PDGravity(**common)
    if c.kind == "ctc_integral":
        return baselines.IntegralComputedTorque(**common, ki=c.ki, control_dt=s.control_dt)
    if c.kind == "adaptive_ctc":
        from twolink.controllers.adaptive import AdaptiveComputedTorque

        return AdaptiveComputedTorque(**common, gamma=c.gamma, control_dt=s.control_dt)
    if c.kind == "sliding_mode":
        from twolink.controllers.sliding import SlidingMode

        return SlidingMode(**common, eta=c.eta, phi=c.phi)
    if c.kind == "ctc_dob":
        from twolink.controllers.observer import DisturbanceObserverCTC

        return DisturbanceObserverCTC(
            **common, observer_time=c.observer_time, control_dt=s.control_dt
        )
    if c.kind == "fuzzy_ctc":
        engine = _engine(None)
    else:
        path = resolve_rule_base(c.rule_base, s.source).resolve()
        stat = path.stat()
        engine = _engine(str(path), stat.st_mtime_ns, stat.st_size)
    f = c.fuzzy
    if f.inference == "continuous":
        engine = _continuous(engine)
    if f.engine == "table":
        engine = _table(engine, f.table_points)
    if c.kind == "fuzzy_pd":
        return baselines.FuzzyPD(**common, engine=engine, ke=f.ke, kde=f.kde, ku=f.ku)
    from twolink.controllers.fuzzy_ctc import FuzzyComputedTorque

    return FuzzyComputedTorque(**common, engine=engine, ke=f.ke, kde=f.kde, ku=f.ku, mode=f.mode)


@functools.lru_cache(maxsize=32)
def _engine(rule_base: str | None, *version: int):
    """The engine of a rule-base file (None: the 7x7 heuristic; a .fis that is not the
    project's 7-label partition: its :class:`~controllers.fuzzy.fis.matlab.FisTerm`), built
    once per file version: controllers of one rule base share their engine, which is what lets the
    batch engine run them as one law (``controllers/batch.py``)."""
    from twolink.controllers import fuzzy
    from twolink.controllers.fuzzy.fis.matlab import rule_base_engine

    if rule_base is None:
        return fuzzy.default_fuzzy_pd()
    return rule_base_engine(rule_base)  # any two-input .fis too (docs/fuzzy.md)


@functools.lru_cache(maxsize=32)
def _continuous(engine):
    """The continuous inference of a cached engine's rules (shared like it)."""
    from twolink.controllers.fuzzy.continuous import ContinuousEngine

    return ContinuousEngine(engine)


@functools.lru_cache(maxsize=32)
def _table(engine, points: int):
    """The lookup table of a cached engine (one per engine and size, shared like it)."""
    from twolink.controllers.fuzzy.table import FuzzyTable

    return FuzzyTable(engine, points)


def measurement_noise(s: Scenario) -> np.ndarray | None:
    """Seeded Gaussian noise on the measured angles, or None when the scenario has none."""
    if s.sensor.noise_std_rad == 0:
        return None
    n = round(s.duration / s.control_dt)
    return np.random.default_rng(s.seed).normal(0.0, s.sensor.noise_std_rad, size=(n + 1, 2))


def run_scenario(
    s: Scenario, controller: Controller | None = None, plant: Plant | None = None
) -> Trajectory:
    """Simulate the scenario (deterministic for its seed). A flexible arm starts as its
    ``[plant.flexibility] start`` says (:func:`start_motor_q`, from the scenario's plant:
    a ``plant`` passed in must be :func:`build_plant`'s). Links that bend (``[arm.links]``)
    run in :func:`twolink.simulation.links_sim.simulate_links`: the law reads the hubs."""
    if s.links is not None:
        from twolink.simulation.links_sim import run_links

        return run_links(s, controller or build_controller(s)).trajectory
    plant = plant or build_plant(s)
    return simulate(
        plant,
        controller or build_controller(s),
        s.duration,
        control_dt=s.control_dt,
        q0=s.q0,
        qd0=s.qd0,
        noise=measurement_noise(s),
        motor_q0=start_motor_q(s),
        sensor=s.sensor,
    )


def holding_start(s: Scenario) -> bool:
    """Whether the scenario's arm starts with its springs holding it at rest (a flexible
    arm whose ``[plant.flexibility] start`` is "holding", the default)."""
    return s.plant.flexibility is not None and s.plant.springs == "holding"


def start_motor_q(s: Scenario) -> tuple[float, float] | None:
    """The rotor angles a scenario's arm starts with: twisted to hold the simulated arm
    (its own gravity and payload, not the controller's model) at rest at q0 for a holding
    start (:func:`twolink.arm.plant.holding_motor_q`), else None (at the links, or rigid)."""
    if not holding_start(s):
        return None
    phi = holding_motor_q(s.plant_params, s.plant_joints, s.q0, s.plant.payload)
    return (float(phi[0]), float(phi[1]))


# The batch engines: MuJoCo on the CPU; MJX (MuJoCo in JAX) in float64 or float32.
BACKENDS = ("cpu", "mjx", "mjx-float32")
BATCH_RECORD_BYTES = 256 * 2**20  # one batch's records (and noise): peak RSS < 1 GB


def run_scenarios(
    scenarios: Sequence[Scenario],
    controllers: Sequence[Controller] | None = None,
    backend: str = "cpu",
    model_g: float | None = None,
) -> list[Trajectory | Exception]:
    """Every trajectory of :func:`iter_scenarios`, in order (all of them in memory: for
    many arms, iterate instead)."""
    results: list[Trajectory | Exception] = [ValueError("not run")] * len(scenarios)
    for i, traj in iter_scenarios(scenarios, controllers, backend, model_g):
        results[i] = traj
    return results


def iter_scenarios(
    scenarios: Sequence[Scenario],
    controllers: Sequence[Controller] | None = None,
    backend: str = "cpu",
    model_g: float | None = None,
    link_runs: bool = False,
) -> Iterator[tuple[int, Trajectory | Exception]]:
    """Simulate many scenarios on the batch engine (:mod:`twolink.simulation.batch`), yielding
    ``(i, trajectory)`` as each batch ends: arm i is ``scenarios[i]`` under
    ``controllers[i]`` (default: each scenario's own), and its trajectory equals
    :func:`run_scenario`'s. Arms sharing a timestep, control period and sensor run in batches
    whose records stay under :data:`BATCH_RECORD_BYTES`, and a trajectory is made only
    when yielded, so memory stays bounded whatever the number of scenarios. An arm that
    cannot be built (MuJoCo refuses it) yields its exception; the others still run.
    ``backend``: "cpu" (MuJoCo, :mod:`twolink.simulation.batch`), or "mjx" / "mjx-float32"
    (MuJoCo's accelerator backend, :mod:`twolink.simulation.mjx_engine`, in float64 /
    float32). ``link_runs``: a bending-link arm yields its whole
    :class:`twolink.simulation.links_sim.LinkRun` (the tip too), not its trajectory.

    ``model_g``: the gravity of every batch's model, which an arm off it is tilted against
    (:func:`twolink.simulation.batch.batch_model`); None: the largest |g| of all
    ``scenarios``, so no arm's run depends on how the arms were split into batches. A
    caller that splits one set of runs over several calls (a sweep's chunks) passes the
    same ``model_g`` to each (:meth:`twolink.sweep.plan.SweepPlan.model_gravity`). An arm
    of larger |g| than ``model_g`` yields a ValueError.
    """
    from twolink.simulation.batch import model_gravity, record_bytes

    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {list(BACKENDS)}, got {backend!r}")
    controllers = controllers or [build_controller(s) for s in scenarios]
    if model_g is None:
        model_g = model_gravity([s.plant_params.g for s in scenarios if s.links is None])
    bending = [i for i, s in enumerate(scenarios) if s.links is not None]
    if bending:  # links that bend: their own batches (twolink.simulation.links_sim)
        if backend != "cpu":
            raise ValueError(f"links that bend ([arm.links]) run on the cpu backend, not {backend}")
        from twolink.simulation.links_sim import iter_links_scenarios

        yield from iter_links_scenarios(scenarios, controllers, bending, whole=link_runs)
    groups: dict[tuple[float, float, Sensor], list[int]] = {}
    for i, s in enumerate(scenarios):
        if s.links is None:
            groups.setdefault((s.timestep, s.control_dt, s.sensor), []).append(i)
    for (timestep, control_dt, sensor), members in groups.items():
        cost = max(_arm_bytes(scenarios[i], control_dt, record_bytes) for i in members)
        size = max(1, BATCH_RECORD_BYTES // cost)
        for start in range(0, len(members), size):
            batch = members[start : start + size]
            yield from _trajectories(
                *_simulate_batch(
                    scenarios, controllers, batch, timestep, control_dt, sensor, backend, model_g
                )
            )


def _simulate_batch(
    scenarios: Sequence[Scenario],
    controllers: Sequence[Controller],
    members: list[int],
    timestep: float,
    control_dt: float,
    sensor: Sensor,
    backend: str = "cpu",
    model_g: float | None = None,
) -> tuple[list[tuple[int, Exception]], list[int], Any]:
    """One batch of :func:`iter_scenarios`: the arms MuJoCo refuses with their errors, and
    the arms simulated with their records (a :class:`twolink.simulation.batch.BatchResult`)."""
    from twolink.simulation.batch import BatchPlant, simulate_batch

    errors: list[tuple[int, Exception]] = []
    arms = {}
    for i in members:
        try:
            arms[i] = _arm(scenarios[i])
        except Exception as exc:  # this arm's error, not the batch's
            errors.append((i, exc))
    if backend != "cpu":
        return errors, *_simulate_batch_mjx(
            scenarios, controllers, arms, timestep, control_dt, sensor, backend, errors, model_g
        )
    try:
        plant = BatchPlant(list(arms.values()), timestep, model_g) if arms else None
    except ValueError:  # find the arms MuJoCo refuses; run the rest
        for i in list(arms):
            try:
                BatchPlant([arms[i]], timestep, model_g)
            except ValueError as exc:
                del arms[i]
                errors.append((i, exc))
        plant = BatchPlant(list(arms.values()), timestep, model_g) if arms else None
    if plant is None:
        return errors, [], None
    batch = list(arms)
    run = simulate_batch(
        plant,
        [controllers[i] for i in batch],
        [scenarios[i].duration for i in batch],
        control_dt,
        q0=np.array([scenarios[i].q0 for i in batch]),
        qd0=np.array([scenarios[i].qd0 for i in batch]),
        noise=[measurement_noise(scenarios[i]) for i in batch],
        holding=np.array([holding_start(scenarios[i]) for i in batch]),
        sensor=sensor,
    )
    return errors, batch, run


def _simulate_batch_mjx(
    scenarios: Sequence[Scenario],
    controllers: Sequence[Controller],
    arms: dict[int, Any],
    timestep: float,
    control_dt: float,
    sensor: Sensor,
    backend: str,
    errors: list[tuple[int, Exception]],
    model_g: float | None = None,
) -> tuple[list[int], Any]:
    """:func:`_simulate_batch` on MJX (the arms MuJoCo refuses are added to ``errors``)."""
    from twolink.simulation.mjx_engine import arm_model, simulate_batch_mjx

    models = {}
    for i in list(arms):
        try:
            models[i] = arm_model(arms[i], timestep, model_g)
        except ValueError as exc:
            del arms[i]
            errors.append((i, exc))
    batch = list(arms)
    if not batch:
        return [], None
    run = simulate_batch_mjx(
        [arms[i] for i in batch],
        timestep,
        [controllers[i] for i in batch],
        [scenarios[i].duration for i in batch],
        control_dt,
        q0=np.array([scenarios[i].q0 for i in batch]),
        qd0=np.array([scenarios[i].qd0 for i in batch]),
        noise=[measurement_noise(scenarios[i]) for i in batch],
        sensor=sensor,
        precision="float32" if backend == "mjx-float32" else "float64",
        models=[models[i] for i in batch],
        model_g=model_g,
    )
    return batch, run


def _trajectories(
    errors: list[tuple[int, Exception]], batch: list[int], run: Any
) -> Iterator[tuple[int, Trajectory | Exception]]:
    """A simulated batch's ``(i, trajectory)``, each made only when it is asked for."""
    yield from errors
    for k, i in enumerate(batch):
        yield i, run.trajectory(k)


def _arm_bytes(s: Scenario, control_dt: float, record_bytes) -> int:
    """Memory one arm of ``s`` takes in a batch: its records, and its noise if any."""
    steps = round(s.duration / control_dt)
    noise = (steps + 1) * 2 * 8 * 2 if s.sensor.noise_std_rad else 0  # drawn, then stacked
    return record_bytes(steps, bool(s.plant.flexibility)) + noise


def _arm(s: Scenario):
    from twolink.simulation.batch import Arm

    if s.links is not None:
        raise ValueError(f"{s.name}: links that bend ([arm.links]) run one at a time, not batched")
    return Arm(s.plant_params, s.plant_joints, s.plant.payload, s.plant.friction, s.disturbance)


@dataclass(frozen=True)
class RunMetrics:
    """Everything measured on one run. ``step[j]`` is None where joint j has no step."""

    step: tuple[Any, Any]
    errors: Any
    torque: Any
    status: str
    message: str
    # The mean |θ_target − θ| per joint over the settling window: against the target (the
    # reference's final value), not the reference at T, so a run cut short is as far off as
    # it is (|e| for a sine); a mean, not one sample, so a cycle is not read at one phase
    final_error: tuple[float, float] = (math.nan, math.nan)
    # Over the settling window (twolink.simulation.outcome.settling_window): the largest
    # |θ_target − θ| per joint, and the growth of the error (twolink.simulation.outcome.tail_growth)
    tail_error: tuple[float, float] = (math.nan, math.nan)
    tail_growth: tuple[float, float] = (math.nan, math.nan)
    # The closed loop's growth rate σ [1/s] linearised at its rest state near the target
    # (twolink.simulation.stability), the loop's, shown for both joints; NaN where the loop
    # has no linearisation there (a relay, no rest state found, a sensor with dynamics)
    linear_growth: tuple[float, float] = (math.nan, math.nan)
    # Fuzzy laws: the share of samples where the fuzzy term's output is not 0 (it acts),
    # per joint, on the run's errors; NaN for laws without a fuzzy term
    fuzzy_active: tuple[float, float] = (math.nan, math.nan)
    oscillation: tuple[float, float] = (math.nan, math.nan)  # sustained, per joint
    # Ts to the target (within 2 % of the step of θd's final value), NaN where it never gets
    # there or the joint has no step; ``step[j].settling_time`` is Ts to the final value.
    settling_target: tuple[float, float] = (math.nan, math.nan)
    # Flexible joints: the largest spring twist |φ − θ| per joint (NaN for the rigid arm);
    # beyond twolink.arm.params.TWIST_LIMIT the joint is no physical spring (``warnings``).
    max_twist: tuple[float, float] = (math.nan, math.nan)
    # MuJoCo's warnings during the run (an unstable step), in words: Trajectory.warnings
    mujoco_warnings: tuple[str, ...] = ()

    @property
    def warnings(self) -> list[str]:
        """Physically meaningless states of the run, and MuJoCo's warnings during it, in
        words (empty when none)."""
        from twolink.arm.params import TWIST_LIMIT

        return [
            f"joint {j} spring twisted by {twist:.3g} rad, beyond the {TWIST_LIMIT} rad a real "
            "elastic joint takes (docs/model.md, 'Realistic joints')"
            for j, twist in enumerate(self.max_twist, start=1)
            if twist > TWIST_LIMIT
        ] + list(self.mujoco_warnings)

    def table(self) -> Any:
        """Every metric by key (rows) for both joints (columns), as a pandas DataFrame:
        what a terminal (``print``) and a notebook (an HTML table) show."""
        import pandas as pd

        return pd.DataFrame({f"joint{j}": joint_values(self, j) for j in (1, 2)})

    def __str__(self) -> str:
        values = self.table().map(format_value)
        return f"{self.status}{': ' + self.message if self.message else ''}\n{values}"

    def _repr_html_(self) -> str:
        return f"<p>{self.status} {self.message}</p>" + self.table().map(format_value).to_html()

    def to_dict(self, controller: str = "", outcome: str = "") -> dict[str, Any]:
        """``metrics.json``: status, outcome (``twolink.simulation.outcome``), and every metric of
        each joint by its key (``twolink.simulation.vocabulary``); undefined values are ``null``."""
        return metrics_dict(
            controller=controller,
            status=self.status,
            outcome=outcome,
            message=self.message,
            joint1=joint_values(self, 1),
            joint2=joint_values(self, 2),
            max_twist_rad=list(self.max_twist),
            warnings=self.warnings,
        )


def measure(s: Scenario, traj: Trajectory, controller: Controller | None = None) -> RunMetrics:
    """Step metrics per joint (towards the reference's final value, Ts both to the final
    value and to the target), error measures (integrals, max |e|), torque, oscillation,
    the settling window's error and growth, and the loop's linear growth rate at its rest
    state (every law, every plant but links that bend, whose NaN says "not linearised":
    :mod:`twolink.simulation.stability` models rigid links), of ``controller``
    (default: the scenario's; a sweep's arms carry their own). :func:`measure_runs` measures
    many runs at once, linearising their loops together."""
    growth = math.nan
    if controller is None:
        controller = build_controller(s)
    if traj.ok and s.links is None:  # every law, every rigid-link plant
        from twolink.simulation.stability import closed_loop_growth

        growth = closed_loop_growth(s, build_plant(s), controller, near=rest_guess(traj))
    return Measured.of(s, traj, controller).finish(growth)


def rest_guess(traj: Trajectory) -> tuple[Any, Any]:
    """Where a run's loop may rest, for its linearisation: its last link and rotor angles
    (copies: a view would keep the run's whole record alive)."""
    return (traj.q[-1].copy(), traj.motor_q[-1].copy() if len(traj.motor_q) else ())


@dataclass(frozen=True)
class Measured:
    """A run measured but for its loop's linear growth rate (which the settling window's
    growth depends on, ``_tail``): :meth:`finish` with it gives :func:`measure`'s metrics."""

    metrics: dict[str, Any]  # RunMetrics' fields but linear_growth and the tail's
    tails: tuple[dict[str, Any], dict[str, Any]]  # the tail without and with ``settling``

    @classmethod
    def of(cls, s: Scenario, traj: Trajectory, controller: Controller) -> Measured:
        steps = []
        to_target = []
        for j, target in enumerate(s.reference.final):
            moves = np.isfinite(target) and target != s.q0[j]
            steps.append(step_metrics(traj.t, traj.q[:, j], target, y0=s.q0[j]) if moves else None)
            # Ts to the target: step_metrics(..., final_value=target).settling_time
            to_target.append(
                settling_time(traj.t, traj.q[:, j], target, s.q0[j]) if moves else math.nan
            )
        metrics = dict(
            step=(steps[0], steps[1]),
            errors=error_measures(traj.t, traj.e),
            torque=torque_measures(traj.tau),
            status=traj.status,
            message=traj.message,
            fuzzy_active=fuzzy_active_share(controller, traj),
            oscillation=_oscillation(s, traj),
            settling_target=(to_target[0], to_target[1]),
            max_twist=max_twist(traj),
            mujoco_warnings=traj.warnings,
        )
        return cls(metrics, _tails(s, traj))

    def finish(self, growth: float) -> RunMetrics:
        """The run's metrics, its loop's growth rate σ [1/s] given (NaN: none)."""
        tail = self.tails[1] if growth < 0 else self.tails[0]
        return RunMetrics(**self.metrics, **tail, linear_growth=(growth, growth))


def measure_runs(
    runs: Iterator[tuple[Scenario, Trajectory, Controller]],
) -> list[RunMetrics | Exception]:
    """:func:`measure` of many runs, ``(scenario, trajectory, controller)`` (a trajectory
    is dropped once measured: an iterator of them keeps one in memory at a time), with
    their loops linearised together (:func:`twolink.simulation.stability_batch.linearise_many`:
    the same answers, at a fraction of the cost). A run whose measuring raises gets the
    exception :func:`measure` would raise."""
    from twolink.simulation.stability_batch import linearise_many

    measured: list[Measured | Exception] = []
    requests, asked = [], []
    for i, (s, traj, controller) in enumerate(runs):
        try:
            measured.append(Measured.of(s, traj, controller))
        except Exception as exc:
            measured.append(exc)
        if traj.ok and s.links is None:  # its linearisation's error comes first, as in measure
            requests.append((s, controller, rest_guess(traj)))
            asked.append(i)
    growth: dict[int, Any] = dict(zip(asked, linearise_many(requests), strict=True))
    out: list[RunMetrics | Exception] = []
    for i, part in enumerate(measured):
        answer = growth.get(i)
        if isinstance(answer, Exception):
            out.append(answer)
        elif isinstance(part, Exception):
            out.append(part)
        else:
            out.append(part.finish(math.nan if answer is None else answer.sigma))
    return out


def _oscillation(s: Scenario, traj: Trajectory) -> tuple[float, float]:
    """The oscillation at the end of the run, of the turns after its reference stopped
    (the move's own tracking error is no swing of it)."""
    from twolink.simulation.outcome import reference_end

    if not len(traj.t):
        return (math.nan, math.nan)
    since = reference_end(s.reference)
    return oscillation_amplitude(  # type: ignore[return-value]
        traj.t, traj.e, since=since if math.isfinite(since) else -math.inf
    )


# The fuzzy term acts where its normalised output exceeds this: the centroid of the Z label
# alone (a rule firing at rest) is 4e-17 from rounding, not an action.
FUZZY_ACTS = 1e-9


def fuzzy_active_share(controller: Controller | None, traj: Trajectory) -> tuple[float, float]:
    """Per joint, the share of a run's samples where ``controller``'s fuzzy term acts: its
    engine's output on the run's (scaled) error and error rate exceeds :data:`FUZZY_ACTS`
    of its full scale. NaN for a law
    without a fuzzy term, or a run whose errors are not finite (it diverged). Where the
    term is 0 the fuzzy law is its CTC (issue: the designed rule base fires on no sample
    of the nominal quintic moves, so FCM-CTC equals CTC there)."""
    engine = getattr(controller, "engine", None)
    e, de = traj.e, traj.de
    if engine is None or not len(traj.t) or not (np.isfinite(e).all() and np.isfinite(de).all()):
        return (math.nan, math.nan)
    u = _fuzzy_output(engine, controller.ke * e, controller.kde * de)  # type: ignore[union-attr]
    acts = np.abs(np.asarray(u)) > FUZZY_ACTS
    # np.mean(acts, axis=0): a count, exact in any order, over the samples
    share = np.count_nonzero(np.ascontiguousarray(acts.T), axis=1) / acts.shape[0]
    return (float(share[0]), float(share[1]))


# |u| this close to FUZZY_ACTS is decided by the engine's own numpy path (below)
_UNDECIDED = 1e-10


def _fuzzy_output(engine: Any, e: np.ndarray, de: np.ndarray) -> np.ndarray:
    """``engine(e, de)`` as far as :func:`fuzzy_active_share` reads it (|u| against
    :data:`FUZZY_ACTS`), at a fraction of the cost where the engine's compiled kernel is
    loaded (a sweep's worker: the batch laws load it; a single run never imports numba).
    The kernel equals the engines' pure-Python path to the bit, and their numpy path, which
    ``engine(e, de)`` takes here, to 1e-12 (the exact Mamdani engine; the table and the
    continuous inference to the bit; ``controllers/fuzzy/kernels.py``): where some |u| lies
    within 1e-10 of the threshold the numpy path decides, so the share is the same."""
    import sys

    compiled = getattr(engine, "evaluate_compiled", None)
    if compiled is None or "numba" not in sys.modules:
        return engine(e, de)
    from twolink.controllers.fuzzy import kernels

    if not kernels.available():
        return engine(e, de)
    u = compiled(e, de)
    if np.any(np.abs(np.abs(u) - FUZZY_ACTS) <= _UNDECIDED):
        return engine(e, de)
    return u


def _tail(s: Scenario, traj: Trajectory, settling: bool = False) -> dict[str, tuple[float, float]]:
    """The final error (the settling window's mean |error|), the window's largest error and
    its growth, per joint, all against the target (twolink.simulation.outcome); with
    ``settling`` (the loop's linearisation at its rest state is stable) a trend that
    accelerates away at the end is a transient not yet turned, not growth (NaN)."""
    return _tails(s, traj)[1 if settling else 0]


def _tails(s: Scenario, traj: Trajectory) -> tuple[dict[str, Any], dict[str, Any]]:
    """:func:`_tail` without and with ``settling``, from one pass over the record."""
    from twolink.simulation.outcome import reference_end, settling_window, tail_growths

    if not len(traj.t):
        nan = (math.nan, math.nan)
        empty = {"final_error": nan, "tail_error": nan, "tail_growth": nan}
        return empty, dict(empty)
    target = np.array(s.reference.final, dtype=float)
    off = np.where(np.isfinite(target), target - traj.q, traj.e)  # a sine: e itself
    window = settling_window(s.duration)
    tail = traj.t >= traj.t[-1] - window - 1e-12
    with np.errstate(invalid="ignore"):
        size = np.abs(off[tail])
        worst = column_max(size)
        mean = size.mean(axis=0)  # over the window, not one sample
    since = reference_end(s.reference) if hasattr(s.reference, "joint1") else -math.inf
    since = since if math.isfinite(since) else -math.inf
    common = {
        "final_error": tuple(float(x) for x in mean),
        "tail_error": tuple(float(x) for x in worst),
    }
    return tuple(  # type: ignore[return-value]
        {**common, "tail_growth": tuple(float(x) for x in growth)}
        for growth in tail_growths(traj.t, off, window, since)
    )


def max_twist(traj: Trajectory) -> tuple[float, float]:
    """The largest |φ − θ| per joint over a run (NaN for the rigid arm, or where the
    twist was never finite)."""
    twist = np.abs(traj.twist)
    if not len(twist):
        return (math.nan, math.nan)
    finite = np.where(np.isfinite(twist), twist, -np.inf).max(axis=0)
    return tuple(float(x) if np.isfinite(x) else math.nan for x in finite)  # type: ignore[return-value]


TRACE_EVERY = 5  # recordings at 200 Hz: smooth to watch; trajectory.npz keeps every sample


def trace_extras(
    controller: Controller, traj: Trajectory, centres: Any = (), centre_labels: Any = ()
) -> dict[str, Any]:
    """Phase-plane extras of a fuzzy run for its recording: the engine's normalised view,
    the fired rule at each sample and, if given, FCM cluster centres, named by
    ``centre_labels`` (the reproduction: each centre's kept rule). Empty for CTC."""
    engine = getattr(controller, "engine", None)
    if engine is None:
        return {}
    from twolink.controllers.fuzzy import fired_rule_labels

    ke, kde = controller.ke, controller.kde
    extras: dict[str, Any] = {
        "phase_scale": (ke, kde),
        "fired_rules": fired_rule_labels(engine, ke * traj.e, kde * traj.de),
    }
    if len(centres):
        extras["centres"] = np.array(centres, dtype=float)
        if len(centre_labels):
            extras["centre_labels"] = [str(n) for n in centre_labels]
    return extras
