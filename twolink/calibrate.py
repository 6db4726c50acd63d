"""Calibrating the paper's unstated parameters to its own tables (``twolink calibrate``).

The paper gives no gains, step sizes, ramp slopes or model mismatch. This fits them to its
nominal tables (``runs/paper/calibrate.toml``) with :func:`scipy.optimize.differential_evolution`
(``vectorized=True``: one generation is one batch of arms on the batch engine), in two
stages: the CTC rows (natural frequency and damping per joint, step and ramp sizes, the
ramp's duration, the plant's mass against the controller's model), then the FCM-CTC rows
(the fuzzy scaling ke, kde, ku) with the CTC parameters fixed. Each run uses the paper's
own reference kinds (a raw step, a saturating ramp) with no torque limit.

Objective (docs/reproduction.md): per table row, the mean over the metrics the paper gives
of ``min(|ours - paper| / max(|paper|, floor), penalty)``, a metric undefined in our
response counting ``penalty``; a stage's objective is the mean over its rows. The result,
``runs/paper/calibrated.toml``, holds the parameters, each row's metrics, the objective's
profile along each parameter, and the digest of the study it came from (the report reruns
the calibrated rows from it, never the optimisation).
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from twolink.config import TomlTable, merge, read_toml, scenario_from_dict
from twolink.metrics import step_metrics

__all__ = [
    "Calibration",
    "Row",
    "Shipped",
    "calibrate",
    "load_calibration",
    "load_result",
    "rerun",
    "rerun_shipped",
    "report_section",
    "second_order_check",
    "table_values",
]

DEFAULT_STUDY = Path(__file__).resolve().parent.parent / "runs" / "paper" / "calibrate.toml"
SYMBOLS = ("Tp", "Td", "Ts", "Tr", "Mp", "ess")
FIELDS = {
    "Tp": "peak_time",
    "Td": "delay_time",
    "Ts": "settling_time",
    "Tr": "rise_time",
    "Mp": "overshoot",
    "ess": "steady_state_error",
}
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
        from twolink.config import resolve_rule_base

        data = {k: v for k, v in asdict(self).items() if k != "source"}
        rule_base = resolve_rule_base("designed").read_bytes()  # the FCM rows' rule base
        data["rule_base"] = hashlib.sha256(rule_base).hexdigest()
        blob = json.dumps(data, sort_keys=True, default=str)
        return hashlib.sha256(blob.encode()).hexdigest()

    def stage_rows(self, controller: str) -> list[Row]:
        return [r for r in self.rows if r.controller == controller]


def load_calibration(path: str | Path = DEFAULT_STUDY, overrides: dict | None = None):
    """Read and validate a calibration file; errors name the file and key."""
    from twolink.manifest import load_manifest

    path = Path(path)
    data = merge(read_toml(path), overrides or {})
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
    if study.refine_rounds < 0:
        t.fail("refine_rounds", f"must be >= 0, got {study.refine_rounds}")
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
    undefined or the run failed)."""
    from twolink.experiment import iter_scenarios

    data = [scenario_data(study, row, p) for row, p in jobs]
    scenarios = [scenario_from_dict(d, study.source) for d in data]
    out: list[dict[str, float]] = [dict.fromkeys(SYMBOLS, math.nan) for _ in jobs]
    for i, traj in iter_scenarios(scenarios):
        if isinstance(traj, Exception) or traj.status != "ok" or not len(traj.t):
            continue
        row, p = jobs[i]
        size = p[f"{row.kind}{row.joint}"]
        m = step_metrics(traj.t, traj.q[:, row.joint - 1], size, y0=0.0)
        out[i] = {s: float(getattr(m, FIELDS[s])) for s in SYMBOLS}
    return out


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


