"""Calibrating the paper's unstated parameters to its own tables (``twolink calibrate``).

The paper gives no gains, step sizes, ramp slopes or model mismatch. This fits them to its
nominal tables (``runs/paper/calibrate.toml``) with :func:`scipy.optimize.differential_evolution`
(``vectorized=True``: one generation is one batch of arms on the batch engine), in two
stages: the CTC rows (natural frequency and damping per joint, step and ramp sizes, the
ramp's duration, the plant's mass against the controller's model), then the FCM-CTC rows
(the fuzzy scaling ke, kde, ku) with the CTC parameters fixed. Each stage runs
differential evolution from ``starts`` seeds and refines the best to convergence
(coordinate descent over the profile grid and a compass search, :func:`_refine`). Each run
uses the paper's own reference kinds (a raw step, a saturating ramp) with no torque limit.

Objective (docs/reproduction.md): per table row, the mean over the metrics the paper gives
of ``min(|ours - paper| / max(|paper|, floor), penalty)``, a metric undefined in our
response counting ``penalty``; a stage's objective is the mean over its rows. The result,
``runs/paper/calibrated.toml``, holds the parameters, each row's metrics, the objective's
profile along each parameter, and the digest of the study it came from (the report reruns
the calibrated rows from it, never the optimisation;
:mod:`twolink.studies.designs.calibration_report`
writes the comparison and the analysis).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from twolink.foundation.shipped import locate, runs_dir
from twolink.simulation.config import (
    TomlTable,
    expect_kind,
    merge,
    read_toml,
    scenario_from_dict,
)
from twolink.simulation.metrics import step_metrics
from twolink.simulation.vocabulary import STEP_KEYS, metric

__all__ = [
    "Calibration",
    "Row",
    "calibrate",
    "load_calibration",
    "load_result",
    "rerun",
]

DEFAULT_STUDY = runs_dir() / "paper" / "calibrate.toml"  # package data
SYMBOLS = ("Tp", "Td", "Ts", "Tr", "Mp", "ess")
FIELDS = {
    "Tp": "peak_time",
    "Td": "delay_time",
    "Ts": "settling_time",
    "Tr": "rise_time",
    "Mp": "overshoot",
    "ess": "steady_state_error",
}
# Output units (Mp in percent) -> the paper's (Mp a fraction): the study compares in these.
PAPER_SCALE = {metric(k).symbol: metric(k).paper_scale for k in STEP_KEYS}
CTC_PARAMS = ("wn1", "zeta1", "wn2", "zeta2", "step1", "step2", "ramp1", "ramp2", "ramp_time")
CTC_PARAMS = (*CTC_PARAMS, "mass")
FCM_PARAMS = ("ke", "kde", "ku")
STAGES = {"CTC": ("ctc", CTC_PARAMS), "FCM-CTC": ("fcm", FCM_PARAMS)}


@dataclass(frozen=True)
class Row:
    """One table row of the paper: its table, joint, reference kind and values."""

    table: int
    controller: str  # "CTC" or "FCM-CTC"
    joint: int
    kind: str  # "step" or "ramp"
    paper: dict[str, float]  # symbol -> value (NaN: not given)


@dataclass(frozen=True)
class Calibration:
    """A calibration study as its file describes it (``runs/paper/calibrate.toml``)."""

    source: str
    arm: dict[str, float]
    rows: tuple[Row, ...]
    duration: float
    timestep: float
    control_dt: float
    seed: int
    starts: int
    popsize: int
    maxiter: int
    penalty: float
    floors: dict[str, float]
    within: float
    profile_points: int
    refine_rounds: int
    bounds: dict[str, dict[str, tuple[float, float]]]  # stage key -> parameter -> bounds

    def digest(self) -> str:
        """What decides the result: every setting, bound, paper value, the arm and the
        designed rule base the FCM-CTC rows run."""
        from twolink.simulation.config import resolve_rule_base

        data = {k: v for k, v in asdict(self).items() if k != "source"}
        rule_base = resolve_rule_base("designed").read_bytes()  # the FCM rows' rule base
        data["rule_base"] = hashlib.sha256(rule_base).hexdigest()
        blob = json.dumps(data, sort_keys=True, default=str)
        return hashlib.sha256(blob.encode()).hexdigest()

    def stage_rows(self, controller: str) -> list[Row]:
        return [r for r in self.rows if r.controller == controller]


def load_calibration(path: str | Path = DEFAULT_STUDY, overrides: dict | None = None):
    """Read and validate a calibration file; errors name the file and key."""
    from twolink.studies.reproduction.manifest import load_manifest

    path = locate(path)
    data = read_toml(path)
    expect_kind(data, path, "calibration")
    data = merge(data, overrides or {})
    t = TomlTable(data, "", str(path))
    manifest = load_manifest(path.parent / t.string("manifest", "reproduce.toml"))
    base = read_toml(path.parent / t.string("base", "base.toml"))
    tables = t.raw("tables", [2, 3, 5, 7])
    rows = []
    for exp in manifest.experiments:
        if exp.table not in tables:
            continue
        ref = read_toml(exp.scenario).get("reference", {}).get(f"joint{exp.joint}", {})
        kind = "ramp" if ref.get("kind") == "ramp" else "step"
        for ctrl in STAGES:
            paper = {s: float(exp.paper.get(ctrl, {}).get(s, math.nan)) for s in SYMBOLS}
            rows.append(Row(exp.table, ctrl, exp.joint, kind, paper))
    if {r.table for r in rows} != set(tables):
        t.fail("tables", f"must name tables of {manifest.path.name}, got {tables!r}")
    floors_t = t.table("floors")
    floors = {s: floors_t.number(s, 0.1, positive=True) for s in SYMBOLS}
    floors_t.done()
    bounds: dict[str, dict[str, tuple[float, float]]] = {}
    for key, names in STAGES.values():
        bt = t.table(key)
        bounds[key] = {}
        for name in names:
            lo, hi = bt.pair(name, (math.nan, math.nan))
            if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
                bt.fail(name, f"must be bounds [low, high] with low <= high, got {[lo, hi]}")
            bounds[key][name] = (lo, hi)
        bt.done()
    study = Calibration(
        source=str(path),
        arm=dict(base.get("arm", {})),
        rows=tuple(rows),
        duration=t.number("duration", 15.0, positive=True),
        timestep=t.number("timestep", 0.005, positive=True),
        control_dt=t.number("control_dt", 0.01, positive=True),
        seed=t.integer("seed", 0),
        starts=t.integer("starts", 1),
        popsize=t.integer("popsize", 5),
        maxiter=t.integer("maxiter", 25),
        penalty=t.number("penalty", 1.0, positive=True),
        floors=floors,
        within=t.number("within", 0.1, positive=True),
        profile_points=t.integer("profile_points", 13),
        refine_rounds=t.integer("refine_rounds", 4),
        bounds=bounds,
    )
    if study.popsize < 1 or study.maxiter < 0 or study.profile_points < 2:
        t.fail("popsize", "popsize >= 1, maxiter >= 0 and profile_points >= 2 are needed")
    if study.starts < 1:
        t.fail("starts", f"must be >= 1, got {study.starts}")
    if study.refine_rounds < 0:
        t.fail("refine_rounds", f"must be >= 0, got {study.refine_rounds}")
    steps = n_runs(study) * math.ceil(study.duration / study.timestep)
    if steps > MAX_CALIBRATION_STEPS:
        t.fail(
            "popsize",
            f"{steps:,} arm steps (the arms popsize, maxiter, starts and refine_rounds ask "
            f"for x duration / timestep) > {MAX_CALIBRATION_STEPS:,}, about 3 days at the "
            "measured ~9 us a step: lower popsize or maxiter",
        )
    t.done()
    return study


# ---- runs -----------------------------------------------------------------------------


def scenario_data(study: Calibration, row: Row, p: dict[str, float]) -> dict[str, Any]:
    """The scenario of ``row`` under parameters ``p`` (stage 1's, plus stage 2's for FCM)."""
    j = row.joint
    size = p[f"{row.kind}{j}"]
    if row.kind == "step":
        moving = {"kind": "step", "initial": 0.0, "final": size}
    else:
        moving = {"kind": "ramp", "initial": 0.0, "final": size, "duration": p["ramp_time"]}
    held = {"kind": "step", "initial": 0.0, "final": 0.0}
    wn, zeta = (p["wn1"], p["wn2"]), (p["zeta1"], p["zeta2"])
    controller: dict[str, Any] = {
        "kind": "ctc",
        "kp": [w * w for w in wn],
        "kd": [2 * z * w for z, w in zip(zeta, wn, strict=True)],
    }
    if row.controller == "FCM-CTC":
        fuzzy = {"ke": p["ke"], "kde": p["kde"], "ku": p["ku"], "mode": "add"}
        controller.update(kind="fcm_ctc", rule_base="designed", fuzzy=fuzzy)
    return {
        "name": f"Table {row.table}, {row.controller} (calibrated)",
        "duration": study.duration,
        "timestep": study.timestep,
        "control_dt": study.control_dt,
        "arm": dict(study.arm),
        "controller": controller,
        "reference": {f"joint{j}": moving, f"joint{3 - j}": held},
        "plant": {"scale": {"m1": p["mass"], "m2": p["mass"]}},
    }


def run_rows(
    study: Calibration, jobs: list[tuple[Row, dict[str, float]]]
) -> list[dict[str, float]]:
    """Each (row, parameters) run on the batch engine: its metrics by symbol (NaN where
    undefined or the run failed). The arms are split into one batch per core, run in
    threads (MuJoCo releases the GIL while it steps); an arm's run does not depend on its
    batch (one model gravity for all the shares), so the split changes no number."""
    from concurrent.futures import ThreadPoolExecutor

    from twolink.simulation.batch import model_gravity
    from twolink.simulation.experiment import iter_scenarios

    data = [scenario_data(study, row, p) for row, p in jobs]
    scenarios = [scenario_from_dict(d, study.source) for d in data]
    out: list[dict[str, float]] = [dict.fromkeys(SYMBOLS, math.nan) for _ in jobs]
    if not jobs:
        return out

    model_g = model_gravity([s.plant_params.g for s in scenarios])  # one for every share

    def measure(share: range) -> None:
        for k, traj in iter_scenarios([scenarios[i] for i in share], model_g=model_g):
            if isinstance(traj, Exception) or traj.status != "ok" or not len(traj.t):
                continue
            i = share[k]
            row, p = jobs[i]
            size = p[f"{row.kind}{row.joint}"]
            # ess as the paper's tables give it, one reading at the end of its plots (the
            # last sample), as the shipped fit was made (docs/metrics.md, "Reading the end
            # of a run": every other output reads the settling window's mean)
            m = step_metrics(traj.t, traj.q[:, row.joint - 1], size, y0=0.0, ess_window=0.0)
            # in the paper's units, as its tables and the study's floors (Mp a fraction)
            out[i] = {s: float(getattr(m, FIELDS[s])) / PAPER_SCALE[s] for s in SYMBOLS}

    # A batch's cost per step is mostly fixed below ~50 arms: split only larger ones.
    parts = max(1, min(os.cpu_count() or 1, len(jobs) // MIN_BATCH))
    size = -(-len(jobs) // parts)
    shares = [range(k, min(k + size, len(jobs))) for k in range(0, len(jobs), size)]
    with ThreadPoolExecutor(len(shares)) as pool:
        list(pool.map(measure, shares))  # list(): re-raise a thread's error here
    return out


MIN_BATCH = 50  # arms below which run_rows does not split a batch over threads


def relative_errors(study: Calibration, ours: dict[str, float], paper: dict[str, float]):
    """Per metric the paper gives: |ours - paper| / max(|paper|, floor) (inf: undefined)."""
    out = {}
    for s in SYMBOLS:
        if math.isnan(paper[s]):
            continue
        o = ours[s]
        out[s] = (
            math.inf if math.isnan(o) else abs(o - paper[s]) / max(abs(paper[s]), study.floors[s])
        )
    return out


def row_cost(study: Calibration, ours: dict[str, float], paper: dict[str, float]) -> float:
    errors = relative_errors(study, ours, paper).values()
    return float(np.mean([min(e, study.penalty) for e in errors]))


def _objective(
    study: Calibration,
    controller: str,
    fixed: dict[str, float],
    free: list[str],
    count: list[int] | None = None,
):
    """The stage's objective as a vectorized function of the ``free`` parameters (one
    column a parameter set; one batch of arms per call); ``count[0]`` adds up the
    parameter sets evaluated."""
    rows = study.stage_rows(controller)

    def f(x: np.ndarray) -> np.ndarray:
        x = np.atleast_2d(np.asarray(x, dtype=float).T).T  # (N,) or (N, S) -> (N, S)
        members = [{**fixed, **dict(zip(free, x[:, k], strict=True))} for k in range(x.shape[1])]
        if count is not None:
            count[0] += len(members)
        jobs = [(row, p) for p in members for row in rows]
        metrics = run_rows(study, jobs)
        costs = [row_cost(study, m, row.paper) for (row, _), m in zip(jobs, metrics, strict=True)]
        return np.asarray(costs).reshape(len(members), len(rows)).mean(axis=1)

    return f


def _fit_stage(study: Calibration, controller: str, fixed: dict[str, float], log=None):
    """Differential evolution over the stage's free parameters (the others ``fixed``),
    once per start (seeds ``seed``, ``seed + 1``, ...: the objective has several basins and
    one run finds one), each start refined to convergence (:func:`_refine`); the best
    refined start wins (ties: the earlier). Returns the parameters, the objective and how
    many parameter sets were evaluated."""
    from scipy.optimize import differential_evolution

    key, names = STAGES[controller]
    bounds = study.bounds[key]
    free = [n for n in names if bounds[n][0] < bounds[n][1]]
    fixed = {**fixed, **{n: bounds[n][0] for n in names if n not in free}}
    count = [0]
    f = _objective(study, controller, fixed, free, count)
    best, cost = dict(fixed), math.inf
    for start in range(study.starts):
        seed = study.seed + start
        gen = [0]

        def callback(*_args, _gen=gen, _start=start, **_kw):
            _gen[0] += 1
            if log:
                log(
                    f"{controller}: start {_start + 1} of {study.starts}: generation "
                    f"{_gen[0]} of {study.maxiter}"
                )

        res = differential_evolution(
            f,
            [bounds[n] for n in free],
            seed=seed,
            popsize=study.popsize,
            maxiter=study.maxiter,
            polish=False,
            vectorized=True,
            updating="deferred",
            tol=0.0,
            callback=callback,
        )
        if log:
            log(f"{controller}: start {start + 1} (seed {seed}): objective {res.fun:.4f}")
        found = {**fixed, **{n: float(v) for n, v in zip(free, res.x, strict=True)}}
        found, found_cost, evals = _refine(study, controller, found, float(res.fun), free, log)
        count[0] += evals
        if found_cost < cost:
            best, cost = found, found_cost
    return best, cost, count[0]


# The refinement's stopping rule: a round must lower the objective by more than this (and
# at most the study's ``refine_rounds`` rounds). A round is one coordinate-descent pass
# over the profile grid (one batch of arms per parameter), and where that finds nothing,
# a compass search.
REFINE_TOL = 1e-3
REFINE_LOCAL = 4  # extra points next to the current value, within one grid step
# The compass search: a poll moves when it lowers the objective by more than COMPASS_TOL,
# else the step halves, from one profile grid step down to 2**-COMPASS_LEVELS of it, in
# at most COMPASS_POLLS polls (each one batch of 2 x the free parameters).
COMPASS_TOL = 1e-4
COMPASS_LEVELS = 6
COMPASS_POLLS = 15


def refine_grid(study: Calibration, lo: float, hi: float, at: float) -> list[float]:
    """The values a refinement round tries for one parameter: the profile's grid over the
    bounds, the current value, and points within one grid step of it."""
    step = (hi - lo) / (study.profile_points - 1)
    local = at + step * np.linspace(-1.0, 1.0, REFINE_LOCAL + 2)[1:-1]
    grid = {*np.linspace(lo, hi, study.profile_points).tolist(), at}
    return sorted(grid | {float(v) for v in np.clip(local, lo, hi)})


def _grid_round(study, controller, best, cost, free, count):
    """One coordinate-descent pass: each parameter in turn moves to the best value of
    :func:`refine_grid` (the others held) where that lowers the objective by more than
    :data:`REFINE_TOL`."""
    key = STAGES[controller][0]
    for name in free:
        lo, hi = study.bounds[key][name]
        values = refine_grid(study, lo, hi, best[name])
        others = {k: v for k, v in best.items() if k != name}
        objective = _objective(study, controller, others, [name], count)(np.array([values]))
        k = int(np.argmin(objective))
        if objective[k] < cost - REFINE_TOL:
            best, cost = {**best, name: float(values[k])}, float(objective[k])
    return best, cost


def _compass(study, controller, best, cost, free, count):
    """Compass search: poll ± h x (bound width) along every free parameter at once (one
    batch), move to the best poll where it lowers the objective by more than
    :data:`COMPASS_TOL`, else halve h; h starts at one profile grid step. Catches what the
    grid's coordinate steps miss: moves of several parameters together, below the grid."""
    key = STAGES[controller][0]
    lo = np.array([study.bounds[key][n][0] for n in free])
    hi = np.array([study.bounds[key][n][1] for n in free])
    x = np.array([best[n] for n in free])
    others = {k: v for k, v in best.items() if k not in free}
    f = _objective(study, controller, others, free, count)
    h, level = 1.0 / (study.profile_points - 1), 0
    for _ in range(COMPASS_POLLS):
        if level > COMPASS_LEVELS:
            break
        trial = np.clip(x + np.vstack([np.eye(len(x)), -np.eye(len(x))]) * h * (hi - lo), lo, hi)
        trial = trial[np.any(trial != x, axis=1)]  # a poll clipped back onto x tells nothing
        values = f(trial.T) if len(trial) else np.array([])
        k = int(np.argmin(values)) if len(values) else -1
        if k >= 0 and values[k] < cost - COMPASS_TOL:
            x, cost = trial[k], float(values[k])
        else:
            h, level = h / 2, level + 1
    return {**others, **{n: float(v) for n, v in zip(free, x, strict=True)}}, cost


