"""The linear opponent by search, per joint (docs/reproduction.md, "The linear opponent
by search").

The family a control engineer tunes: computed torque with its own ωn and ζ per joint
(Kp = ωn², Kd = 2ζωn per joint: 4 parameters), with the actuator's limit as given
(``CTC``) or clipped at FCM-CTC's peak torque per joint (``CTC clipped``). It is searched
with the fuzzy table search's optimiser, seed rule and budget
(:mod:`twolink.studies.designs.search`: differential evolution, seeded, a Latin-hypercube
initial population with the regime's own gains in it, no polish, one batch per
generation) on the same training plants, with the same objective (feasibility first:
within FCM-CTC's effort, the index; beyond it, :data:`~search.OVER` plus the excess).

**The effort rule** (:func:`admissible`): a loop is within FCM-CTC's effort when each of
the four effort values (median peak |τ| and Σ|Δτ| per joint) is at most FCM-CTC's plus the
claims' practical tolerance, *on the training plants and on the plants where the claim is
judged*. The ranking is the training index only: the judged plants veto a loop whose
effort is over budget there, they never promote one by its performance, so the claims'
performance stays held out. The opponent is the first admissible loop in the order of the
training index; a searched fuzzy table over budget on the judged plants is reported so
(:func:`twolink.studies.designs.effort.effort_flags`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from twolink.studies.designs.effort import admissible
from twolink.studies.designs.searched_opponent import (  # its public face too
    LAWS,
    TUNED,
    TUNED_FILE,
    SearchedOpponent,
    controller,
    shipped_opponents,
    shipped_tuned,
)

__all__ = [
    "FAMILIES",
    "SPANS",
    "SearchedOpponent",
    "choose_admissible",
    "controller",
    "evaluate_loops",
    "minimise",
    "shipped_opponents",
    "shipped_tuned",
    "tune",
]

FAMILIES = ("CTC", "CTC clipped")  # CTC-best's families
ZETA = (0.4, 1.5)  # the damping searched per joint: under- to over-damped
RHO = (0.0, 0.9)  # CTC-I's integral gain, a share of its nominal loop's stability bound
LOG_GAMMA = (-2.0, 2.0)  # Slotine-Li's Γ: 1/100 to 100 times the law's default diagonal
LOG_PHI = (-3.0, 1.0)  # sliding mode's boundary layer φ: 1 mrad/s to 10 rad/s
LOG_T = (-2.7, -0.3)  # CTC-DOB's observer time constant: 2 ms (2 control periods) to 0.5 s


def _ctc_start(c: Any) -> np.ndarray:
    """(ωn1, ζ1, ωn2, ζ2) of a controller config's Kp and Kd."""
    wn = np.sqrt(np.asarray(c.kp, dtype=float))
    zeta = np.asarray(c.kd, dtype=float) / (2 * wn)
    return np.array([wn[0], zeta[0], wn[1], zeta[1]])


def _integral_start(c: Any) -> np.ndarray:
    """(ωn1, ζ1, ρ1, ωn2, ζ2, ρ2) of a controller's Kp, Kd and Ki."""
    wn1, z1, wn2, z2 = _ctc_start(c)
    rho = np.asarray(c.ki, dtype=float) / (np.asarray(c.kp) * np.asarray(c.kd))
    return np.array([wn1, z1, rho[0], wn2, z2, rho[1]])


def _adaptive_start(c: Any) -> np.ndarray:
    """(ωn1, ωn2, 0): the regime's ωn, the law's default Γ."""
    wn1, _, wn2, _ = _ctc_start(c)
    return np.array([wn1, wn2, 0.0])


def _sliding_start(c: Any) -> np.ndarray:
    """(ωn1, log10 φ1, ωn2, log10 φ2): the regime's ωn, the law's own φ = K / K_D."""
    wn1, _, wn2, _ = _ctc_start(c)
    return np.array([wn1, np.log10(c.phi[0]), wn2, np.log10(c.phi[1])])


def _observer_start(c: Any) -> np.ndarray:
    """(ωn1, ζ1, ωn2, ζ2, log10 T): the regime's gains, the law's default T."""
    return np.append(_ctc_start(c), np.log10(c.observer_time))


