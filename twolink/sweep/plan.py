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
    chunk_size = 100                    # samples per task, batch and chunk file, >= 1

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
    workers = 4                         # (a Dask scheduler: only --scheduler on the command line)

Parameters: ``m1 m2 l1 l2 g`` are factors on the nominal arm (they replace the base's
``plant.scale`` entry); ``payload`` is a tip mass [kg]; ``k d j`` set the flexible joints'
stiffness [N m/rad], damping [N m s/rad] and rotor inertia [kg m^2] of both joints, ``k1 k2
d1 d2 j1 j2`` one joint's. Sweeping any of them makes the plant flexible (the controllers
keep the rigid model; the flexible-joint laws model the drawn joints). ``k_scale`` and
``j_scale`` are the joints' model error: factors on the plant's stiffness and rotor inertia
against the joints the flexible-joint laws model (``[plant.scale] k, j``). ``zeta_joint``
sets both joints' damping from a damping ratio, d = 2 ζ sqrt(k j) with each joint's k and j
(drawn or the base's): realistic light damping at every stiffness. ``wn`` is the closed
loop's bandwidth [rad/s] at ζ = 1: every controller of the sample gets kp = wn², kd = 2 wn,
ki = wn³ / 4 (the gain study's rule; over the controllers' own gains). Distributions:
``uniform`` (low, high), ``loguniform`` (low, high), ``normal`` (mean, std, optional
low/high truncation by rejection), ``choice`` (values, optional weights), ``grid`` (values:
sample i takes the (i mod size)-th point of the full grid over all grid parameters, the
first parameter by name varying fastest).
"""

from __future__ import annotations

import hashlib
import json
import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from twolink.arm.params import Flexibility
from twolink.foundation.executors import EXECUTORS
from twolink.foundation.io import unsafe_name_problem
from twolink.foundation.planted import read_bounded
from twolink.foundation.shipped import locate, locate_beside, shipped_hint
from twolink.simulation.config import (
    BUILTIN_RULE_BASES,
    MAX_TOML_BYTES,
    RULE_BASE_KINDS,
    ConfigError,
    TomlTable,
    expect_kind,
    merge,
    read_toml,
    refuse_fis,
    resolve_rule_base,
    scenario_from_dict,
    strip_replace,
)
from twolink.simulation.outcome import SuccessSpec, finished, largest_step
from twolink.sweep.results import METRIC_COLUMNS, SweepMeta

__all__ = ["DISTRIBUTIONS", "PARAMETERS", "Execution", "Parameter", "SweepPlan", "load_sweep"]

# Chunk files and manifest (2: Parquet, 3: oscillation_rad, 4: settling_time_target_s,
# max_error_rad and Tp only where there is a peak); in the digest, so older chunks are
# not resumed; 5: max_twist_rad).
FORMAT_VERSION = 8  # 6: tail_error_rad, tail_growth; final error against the target;
# 7: oscillation_rad counts a drift as no oscillation (the smaller of rise and fall);
# 8 (issue 37): ess and the final error the settling window's mean, oscillation_rad the
# envelope at the end, tail_growth e^(σW), linear_growth_1_s of every law on every plant
# Samples per task: each task is one batch of arms (samples x controllers) on the batch
# engine, whose per-step cost is mostly fixed below ~100 arms (docs/sweeps.md).
DEFAULT_CHUNK_SIZE = 100
DISTRIBUTIONS = ("uniform", "loguniform", "normal", "choice", "grid")
SCALE_PARAMETERS = ("m1", "m2", "l1", "l2", "g")
FLEX_PARAMETERS = ("k", "d", "j")
# name -> domain of the drawn value: "positive" (> 0), "nonnegative" (>= 0) or "any".
PARAMETERS: Mapping[str, str] = {
    "m1": "positive",
    "m2": "positive",
    "mass": "positive",  # a factor on both masses (times m1's and m2's own)
    "l1": "positive",
    "l2": "positive",
    "g": "any",
    "payload": "nonnegative",
    **{f"{p}{j}": dom for p, dom in zip("kdj", ("positive", "nonnegative", "positive"), strict=True)
       for j in ("", "1", "2")},
    "zeta_joint": "nonnegative",  # the joints' damping ratio: d = 2 zeta sqrt(k j)
    "k_scale": "positive",  # plant.scale.k: the plant's stiffness / the controllers' model
    "j_scale": "positive",  # plant.scale.j: the same for the rotor inertia
    "wn": "positive",  # the controllers' bandwidth [rad/s], zeta = 1
}  # fmt: skip
FLEX_NAMES = frozenset(
    {"zeta_joint"} | {f"{p}{j}" for p in FLEX_PARAMETERS for j in ("", "1", "2")}
)
TRUNCATION_TRIES = 10_000
# A truncated normal must keep this share of the draws: with 10,000 tries per value, no
# draw in the truncation is then a chance of (1 - 0.01)**10_000 ~ 1e-44.
MIN_TRUNCATION_MASS = 0.01
MAX_SAMPLES = 1_000_000


def too_many_samples(n: int) -> str | None:
    """Why ``n`` plants are more than a sweep holds (None where they are not): what a
    sweep's ``samples``, ``compare -n`` and the gain study's ``plants`` say."""
    if n <= MAX_SAMPLES:
        return None
    return (
        f"at most {MAX_SAMPLES:,}, the most a sweep holds (a table of that many rows per "
        f"controller is about 1 GB; split a larger study into several sweeps), got {n:,}"
    )


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
    success: SuccessSpec = field(default_factory=SuccessSpec)
    step: float = 1.0
    # Whether the base scenario's reference finishes before its settling window: else
    # every run is "off target" (twolink.simulation.outcome.finished)
    finished: bool = True

    def nominal_scenario(self) -> Any:
        """The base scenario as the sweep runs it, with no parameter drawn."""
        return scenario_from_dict(self.base, self.file)

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
    def meta(self) -> SweepMeta:
        """What the results table carries about this sweep."""
        return SweepMeta(self.controller_names, self.parameter_names, self.joints)

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
        for joint_scale in ("k", "j"):  # model error of the joints
            if f"{joint_scale}_scale" in values:
                scale[joint_scale] = values[f"{joint_scale}_scale"]
        if "mass" in values:  # the model mismatch of both links at once
            for m in ("m1", "m2"):
                scale[m] = scale.get(m, 1.0) * values["mass"]
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
            if "zeta_joint" in values:
                z = values["zeta_joint"]
                flex["d"] = [
                    2.0 * z * math.sqrt(k * j) for k, j in zip(flex["k"], flex["j"], strict=True)
                ]
            plant["flexibility"] = flex
        return merge(self.base, {"plant": plant, "seed": noise_seed})

    def controller_data(self, name: str, values: Mapping[str, float] = {}) -> dict[str, Any]:  # noqa: B006
        """The base scenario with controller ``name``'s overrides (and a sample's ``wn``)."""
        return merge(self.base, {"controller": {**dict(self.controllers)[name], **gains(values)}})


def gains(values: Mapping[str, float]) -> dict[str, float]:
    """The controller gains a sample's ``wn`` sets (ζ = 1; ki by the gain study's rule)."""
    if "wn" not in values:
        return {}
    wn = values["wn"]
    return {"kp": wn**2, "kd": 2.0 * wn, "ki": 0.25 * wn**3}


# ----------------------------------------------------------------------------- reading


def _strip_source(exc: ConfigError, source: str) -> str:
    message = str(exc)
    return message[len(source) + 2 :] if message.startswith(f"{source}: ") else message


def _check_value(t: TomlTable, key: str, value: Any, domain: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        t.fail(key, f"must be a number, got {value!r}")
    try:
        value = float(value)
    except OverflowError:
        t.fail(
            key, f"must be a number a float can hold, got an integer of {len(str(value))} digits"
        )
    if not math.isfinite(value):
        t.fail(key, f"must be finite, got {value!r}")
    if domain == "positive" and not value > 0:
        t.fail(key, f"must be > 0 for parameter {t.where.split('.')[-1]!r}, got {value!r}")
    if domain == "nonnegative" and value < 0:
        t.fail(key, f"must be >= 0 for parameter {t.where.split('.')[-1]!r}, got {value!r}")
    return float(value)


def _normal_mass(mean: float, std: float, low: float | None, high: float | None) -> float:
    """The probability that a draw of normal(mean, std) lies in [low, high]."""
    if std == 0:
        return 1.0  # every draw is the mean, which lies within the truncation
    lo = -math.inf if low is None else (low - mean) / std
    hi = math.inf if high is None else (high - mean) / std
    return 0.5 * (math.erf(hi / math.sqrt(2)) - math.erf(lo / math.sqrt(2)))


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
        mass = _normal_mass(mean, std, low, high)
        if mass < MIN_TRUNCATION_MASS:
            t.fail(
                "high" if high is not None else "low",
                f"the truncation [{low}, {high}] keeps {mass:.3g} of normal({mean}, {std})'s "
                f"draws; at least {MIN_TRUNCATION_MASS:g} is needed (values are drawn by "
                "rejection): widen [low, high] or raise std",
            )
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
    if isinstance(name, str) and name not in BUILTIN_RULE_BASES:
        controller = {**controller, "rule_base": str(resolve_rule_base(name, relative_to))}
    return controller


def _rule_base_hashes(plan_controllers: Sequence[tuple[str, dict]], base: dict) -> dict:
    # The rule bases are data that decide results: a changed file is a changed sweep.
    out = {}
    for name, over in plan_controllers:
        ctrl = merge(base.get("controller", {}), over)
        if ctrl.get("kind") not in RULE_BASE_KINDS:
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
    path = locate(path)
    file = str(path)
    refuse_fis(path)
    if not path.is_file():
        raise ConfigError(f"{file}: no such file{shipped_hint(path)}")
    try:
        raw = read_bounded(path, MAX_TOML_BYTES)
        data = tomllib.loads(raw.decode())
    except (ValueError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{file}: not valid TOML: {exc}") from None
    except RecursionError:
        raise ConfigError(f"{file}: not valid TOML: nested too deep") from None
    except OSError as exc:
        raise ConfigError(f"{file}: cannot be read: {exc.strerror or exc}") from None
    expect_kind(data, file, "sweep")
    if overrides:
        data = merge(data, dict(overrides))
    data = strip_replace(data)  # the flags merged onto the sweep's own tables are spent
    top = TomlTable(data, "", file)
    name = top.string("name", path.stem)
    if problem := unsafe_name_problem(name):
        top.fail("name", problem)
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
    if problem := too_many_samples(samples):
        top.fail("samples", problem)
    seed = top.integer("seed", 0)
    chunk_size = top.raw("chunk_size", DEFAULT_CHUNK_SIZE)
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, int) or chunk_size < 1:
        top.fail("chunk_size", f"must be an integer >= 1, got {chunk_size!r}")

    ex = top.table("execution")
    workers = ex.raw("workers")
    if workers is not None and (
        isinstance(workers, bool) or not isinstance(workers, int) or workers < 1
    ):
        ex.fail("workers", f"must be an integer >= 1, got {workers!r}")
    # Only the command line chooses where work runs: a Dask scheduler is trusted with
    # pickles both ways, so a file that names one could run code in this process.
    if "scheduler" in ex.data:
        ex.fail(
            "scheduler",
            "a sweep file cannot choose a Dask scheduler (connecting to one trusts it to run "
            "code here); give it on the command line: twolink sweep FILE --scheduler ADDRESS",
        )
    execution = Execution(
        executor=ex.string("executor", "process", EXECUTORS),
        workers=workers,
        scheduler=None,
    )
    ex.done()

    st = top.table("success")
    defaults = SuccessSpec()
    success = SuccessSpec(
        final_error=st.number("final_error", defaults.final_error, positive=True),
        max_overshoot_pct=st.number(
            "max_overshoot_pct", defaults.max_overshoot_pct, minimum=0.0, allow_inf=True
        ),
        max_tail_growth=st.number(
            "max_tail_growth", defaults.max_tail_growth, minimum=1.0, allow_inf=True
        ),
    )
    st.done()

    # The base scenario: its own errors name its own file.
    base_path = locate_beside(path.parent, scenario_path)  # beside the file, else shipped
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
    for damping in ("d", "d1", "d2"):
        if damping in pt.data and "zeta_joint" in pt.data:
            pt.fail(damping, "conflicts with 'zeta_joint', which sets the damping of both joints")
    parameters = tuple(_parameter(n, pt.raw(n), file) for n in sorted(pt.data))
    pt.done()

    ct = top.table("controllers")
    if not ct.data:
        top.fail("controllers", "missing: at least one [controllers.<name>] table")
    controllers = []
    for cname in ct.data:
        over = ct.raw(cname)
        where = f"controllers.{cname}"
        if problem := unsafe_name_problem(cname):
            top.fail(where, problem)
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
    # What decides the chunks' contents; the [success] spec only classifies finished rows.
    content = {
        k: v for k, v in data.items() if k not in ("samples", "name", "execution", "success")
    }
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
        success=success,
        step=largest_step(nominal.reference, nominal.q0),
        finished=finished(nominal.reference, nominal.duration),
    )