def _refine(study: Calibration, controller: str, best: dict, cost: float, free: list, log=None):
    """Refinement from differential evolution's optimum, in rounds (at most the study's
    ``refine_rounds``): a coordinate-descent pass over the profile grid
    (:func:`_grid_round`); once a pass lowers the objective by at most
    :data:`REFINE_TOL`, a compass search (:func:`_compass`) from there, and where that
    lowers it by more, the grid again. It stops when neither does. Differential evolution
    stops on its generation budget, not on convergence; after this, no point of the
    profile grid along any parameter is better than the fit by more than the tolerance
    (the last pass found none), nor any compass poll by more than :data:`COMPASS_TOL`.
    Returns the parameters, the objective and the parameter sets evaluated."""
    count = [0]
    for round_ in range(study.refine_rounds):
        start = cost
        best, cost = _grid_round(study, controller, best, cost, free, count)
        if log:
            log(f"{controller}: refinement round {round_ + 1}: grid: objective {cost:.4f}")
        if cost < start - REFINE_TOL:
            continue  # the grid still moves: another pass before the compass search
        best, cost = _compass(study, controller, best, cost, free, count)
        if log:
            log(f"{controller}: refinement round {round_ + 1}: compass: objective {cost:.4f}")
        if cost >= start - REFINE_TOL:
            break
    return best, cost, count[0]