# Per family: its span from the frontier's grid of the regime (ωn: the CTC grid's smallest
# to largest; clipped CTC: the clipped grid's) and its start from the regime's own gains
# (the family's kind as the sweep's base scenario builds it).
SPANS: dict[str, tuple[Any, Any]] = {
    "CTC": (lambda g: [_span(g.wn), ZETA, _span(g.wn), ZETA], _ctc_start),
    "CTC clipped": (
        lambda g: [_span(g.clipped_wn), ZETA, _span(g.clipped_wn), ZETA],
        _ctc_start,
    ),
    "CTC-I": (lambda g: [_span(g.wn), ZETA, RHO, _span(g.wn), ZETA, RHO], _integral_start),
    "Slotine-Li": (lambda g: [_span(g.wn), _span(g.wn), LOG_GAMMA], _adaptive_start),
    "sliding mode": (lambda g: [_span(g.wn), LOG_PHI, _span(g.wn), LOG_PHI], _sliding_start),
    "CTC-DOB": (lambda g: [_span(g.wn), ZETA, _span(g.wn), ZETA, LOG_T], _observer_start),
}


def _span(values: tuple[float, ...]) -> tuple[float, float]:
    return (min(values), max(values))


def choose_admissible(index: np.ndarray, ok: np.ndarray) -> int:
    """The row of the lowest training ``index`` among the admissible (``ok``); ties to the
    first. ValueError where none is admissible."""
    rows = np.flatnonzero(np.asarray(ok, dtype=bool) & np.isfinite(index))
    if rows.size == 0:
        raise ValueError("no candidate is within FCM-CTC's effort on both plant sets")
    return int(rows[np.argmin(np.asarray(index)[rows])])


def minimise(
    objective: Callable[[np.ndarray], np.ndarray],
    bounds: list[tuple[float, float]],
    popsize: int,
    maxiter: int,
    seed: int,
    start: np.ndarray | None = None,
) -> tuple[np.ndarray, float, int]:
    """The fuzzy table search's optimiser on continuous parameters: differential evolution,
    seeded, a Latin-hypercube initial population of ``popsize`` x len(bounds) with
    ``start`` in it, no polish, the population evaluated as one batch (``objective`` takes
    (n, d) and returns n costs). Returns the best point, its cost and the evaluations."""
    from scipy.optimize import differential_evolution
    from scipy.stats import qmc

    lo, hi = np.array(bounds, dtype=float).T
    init = lo + qmc.LatinHypercube(d=len(bounds), seed=seed).random(popsize * len(bounds)) * (
        hi - lo
    )
    if start is not None:
        init[0] = np.clip(start, lo, hi)
    seen: list[tuple[float, np.ndarray]] = []

    def batch(x: np.ndarray) -> np.ndarray:
        xs = np.atleast_2d(x.T)
        costs = np.asarray(objective(xs), dtype=float)
        seen.extend(zip(costs, xs.copy(), strict=True))
        return costs

    differential_evolution(
        batch, bounds, popsize=popsize, maxiter=maxiter, seed=seed, init=init, polish=False,
        vectorized=True, updating="deferred", tol=0.0,
    )  # fmt: skip
    cost, best = min(seen, key=lambda s: s[0])
    return best, float(cost), len(seen)


def configured(stp: Any, entry: dict[str, Any]) -> Any:
    """The scenario of the setup's sweep (``stp.plan``) with ``entry`` (a sweep's
    ``[controllers]`` entry) as its controller: built as the sweep builds it."""
    from twolink.foundation.overrides import merge
    from twolink.simulation.config import scenario_from_dict

    return scenario_from_dict(merge(stp.plan.base, {"controller": entry}), stp.plan.file)


