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
    l1 = { dist = "listed", values = [0.9, 1.0, 1.1] }      # sample i takes values[i]

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
ki = wn³ / 4 (the gain study's rule; over the controllers' own gains). ``coulomb1 coulomb2``
are the joints' Coulomb friction [N m] (``friction_level``: both, as a fraction of their
holding gravity torque on the nominal arm), ``stribeck_ratio`` their breakaway / Coulomb and
``stribeck_velocity`` v_s [rad/s], over the base's ``[plant.friction]``
(:mod:`twolink.sweep.friction_draws`). Distributions:
``uniform`` (low, high), ``loguniform`` (low, high), ``normal`` (mean, std, optional
low/high truncation by rejection), ``choice`` (values, optional weights), ``grid`` (values:
sample i takes the (i mod size)-th point of the full grid over all grid parameters, the
first parameter by name varying fastest), ``listed`` (values: sample i takes ``values[i]``;
every listed parameter of a sweep has the same number of values and ``samples`` is at most
that number: a table of the user's own plants, one column per parameter, as ``twolink
compare --plants-file`` writes it). Grid and listed parameters take nothing from the
generator, so the other parameters' draws and the noise seed are those of the same sweep
without them.
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

from twolink.arm import dynamics
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
from twolink.sweep.friction_draws import FRICTION_NAMES, friction_data
from twolink.sweep.parameters import (
    DISTRIBUTIONS,
    NOT_DRAWN,
    PARAMETERS,
    Parameter,
    _parameter,
)
from twolink.sweep.results import METRIC_COLUMNS, SweepMeta

__all__ = ["DISTRIBUTIONS", "PARAMETERS", "Execution", "Parameter", "SweepPlan", "load_sweep"]

# Chunk files and manifest (2: Parquet, 3: oscillation_rad, 4: settling_time_target_s,
# max_error_rad and Tp only where there is a peak); in the digest, so older chunks are
# not resumed; 5: max_twist_rad).
FORMAT_VERSION = 9  # 6: tail_error_rad, tail_growth; final error against the target;
# 7: oscillation_rad counts a drift as no oscillation (the smaller of rise and fall);
# 8 (issue 37): ess and the final error the settling window's mean, oscillation_rad the
# envelope at the end, tail_growth e^(σW), linear_growth_1_s of every law on every plant;
# 9 (issue 48): oscillation_rad the larger persisting swing of two tones
# Samples per task: each task is one batch of arms (samples x controllers) on the batch
# engine, whose per-step cost is mostly fixed below ~100 arms (docs/sweeps.md).
DEFAULT_CHUNK_SIZE = 100
SCALE_PARAMETERS = ("m1", "m2", "l1", "l2", "g")
FLEX_PARAMETERS = ("k", "d", "j")
FLEX_NAMES = frozenset(
    {"zeta_joint"} | {f"{p}{j}" for p in FLEX_PARAMETERS for j in ("", "1", "2")}
)
MAX_SAMPLES = 1_000_000
# Where the sweep's model gravity puts the end of a normal g with no bound on a side
# (SweepPlan.model_gravity): a draw beyond it (a chance of 1.5e-23) is an error row.
NORMAL_REACH = 10.0


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

        Grid parameters come from ``i``, listed ones are their ``values[i]``; the others
        are drawn, in name order, from ``default_rng([seed, i])``, and the noise seed is
        drawn after them; the friction parameters last, so adding friction to a sweep
        leaves its plants and noise as they were (the lab arm's plants are the robustness
        study's).
        """
        values: dict[str, float] = {}
        k = i
        for p in self.parameters:
            if p.dist == "grid":
                values[p.name] = p.values[k % len(p.values)]
                k //= len(p.values)
            elif p.dist == "listed":
                values[p.name] = p.values[i]
        rng = np.random.default_rng([self.seed, i])
        drawn = [p for p in self.parameters if p.dist not in NOT_DRAWN]
        for p in drawn:
            if p.name not in FRICTION_NAMES:
                values[p.name] = p.draw(rng)
        noise_seed = int(rng.integers(0, 2**31))
        for p in drawn:
            if p.name in FRICTION_NAMES:
                values[p.name] = p.draw(rng)
        return {p.name: values[p.name] for p in self.parameters}, noise_seed

    def sample_data(self, values: Mapping[str, float], noise_seed: int) -> dict[str, Any]:
        """The scenario data of a sample: the base with the drawn plant."""
        plant: dict[str, Any] = {}
        scale = {n: v for n, v in values.items() if n in SCALE_PARAMETERS}
        for joint_scale in ("k", "j", "ei"):  # model error of the joints, the links
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
        holding = (0.0, 0.0)
        if "friction_level" in values:  # the nominal arm's holding torque, horizontal
            holding = tuple(dynamics.gravity(self.nominal_scenario().arm, np.zeros(2)))
        friction = friction_data(self.base.get("plant", {}).get("friction", {}), values, holding)
        if friction is not None:
            plant["friction"] = friction
        return merge(self.base, {"plant": plant, "seed": noise_seed})

    def model_gravity(self) -> float:
        """The gravity of every batch model of this sweep (its arms are tilted against it,
        :func:`twolink.simulation.batch.batch_model`): the largest |g| any sample can draw,
        from the sweep's definition alone (the nominal g where ``g`` is not swept; else
        the g of each end of its distribution, each choice, grid or listed value; a normal open on
        a side reaches ``NORMAL_REACH`` standard deviations there). So an arm's run depends
        on its own plant, never on the other arms of its batch, N, the chunk size, the
        executor or the number of workers."""
        arm = self.nominal_scenario().arm
        p = next((p for p in self.parameters if p.name == "g"), None)
        if p is None:
            return self.nominal_scenario().plant_params.g
        if p.values:
            ends: tuple[float, ...] = p.values
        elif p.dist == "normal":
            reach = NORMAL_REACH * p.std
            ends = (
                p.mean - reach if p.low is None else p.low,
                p.mean + reach if p.high is None else p.high,
            )
        else:
            ends = (p.low, p.high)
        from twolink.simulation.batch import model_gravity  # one rule for every set of arms

        return model_gravity([arm.scaled(g=f).g for f in ends])

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
    raw, data = _read_sweep_file(path, file, overrides)
    top = TomlTable(data, "", file)
    name, samples, seed, chunk_size = _sizes(top, path)
    execution = _execution(top)
    success = _success(top)
    base = _base_scenario(top, path, file)
    parameters = _parameters(top, file)
    _check_listed(top, parameters, samples)
    controllers = _controllers(top, base, path, file)
    top.done()

    nominal = scenario_from_dict(base, file)
    joints = tuple(
        j + 1
        for j, target in enumerate(nominal.reference.final)
        if math.isfinite(target) and target != nominal.q0[j]
    )
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
        digest=_digest(data, base, controllers),
        file_sha256=hashlib.sha256(raw).hexdigest(),
        joints=joints,
        success=success,
        step=largest_step(nominal.reference, nominal.q0),
        finished=finished(nominal.reference, nominal.duration),
    )


def _read_sweep_file(
    path: Path, file: str, overrides: Mapping[str, Any] | None
) -> tuple[bytes, dict[str, Any]]:
    """The sweep file's bytes and its data, with ``overrides`` merged in."""
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
    return raw, strip_replace(data)  # the flags merged onto the sweep's own tables are spent