def _objective(study: Calibration, controller: str, fixed: dict[str, float], free: list[str]):
    rows = study.stage_rows(controller)

    def f(x: np.ndarray) -> np.ndarray:
        x = np.atleast_2d(np.asarray(x, dtype=float).T).T  # (N,) or (N, S) -> (N, S)
        members = [{**fixed, **dict(zip(free, x[:, k], strict=True))} for k in range(x.shape[1])]
        jobs = [(row, p) for p in members for row in rows]
        metrics = run_rows(study, jobs)
        costs = [row_cost(study, m, row.paper) for (row, _), m in zip(jobs, metrics, strict=True)]
        return np.asarray(costs).reshape(len(members), len(rows)).mean(axis=1)

    return f


def _fit_stage(study: Calibration, controller: str, fixed: dict[str, float], log=None):
    """Differential evolution over the stage's free parameters (the others ``fixed``)."""
    from scipy.optimize import differential_evolution

    key, names = STAGES[controller]
    bounds = study.bounds[key]
    free = [n for n in names if bounds[n][0] < bounds[n][1]]
    fixed = {**fixed, **{n: bounds[n][0] for n in names if n not in free}}
    f = _objective(study, controller, fixed, free)
    gen = [0]

    def callback(*_args, **_kw):
        gen[0] += 1
        if log:
            log(f"{controller}: generation {gen[0]} of {study.maxiter}")

    res = differential_evolution(
        f,
        [bounds[n] for n in free],
        seed=study.seed,
        popsize=study.popsize,
        maxiter=study.maxiter,
        polish=False,
        vectorized=True,
        updating="deferred",
        tol=0.0,
        callback=callback,
    )
    best = {**fixed, **{n: float(v) for n, v in zip(free, res.x, strict=True)}}
    best, cost, evals = _refine(study, controller, best, float(res.fun), free, log)
    return best, cost, int(res.nfev) + evals


# The refinement's stopping rule: a move must lower the objective by more than this (and
# at most the study's ``refine_rounds`` rounds over the parameters, one batch each).
REFINE_TOL = 1e-3
REFINE_LOCAL = 4  # extra points next to the current value, within one grid step


def refine_grid(study: Calibration, lo: float, hi: float, at: float) -> list[float]:
    """The values a refinement round tries for one parameter: the profile's grid over the
    bounds, the current value, and points within one grid step of it."""
    step = (hi - lo) / (study.profile_points - 1)
    local = at + step * np.linspace(-1.0, 1.0, REFINE_LOCAL + 2)[1:-1]
    grid = {*np.linspace(lo, hi, study.profile_points).tolist(), at}
    return sorted(grid | {float(v) for v in np.clip(local, lo, hi)})


def _refine(study: Calibration, controller: str, best: dict, cost: float, free: list, log=None):
    """Coordinate descent from differential evolution's optimum: each parameter in turn
    moves to the best value of :func:`refine_grid` (the others held), until a whole round
    improves the objective by at most :data:`REFINE_TOL`. Differential evolution stops on
    its generation budget, not on convergence; after this, no point of the profile grid
    along any parameter is better than the fit by more than the tolerance."""
    key = STAGES[controller][0]
    evals = 0
    for round_ in range(study.refine_rounds):
        start = cost
        for name in free:
            lo, hi = study.bounds[key][name]
            values = refine_grid(study, lo, hi, best[name])
            others = {k: v for k, v in best.items() if k != name}
            objective = _objective(study, controller, others, [name])(np.array([values]))
            evals += len(values)
            k = int(np.argmin(objective))
            if objective[k] < cost - REFINE_TOL:
                best, cost = {**best, name: float(values[k])}, float(objective[k])
        if log:
            log(f"{controller}: refinement round {round_ + 1}: objective {cost:.4f}")
        if cost >= start - REFINE_TOL:
            break
    return best, cost, evals


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
    """Per parameter, the share of its bounds where the profile stays within ``slack`` of
    the optimum: small (<= 0.3) means the tables pin it down, large that they leave it free."""
    key, _ = STAGES[controller]
    out = {}
    for name, p in prof.items():
        lo, hi = study.bounds[key][name]
        v, obj = np.asarray(p["values"]), np.asarray(p["objective"])
        near = v[obj <= best + slack]
        out[name] = float((near.max() - near.min()) / (hi - lo)) if near.size else 0.0
    return out