def profile(study: Calibration, controller: str, best: dict[str, float]) -> dict[str, Any]:
    """The stage's objective along each free parameter, the others at the optimum."""
    key, names = STAGES[controller]
    out = {}
    for name in names:
        lo, hi = study.bounds[key][name]
        if lo == hi:
            continue
        values = sorted({*np.linspace(lo, hi, study.profile_points).tolist(), best[name]})
        f = _objective(study, controller, {k: v for k, v in best.items() if k != name}, [name])
        out[name] = {"values": values, "objective": f(np.array([values])).tolist()}
    return out


def pinned(study: Calibration, controller: str, prof: dict[str, Any], best: float, slack=0.05):
    """Per parameter, the share of its bounds where its one-at-a-time slice (the others
    held at the fit) stays within ``slack`` of the optimum. Large means the tables leave
    it free; small does not prove they pin it down (a slice cannot see two parameters
    trading off; a profile, re-fitting the others, could)."""
    key, _ = STAGES[controller]
    out = {}
    for name, p in prof.items():
        lo, hi = study.bounds[key][name]
        v, obj = np.asarray(p["values"]), np.asarray(p["objective"])
        near = v[obj <= best + slack]
        out[name] = float((near.max() - near.min()) / (hi - lo)) if near.size else 0.0
    return out