def evaluate_loops(stp: Any, loops: list[dict[str, Any]]) -> np.ndarray:
    """Per loop (a sweep's ``[controllers]`` entry of any family, e.g. :func:`controller`'s):
    :func:`search.evaluate_controllers`' medians on the setup's plants (``stp``:
    :func:`search.setup`'s), each controller built as the sweep builds it, one per plant (a
    law's own state, an estimate or an observer, is each arm's own)."""
    from twolink.simulation.experiment import build_controller
    from twolink.studies.designs.search import evaluate_controllers

    ctrls = []
    for c in loops:
        scenario = configured(stp, c)
        ctrls.append([build_controller(scenario) for _ in stp.scenarios])
    return evaluate_controllers(stp.scenarios, ctrls, stp.model_g)


def judged_setup(spec: Any, regime: str) -> Any:
    """The claims study's own plants of ``regime`` (all of them: where the claim is
    judged) as a :class:`search.Setup`."""
    from twolink.studies.designs import frontier
    from twolink.studies.designs.search import setup_of
    from twolink.studies.judgments.claims_plans import regime_plan
    from twolink.studies.reproduction.manifest import load_manifest

    fspec = frontier.load_spec(spec.frontier)
    manifest = load_manifest(fspec.manifest)
    plan = regime_plan(manifest, frontier._variant(fspec, regime))
    return setup_of(plan, manifest.proposed, plan.samples)


def bounds(spec: Any, regime: str, family: str) -> list[tuple[float, float]]:
    """The span searched per joint (:data:`SPANS`): ωn over the frontier's grid of the
    family (its smallest to its largest), ζ over :data:`ZETA`, a family's own gains over
    theirs."""
    return SPANS[family][0](frontier_grid(spec, regime))


def frontier_grid(spec: Any, regime: str) -> Any:
    """The linear frontier's grid of ``regime``: the spans' source."""
    from twolink.studies.designs import frontier

    return frontier.load_spec(spec.frontier).grid(regime)


def search_family(spec: Any, stp: Any, regime: str, family: str) -> dict[str, Any]:
    """One search of ``family`` on the training plants (``stp``): the table search's
    optimiser, budget (``popsize``, ``maxiter``, ``seed``) and objective, the regime's own
    gains seeded in. Returns the evaluated loops ranked by training cost (each its ``x``,
    torque limit, cost and values), FCM-CTC's training values and the evaluations."""
    from twolink.studies.designs.effort import tolerances
    from twolink.studies.designs.search import cost, designed_table, evaluate_tables

    fcm = evaluate_tables(stp, designed_table()[None], "mamdani")[0]
    budget = fcm[:4]
    tol = tolerances()
    limit = np.asarray(stp.fcm["torque_limit"], dtype=float)
    if family == "CTC clipped":
        limit = np.minimum(limit, budget[:2])
    law = LAWS[family]
    from twolink.simulation.experiment import build_controller

    start = SPANS[family][1](build_controller(configured(stp, {"kind": law.kind})))
    tried: list[tuple[float, np.ndarray, np.ndarray]] = []

    def objective(xs: np.ndarray) -> np.ndarray:
        values = evaluate_loops(stp, [law.entry(x, limit) for x in xs])
        costs = cost(values, budget, tol)
        tried.extend(zip(costs, xs.copy(), values, strict=True))
        return costs

    minimise(objective, bounds(spec, regime, family), spec.popsize, spec.maxiter, spec.seed, start)
    ranked = sorted(tried, key=lambda t: t[0])
    return {
        "family": family,
        "torque_limit": limit.tolist(),
        "budget": budget.tolist(),
        "fcm": fcm.tolist(),
        "loops": [{"x": x.tolist(), "cost": float(c), "values": v.tolist()} for c, x, v in ranked],
        "evaluations": len(tried),
    }


