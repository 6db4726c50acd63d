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

from twolink.studies.designs.effort import within_budget
from twolink.studies.designs.searched_opponent import (  # its public face too
    SearchedOpponent,
    controller,
    shipped_opponents,
)

__all__ = [
    "FAMILIES",
    "SearchedOpponent",
    "admissible",
    "choose_admissible",
    "controller",
    "evaluate_loops",
    "minimise",
    "shipped_opponents",
    "within_budget",
]

FAMILIES = ("CTC", "CTC clipped")
ZETA = (0.4, 1.5)  # the damping searched per joint: under- to over-damped


def admissible(
    train: np.ndarray,
    judged: np.ndarray,
    budget_train: np.ndarray,
    budget_judged: np.ndarray,
    tolerance: np.ndarray,
) -> np.ndarray:
    """The effort rule (module docstring): within FCM-CTC's effort on both plant sets, each
    against FCM-CTC's own effort on that set."""
    return within_budget(train, budget_train, tolerance) & within_budget(
        judged, budget_judged, tolerance
    )


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


def evaluate_loops(stp: Any, loops: list[dict[str, Any]]) -> np.ndarray:
    """Per loop (a :func:`controller` entry): :func:`search.evaluate_controllers`' medians
    on the setup's plants (``stp``: :func:`search.setup`'s, its arm and reference)."""
    from twolink.controllers.ctc import ComputedTorque
    from twolink.studies.designs.search import evaluate_controllers

    arm, ref = stp.fcm["arm"], stp.fcm["reference"]
    ctrls = [
        ComputedTorque(arm, ref, kp=c["kp"], kd=c["kd"], torque_limit=c["torque_limit"])
        for c in loops
    ]
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
    """The span searched per joint: ωn over the frontier's grid of the family (its
    smallest to its largest), ζ over :data:`ZETA`."""
    from twolink.studies.designs import frontier

    grid = frontier.load_spec(spec.frontier).grid(regime)
    wn = grid.wn if family == "CTC" else grid.clipped_wn
    span = (min(wn), max(wn))
    return [span, ZETA, span, ZETA]


def search_family(spec: Any, stp: Any, regime: str, family: str) -> dict[str, Any]:
    """One search of ``family`` on the training plants (``stp``): the table search's
    optimiser, budget (``popsize``, ``maxiter``, ``seed``) and objective, the regime's own
    gains seeded in. Returns the evaluated loops ranked by training cost (each its ``x``,
    torque limit, cost and values), FCM-CTC's training values and the evaluations."""
    from twolink.studies.designs.search import cost, designed_table, evaluate_tables
    from twolink.studies.judgments.claims import TOLERANCES

    fcm = evaluate_tables(stp, designed_table()[None], "mamdani")[0]
    budget = fcm[:4]
    tol = np.array([TOLERANCES["torque_peak_Nm"]] * 2 + [TOLERANCES["torque_variation_Nm"]] * 2)
    limit = np.asarray(stp.fcm["torque_limit"], dtype=float)
    if family == "CTC clipped":
        limit = np.minimum(limit, budget[:2])
    wn = np.sqrt(np.asarray(stp.fcm["kp"], dtype=float))
    zeta = np.asarray(stp.fcm["kd"], dtype=float) / (2 * wn)
    start = np.array([wn[0], zeta[0], wn[1], zeta[1]])
    tried: list[tuple[float, np.ndarray, np.ndarray]] = []

    def objective(xs: np.ndarray) -> np.ndarray:
        values = evaluate_loops(stp, [controller(x, limit) for x in xs])
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


def search_opponent(spec: Any, regime: str, batch: int = 4) -> dict[str, Any]:
    """Both families searched on the training plants, then the effort rule: the loops
    within budget on training, in the order of their training index, are run on the
    judged plants ``batch`` at a time; the first within FCM-CTC's effort there too is the
    opponent. Returns it (family, ωn and ζ per joint, torque limit, both sides' effort on
    both plant sets), the loops refused and the evaluations."""
    from twolink.studies.designs.search import OVER, designed_table, evaluate_tables, setup
    from twolink.studies.judgments.claims import TOLERANCES

    tol = np.array([TOLERANCES["torque_peak_Nm"]] * 2 + [TOLERANCES["torque_variation_Nm"]] * 2)
    stp = setup(spec, regime)
    found = [search_family(spec, stp, regime, f) for f in FAMILIES]
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
    refused = []
    for start in range(0, len(candidates), batch):
        group = candidates[start : start + batch]
        values = evaluate_loops(judged, [controller(c["x"], c["torque_limit"]) for c in group])
        train = np.array([c["values"][:4] for c in group])
        ok = admissible(train, values[:, :4], found[0]["budget"], fcm_judged[:4], tol)
        if not ok.any():
            refused += [{**c, "judged": v.tolist()} for c, v in zip(group, values, strict=True)]
            continue
        k = choose_admissible(np.array([c["cost"] for c in group]), ok)
        refused += [{**c, "judged": v.tolist()} for c, v in zip(group[:k], values, strict=False)]
        c, x = group[k], group[k]["x"]
        return {
            "regime": regime,
            "family": c["family"],
            "wn": [x[0], x[2]],
            "zeta": [x[1], x[3]],
            "torque_limit": c["torque_limit"],
            "train": c["values"],
            "train_fcm": found[0]["fcm"],
            "judged": values[k].tolist(),
            "judged_fcm": fcm_judged.tolist(),
            "judged_plants": len(judged.scenarios),
            "refused": refused,
            "evaluations": sum(f["evaluations"] for f in found),
            "searched": [  # every loop tried on the training plants: the frontier's figure
                {
                    "family": f["family"],
                    "x": [p["x"] for p in f["loops"]],
                    "values": [p["values"] for p in f["loops"]],
                }
                for f in found
            ],  # fmt: skip
        }
    raise ValueError(f"{regime}: no searched loop is within FCM-CTC's effort on both plant sets")


def shipped_path(spec: Any) -> Path:
    """The shipped result beside the search file: ``runs/paper/frontier_per_joint.json``."""
    return Path(spec.source).parent / "frontier_per_joint.json"


def main(argv: list[str] | None = None) -> int:
    """``python -m twolink.studies.designs.opponent_search --out DIR`` (or ``--install``:
    into runs/paper/): each regime's searched opponent, as JSON."""
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
    args = parser.parse_args(argv)
    spec = load_spec()
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
