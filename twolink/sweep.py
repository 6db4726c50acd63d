"""Monte Carlo robustness sweeps: many drawn plants, every controller on each, in parallel.

A sweep file (TOML) names a base scenario, distributions over plant parameters, the
controllers to compare and how many samples to draw. Sample ``i`` draws its parameters
from ``numpy.random.default_rng([seed, i])``, so a sample is the same whatever the
execution order, the executor or ``samples``; every controller runs on the same drawn
plant. See ``docs/sweeps.md`` for the schema and the output folder.

Schema::

    name = "robustness"                 # optional; default: the file's stem
    scenario = "../paper/base.toml"     # base scenario file, relative to this file
    samples = 200                       # N >= 1
    seed = 0                            # >= 0
    chunk_size = 10                     # samples per task and per chunk file, >= 1

    [overrides]                         # optional: any scenario keys, merged over the base
    duration = 10.0
    [reference.joint1]                  # optional: merged over the scenario's [reference]
    kind = "step"
    final = 1.0

    [parameters]                        # what each sample draws
    m1 = { dist = "uniform", low = 0.8, high = 1.2 }        # scale factor on arm.m1
    g = { dist = "normal", mean = 1.0, std = 0.02 }         # scale factor on arm.g
    payload = { dist = "choice", values = [0.0, 0.2, 0.5] } # kg at the tip
    k = { dist = "loguniform", low = 20.0, high = 2e4 }     # joint stiffness, both joints
    d1 = { dist = "grid", values = [0.1, 1.0] }             # joint 1 damping

    [controllers.ctc]                   # name = overrides of the scenario's [controller]
    kind = "ctc"
    [controllers.fcm]
    kind = "fcm_ctc"
    rule_base = "paper"

    [execution]                         # optional defaults for the command-line options
    executor = "process"                # "inprocess", "process" or "dask"
    workers = 4
    scheduler = "tcp://10.0.0.1:8786"

Parameters: ``m1 m2 l1 l2 g`` are factors on the nominal arm (they replace the base's
``plant.scale`` entry); ``payload`` is a tip mass [kg]; ``k d j`` set the flexible joints'
stiffness [N m/rad], damping [N m s/rad] and rotor inertia [kg m^2] of both joints, ``k1 k2
d1 d2 j1 j2`` one joint's. Sweeping any of them makes the plant flexible (the controllers
keep the rigid model). Distributions: ``uniform`` (low, high), ``loguniform`` (low, high),
``normal`` (mean, std, optional low/high truncation by rejection), ``choice`` (values,
optional weights), ``grid`` (values: sample i takes the (i mod size)-th point of the full
grid over all grid parameters, the first parameter by name varying fastest).
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import os
import re
import signal
import sys
import time
import tomllib
from collections.abc import Iterator, Mapping, Sequence
from concurrent import futures
from contextlib import contextmanager
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
import numpy as np

from twolink.config import ConfigError, TomlTable, merge, read_toml, scenario_from_dict
from twolink.executors import (
    EXECUTORS,
    ExecutorError,
    SweepExecutor,
    check_options,
    open_executor,
)
from twolink.experiment import (
    build_controller,
    build_plant,
    measure,
    resolve_rule_base,
    run_scenario,
)
from twolink.io import atomic_path, atomic_write_json, atomic_write_text
from twolink.metrics import StepMetrics
from twolink.params import Flexibility

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "DISTRIBUTIONS",
    "PARAMETERS",
    "ChunkResult",
    "Parameter",
    "SweepInterrupted",
    "SweepOutcome",
    "SweepPlan",
    "SweepResults",
    "flexible_study_figure",
    "flexible_study_table",
    "format_summary",
    "load_results",
    "load_sweep",
    "run_chunk",
    "run_sweep",
    "save_sweep_plots",
    "summarize",
    "sweep_command",
    "sweep_figures",
]

FORMAT_VERSION = 1  # of the chunk files and the manifest: part of the sweep's digest
DISTRIBUTIONS = ("uniform", "loguniform", "normal", "choice", "grid")
SCALE_PARAMETERS = ("m1", "m2", "l1", "l2", "g")
FLEX_PARAMETERS = ("k", "d", "j")
# name -> domain of the drawn value: "positive" (> 0), "nonnegative" (>= 0) or "any".
PARAMETERS: Mapping[str, str] = {
    "m1": "positive",
    "m2": "positive",
    "l1": "positive",
    "l2": "positive",
    "g": "any",
    "payload": "nonnegative",
    **{f"{p}{j}": dom for p, dom in zip("kdj", ("positive", "nonnegative", "positive"), strict=True)
       for j in ("", "1", "2")},
}  # fmt: skip
FLEX_NAMES = frozenset(f"{p}{j}" for p in FLEX_PARAMETERS for j in ("", "1", "2"))
STEP_FIELDS = tuple(f.name for f in fields(StepMetrics))
JOINT_FIELDS = (*STEP_FIELDS, "iae", "ise", "itae", "torque_rms", "torque_peak")
METRIC_COLUMNS = tuple(f"joint{j}_{f}" for j in (1, 2) for f in JOINT_FIELDS)
SUMMARY_METRICS = ("steady_state_error", "overshoot", "settling_time")
METRIC_LABELS = {
    "steady_state_error": "ess [rad]",
    "overshoot": "Mp [fraction]",
    "settling_time": "Ts [s]",
}
STATUS_ERROR = "error"  # a sample that raised (the simulation's own are "ok", "diverged")
NAME_RE = re.compile(r"^[A-Za-z0-9_.-]+$")
TRUNCATION_TRIES = 10_000


# ----------------------------------------------------------------------------- the plan


@dataclass(frozen=True)
class Parameter:
    """One swept plant parameter and its distribution.

    Attributes
    ----------
    name : str
        A key of :data:`PARAMETERS`.
    dist : str
        One of :data:`DISTRIBUTIONS`.
    low, high : float or None
        Bounds (uniform, loguniform; optional truncation of normal).
    mean, std : float or None
        Normal distribution.
    values, weights : tuple of float
        Choice and grid points; optional choice weights.
    """

    name: str
    dist: str
    low: float | None = None
    high: float | None = None
    mean: float | None = None
    std: float | None = None
    values: tuple[float, ...] = ()
    weights: tuple[float, ...] = ()

    def draw(self, rng: np.random.Generator) -> float:
        """Draw one value (not for "grid", whose value comes from the sample index)."""
        if self.dist == "uniform":
            return float(rng.uniform(self.low, self.high))
        if self.dist == "loguniform":
            return float(math.exp(rng.uniform(math.log(self.low), math.log(self.high))))
        if self.dist == "choice":
            p = None
            if self.weights:
                w = np.asarray(self.weights)
                p = w / w.sum()
            return float(self.values[int(rng.choice(len(self.values), p=p))])
        if self.dist == "normal":
            lo = -math.inf if self.low is None else self.low
            hi = math.inf if self.high is None else self.high
            for _ in range(TRUNCATION_TRIES):
                x = float(rng.normal(self.mean, self.std))
                if lo <= x <= hi:
                    return x
            raise ValueError(
                f"{self.name}: no draw of normal({self.mean}, {self.std}) fell in "
                f"[{lo}, {hi}] in {TRUNCATION_TRIES} tries"
            )
        raise ValueError(f"{self.name}: {self.dist!r} values are not drawn")


@dataclass(frozen=True)
class Execution:
    """The sweep file's defaults for how to run (not part of what is computed)."""

    executor: str = "process"
    workers: int | None = None
    scheduler: str | None = None