def _sizes(top: TomlTable, path: Path) -> tuple[str, int, int, int]:
    """The sweep's name, samples, seed and chunk size."""
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
    return name, samples, seed, chunk_size


def _execution(top: TomlTable) -> Execution:
    """The file's ``[execution]`` defaults."""
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
    return execution


def _success(top: TomlTable) -> SuccessSpec:
    """The file's ``[success]`` spec."""
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
    return success


def _base_scenario(top: TomlTable, path: Path, file: str) -> dict[str, Any]:
    """The base scenario as data, with the sweep's ``[overrides]`` and ``[reference]``
    merged in; its own errors name its own file."""
    scenario_path = top.raw("scenario")
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
    return base


def parameter_conflict(names: Sequence[str]) -> tuple[str, str] | None:
    """The first of ``names`` that two parameters set at once, with why (None where none
    does): ``k`` and ``k1``, ``friction_level`` and ``coulomb1``, ``zeta_joint`` and
    ``d``... What a sweep file's ``[parameters]`` and a plants file's columns refuse."""
    for p in FLEX_PARAMETERS:
        both = [f"{p}{j}" for j in (1, 2) if f"{p}{j}" in names]
        if p in names and both:
            return both[0], f"conflicts with {p!r}, which sets both joints"
    for coulomb in ("coulomb1", "coulomb2"):
        if coulomb in names and "friction_level" in names:
            return coulomb, "conflicts with 'friction_level', which sets both joints' Coulomb"
    for damping in ("d", "d1", "d2"):
        if damping in names and "zeta_joint" in names:
            return damping, "conflicts with 'zeta_joint', which sets the damping of both joints"
    return None


def _parameters(top: TomlTable, file: str) -> tuple[Parameter, ...]:
    """The ``[parameters]`` drawn, sorted by name."""
    pt = top.table("parameters")
    for pname in pt.data:
        if pname not in PARAMETERS:
            pt.fail(pname, f"unknown parameter (known: {sorted(PARAMETERS)})")
    if conflict := parameter_conflict(list(pt.data)):
        pt.fail(*conflict)
    parameters = tuple(_parameter(n, pt.raw(n), file) for n in sorted(pt.data))
    pt.done()
    return parameters


def _check_listed(top: TomlTable, parameters: Sequence[Parameter], samples: int) -> None:
    """Every listed parameter has one value per sample: the same number of values each,
    and ``samples`` at most that number."""
    listed = [p for p in parameters if p.dist == "listed"]
    if not listed:
        return
    first = listed[0]
    n = len(first.values)
    for p in listed[1:]:
        if len(p.values) != n:
            top.fail(
                f"parameters.{p.name}.values",
                f"has {len(p.values)} value{'s' * (len(p.values) != 1)}, but "
                f"parameters.{first.name}.values has {n}: "
                "every listed parameter gives one value per sample",
            )
    if samples > n:
        top.fail(
            "samples",
            f"must be at most {n}, the number of values of the listed parameters "
            f"(parameters.{first.name}.values: sample i takes values[i]), got {samples}",
        )


def _controllers(
    top: TomlTable, base: dict[str, Any], path: Path, file: str
) -> list[tuple[str, dict[str, Any]]]:
    """The ``[controllers.NAME]`` tables, each checked on the base scenario."""
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
    return controllers


def _digest(
    data: dict[str, Any], base: dict[str, Any], controllers: list[tuple[str, dict[str, Any]]]
) -> str:
    """SHA-256 of what decides the chunks' contents (the [success] spec only classifies
    finished rows; N, the name and the execution decide none)."""
    content = {
        k: v for k, v in data.items() if k not in ("samples", "name", "execution", "success")
    }
    digest_source = {
        "format": FORMAT_VERSION,
        "sweep": content,
        "base": base,
        "rule_bases": _rule_base_hashes(controllers, base),
    }
    return hashlib.sha256(
        json.dumps(digest_source, sort_keys=True, default=str).encode()
    ).hexdigest()