# The budget's bound by time: 788 arms of 3,000 steps (maxiter 0, popsize 1, one start,
# no refinement) took 22 s in all on a loaded 2-core VM, ~9 us an arm step
MAX_CALIBRATION_STEPS = 30_000_000_000


def n_runs(study: Calibration) -> int:
    """How many arms :func:`calibrate` runs at most: per stage and start, (maxiter + 1)
    generations of popsize x free parameters members, each on the stage's rows, and the
    refinement's rounds (each the grid over every parameter and the compass search's
    polls, all of them); then the profiles and the rerun. Fits use far fewer (the
    refinement mostly stops after one or two rounds, the compass search after a dozen
    polls)."""
    total = len(study.rows)
    for ctrl, (key, _names) in STAGES.items():
        free = sum(lo < hi for lo, hi in study.bounds[key].values())
        rows = len(study.stage_rows(ctrl))
        total += study.starts * (study.maxiter + 1) * study.popsize * free * rows
        grid = free * (study.profile_points + 1 + REFINE_LOCAL)
        total += study.starts * study.refine_rounds * (grid + COMPASS_POLLS * 2 * free) * rows
        total += free * (study.profile_points + 1) * rows
    return total


def calibrate(study: Calibration, log=None) -> dict[str, Any]:
    """Both stages, the rows at the optimum and the profiles: the calibrated result."""
    ctc, ctc_cost, ctc_evals = _fit_stage(study, "CTC", {}, log)
    fcm, fcm_cost, fcm_evals = _fit_stage(study, "FCM-CTC", ctc, log)
    result: dict[str, Any] = {
        "kind": "calibrated",
        "study": Path(study.source).name,
        "digest": study.digest(),
        "objective": {"CTC": ctc_cost, "FCM-CTC": fcm_cost},
        "evaluations": {"CTC": ctc_evals, "FCM-CTC": fcm_evals},  # parameter sets
        "parameters": {**ctc, **{k: fcm[k] for k in FCM_PARAMS}},
    }
    result["rows"] = rerun(study, result)
    result["profile"] = {c: profile(study, c, fcm) for c in STAGES}
    return result