def _search_and_judge(
    spec: Any, regime: str, families: tuple[str, ...], batch: int = 4
) -> dict[str, Any]:
    """The rule every searched opponent is chosen by: ``families`` searched on the training
    plants, then the effort rule: the loops within budget on training, in the order of
    their training index, are run on the judged plants ``batch`` at a time; the first
    within FCM-CTC's effort there too is chosen (``chosen``, with its ``judged`` values).
    Where none is, ``chosen`` is None. Returns the searches, FCM-CTC's judged values, the
    loops refused and the judged setup."""
    from twolink.studies.designs.search import OVER, designed_table, evaluate_tables, setup

    stp = setup(spec, regime)
    found = [search_family(spec, stp, regime, f) for f in families]
    candidates = sorted(
        (
            {**loop, "family": f["family"], "torque_limit": f["torque_limit"]}
            for f in found
            for loop in f["loops"]
            if loop["cost"] < OVER
        ),
        key=lambda c: c["cost"],
    )
    judged = judged_setup(spec, regime)
    fcm_judged = evaluate_tables(judged, designed_table()[None], "mamdani")[0]
    refused: list[dict[str, Any]] = []
    out = {"found": found, "judged_fcm": fcm_judged, "refused": refused, "judged_setup": judged}
    for start in range(0, len(candidates), batch):
        group = candidates[start : start + batch]
        values = evaluate_loops(judged, [_entry(c) for c in group])
        train = np.array([c["values"][:4] for c in group])
        ok = admissible(train, values[:, :4], found[0]["budget"], fcm_judged[:4])
        if not ok.any():
            refused += [{**c, "judged": v.tolist()} for c, v in zip(group, values, strict=True)]
            continue
        k = choose_admissible(np.array([c["cost"] for c in group]), ok)
        refused += [{**c, "judged": v.tolist()} for c, v in zip(group[:k], values, strict=False)]
        return {**out, "chosen": {**group[k], "judged": values[k].tolist()}}
    return {**out, "chosen": None}


def _entry(candidate: dict[str, Any]) -> dict[str, Any]:
    law = LAWS[candidate["family"]]
    return law.entry(np.asarray(candidate["x"]), candidate["torque_limit"])