@dataclass(frozen=True)
class SweepPlan:
    """A validated sweep: everything a worker needs to compute any chunk.

    Attributes
    ----------
    name : str
        Default output folder name.
    file : str
        The sweep file it was read from.
    samples, seed, chunk_size : int
        N, the seed of every draw, and samples per chunk.
    base : dict
        The resolved base scenario as plain data, with the sweep's overrides and
        reference merged in and relative rule-base paths made absolute.
    controllers : tuple of (str, dict)
        Controller name and its overrides of the scenario's ``[controller]`` table.
    parameters : tuple of Parameter
        Sorted by name; random draws are taken in this order.
    execution : Execution
        The file's defaults for the executor.
    digest : str
        SHA-256 of everything that decides the results except ``samples``: chunks written
        under one digest are valid for any ``samples``.
    file_sha256 : str
        SHA-256 of the sweep file's bytes (recorded for the record).
    joints : tuple of int
        Joints (1, 2) whose reference is a move, i.e. that have step metrics.
    """

    name: str
    file: str
    samples: int
    seed: int
    chunk_size: int
    base: dict[str, Any]
    controllers: tuple[tuple[str, dict[str, Any]], ...]
    parameters: tuple[Parameter, ...]
    execution: Execution = field(default_factory=Execution)
    digest: str = ""
    file_sha256: str = ""
    joints: tuple[int, ...] = (1, 2)

    @property
    def controller_names(self) -> tuple[str, ...]:
        return tuple(name for name, _ in self.controllers)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def columns(self) -> tuple[str, ...]:
        """Columns of the results table, in order."""
        return ("sample", "controller", *self.parameter_names, *METRIC_COLUMNS, "status", "message")

    @property
    def n_chunks(self) -> int:
        return -(-self.samples // self.chunk_size)

    def chunk_samples(self, chunk: int) -> range:
        """Sample indices of chunk ``chunk`` (the last chunk may be short)."""
        return range(chunk * self.chunk_size, min((chunk + 1) * self.chunk_size, self.samples))

    def draw(self, i: int) -> tuple[dict[str, float], int]:
        """Parameter values of sample ``i`` and its measurement-noise seed.

        Grid parameters come from ``i``; the others are drawn, in name order, from
        ``default_rng([seed, i])``, and the noise seed is drawn after them.
        """
        values: dict[str, float] = {}
        k = i
        for p in self.parameters:
            if p.dist == "grid":
                values[p.name] = p.values[k % len(p.values)]
                k //= len(p.values)
        rng = np.random.default_rng([self.seed, i])
        for p in self.parameters:
            if p.dist != "grid":
                values[p.name] = p.draw(rng)
        noise_seed = int(rng.integers(0, 2**31))
        return {p.name: values[p.name] for p in self.parameters}, noise_seed

    def sample_data(self, values: Mapping[str, float], noise_seed: int) -> dict[str, Any]:
        """The scenario data of a sample: the base with the drawn plant."""
        plant: dict[str, Any] = {}
        scale = {n: v for n, v in values.items() if n in SCALE_PARAMETERS}
        if scale:
            plant["scale"] = scale
        if "payload" in values:
            plant["payload"] = values["payload"]
        if any(n in FLEX_NAMES for n in values):
            current = self.base.get("plant", {}).get("flexibility", {})
            flex: dict[str, list[float]] = {}
            for p in FLEX_PARAMETERS:
                default = getattr(Flexibility(), p)
                pair = current.get(p, default)
                flex[p] = list(pair) if isinstance(pair, list | tuple) else [pair, pair]
                if p in values:
                    flex[p] = [values[p], values[p]]
                for j in (1, 2):
                    if f"{p}{j}" in values:
                        flex[p][j - 1] = values[f"{p}{j}"]
            plant["flexibility"] = flex
        return merge(self.base, {"plant": plant, "seed": noise_seed})

    def controller_data(self, name: str) -> dict[str, Any]:
        """The base scenario with controller ``name``'s overrides."""
        return merge(self.base, {"controller": dict(self.controllers)[name]})


# ----------------------------------------------------------------------------- reading


def _strip_source(exc: ConfigError, source: str) -> str:
    message = str(exc)
    return message[len(source) + 2 :] if message.startswith(f"{source}: ") else message


def _check_value(t: TomlTable, key: str, value: Any, domain: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        t.fail(key, f"must be a number, got {value!r}")
    if not math.isfinite(value):
        t.fail(key, f"must be finite, got {value!r}")
    if domain == "positive" and not value > 0:
        t.fail(key, f"must be > 0 for parameter {t.where.split('.')[-1]!r}, got {value!r}")
    if domain == "nonnegative" and value < 0:
        t.fail(key, f"must be >= 0 for parameter {t.where.split('.')[-1]!r}, got {value!r}")
    return float(value)


def _number_list(t: TomlTable, key: str, domain: str) -> tuple[float, ...]:
    values = t.raw(key)
    if values is None:
        t.fail(key, "missing: a list of numbers")
    if not isinstance(values, list) or not values:
        t.fail(key, f"must be a non-empty list of numbers, got {values!r}")
    return tuple(_check_value(t, key, v, domain) for v in values)


def _parameter(name: str, data: Any, file: str) -> Parameter:
    t = TomlTable(data, f"parameters.{name}", file)
    domain = PARAMETERS[name]
    dist = t.raw("dist")
    if dist is None:
        t.fail("dist", f"missing: one of {list(DISTRIBUTIONS)}")
    if dist not in DISTRIBUTIONS:
        t.fail("dist", f"must be one of {list(DISTRIBUTIONS)}, got {dist!r}")
    known = {
        "uniform": ("low", "high"),
        "loguniform": ("low", "high"),
        "normal": ("mean", "std", "low", "high"),
        "choice": ("values", "weights"),
        "grid": ("values",),
    }[dist]
    for key in t.data:  # a misspelt key first: it explains a "missing" one
        if key not in ("dist", *known):
            t.fail(key, f"unknown key for {dist} (known: {['dist', *known]})")

    def need(key: str, dom: str = domain) -> float:
        if key not in t.data:
            t.fail(key, f"missing: {dist} needs it")
        return _check_value(t, key, t.raw(key), dom)

    if dist in ("uniform", "loguniform"):
        low = need("low", "positive" if dist == "loguniform" else domain)
        high = need("high", "positive" if dist == "loguniform" else domain)
        if low > high:
            t.fail("high", f"must be >= low ({low}): the distribution is empty, got {high}")
        p = Parameter(name, dist, low=low, high=high)
    elif dist == "normal":
        mean = need("mean", "any")
        std = need("std", "nonnegative")
        low = need("low") if "low" in t.data else None
        high = need("high") if "high" in t.data else None
        if low is None and domain != "any":
            t.fail("low", f"missing: a normal draw of {name!r} can be negative; truncate it")
        if low is not None and high is not None and low > high:
            t.fail("high", f"must be >= low ({low}): the distribution is empty, got {high}")
        if (low is not None and mean < low) or (high is not None and mean > high):
            t.fail("mean", f"must lie within the truncation [{low}, {high}], got {mean}")
        p = Parameter(name, dist, low=low, high=high, mean=mean, std=std)
    else:
        values = _number_list(t, "values", domain)
        weights: tuple[float, ...] = ()
        if dist == "choice" and "weights" in t.data:
            weights = _number_list(t, "weights", "nonnegative")
            if len(weights) != len(values):
                t.fail("weights", f"must have {len(values)} entries (one per value)")
            if sum(weights) <= 0:
                t.fail("weights", "must not all be zero")
        p = Parameter(name, dist, values=values, weights=weights)
    t.done()
    return p


def _absolute_rule_base(controller: dict[str, Any], relative_to: Path) -> dict[str, Any]:
    name = controller.get("rule_base")
    if isinstance(name, str) and name not in ("paper", "designed", "default"):
        controller = {**controller, "rule_base": str(resolve_rule_base(name, relative_to))}
    return controller


def _rule_base_hashes(plan_controllers: Sequence[tuple[str, dict]], base: dict) -> dict:
    # The rule bases are data that decide results: a changed file is a changed sweep.
    out = {}
    for name, over in plan_controllers:
        ctrl = merge(base.get("controller", {}), over)
        if ctrl.get("kind") != "fcm_ctc":
            continue
        path = resolve_rule_base(ctrl.get("rule_base", "paper"))
        if path.is_file():
            out[name] = hashlib.sha256(path.read_bytes()).hexdigest()
    return out


def load_sweep(path: str | Path, overrides: Mapping[str, Any] | None = None) -> SweepPlan:
    """Read and validate a sweep file.

    Parameters
    ----------
    path : str or Path
        The sweep file (TOML).
    overrides : mapping, optional
        Merged over the file's data before validation (e.g. ``{"samples": 10}``).

    Returns
    -------
    SweepPlan

    Raises
    ------
    ConfigError
        The file or its base scenario is invalid; the message names the file and key.
    """
    path = Path(path)
    file = str(path)
    if not path.is_file():
        raise ConfigError(f"{file}: no such file")
    raw = path.read_bytes()
    try:
        data = tomllib.loads(raw.decode())
    except (ValueError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{file}: not valid TOML: {exc}") from None
    if overrides:
        data = merge(data, dict(overrides))
    top = TomlTable(data, "", file)
    name = top.string("name", path.stem)
    if not NAME_RE.match(name):
        top.fail("name", f"must be letters, digits, '_', '-', '.' (a folder name), got {name!r}")
    scenario_path = top.raw("scenario")
    if scenario_path is None:
        top.fail("scenario", "missing: the base scenario file, relative to the sweep file")
    if not isinstance(scenario_path, str):
        top.fail("scenario", f"must be a file path, got {scenario_path!r}")
    samples = top.raw("samples")
    if samples is None:
        top.fail("samples", "missing: the number of samples N >= 1")
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
        top.fail("samples", f"must be an integer >= 1, got {samples!r}")
    seed = top.integer("seed", 0)
    chunk_size = top.raw("chunk_size", 10)
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, int) or chunk_size < 1:
        top.fail("chunk_size", f"must be an integer >= 1, got {chunk_size!r}")

    ex = top.table("execution")
    workers = ex.raw("workers")
    if workers is not None and (
        isinstance(workers, bool) or not isinstance(workers, int) or workers < 1
    ):
        ex.fail("workers", f"must be an integer >= 1, got {workers!r}")
    scheduler = ex.raw("scheduler")
    if scheduler is not None and not isinstance(scheduler, str):
        ex.fail("scheduler", f"must be an address string, got {scheduler!r}")
    execution = Execution(
        executor=ex.string("executor", "dask" if scheduler else "process", EXECUTORS),
        workers=workers,
        scheduler=scheduler,
    )
    if scheduler and execution.executor != "dask":
        ex.fail("scheduler", f"needs executor = 'dask', not {execution.executor!r}")
    ex.done()

    # The base scenario: its own errors name its own file.
    base_path = path.parent / scenario_path
    try:
        base = read_toml(base_path)
        scenario_from_dict(base, str(base_path))
    except ConfigError as exc:
        top.fail("scenario", str(exc))
    if "controller" in base:
        base["controller"] = _absolute_rule_base(base["controller"], base_path)
    for key in ("overrides", "reference"):
        over = top.raw(key, {})
        if not isinstance(over, dict):
            top.fail(key, f"must be a table, got {over!r}")
        merged = merge(base, over if key == "overrides" else {"reference": over})
        if key == "overrides" and "controller" in over:
            merged["controller"] = _absolute_rule_base(merged["controller"], path)
        try:
            scenario_from_dict(merged, file)
        except ConfigError as exc:
            problem = _strip_source(exc, file)
            # A reference error already names its key ("reference.joint1.final: ...").
            raise ConfigError(
                f"{file}: {problem}" if key == "reference" else f"{file}: {key}.{problem}"
            ) from None
        base = merged

    pt = top.table("parameters")
    for pname in pt.data:
        if pname not in PARAMETERS:
            pt.fail(pname, f"unknown parameter (known: {sorted(PARAMETERS)})")
    for p in FLEX_PARAMETERS:
        both = [f"{p}{j}" for j in (1, 2) if f"{p}{j}" in pt.data]
        if p in pt.data and both:
            pt.fail(both[0], f"conflicts with {p!r}, which sets both joints")
    parameters = tuple(_parameter(n, pt.raw(n), file) for n in sorted(pt.data))
    pt.done()

    ct = top.table("controllers")
    if not ct.data:
        top.fail("controllers", "missing: at least one [controllers.<name>] table")
    controllers = []
    for cname in ct.data:
        over = ct.raw(cname)
        where = f"controllers.{cname}"
        if not NAME_RE.match(cname):
            top.fail(where, "a controller name must be letters, digits, '_', '-', '.'")
        if not isinstance(over, dict):
            top.fail(where, f"must be a table of [controller] overrides, got {over!r}")
        over = _absolute_rule_base(over, path)
        try:
            scenario_from_dict(merge(base, {"controller": over}), file)
        except ConfigError as exc:
            problem = _strip_source(exc, file)
            if problem.startswith("controller."):
                raise ConfigError(
                    f"{file}: {where}.{problem.removeprefix('controller.')}"
                ) from None
            top.fail(where, problem)
        controllers.append((cname, over))
    ct.done()
    top.done()

    nominal = scenario_from_dict(base, file)
    joints = tuple(
        j + 1
        for j, target in enumerate(nominal.reference.final)
        if math.isfinite(target) and target != nominal.q0[j]
    )
    content = {k: v for k, v in data.items() if k not in ("samples", "name", "execution")}
    digest_source = {
        "format": FORMAT_VERSION,
        "sweep": content,
        "base": base,
        "rule_bases": _rule_base_hashes(controllers, base),
    }
    digest = hashlib.sha256(
        json.dumps(digest_source, sort_keys=True, default=str).encode()
    ).hexdigest()
    return SweepPlan(
        name=name,
        file=file,
        samples=samples,
        seed=seed,
        chunk_size=chunk_size,
        base=base,
        controllers=tuple(controllers),
        parameters=parameters,
        execution=execution,
        digest=digest,
        file_sha256=hashlib.sha256(raw).hexdigest(),
        joints=joints,
    )


# ----------------------------------------------------------------------------- computing


@dataclass(frozen=True)
class ChunkResult:
    """The rows of one chunk, as computed by a worker.

    Attributes
    ----------
    chunk : int
        Chunk index.
    rows : tuple of tuple
        One row per (sample, controller), in sample then controller order, with the
        values of :attr:`SweepPlan.columns`.
    wall_s : float
        Seconds the worker spent on it.
    pid : int
        The worker's process id.
    """

    chunk: int
    rows: tuple[tuple[Any, ...], ...]
    wall_s: float
    pid: int


def _metric_values(m: Any) -> list[float]:
    out: list[float] = []
    for j in range(2):
        step = m.step[j]
        out += (
            [math.nan] * len(STEP_FIELDS)
            if step is None
            else [float(getattr(step, f)) for f in STEP_FIELDS]
        )
        out += [
            float(m.errors.iae[j]),
            float(m.errors.ise[j]),
            float(m.errors.itae[j]),
            float(m.torque.rms[j]),
            float(m.torque.peak[j]),
        ]
    return out


def _error_text(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


def run_chunk(plan: SweepPlan, chunk: int) -> ChunkResult:
    """Compute every (sample, controller) of one chunk.

    The controllers are built once per chunk (they are modelled on the nominal arm,
    which does not change) and the plant once per sample, shared by the controllers.
    A sample that raises or diverges gives rows with status "error" or "diverged" and
    the message; it never stops the chunk.
    """
    start = time.perf_counter()
    nan_metrics = [math.nan] * len(METRIC_COLUMNS)
    controllers: dict[str, Any] = {}
    build_errors: dict[str, str] = {}
    for name in plan.controller_names:
        try:
            s = scenario_from_dict(plan.controller_data(name), plan.file)
            controllers[name] = build_controller(s)
        except Exception as exc:  # recorded on every row of this controller
            build_errors[name] = _error_text(exc)
    rows: list[tuple[Any, ...]] = []
    for i in plan.chunk_samples(chunk):
        values, noise_seed = plan.draw(i)
        head = list(values.values())
        try:
            s = scenario_from_dict(plan.sample_data(values, noise_seed), plan.file)
            plant = build_plant(s)
            sample_error = ""
        except Exception as exc:
            sample_error = _error_text(exc)
        for name in plan.controller_names:
            error = sample_error or build_errors.get(name, "")
            if not error:
                try:
                    traj = run_scenario(s, controllers[name], plant)
                except Exception as exc:
                    error = _error_text(exc)
                else:
                    try:
                        metrics = _metric_values(measure(s, traj))
                    except Exception as exc:
                        if traj.ok:
                            error = _error_text(exc)
                        else:  # diverged too early to measure anything
                            metrics = nan_metrics
                    if not error:
                        rows.append((i, name, *head, *metrics, traj.status, traj.message))
                        continue
            rows.append((i, name, *head, *nan_metrics, STATUS_ERROR, error))
    return ChunkResult(chunk, tuple(rows), time.perf_counter() - start, os.getpid())


# ----------------------------------------------------------------------------- files


def _cell(value: Any) -> str:
    if isinstance(value, float):
        return repr(value)  # shortest text that reads back to the same float
    return str(value)


def _rows_csv(columns: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(columns)
    writer.writerows([_cell(v) for v in row] for row in rows)
    return buf.getvalue()


def _parse_row(columns: Sequence[str], cells: Sequence[str]) -> tuple[Any, ...]:
    out: list[Any] = []
    for name, cell in zip(columns, cells, strict=True):
        if name == "sample":
            out.append(int(cell))
        elif name in ("controller", "status", "message"):
            out.append(cell)
        else:
            out.append(float(cell))
    return tuple(out)


def _read_csv(path: Path) -> tuple[list[str], list[tuple[Any, ...]]]:
    with open(path, newline="") as fh:
        reader = csv.reader(fh)
        header = next(reader)
        return header, [_parse_row(header, cells) for cells in reader]


def _chunk_path(out: Path, chunk: int) -> Path:
    return out / "chunks" / f"chunk_{chunk:05d}.csv"


def _valid_chunk(plan: SweepPlan, out: Path, chunk: int) -> list[tuple[Any, ...]] | None:
    """The chunk's rows if its file holds exactly what the plan asks for, else None."""
    path = _chunk_path(out, chunk)
    if not path.is_file():
        return None
    try:
        header, rows = _read_csv(path)
    except (OSError, ValueError, StopIteration):
        return None
    expected = [(i, c) for i in plan.chunk_samples(chunk) for c in plan.controller_names]
    if tuple(header) != plan.columns or [(r[0], r[1]) for r in rows] != expected:
        return None  # e.g. the last chunk of a run with fewer samples
    return rows


def _write_table(out: Path, columns: Sequence[str], rows: Sequence[tuple[Any, ...]]) -> Path:
    """``results.parquet`` if pyarrow is installed, else ``results.csv``."""
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        path = out / "results.csv"
        atomic_write_text(path, _rows_csv(columns, rows))
        (out / "results.parquet").unlink(missing_ok=True)
        return path
    table = pa.table({c: [r[k] for r in rows] for k, c in enumerate(columns)})
    path = out / "results.parquet"
    with atomic_path(path, suffix=".parquet") as tmp:
        pq.write_table(table, tmp)
    (out / "results.csv").unlink(missing_ok=True)
    return path


# ----------------------------------------------------------------------------- results


@dataclass(frozen=True)
class SweepResults:
    """The results table in columns, with what it was computed from.

    Attributes
    ----------
    columns : dict of str to ndarray
        One array per column of :attr:`SweepPlan.columns` (strings as object arrays).
    controllers : tuple of str
        Controller names, in the sweep file's order.
    parameters : tuple of str
        Swept parameter names.
    joints : tuple of int
        Joints with step metrics.
    """

    columns: dict[str, np.ndarray]
    controllers: tuple[str, ...]
    parameters: tuple[str, ...]
    joints: tuple[int, ...]

    def __len__(self) -> int:
        return len(self.columns["sample"])

    def select(self, controller: str, ok_only: bool = False) -> np.ndarray:
        """Boolean mask of the rows of ``controller`` (only status "ok" if ``ok_only``)."""
        mask = self.columns["controller"] == controller
        return mask & (self.columns["status"] == "ok") if ok_only else mask

    @classmethod
    def from_rows(
        cls, plan_like: Mapping[str, Any], columns: Sequence[str], rows: Sequence[tuple]
    ) -> SweepResults:
        cols: dict[str, np.ndarray] = {}
        for k, c in enumerate(columns):
            values = [r[k] for r in rows]
            if c == "sample":
                cols[c] = np.asarray(values, dtype=np.int64)
            elif c in ("controller", "status", "message"):
                cols[c] = np.asarray(values, dtype=object)
            else:
                cols[c] = np.asarray(values, dtype=float)
        return cls(
            columns=cols,
            controllers=tuple(plan_like["controllers"]),
            parameters=tuple(plan_like["parameters"]),
            joints=tuple(plan_like["joints"]),
        )


def load_results(out: str | Path) -> SweepResults:
    """Read a finished sweep's table (Parquet or CSV) and manifest from its folder."""
    out = Path(out)
    manifest = json.loads((out / "manifest.json").read_text())
    if (out / "results.parquet").is_file():
        import pyarrow.parquet as pq

        table = pq.read_table(out / "results.parquet")
        columns = table.column_names
        rows = list(zip(*(table.column(c).to_pylist() for c in columns), strict=True))
    else:
        header, rows = _read_csv(out / "results.csv")
        columns = header
    return SweepResults.from_rows(manifest, columns, rows)


def _stats(x: np.ndarray) -> dict[str, float]:
    x = x[np.isfinite(x)]
    if x.size == 0:
        return {"mean": math.nan, "median": math.nan, "p95": math.nan, "n": 0}
    return {
        "mean": float(np.mean(x)),
        "median": float(np.median(x)),
        "p95": float(np.percentile(x, 95)),
        "n": int(x.size),
    }


def summarize(results: SweepResults) -> dict[str, Any]:
    """Per controller: counts by status, success rate, and stats of ess, Mp and Ts.

    Success means status "ok" (no divergence, no error). The metric statistics (mean,
    median, 95th percentile, and ``n`` finite values) are over the successful runs.
    """
    out: dict[str, Any] = {}
    status = results.columns["status"]
    for c in results.controllers:
        rows = results.select(c)
        n = int(rows.sum())
        counts = {s: int((rows & (status == s)).sum()) for s in ("ok", "diverged", STATUS_ERROR)}
        ok = results.select(c, ok_only=True)
        metrics = {
            f"joint{j}_{m}": _stats(results.columns[f"joint{j}_{m}"][ok])
            for j in results.joints
            for m in SUMMARY_METRICS
        }
        out[c] = {
            "runs": n,
            **counts,
            "success_rate": counts["ok"] / n if n else math.nan,
            "metrics": metrics,
        }
    return out


def _summary_csv(summary: Mapping[str, Any]) -> str:
    header: list[str] = ["controller", "runs", "ok", "diverged", "error", "success_rate"]
    rows = []
    for c, s in summary.items():
        row = [c, s["runs"], s["ok"], s["diverged"], s[STATUS_ERROR], s["success_rate"]]
        for metric, st in s["metrics"].items():
            for k in ("mean", "median", "p95"):
                if len(rows) == 0:
                    header.append(f"{metric}_{k}")
                row.append(st[k])
        rows.append(row)
    return _rows_csv(header, rows)


def format_summary(summary: Mapping[str, Any]) -> str:
    """A short plain-text table of the summary (what the command prints)."""
    lines = []
    for c, s in summary.items():
        lines.append(
            f"{c}: {s['ok']}/{s['runs']} ok ({100 * s['success_rate']:.1f} %), "
            f"{s['diverged']} diverged, {s[STATUS_ERROR]} errors"
        )
        for metric, st in s["metrics"].items():
            lines.append(
                f"    {metric:28s} mean {st['mean']:.4g}  median {st['median']:.4g}  "
                f"p95 {st['p95']:.4g}  (n={st['n']})"
            )
    return "\n".join(lines)


# ----------------------------------------------------------------------------- figures


def _pyplot() -> Any:
    # Through twolink.plots, which selects the headless Agg backend before pyplot loads.
    from twolink import plots

    return plots.plt


def _metric_grid(results: SweepResults) -> list[tuple[str, str]]:
    return [(f"joint{j}_{m}", f"θ{j} {METRIC_LABELS[m]}") for j in results.joints
            for m in SUMMARY_METRICS]  # fmt: skip


def sweep_figures(results: SweepResults) -> dict[str, Figure]:
    """Histograms and box plots of ess, Mp, Ts per controller, success rates, and
    every metric against every swept parameter."""
    plt = _pyplot()
    grid = _metric_grid(results)
    figs: dict[str, Figure] = {}
    colours = {c: f"C{k}" for k, c in enumerate(results.controllers)}

    def finite(column: str, controller: str) -> np.ndarray:
        x = results.columns[column][results.select(controller, ok_only=True)]
        return x[np.isfinite(x)]

    n = max(len(grid), 1)
    fig, axes = plt.subplots(n, 2, figsize=(11, 2.6 * n), squeeze=False, layout="constrained")
    for row, (col, label) in enumerate(grid):
        data = {c: finite(col, c) for c in results.controllers}
        every = np.concatenate([*data.values(), np.zeros(0)])
        bins = np.histogram_bin_edges(every, bins=30) if every.size else 10
        hist, box = axes[row]
        for c, x in data.items():
            hist.hist(x, bins=bins, alpha=0.5, color=colours[c], label=c)
        hist.set_xlabel(label)
        hist.set_ylabel("runs")
        hist.legend(fontsize=8)
        shown = [c for c, x in data.items() if x.size]
        if shown:
            box.boxplot([data[c] for c in shown])
            box.set_xticks(range(1, len(shown) + 1), shown)
        box.set_ylabel(label)
        for ax in (hist, box):
            ax.grid(alpha=0.3)
    fig.suptitle("Sweep metrics over the successful runs")
    figs["metrics"] = fig

    summary = summarize(results)
    fig, ax = plt.subplots(
        figsize=(1.5 + 1.2 * len(results.controllers), 3.5), layout="constrained"
    )
    rates = [100 * summary[c]["success_rate"] for c in results.controllers]
    ax.bar(results.controllers, rates, color=[colours[c] for c in results.controllers])
    for k, r in enumerate(rates):
        ax.annotate(f"{r:.1f} %", (k, r), ha="center", va="bottom", fontsize=8)
    ax.set_ylim(0, 110)
    ax.set_ylabel("success rate [%]")
    ax.set_title("Runs without divergence or error")
    figs["success_rate"] = fig

    if results.parameters:
        np_ = len(results.parameters)
        fig, axes = plt.subplots(
            n, np_, figsize=(3.2 * np_ + 1, 2.4 * n), squeeze=False, layout="constrained"
        )
        for row, (col, label) in enumerate(grid):
            for k, p in enumerate(results.parameters):
                ax = axes[row][k]
                for c in results.controllers:
                    ok = results.select(c, ok_only=True)
                    ax.plot(results.columns[p][ok], results.columns[col][ok], ".", ms=3,
                            color=colours[c], alpha=0.6, label=c)  # fmt: skip
                x = results.columns[p]
                # Log axis for values spread over decades (a loguniform stiffness), not for
                # a uniform draw that merely starts near zero.
                if x.size and np.all(x > 0) and x.max() > 10 * np.median(x):
                    ax.set_xscale("log")
                if row == n - 1:
                    ax.set_xlabel(p)
                if k == 0:
                    ax.set_ylabel(label)
                ax.grid(alpha=0.3)
        axes[0][0].legend(fontsize=8)
        fig.suptitle("Metrics against the drawn parameters (successful runs)")
        figs["metric_vs_parameter"] = fig
    return figs


def save_sweep_plots(out: str | Path, results: SweepResults) -> list[Path]:
    """Write the :func:`sweep_figures` as PNG files under ``out/plots``."""
    from twolink.plots import save_figure

    paths = []
    for name, fig in sweep_figures(results).items():
        path = Path(out) / "plots" / f"{name}.png"
        save_figure(fig, path)
        paths.append(path)
    return paths


def _as_results(results: SweepResults | str | Path, parameter: str) -> SweepResults:
    r = results if isinstance(results, SweepResults) else load_results(results)
    if parameter not in r.parameters:
        raise ValueError(f"the sweep did not vary {parameter!r}; it varied {list(r.parameters)}")
    return r


def _stiffness_bins(k: np.ndarray, bins: int | None) -> list[tuple[float, float]]:
    values = np.unique(k[np.isfinite(k)])
    if values.size == 0:
        return []
    if bins is None and values.size <= 20:  # a grid: one row per stiffness
        return [(v, v) for v in values]
    edges = np.geomspace(values[0], values[-1], (bins or 6) + 1)
    return list(zip(edges[:-1], edges[1:], strict=True))


def _in_bin(k: np.ndarray, lo: float, hi: float, last: bool) -> np.ndarray:
    if lo == hi:
        return k == lo
    return (k >= lo) & ((k <= hi) if last else (k < hi))


def flexible_study_table(
    results: SweepResults | str | Path, parameter: str = "k", bins: int | None = None
) -> str:
    """Markdown table of the flexible-joint study: metrics by stiffness and controller.

    Parameters
    ----------
    results : SweepResults or path of a sweep's output folder
        A sweep over joint stiffness (``k``, or ``k1``/``k2``).
    parameter : str
        The stiffness column.
    bins : int, optional
        Number of log-spaced stiffness bins. Default: one row per value when there are
        at most 20 distinct values (a grid), else 6 bins.

    Returns
    -------
    str
        Rows from stiff to soft; per controller the runs, the success rate and the
        medians of ess, Mp and Ts of each moving joint over the successful runs.
    """
    r = _as_results(results, parameter)
    k = r.columns[parameter]
    head = ["stiffness [N·m/rad]", "controller", "runs", "ok"]
    names = {"steady_state_error": "ess", "overshoot": "Mp", "settling_time": "Ts [s]"}
    metrics = [(f"joint{j}_{m}", f"θ{j} median {names[m]}") for j in r.joints
               for m in SUMMARY_METRICS]  # fmt: skip
    head += [label for _, label in metrics]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    ranges = _stiffness_bins(k, bins)
    for b, (lo, hi) in reversed(list(enumerate(ranges))):
        in_bin = _in_bin(k, lo, hi, last=b == len(ranges) - 1)
        label = f"{lo:.4g}" if lo == hi else f"{lo:.4g} – {hi:.4g}"
        for c in r.controllers:
            rows = in_bin & r.select(c)
            ok = in_bin & r.select(c, ok_only=True)
            cells = [label, c, str(int(rows.sum()))]
            cells.append(f"{100 * ok.sum() / rows.sum():.0f} %" if rows.sum() else "–")
            for col, _ in metrics:
                x = r.columns[col][ok]
                x = x[np.isfinite(x)]
                cells.append(f"{np.median(x):.3g}" if x.size else "–")
            lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def flexible_study_figure(
    results: SweepResults | str | Path, parameter: str = "k", bins: int | None = None
) -> Figure:
    """Success rate, ess, Mp and Ts against joint stiffness, per controller.

    Each successful run is a dot; the line joins the medians per stiffness bin (as in
    :func:`flexible_study_table`). The stiffness axis is logarithmic.
    """
    plt = _pyplot()
    r = _as_results(results, parameter)
    k = r.columns[parameter]
    ranges = _stiffness_bins(k, bins)
    centres = np.array([math.sqrt(lo * hi) for lo, hi in ranges])
    grid = _metric_grid(r)
    ncols = min(4, 1 + len(grid))
    nrows = -(-(1 + len(grid)) // ncols)
    fig, all_axes = plt.subplots(nrows, ncols, figsize=(3.4 * ncols, 3.0 * nrows),
                                 squeeze=False, layout="constrained")  # fmt: skip
    axes = all_axes.ravel()[: 1 + len(grid)]
    for ax in all_axes.ravel()[1 + len(grid) :]:
        ax.set_visible(False)
    for n_c, c in enumerate(r.controllers):
        colour = f"C{n_c}"
        rows, ok = r.select(c), r.select(c, ok_only=True)
        masks = [_in_bin(k, lo, hi, b == len(ranges) - 1) for b, (lo, hi) in enumerate(ranges)]
        rate = [100 * (m & ok).sum() / (m & rows).sum() if (m & rows).sum() else np.nan
                for m in masks]  # fmt: skip
        axes[0].plot(centres, rate, "o-", color=colour, label=c)
        for ax, (col, label) in zip(axes[1:], grid, strict=True):
            y = r.columns[col]
            ax.plot(k[ok], y[ok], ".", ms=3, alpha=0.4, color=colour)
            med = []
            for m in masks:
                x = y[m & ok]
                x = x[np.isfinite(x)]
                med.append(np.median(x) if x.size else np.nan)
            ax.plot(centres, med, "-", color=colour, lw=1.5, label=c)
            ax.set_ylabel(label)
    axes[0].set_ylabel("success rate [%]")
    axes[0].set_ylim(-5, 105)
    axes[0].legend(fontsize=8)
    for ax in axes:
        ax.set_xscale("log")
        ax.set_xlabel(f"joint stiffness {parameter} [N·m/rad]")
        ax.grid(alpha=0.3, which="both")
    fig.suptitle("Flexible joints: controllers designed on the rigid model")
    return fig


# ----------------------------------------------------------------------------- running


class SweepInterrupted(Exception):
    """The sweep stopped on SIGINT/SIGTERM; finished chunks are kept.

    Attributes
    ----------
    signum : int
        The signal that stopped it.
    done, total : int
        Chunks on disk and chunks in the sweep.
    """

    def __init__(self, signum: int, done: int, total: int, out: Path):
        self.signum, self.done, self.total, self.out = signum, done, total, out
        super().__init__(
            f"interrupted by {signal.Signals(signum).name}: {done}/{total} chunks are kept in "
            f"{out / 'chunks'}; run the same command again to compute only the missing ones"
        )


class SweepOutputError(RuntimeError):
    """The output folder holds a different sweep's chunks."""


class SweepTaskError(RuntimeError):
    """A chunk task failed outside the per-sample error handling (a bug or a lost worker)."""


@dataclass(frozen=True)
class SweepOutcome:
    """What a finished :func:`run_sweep` did.

    Attributes
    ----------
    out : Path
        The output folder.
    table : Path
        ``results.parquet`` or ``results.csv``.
    results : SweepResults
        The table in columns.
    summary : dict
        :func:`summarize`'s output.
    computed, reused : tuple of int
        Chunks computed by this call, and chunks found on disk.
    wall_s : float
        Seconds from start to finished table (plots not included).
    busy_s : float
        Seconds the workers spent inside the computed chunks, summed over chunks.
    workers : int
        Size of the executor (0 when nothing was computed).
    """

    out: Path
    table: Path
    results: SweepResults
    summary: dict[str, Any]
    computed: tuple[int, ...]
    reused: tuple[int, ...]
    wall_s: float
    busy_s: float
    workers: int


def _prepare_out(plan: SweepPlan, out: Path, fresh: bool) -> None:
    manifest_path = out / "manifest.json"
    chunk_dir = out / "chunks"
    has_chunks = chunk_dir.is_dir() and any(chunk_dir.glob("chunk_*.csv"))
    digest = None
    if manifest_path.is_file():
        try:
            digest = json.loads(manifest_path.read_text()).get("digest")
        except (OSError, ValueError):
            digest = "unreadable"
    foreign = (digest is not None and digest != plan.digest) or (digest is None and has_chunks)
    if foreign and not fresh:
        raise SweepOutputError(
            f"{out} holds results of a different sweep (its manifest.json digest "
            f"{str(digest)[:12]} != {plan.digest[:12]} of {plan.file}); "
            "use another --out, or --fresh to discard them"
        )
    if foreign or fresh:
        for path in chunk_dir.glob("chunk_*.csv") if chunk_dir.is_dir() else ():
            path.unlink()
        (out / "computed.log").unlink(missing_ok=True)
    out.mkdir(parents=True, exist_ok=True)
    chunk_dir.mkdir(exist_ok=True)
    atomic_write_json(
        manifest_path,
        {
            "format": FORMAT_VERSION,
            "digest": plan.digest,
            "file": plan.file,
            "file_sha256": plan.file_sha256,
            "name": plan.name,
            "samples": plan.samples,
            "seed": plan.seed,
            "chunk_size": plan.chunk_size,
            "controllers": list(plan.controller_names),
            "parameters": list(plan.parameter_names),
            "joints": list(plan.joints),
            "columns": list(plan.columns),
        },
    )
    atomic_write_text(out / "sweep.toml", Path(plan.file).read_text())


class _StopSignals:
    """SIGINT and SIGTERM as KeyboardInterrupt, held back inside critical sections.

    A handler runs in the main thread, whichever thread the signal reached, so a flag
    (not a signal mask) is what keeps a chunk file and its log line together.
    """

    def __init__(self) -> None:
        self.received: list[int] = []
        self._depth = 0
        self._pending = False

    def _handler(self, signum: int, frame: Any) -> None:
        self.received.append(signum)
        if self._depth:
            self._pending = True
        else:
            raise KeyboardInterrupt

    @contextmanager
    def installed(self) -> Iterator[None]:
        """Install the handlers for SIGINT and SIGTERM (main thread only; else no-op)."""
        try:
            old = {s: signal.signal(s, self._handler) for s in (signal.SIGINT, signal.SIGTERM)}
        except ValueError:  # not the main thread: leave signals to the caller
            yield
            return
        try:
            yield
        finally:
            for s, handler in old.items():
                signal.signal(s, handler)

    @contextmanager
    def critical(self) -> Iterator[None]:
        """Defer a stop until the block is done."""
        self._depth += 1
        try:
            yield
        finally:
            self._depth -= 1
        if not self._depth and self._pending:
            self._pending = False
            raise KeyboardInterrupt


def run_sweep(
    plan: SweepPlan,
    out: str | Path,
    executor: str | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = False,
    plots: bool = True,
    fresh: bool = False,
) -> SweepOutcome:
    """Compute the missing chunks of a sweep, then write its table, summary and plots.

    Parameters
    ----------
    plan : SweepPlan
        From :func:`load_sweep`.
    out : str or Path
        Output folder. Chunks already there (of the same sweep) are kept, not recomputed.
    executor, workers, scheduler : optional
        See :func:`twolink.executors.open_executor`; default: the sweep file's
        ``[execution]`` table, else a process pool on all cores.
    progress : bool
        Show a tqdm progress bar over samples (on stderr).
    plots : bool
        Write the PNG plots.
    fresh : bool
        Discard chunks already in ``out`` (also those of a different sweep).

    Returns
    -------
    SweepOutcome

    Raises
    ------
    SweepInterrupted
        On SIGINT or SIGTERM: running tasks are abandoned, finished chunks kept.
    SweepOutputError
        ``out`` holds a different sweep's chunks and ``fresh`` is false.
    ExecutorError, ValueError
        The executor cannot be started or its options are inconsistent.
    """
    from tqdm import tqdm

    start = time.perf_counter()
    out = Path(out)
    if executor is None:
        executor = "dask" if scheduler else plan.execution.executor
    workers = workers or plan.execution.workers
    if scheduler is None and executor == plan.execution.executor:
        scheduler = plan.execution.scheduler
    check_options(executor, workers, scheduler)
    _prepare_out(plan, out, fresh)

    rows_by_chunk: dict[int, list[tuple[Any, ...]]] = {}
    for c in range(plan.n_chunks):
        rows = _valid_chunk(plan, out, c)
        if rows is not None:
            rows_by_chunk[c] = rows
    reused = tuple(sorted(rows_by_chunk))
    missing = [c for c in range(plan.n_chunks) if c not in rows_by_chunk]
    computed: list[tuple[int, float]] = []  # (chunk, worker seconds)
    stops = _StopSignals()
    n_workers = 0
    bar = tqdm(
        total=plan.samples,
        initial=sum(len(plan.chunk_samples(c)) for c in reused),
        unit="sample",
        disable=not progress,
        desc=plan.name,
        file=sys.stderr,
    )
    try:
        with stops.installed():
            try:
                if missing:
                    ex = open_executor(executor, workers, scheduler)
                    n_workers = ex.workers
                    try:
                        _drive(plan, out, ex, missing, rows_by_chunk, computed, bar, stops)
                    except BaseException:
                        with stops.critical():
                            ex.abort()
                        raise
                    ex.shutdown(wait=True)
            except KeyboardInterrupt:
                signum = stops.received[0] if stops.received else signal.SIGINT
                raise SweepInterrupted(signum, len(rows_by_chunk), plan.n_chunks, out) from None
    finally:
        bar.close()

    rows = [row for c in range(plan.n_chunks) for row in rows_by_chunk[c]]
    table = _write_table(out, plan.columns, rows)
    results = SweepResults.from_rows(
        {
            "controllers": plan.controller_names,
            "parameters": plan.parameter_names,
            "joints": plan.joints,
        },
        plan.columns,
        rows,
    )
    summary = summarize(results)
    atomic_write_json(out / "summary.json", summary)
    atomic_write_text(out / "summary.csv", _summary_csv(summary))
    wall_s = time.perf_counter() - start
    if plots:
        save_sweep_plots(out, results)
    return SweepOutcome(
        out=out,
        table=table,
        results=results,
        summary=summary,
        computed=tuple(c for c, _ in computed),
        reused=reused,
        wall_s=wall_s,
        busy_s=sum(w for _, w in computed),
        workers=n_workers,
    )


def _drive(
    plan: SweepPlan,
    out: Path,
    ex: SweepExecutor,
    missing: list[int],
    rows_by_chunk: dict[int, list[tuple[Any, ...]]],
    computed: list[tuple[int, float]],
    bar: Any,
    stops: _StopSignals,
) -> None:
    """Keep a bounded window of chunks in flight; write each chunk as it finishes."""
    todo = iter(missing)
    # Enough queued work that no worker waits on the client, little to cancel on Ctrl-C.
    window = 1 if ex.name == "inprocess" else 2 * ex.workers
    pending: set[futures.Future] = set()

    def fill() -> None:
        while len(pending) < window:
            chunk = next(todo, None)
            if chunk is None:
                return
            pending.add(ex.submit(run_chunk, plan, chunk))

    fill()
    while pending:
        done, pending = futures.wait(pending, return_when=futures.FIRST_COMPLETED)
        for future in done:
            try:
                result: ChunkResult = future.result()
            except futures.BrokenExecutor:
                raise
            except Exception as exc:  # outside run_chunk's per-sample net: a real bug
                raise SweepTaskError(f"a chunk task failed: {_error_text(exc)}") from exc
            with stops.critical():
                atomic_write_text(
                    _chunk_path(out, result.chunk), _rows_csv(plan.columns, result.rows)
                )
                with open(out / "computed.log", "a") as log:
                    samples = plan.chunk_samples(result.chunk)
                    log.write(
                        f"{result.chunk} samples={samples.start}-{samples.stop - 1} "
                        f"wall_s={result.wall_s:.3f} pid={result.pid} executor={ex.name}\n"
                    )
            rows_by_chunk[result.chunk] = list(result.rows)
            computed.append((result.chunk, result.wall_s))
            bar.update(len(plan.chunk_samples(result.chunk)))
        fill()


# ----------------------------------------------------------------------------- command


def _fail_input(message: str) -> None:
    click.echo(f"error: {message}", err=True)
    sys.exit(2)


@click.command("sweep")
@click.argument("sweep_file", type=click.Path(path_type=Path))
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="Output folder [default: results/sweeps/<sweep name>].",
)
@click.option(
    "--executor",
    type=click.Choice(EXECUTORS),
    default=None,
    help="Where samples run [default: the sweep file's, else process].",
)
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=None,
    help="Worker processes [default: all cores].",
)
@click.option("--scheduler", default=None, help="Dask scheduler address (implies dask).")
@click.option("-n", "--samples", type=click.IntRange(min=1), default=None, help="Override N.")
@click.option("--fresh", is_flag=True, help="Discard chunks already in --out.")
@click.option("--no-plots", is_flag=True, help="Skip the PNG plots.")
@click.option("--progress/--no-progress", default=True, show_default=True)
def sweep_command(
    sweep_file: Path,
    out: Path | None,
    executor: str | None,
    workers: int | None,
    scheduler: str | None,
    samples: int | None,
    fresh: bool,
    no_plots: bool,
    progress: bool,
) -> None:
    """Run a Monte Carlo sweep file: every controller on N drawn plants.

    Resumable: rerun the same command to compute only the chunks not yet in --out.
    Exit 0 when the table is written (diverged samples are results, not failures),
    1 when the executor fails, 2 on bad input, 130/143 when stopped by SIGINT/SIGTERM.
    """
    try:
        plan = load_sweep(sweep_file, {"samples": samples} if samples else None)
    except ConfigError as exc:
        _fail_input(str(exc))
    if scheduler and executor not in (None, "dask"):
        _fail_input(f"--scheduler needs --executor dask, not {executor}")
    out = out or Path("results") / "sweeps" / plan.name
    try:
        outcome = run_sweep(
            plan,
            out,
            executor=executor,
            workers=workers,
            scheduler=scheduler,
            progress=progress,
            plots=not no_plots,
            fresh=fresh,
        )
    except SweepOutputError as exc:
        _fail_input(str(exc))
    except SweepInterrupted as exc:
        click.echo(f"\n{exc}", err=True)
        sys.exit(128 + exc.signum)
    except ValueError as exc:  # inconsistent executor options
        _fail_input(str(exc))
    except (ExecutorError, SweepTaskError, futures.BrokenExecutor) as exc:
        click.echo(f"error: {exc}; finished chunks are kept in {out}, rerun to resume", err=True)
        sys.exit(1)
    click.echo(format_summary(outcome.summary))
    click.echo(
        f"{plan.samples} samples x {len(plan.controllers)} controllers: "
        f"{len(outcome.computed)} chunks computed, {len(outcome.reused)} reused, "
        f"{outcome.wall_s:.1f} s; results in {outcome.table}"
    )


if __name__ == "__main__":
    # The importable module's command, so that tasks pickle as twolink.sweep.run_chunk
    # (which any worker can import), not as __main__.run_chunk.
    from twolink.sweep import sweep_command as _command

    _command(prog_name="twolink sweep")