def rerun(study: Calibration, result: dict[str, Any]) -> dict[str, dict[str, float]]:
    """The calibrated rows, run again from the saved parameters: ``"table2 CTC"`` -> metrics."""
    p = result["parameters"]
    metrics = run_rows(study, [(row, p) for row in study.rows])
    return {f"table{r.table} {r.controller}": m for r, m in zip(study.rows, metrics, strict=True)}


def save_result(result: dict[str, Any], path: Path) -> Path:
    from twolink.foundation.io import atomic_write_text, to_toml

    path.parent.mkdir(parents=True, exist_ok=True)
    head = (
        "# Written by `twolink calibrate` (twolink.studies.designs.calibrate): "
        "do not edit by hand.\n"
    )
    atomic_write_text(path, head + to_toml(result))
    return path


def result_path(study: Calibration) -> Path:
    """Where the shipped result lives: ``calibrated.toml`` beside the study file."""
    return Path(study.source).with_name("calibrated.toml")


def load_result(study: Calibration, path: Path | None = None) -> tuple[dict[str, Any], bool] | None:
    """The saved result (None if absent) and whether it is current (its digest matches)."""
    import tomllib

    path = result_path(study) if path is None else path
    if not path.is_file():
        return None
    result = tomllib.loads(path.read_text())
    return result, result.get("digest") == study.digest()