def _searched(found: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Every loop tried on the training plants, by family: the figure's points."""
    return [
        {
            "family": f["family"],
            "x": [p["x"] for p in f["loops"]],
            "values": [p["values"] for p in f["loops"]],
        }
        for f in found
    ]


def search_opponent(spec: Any, regime: str, batch: int = 4) -> dict[str, Any]:
    """CTC-best: both of :data:`FAMILIES` by :func:`_search_and_judge`'s rule. Returns it
    (family, ωn and ζ per joint, torque limit, both sides' effort on both plant sets), the
    loops refused and the evaluations. ValueError where none is within on both sets."""
    done = _search_and_judge(spec, regime, FAMILIES, batch)
    c, found = done["chosen"], done["found"]
    if c is None:
        raise ValueError(
            f"{regime}: no searched loop is within FCM-CTC's effort on both plant sets"
        )
    x = c["x"]
    return {
        "regime": regime,
        "family": c["family"],
        "wn": [x[0], x[2]],
        "zeta": [x[1], x[3]],
        "torque_limit": c["torque_limit"],
        "train": c["values"],
        "train_fcm": found[0]["fcm"],
        "judged": c["judged"],
        "judged_fcm": done["judged_fcm"].tolist(),
        "judged_plants": len(done["judged_setup"].scenarios),
        "refused": done["refused"],
        "evaluations": sum(f["evaluations"] for f in found),
        "searched": _searched(found),  # every loop tried on the training plants
    }


def tune(spec: Any, regime: str, family: str, batch: int = 4) -> dict[str, Any]:
    """One law family (:data:`LAWS`) tuned by CTC-best's rule (:func:`_search_and_judge`:
    the same optimiser, seed, budget, training plants, objective and effort rule). Where no
    loop is within FCM-CTC's effort on both sets, the family's loop of the lowest training
    cost (the nearest the budget, feasibility first) is returned with ``within`` false and
    its judged values: the study shows it as over the budget. Returns the loop (family,
    gain vector ``x`` and its names, torque limit, both sides' effort on both sets,
    ``within``), the loops refused and the evaluations."""
    import time

    start = time.perf_counter()
    done = _search_and_judge(spec, regime, (family,), batch)
    found, c = done["found"], done["chosen"]
    within = c is not None
    if c is None:  # the nearest the budget, run where judged for its figures
        c = {**found[0]["loops"][0], "family": family, "torque_limit": found[0]["torque_limit"]}
        c["judged"] = evaluate_loops(done["judged_setup"], [_entry(c)])[0].tolist()
    return {
        "regime": regime,
        "family": family,
        "params": list(LAWS[family].params),
        "x": c["x"],
        "torque_limit": c["torque_limit"],
        "train": c["values"],
        "train_fcm": found[0]["fcm"],
        "judged": c["judged"],
        "judged_fcm": done["judged_fcm"].tolist(),
        "judged_plants": len(done["judged_setup"].scenarios),
        "within": within,
        "refused": len(done["refused"]),
        "evaluations": found[0]["evaluations"],
        "wall_s": time.perf_counter() - start,
    }


def shipped_path(spec: Any) -> Path:
    """The shipped result beside the search file: ``runs/paper/frontier_per_joint.json``."""
    return Path(spec.source).parent / "frontier_per_joint.json"


def tuned_path(spec: Any) -> Path:
    """The shipped tuned laws beside the search file: ``runs/paper/tuned_opponents.json``."""
    return Path(spec.source).parent / TUNED_FILE


def tune_all(spec: Any, regimes: Any = None, names: Any = None) -> dict[str, Any]:
    """Every tuned opponent of :data:`TUNED` (or ``names``) in every regime of the search
    file (or ``regimes``): :func:`tune`'s result by name, then regime, with the settings
    and the wall time; the shipped file's content."""
    import time

    start = time.perf_counter()
    opponents = {
        name: {r: tune(spec, r, TUNED[name]) for r in (regimes or spec.regimes)}
        for name in (names or TUNED)
    }
    wall = time.perf_counter() - start
    return {"settings": spec.settings(), "wall_s": wall, "opponents": opponents}


def main(argv: list[str] | None = None) -> int:
    """``python -m twolink.studies.designs.opponent_search --out DIR`` (or ``--install``:
    into runs/paper/): each regime's searched opponent, as JSON; with ``--tuned``, the
    tuned laws instead (``tuned_opponents.json``)."""
    import argparse
    import json
    import time

    from twolink.foundation.io import atomic_write_json, atomic_write_text
    from twolink.studies.designs.search import load_spec

    parser = argparse.ArgumentParser(description=main.__doc__)
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--out", type=Path, help="the folder to write frontier_per_joint.json in")
    where.add_argument("--install", action="store_true", help="rewrite the shipped result")
    parser.add_argument("--regimes", nargs="*", default=None, help="default: the search file's")
    parser.add_argument("--claims", action="store_true", help="and claims_per_joint.csv")
    parser.add_argument("--reuse", action="store_true", help="judge the shipped opponents only")
    parser.add_argument("--tuned", nargs="*", default=None, metavar="NAME",
                        help=f"tune these laws (default: all of {', '.join(TUNED)})")  # fmt: skip
    args = parser.parse_args(argv)
    spec = load_spec()
    if args.tuned is not None:
        if any(n not in TUNED for n in args.tuned):
            parser.error(f"--tuned takes names of {list(TUNED)}, got {args.tuned}")
        tuned = tune_all(spec, args.regimes, args.tuned)
        path = tuned_path(spec) if args.install else args.out / TUNED_FILE
        if path.is_file() and args.tuned:  # the other laws' shipped results stay theirs
            tuned["opponents"] = {**json.loads(path.read_text())["opponents"], **tuned["opponents"]}
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_json(path, tuned)
        print(path)
        return 0
    start = time.perf_counter()
    if args.reuse:
        found = json.loads(shipped_path(spec).read_text())["opponents"]
    else:
        found = {r: search_opponent(spec, r) for r in (args.regimes or spec.regimes)}
    meta = {"settings": spec.settings(), "wall_s": time.perf_counter() - start, "opponents": found}
    path = shipped_path(spec) if args.install else args.out / "frontier_per_joint.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    if not args.reuse:  # the shipped search's own numbers stay its own
        atomic_write_json(path, meta)
    if args.claims:
        table = claims_against(spec, found)
        atomic_write_text(path.parent / "claims_per_joint.csv", table.to_csv(index=False))
    if args.out is not None:  # the figure (docs/figures/ holds the shipped result's)
        figure(found, args.out / "figures" / "frontier_per_joint.png")
    print(path)
    return 0


def _ratio_and_index(budget: np.ndarray) -> Callable[[Any], tuple[Any, Any]]:
    """Rows of (peak τ1, peak τ2, Σ|Δτ|1, Σ|Δτ|2, index) -> (largest effort ratio, index)."""

    def point(values: Any) -> tuple[Any, Any]:
        v = np.atleast_2d(values)
        return (v[:, :4] / budget).max(axis=1), v[:, 4]

    return point


def figure(opponents: dict[str, Any], path: Path) -> Path:
    """Per regime: every loop the per-joint search tried (effort, the largest of the four
    ratios to FCM-CTC's on the training plants, against the training index), by family;
    FCM-CTC; the loops the judged plants refused; the opponent chosen."""
    from twolink.figures.plots import plt, save_figure
    from twolink.studies.designs import frontier

    fig, axes = plt.subplots(1, len(opponents), figsize=(6.2 * len(opponents), 5.0), squeeze=False)
    for ax, (regime, o) in zip(axes[0], opponents.items(), strict=True):
        point = _ratio_and_index(np.asarray(o["train_fcm"][:4]))

        for f, colour in zip(o["searched"], ("tab:green", "tab:orange"), strict=True):
            ax.scatter(*point(f["values"]), s=10, alpha=0.5, color=colour, label=f["family"])
        if o["refused"]:
            ax.scatter(*point([r["values"] for r in o["refused"]]), marker="x", color="k", s=40,
                       label="within on training, over where judged")  # fmt: skip
        ax.scatter(*point(o["train_fcm"]), marker="*", s=160, color="tab:red", label="FCM-CTC")
        wn, z = o["wn"], o["zeta"]
        label = f"CTC-best: ωn {wn[0]:.3g} / {wn[1]:.3g}, ζ {z[0]:.2g} / {z[1]:.2g} ({o['family']})"
        ax.scatter(*point(o["train"]), s=220, facecolors="none", edgecolors="k", lw=1.5,
                   label=label)  # fmt: skip
        frontier.frontier_axes(ax, f"per-joint linear search: {regime}")
    fig.tight_layout()
    save_figure(fig, path)
    return path


def claims_against(spec: Any, opponents: dict[str, Any], pool: Any = None) -> Any:
    """FCM-CTC judged on the claims' 200 plants of each regime against the per-joint
    CTC-best (``against`` "CTC-best-per-joint") and against the grid's CTC-best
    (``frontier.json``), with paired_claims on the claim metrics: one table, columns
    ``regime``, ``controller``, ``against`` and paired_claims'."""
    import pandas as pd

    from twolink.studies.designs import frontier
    from twolink.studies.judgments.claims import CLAIM_METRICS, paired_claims
    from twolink.studies.judgments.claims_plans import reference_values, regime_plan
    from twolink.studies.reproduction.manifest import load_manifest

    fspec = frontier.load_spec(spec.frontier)
    _, grid, _ = frontier.opponents(fspec, pool)
    manifest = load_manifest(fspec.manifest)
    tables = []
    for regime, o in opponents.items():
        variant = frontier._variant(fspec, regime)
        x = [o["wn"][0], o["zeta"][0], o["wn"][1], o["zeta"][1]]
        controllers = {
            PER_JOINT: controller(x, o["torque_limit"]),
            frontier.OPPONENT: grid[regime].controller(),
            manifest.proposed: dict(regime_plan(manifest, variant).controllers)[manifest.proposed],
        }
        plan = regime_plan(manifest, variant, {"controllers": {"replace": True, **controllers}})
        results = frontier._run(plan, pool)
        refs = reference_values(plan.nominal_scenario(), plan.joints)
        for against in (PER_JOINT, frontier.OPPONENT):
            t = paired_claims(results, manifest.proposed, against, CLAIM_METRICS, plan.joints, refs)
            tables.append(t.assign(regime=regime, controller=manifest.proposed, against=against))
    return pd.concat(tables, ignore_index=True)


PER_JOINT = "CTC-best-per-joint"  # the searched opponent's name in claims_against's table


if __name__ == "__main__":
    raise SystemExit(main())