def n_runs(study: Calibration) -> int:
    """How many arms :func:`calibrate` runs at most: per stage (maxiter + 1) generations of
    popsize x free parameters members, each on the stage's rows, the refinement's rounds,
    then the profiles and the rerun."""
    total = len(study.rows)
    for ctrl, (key, _names) in STAGES.items():
        free = sum(lo < hi for lo, hi in study.bounds[key].values())
        rows = len(study.stage_rows(ctrl))
        total += (study.maxiter + 1) * study.popsize * free * rows
        total += study.refine_rounds * free * (study.profile_points + 1 + REFINE_LOCAL) * rows
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
        "evaluations": {"CTC": ctc_evals, "FCM-CTC": fcm_evals},
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
    from twolink.io import atomic_write_text, to_toml

    path.parent.mkdir(parents=True, exist_ok=True)
    head = "# Written by `twolink calibrate` (twolink.calibrate): do not edit by hand.\n"
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


# ---- the analysis ---------------------------------------------------------------------


def second_order_times(zeta: float) -> dict[str, float]:
    """Td, Tr (10-90 %), Tp of the unit step response of ω² / (s² + 2ζωs + ω²) at ω = 1."""
    t = np.linspace(0.0, 60.0, 600001)
    wd = math.sqrt(1 - zeta * zeta)
    y = 1 - np.exp(-zeta * t) * (np.cos(wd * t) + zeta / wd * np.sin(wd * t))
    m = step_metrics(t, y, 1.0)
    t10 = float(t[np.argmax(y >= 0.1)])
    return {"Td": m.delay_time, "Tr": m.rise_time, "Tp": m.peak_time, "T10": t10}


def second_order_check(paper: dict[str, float]) -> dict[str, float] | None:
    """What a second-order step response with the paper's Mp implies, and a model-free
    bound: with Mp > 0 the response passes 90 % before its peak, so T10 <= Tp - Tr, and
    rising 10 -> 50 % takes at least Td - (Tp - Tr) while 50 -> 90 % takes at most Tp - Td.
    None where the row has no overshoot (or no Tp, Td, Tr)."""
    mp, tp, td, tr = (paper[s] for s in ("Mp", "Tp", "Td", "Tr"))
    if not (0 < mp < 1) or any(math.isnan(v) for v in (tp, td, tr)):
        return None
    zeta = -math.log(mp) / math.sqrt(math.pi**2 + math.log(mp) ** 2)
    so = second_order_times(zeta)
    slow_half = so["Td"] - so["T10"]  # 10 -> 50 %
    fast_half = so["T10"] + so["Tr"] - so["Td"]  # 50 -> 90 %
    return {
        "zeta": zeta,
        "Td/Tp": td / tp,
        "Td/Tp 2nd order": so["Td"] / so["Tp"],
        "Tr/Tp": tr / tp,
        "Tr/Tp 2nd order": so["Tr"] / so["Tp"],
        "T10 max": tp - tr,
        "10-50 min": td - (tp - tr),
        "50-90 max": tp - td,
        "ratio 2nd order": slow_half / fast_half,
    }


def check_lines(study: Calibration) -> list[str]:
    """The analytic check of every step row with overshoot, as markdown (a ramp's own
    slope shapes the rise, so the second-order ratios do not apply to it)."""
    lines = [
        "| row | Mp | implied ζ | Td/Tp paper / 2nd order | Tr/Tp paper / 2nd order "
        "| T10 at most | 10→50 % at least / 50→90 % at most (2nd order: ratio) |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in study.rows:
        c = second_order_check(r.paper) if r.kind == "step" else None  # a ramp delays 10 %
        if c is None:
            continue
        lines.append(
            f"| Table {r.table} {r.controller} ({r.kind}) | {r.paper['Mp']:g} | {c['zeta']:.3f} "
            f"| {c['Td/Tp']:.2f} / {c['Td/Tp 2nd order']:.2f} "
            f"| {c['Tr/Tp']:.2f} / {c['Tr/Tp 2nd order']:.2f} | {c['T10 max']:.2f} s "
            f"| {c['10-50 min']:.2f} s / {c['50-90 max']:.2f} s "
            f"({c['ratio 2nd order']:.2f}) |"
        )
    return lines


# ---- the report -----------------------------------------------------------------------


def comparison_lines(study: Calibration, rows: dict[str, dict[str, float]]) -> list[str]:
    """Per table row: paper / calibrated (relative error) per metric, the row's best
    relative error, and which metrics come within ``study.within``."""
    lines = [
        "| row | " + " | ".join(SYMBOLS) + f" | best | within {study.within:.0%} |",
        "|---|" + "---|" * (len(SYMBOLS) + 2),
    ]
    for r in study.rows:
        ours = rows[f"table{r.table} {r.controller}"]
        err = relative_errors(study, ours, r.paper)
        cells = []
        for s in SYMBOLS:
            p = "—" if math.isnan(r.paper[s]) else f"{r.paper[s]:.3g}"
            e = f" ({err[s]:.0%})" if s in err and math.isfinite(err[s]) else ""
            cells.append(f"{p} / {ours[s]:.3g}{e}")
        best = min(err, key=err.get) if err else None
        fits = [s for s, e in err.items() if e <= study.within]
        lines.append(
            f"| Table {r.table} {r.controller} ({r.kind}) | "
            + " | ".join(cells)
            + f" | {best} {err[best]:.0%} | {', '.join(fits) or 'none'} |"
        )
    return lines


def _key(r: Row) -> str:
    return f"table{r.table} {r.controller}"


def fit_counts(study: Calibration, rows: dict[str, dict[str, float]]) -> tuple[int, int]:
    """(metrics within ``study.within``, metrics the paper gives) over all rows."""
    fit = total = 0
    for r in study.rows:
        err = relative_errors(study, rows[f"table{r.table} {r.controller}"], r.paper)
        total += len(err)
        fit += sum(e <= study.within for e in err.values())
    return fit, total


def profile_figure(study: Calibration, result: dict[str, Any], path: Path) -> Path:
    """The objective along each parameter (others at the optimum), one panel each."""
    from twolink.plots import plt, save_figure

    panels = [(c, n, p) for c, prof in result["profile"].items() for n, p in prof.items()]
    cols = 5
    fig, axes = plt.subplots(
        -(-len(panels) // cols), cols, figsize=(14, 2.6 * -(-len(panels) // cols))
    )
    for ax, (ctrl, name, p) in zip(np.ravel(axes), panels, strict=False):
        ax.plot(p["values"], p["objective"], "o-", ms=3)
        ax.axvline(result["parameters"][name], color="tab:red", lw=1)
        ax.axhline(result["objective"][ctrl] + 0.05, color="k", lw=0.6, ls=":")
        ax.set(title=f"{ctrl}: {name}", ylim=(0, None))
        ax.grid(alpha=0.3)
    for ax in np.ravel(axes)[len(panels) :]:
        ax.axis("off")
    fig.suptitle("Calibration objective along each parameter (others at the optimum; red: fit)")
    fig.tight_layout()
    save_figure(fig, path, dpi=100)  # atomic, as every output
    return path


def summary_lines(study: Calibration, result: dict[str, Any], rows) -> list[str]:
    """Parameters with how well the tables pin them, and the per-row comparison."""
    p = result["parameters"]
    share = {}
    for ctrl in STAGES:
        share.update(pinned(study, ctrl, result["profile"][ctrl], result["objective"][ctrl]))
    words = {n: f" ({'pinned' if v <= 0.3 else 'free'}: {v:.0%})" for n, v in share.items()}
    params = ", ".join(f"{n} = {p[n]:.3g}{words.get(n, '')}" for n in (*CTC_PARAMS, *FCM_PARAMS))
    better = [
        f"{n} = {v:.3g} gives {o:.3f} ({ctrl})"
        for ctrl in STAGES
        for n, prof in result["profile"][ctrl].items()
        for v, o in zip(prof["values"], prof["objective"], strict=True)
        if o < result["objective"][ctrl] - 0.01 and o == min(prof["objective"])
    ]
    note = (
        f" The fit is not the global optimum: along one parameter, {'; '.join(better)}."
        if better
        else ""
    )
    return [
        f"Objective (mean capped relative error): CTC rows {result['objective']['CTC']:.3f}, "
        f"FCM-CTC rows {result['objective']['FCM-CTC']:.3f}.{note}",
        "",
        f"Parameters (share of the bounds within 0.05 of the optimum): {params}.",
        "",
        *comparison_lines(study, rows),
    ]


@dataclass(frozen=True)
class Shipped:
    """The shipped calibration rerun: its study, saved result, whether the result is of
    the study as it is now, and each row's metrics from the rerun."""

    study: Calibration
    result: dict[str, Any]
    current: bool
    rows: dict[str, dict[str, float]]


def rerun_shipped(path: Path) -> Shipped | None:
    """Load the study at ``path`` and rerun its shipped result (a few runs); None where
    nothing is shipped. What the report's section and its calibrated column both show."""
    study = load_calibration(Path(path))
    loaded = load_result(study)
    if loaded is None:
        return None
    result, current = loaded
    return Shipped(study, result, current, rerun(study, result))


def table_values(shipped: Shipped | None) -> dict[int, dict[str, dict[str, float]]]:
    """The rerun's metrics per paper table and controller (symbol -> value, Mp a fraction):
    the report's calibrated column (:func:`twolink.report.render`)."""
    if shipped is None:
        return {}
    out: dict[int, dict[str, dict[str, float]]] = {}
    for r in shipped.study.rows:
        out.setdefault(r.table, {})[r.controller] = dict(shipped.rows[_key(r)])
    return out


def report_section(path: Path, out: Path, shipped: Shipped | None = None) -> list[str]:
    """The calibration's part of the report: the shipped parameters rerun here (a few
    runs; ``shipped`` if already rerun), paper / calibrated per metric, the profile figure
    and the analytic check."""
    path = Path(path)
    shipped = shipped or rerun_shipped(path)
    head = ["", "## Calibrated against the paper", ""]
    if shipped is None:
        return [*head, f"No calibration shipped: run `twolink calibrate --install` ({path.name})."]
    study, result, current, rows = shipped.study, shipped.result, shipped.current, shipped.rows
    profile_figure(study, result, out / "figures" / "calibration_profile.png")
    fit, total = fit_counts(study, rows)
    whole = ", ".join(
        f"Table {r.table} {r.controller}"
        for r in study.rows
        if all(e <= study.within for e in relative_errors(study, rows[_key(r)], r.paper).values())
    )
    stale = (
        "" if current else " **Stale**: the study changed since; run `twolink calibrate --install`."
    )
    return [
        *head,
        f"`twolink calibrate` fitted the paper's unstated parameters to Tables "
        f"{', '.join(str(t) for t in sorted({r.table for r in study.rows}))} (`{path.name}`; "
        "docs/reproduction.md, 'Calibrating to the paper's tables'); here the shipped "
        f"`{result_path(study).name}` is rerun ({len(study.rows)} runs: raw steps and "
        f"saturating ramps, no torque limit).{stale} Cells: paper / calibrated (relative error). "
        "The rigid arm's tables above print the same calibrated values between ours and the "
        "paper's.",
        "",
        *summary_lines(study, result, rows),
        "",
        "![calibration profile](figures/calibration_profile.png)",
        "",
        "**Which published numbers contradict each other.** With overshoot, a response "
        "passes 90 % before its peak, so T10 <= Tp - Tr; a second-order response with the "
        "paper's Mp has the damping ratio below and these time ratios:",
        "",
        *check_lines(study),
        "",
        f"**How close the paper can be reproduced**: at the best parameters {fit} of the "
        f"{total} published metrics of these rows come within {study.within:.0%} (objective "
        f"{result['objective']['CTC']:.2f} on the CTC rows, {result['objective']['FCM-CTC']:.2f} "
        f"on the FCM-CTC rows); the fit reproduces {whole or 'no row'} whole, and some rows no "
        "parameters can: Table 2's CTC row contradicts itself (above), and Table 5's negative "
        "Mp is no overshoot.",
    ]
