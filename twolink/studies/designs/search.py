"""The strongest fuzzy term: a search over FCM-CTC's rule table at FCM-CTC's effort
(docs/reproduction.md, "The strongest fuzzy term").

The structure searched is the paper's: CTC at the regime's gains with a fuzzy PD term in
its bracket, the designs' partition (7 labels on e, ė and u) and scaling; what is free is
the table, each of the 7 x 7 cells a consequent label or no rule, under each inference
(Mamdani, the paper's; continuous, our extension). The tables are odd-symmetric, as the
designs' are (u(−e, −ė) = −u(e, ė): the cell (i, j) holds the mirror of (6−i, 6−j)'s
label), which leaves 24 free cells of 8 choices and the centre (no rule or Z): 25 integers.

**Objective** on the training plants of the linear frontier
(:mod:`twolink.studies.designs.frontier`,
the first ``plants`` of them): feasibility first (Deb, "An efficient constraint handling
method for genetic algorithms", 2000). A table within FCM-CTC's effort (each of the four
effort values, median peak |τ| and Σ|Δτ| per joint, at most FCM-CTC's plus the claims'
practical tolerance: the fair opponent's budget) costs the frontier's performance index,
the median IAE₁ + IAE₂; a table beyond it costs :data:`OVER` plus its summed relative
excess, more than any table within; a failed run costs :data:`FAILED`.

**Optimiser**: :func:`scipy.optimize.differential_evolution` with ``integrality``, seeded,
its population evaluated as one batch of the batch engine per generation (``vectorized``),
the initial population a Latin hypercube with the designed table and the empty one (CTC)
in it, so the best found is at least as good as both on the training plants. No polish.

**Held out**: the best table of each (regime, inference) against the frontier's opponent,
CTC-best, on the claims study's own plants (the 200 that judge the claims), with
:func:`twolink.studies.judgments.claims.paired_claims`.
"""

from __future__ import annotations

import hashlib
import json
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from twolink.foundation.shipped import runs_dir
from twolink.simulation.config import TomlTable, read_toml
from twolink.studies.designs import effort

__all__ = [
    "DEFAULT_SPEC",
    "SearchSpec",
    "conclusion_sentence",
    "decode",
    "encode",
    "evaluate_tables",
    "load_spec",
    "run_search",
]

DEFAULT_SPEC = runs_dir() / "paper" / "search.toml"  # package data
SEARCHED = "FCM-CTC-searched"  # the best table's controller (+ "-continuous")
INFERENCES = ("mamdani", "continuous")
FAILED = 1e6
OVER = 1e3  # above any index (rad·s over a 4 s run of 1 rad moves): feasibility first
N_FREE = 24  # cells (i, j) with 7 i + j < 24: each mirror pair once, the centre apart


@dataclass(frozen=True)
class SearchSpec:
    """``runs/paper/search.toml``: the frontier file (regimes, training plants, opponent),
    the training plants used, the regimes and inferences searched, and the optimiser's
    budget (``popsize`` x 25 tables per generation, ``maxiter`` generations, ``seed``)."""

    source: str
    frontier: Path
    plants: int
    regimes: tuple[str, ...]
    inferences: tuple[str, ...]
    popsize: int
    maxiter: int
    seed: int

    def settings(self) -> dict[str, Any]:
        return {k: v for k, v in asdict(self).items() if k not in ("source", "frontier")}

    def digest(self) -> str:
        """The search's inputs: its settings, each searched regime's training plants and
        FCM-CTC (the claims sweep's data on them and the rule base's bytes), and the
        opponents that judge the best tables on the held-out plants (CTC-best: the per-joint
        loop where one is shipped, :func:`judging_opponents`). Not the frontier's grids:
        the search does not read them (a finer grid that chooses the same opponent leaves
        the search current; one that chooses another makes it stale)."""
        from twolink.studies.designs import frontier

        fspec = frontier.load_spec(self.frontier)
        parts: list[Any] = [self.settings(), fspec.plants, fspec.seed]
        for regime in self.regimes:
            plan = frontier.training_plan(fspec, regime)
            parts.append([plan.base, [asdict(p) for p in plan.parameters], plan.controllers])
            parts.append(frontier._rule_base_bytes(plan))
        parts.append(judging_opponents(fspec, saved_only=True))
        blob = json.dumps(parts, sort_keys=True, default=str)
        return hashlib.sha256(blob.encode()).hexdigest()


def load_spec(path: str | Path = DEFAULT_SPEC, overrides: dict | None = None) -> SearchSpec:
    from twolink.foundation.overrides import merge
    from twolink.studies.designs import frontier

    path = Path(path)
    data = merge(read_toml(path), overrides or {})
    top = TomlTable(data, "", str(path))
    fpath = path.parent / top.string("frontier", "frontier.toml")
    fspec = frontier.load_spec(fpath)
    plants = top.integer("plants", 10)
    if not 1 <= plants <= fspec.plants:
        top.fail(
            "plants", f"must be 1 to the frontier's {fspec.plants} training plants, got {plants}"
        )
    known = tuple(r for r, _ in fspec.grids)
    regimes = top.raw("regimes", list(known))
    if not isinstance(regimes, list) or not regimes or any(r not in known for r in regimes):
        top.fail("regimes", f"must be a non-empty list of {known}, got {regimes!r}")
    inferences = top.raw("inferences", list(INFERENCES))
    if (
        not isinstance(inferences, list)
        or not inferences
        or any(i not in INFERENCES for i in inferences)
    ):
        top.fail("inferences", f"must be a non-empty list of {INFERENCES}, got {inferences!r}")
    spec = SearchSpec(
        source=str(path),
        frontier=fpath,
        plants=plants,
        regimes=tuple(regimes),
        inferences=tuple(inferences),
        popsize=top.integer("popsize", 2),
        maxiter=top.integer("maxiter", 15),
        seed=top.integer("seed", 0),
    )
    if spec.popsize < 1 or spec.maxiter < 0:
        top.fail("popsize", f"popsize >= 1 and maxiter >= 0, got {spec.popsize}, {spec.maxiter}")
    runs = search_runs(spec)
    if runs > MAX_SEARCH_RUNS:
        top.fail(
            "popsize",
            f"{runs:,} runs (popsize x 25 tables x (maxiter + 1) x plants x regimes x "
            f"inferences) > {MAX_SEARCH_RUNS:,}, about 4 days at the fastest measured "
            "0.035 s a run: lower popsize or maxiter",
        )
    top.done()
    return spec


# The budget's bound by time: the shipped search's four runs took 228-742 s for 650
# tables on 10 plants (runs/paper/search/search.json, wall_s): 0.035-0.11 s a table and
# plant on a 2-core VM
MAX_SEARCH_RUNS = 10_000_000


def search_runs(spec: SearchSpec) -> int:
    """Table-and-plant runs of a search at most: per regime and inference, (maxiter + 1)
    generations of popsize x 25 tables, each on the plants."""
    tables = spec.popsize * len(BOUNDS) * (spec.maxiter + 1)
    return tables * spec.plants * len(spec.regimes) * len(spec.inferences)


# ----------------------------------------------------------------------------- the tables


def decode(x: np.ndarray) -> np.ndarray:
    """The odd-symmetric 7 x 7 table of 25 integers: 24 free cells (-1 no rule, 0..6 a
    label) and the centre (0 no rule, 1 Z)."""
    x = np.rint(np.asarray(x, dtype=float)).astype(int)
    t = np.full(49, -1, dtype=int)
    free = x[:N_FREE]
    t[:N_FREE] = free
    t[48 - np.arange(N_FREE)] = np.where(free >= 0, 6 - free, -1)
    t[24] = 3 if x[N_FREE] == 1 else -1
    return t.reshape(7, 7)


def encode(table: np.ndarray) -> np.ndarray:
    """The 25 integers of an odd-symmetric table (ValueError if it is not one)."""
    t = np.asarray(table, dtype=int).ravel()
    if t[24] not in (-1, 3):
        raise ValueError("the centre of an odd-symmetric table is Z or no rule")
    x = np.append(t[:N_FREE], 1 if t[24] == 3 else 0)
    if not np.array_equal(decode(x).ravel(), t):
        raise ValueError("the table is not odd-symmetric")
    return x


BOUNDS = [(-1, 6)] * N_FREE + [(0, 1)]


# ----------------------------------------------------------------------------- evaluation


@dataclass(frozen=True)
class Setup:
    """What evaluating a table needs: the training plants' scenarios and FCM-CTC's
    arguments (model, reference, gains, limits) in one regime, and the sweep ``plan`` they
    come from (its base scenario builds any other controller as the sweep would)."""

    scenarios: tuple[Any, ...]
    fcm: dict[str, Any]
    # the batch models' gravity: the sweep's (plan.model_gravity()), so each plant runs
    # as in the sweep; None: the largest |g| of these plants (a set not drawn from a plan)
    model_g: float | None = None
    plan: Any = None


def setup(spec: SearchSpec, regime: str) -> Setup:
    """The first ``spec.plants`` training plants of ``regime`` and FCM-CTC's arguments."""
    from twolink.studies.designs import frontier
    from twolink.studies.reproduction.manifest import load_manifest

    fspec = frontier.load_spec(spec.frontier)
    plan = frontier.training_plan(fspec, regime)
    return setup_of(plan, load_manifest(fspec.manifest).proposed, spec.plants)


def setup_of(plan: Any, proposed: str, plants: int) -> Setup:
    """The first ``plants`` plants of a sweep ``plan`` and its ``proposed`` FCM-CTC's
    arguments."""
    from twolink.simulation.config import scenario_from_dict

    scenarios = []
    for i in range(plants):
        values, noise_seed = plan.draw(i)
        scenarios.append(scenario_from_dict(plan.sample_data(values, noise_seed), plan.file))
    s = scenario_from_dict(plan.controller_data(proposed), plan.file)
    c = s.controller
    if c.kind != "fcm_ctc" or c.fuzzy.mode != "add" or c.fuzzy.authority != 1.0:
        raise ValueError(f"the search needs {proposed} as fcm_ctc in mode add at authority 1")
    fcm = {
        "arm": s.arm,
        "reference": s.reference,
        "kp": c.kp,
        "kd": c.kd,
        "torque_limit": c.torque_limit,
    }
    return Setup(tuple(scenarios), fcm, plan.model_gravity(), plan)


def evaluate_tables(stp: Setup, tables: np.ndarray, inference: str) -> np.ndarray:
    """Per table (n, 7, 7): the medians over the training plants of peak |τ|₁, peak |τ|₂,
    Σ|Δτ|₁, Σ|Δτ|₂ and IAE₁ + IAE₂, (n, 5); NaN where a run failed."""
    from twolink.controllers.rule_table import RuleTableCTC

    ctrls = [RuleTableCTC.from_table(t, inference, **stp.fcm) for t in tables]
    return evaluate_controllers(stp.scenarios, ctrls, stp.model_g)


def evaluate_controllers(
    scenarios: Any, ctrls: list[Any], model_g: float | None = None
) -> np.ndarray:
    """Per controller, on every scenario (the batch engine, its models under the gravity
    ``model_g``: :func:`twolink.simulation.experiment.iter_scenarios`): the medians of peak
    |τ|₁, peak |τ|₂, Σ|Δτ|₁, Σ|Δτ|₂ and IAE₁ + IAE₂, (n, 5); NaN where a run failed. A
    controller with a state of its own (an estimate, an observer) comes as a list, one
    object per scenario, so that no two arms share its state."""
    from twolink.simulation.experiment import iter_scenarios
    from twolink.simulation.metrics import error_measures, torque_measures

    n, p = len(ctrls), len(scenarios)
    values = np.full((n, p, 5), np.nan)
    arms = [(k, i) for k in range(n) for i in range(p)]
    per_arm = [ctrls[k][i] if isinstance(ctrls[k], list) else ctrls[k] for k, i in arms]
    runs = iter_scenarios([scenarios[i] for _, i in arms], per_arm, model_g=model_g)
    for m, traj in runs:
        k, i = arms[m]
        if isinstance(traj, Exception) or traj.status != "ok":
            continue
        tq = torque_measures(traj.tau)
        iae = error_measures(traj.t, traj.e).iae
        values[k, i] = (*tq.peak, *tq.variation, iae[0] + iae[1])
    out = np.median(values, axis=1)
    out[np.isnan(values).any(axis=(1, 2))] = np.nan
    return out


def cost(values: np.ndarray, budget: np.ndarray, tolerance: np.ndarray) -> np.ndarray:
    """The objective (module docstring) of :func:`evaluate_tables`' rows."""
    excess = np.maximum(values[:, :4] - (budget + tolerance), 0.0) / budget
    over = excess.sum(axis=1)
    out = np.where(over > 0.0, OVER + over, values[:, 4])
    return np.where(np.isfinite(values).all(axis=1), out, FAILED)


def _chunks(tables: np.ndarray, pool: Any, stp: Setup, inference: str) -> np.ndarray:
    if pool is None or len(tables) < 2:
        return evaluate_tables(stp, tables, inference)
    parts = np.array_split(
        np.arange(len(tables)), min(len(tables), 2 * getattr(pool, "workers", 1))
    )
    futures = [
        pool.submit(evaluate_tables, stp, tables[idx], inference) for idx in parts if idx.size
    ]
    return np.concatenate([f.result() for f in futures])


def designed_table() -> np.ndarray:
    from twolink.controllers.fuzzy.fis.engine_files import read_rule_base
    from twolink.controllers.fuzzy.rulebase import resolve_rule_base
    from twolink.controllers.rule_table import table_of

    return table_of(read_rule_base(resolve_rule_base("designed")))


def search_one(
    spec: SearchSpec, regime: str, inference: str, pool: Any = None, progress: bool = False
) -> dict[str, Any]:
    """One differential evolution; returns the best table, its training values, the
    budget, the designed and empty tables' values, the evaluations and the wall time."""
    from scipy.optimize import differential_evolution
    from scipy.stats import qmc

    from twolink.studies.judgments.claims import TOLERANCES

    start = time.perf_counter()
    stp = setup(spec, regime)
    designed, empty = designed_table(), np.full((7, 7), -1)
    reference = evaluate_tables(stp, np.stack([designed, empty]), "mamdani")
    budget = reference[0, :4]
    if inference == "continuous":
        reference = np.vstack([evaluate_tables(stp, designed[None], "continuous"), reference[1:]])
    tol = np.array([TOLERANCES["torque_peak_Nm"]] * 2 + [TOLERANCES["torque_variation_Nm"]] * 2)
    seen: dict[bytes, tuple[float, np.ndarray]] = {}
    count = [0]

    def objective(x: np.ndarray) -> np.ndarray:
        xs = np.rint(np.atleast_2d(x.T)).astype(int)
        tables = np.stack([decode(v) for v in xs])
        keys = [t.tobytes() for t in tables]
        todo = [k for k in dict.fromkeys(keys) if k not in seen]
        if todo:
            vals = _chunks(
                np.stack([np.frombuffer(k, dtype=int).reshape(7, 7) for k in todo]),
                pool,
                stp,
                inference,
            )
            for k, v in zip(todo, vals, strict=True):
                seen[k] = (float(cost(v[None], budget, tol)[0]), v)
            count[0] += len(todo)
        if progress:
            best = min(c for c, _ in seen.values())
            print(f"  {regime} {inference}: {count[0]} tables, best {best:.5g}", flush=True)
        return np.array([seen[k][0] for k in keys])

    size = spec.popsize * len(BOUNDS)
    init = qmc.LatinHypercube(d=len(BOUNDS), seed=spec.seed).random(size)
    lo, hi = np.array(BOUNDS, dtype=float).T
    init = np.rint(lo + init * (hi - lo))
    init[0], init[1] = encode(designed), encode(empty)
    result = differential_evolution(
        objective, BOUNDS, integrality=[True] * len(BOUNDS), popsize=spec.popsize,
        maxiter=spec.maxiter, seed=spec.seed, init=init, polish=False, vectorized=True,
        updating="deferred", tol=0.0,
    )  # fmt: skip
    best_key = min(seen, key=lambda k: seen[k][0])
    best = np.frombuffer(best_key, dtype=int).reshape(7, 7)
    return {
        "regime": regime,
        "inference": inference,
        "table": best.tolist(),
        "cost": seen[best_key][0],
        "values": seen[best_key][1].tolist(),
        "budget": budget.tolist(),
        "designed": reference[0].tolist(),
        "empty": reference[1].tolist(),
        "evaluations": count[0],
        "generations": int(result.nit),
        "wall_s": time.perf_counter() - start,
    }


def run_search(spec: SearchSpec, pool: Any = None, progress: bool = False) -> list[dict[str, Any]]:
    """:func:`search_one` for every regime and inference of the spec."""
    return [search_one(spec, r, i, pool, progress) for r in spec.regimes for i in spec.inferences]


def controller_name(inference: str) -> str:
    return SEARCHED if inference == "mamdani" else f"{SEARCHED}-continuous"


def judging_opponents(
    fspec: Any, pool: Any = None, saved_only: bool = False
) -> dict[str, dict[str, Any]] | None:
    """CTC-best of each regime, as the claims studies judge against it
    (:func:`twolink.studies.judgments.claims_studies.fair_opponent`): the per-joint loop
    shipped beside the manifest where there is one, else the frontier grid's best loop; as
    ``[controllers]`` entries. ``saved_only``: the grid's from its shipped table only (None
    where a regime needs it and it is absent), for the digest, which must not run it."""
    from twolink.studies.designs import frontier
    from twolink.studies.designs.searched_opponent import shipped_opponents

    regimes = [r for r, _ in fspec.grids]
    searched = shipped_opponents(Path(fspec.manifest).parent)
    out = {r: o.controller() for r, o in searched.items() if r in regimes}
    if all(r in out for r in regimes):
        return out
    if saved_only:
        saved = frontier.load_frontier(fspec)
        if saved is None:
            return None
        chosen = saved[1]
    else:
        _, chosen, _ = frontier.opponents(fspec, pool)
    return {r: out.get(r) or chosen[r].controller() for r in regimes}


def heldout(
    spec: SearchSpec, found: list[dict[str, Any]], folder: Path, pool: Any = None
) -> pd.DataFrame:
    """The best tables (their rule bases written into ``folder``) against CTC-best, FCM-CTC
    against CTC-best, on the claims study's own plants of each regime: paired_claims on the
    claim metrics and the report's who-wins metrics, one table (columns ``regime``,
    ``controller``, ``against`` and paired_claims')."""
    from twolink.studies.designs import frontier
    from twolink.studies.judgments.claims import CLAIM_METRICS, paired_claims
    from twolink.studies.judgments.claims_plans import reference_values, regime_plan
    from twolink.studies.reproduction.manifest import load_manifest
    from twolink.studies.reproduction.report import WINNER_METRICS

    fspec = frontier.load_spec(spec.frontier)
    chosen = judging_opponents(fspec, pool=pool)
    manifest = load_manifest(fspec.manifest)
    metrics = tuple(dict.fromkeys((*CLAIM_METRICS, *WINNER_METRICS)))
    tables = []
    for regime in spec.regimes:
        variant = (
            None
            if regime == frontier.QUINTIC
            else next(v for v in manifest.variants if v.name == regime)
        )
        controllers = {
            frontier.OPPONENT: chosen[regime],
            manifest.proposed: dict(regime_plan(manifest, variant).controllers)[manifest.proposed],
        }
        for f in found:
            if f["regime"] == regime:
                path = save_table(
                    np.array(f["table"]), folder / f"{regime}_{f['inference']}.toml", f
                )
                entry = {"kind": "fcm_ctc", "rule_base": str(path.resolve())}
                if f["inference"] == "continuous":
                    entry["fuzzy"] = {"inference": "continuous"}
                controllers[controller_name(f["inference"])] = entry
        plan = regime_plan(manifest, variant, {"controllers": {"replace": True, **controllers}})
        results = frontier._run(plan, pool)
        refs = reference_values(plan.nominal_scenario(), plan.joints)
        for name in controllers:
            if name != frontier.OPPONENT:
                t = paired_claims(results, name, frontier.OPPONENT, metrics, plan.joints, refs)
                tables.append(t.assign(regime=regime, controller=name, against=frontier.OPPONENT))
    return pd.concat(tables, ignore_index=True)


def save_table(table: Any, path: Path, found: dict[str, Any]) -> Path:
    """The table as a rule-base TOML file, with the search's numbers as its evidence."""
    from twolink.controllers.fuzzy.rulebase import save_rule_base
    from twolink.controllers.rule_table import rules_of

    path.parent.mkdir(parents=True, exist_ok=True)
    evidence = {k: found[k] for k in ("regime", "inference", "cost", "evaluations", "generations")}
    meta = {
        "source": {"what": "the best table of twolink search (twolink/studies/designs/search.py)"},
        "evidence": evidence,
    }
    rules = rules_of(np.asarray(table))
    if not rules:  # an empty table: no rule at all (FCM-CTC is CTC); a file needs one, Z Z -> Z
        rules = [("Z", "Z", "Z")]  # (odd, 0 at rest: the continuous inference of it is 0)
    return save_rule_base(path, rules, metadata=meta)


def folder_of(spec: SearchSpec) -> Path:
    """The shipped result's folder beside the spec (``search.toml`` -> ``search/``)."""
    return Path(spec.source).with_suffix("")


def save_search(
    spec: SearchSpec, found: list[dict[str, Any]], held: pd.DataFrame, folder: Path
) -> Path:
    """``search.json`` (digest, settings, per search its best table and numbers) and
    ``heldout.csv`` into ``folder`` (the rule bases are there already)."""
    from twolink.foundation.io import atomic_write_json, atomic_write_text

    folder.mkdir(parents=True, exist_ok=True)
    atomic_write_text(folder / "heldout.csv", held.to_csv(index=False))
    meta = {
        "spec": Path(spec.source).name,
        "digest": spec.digest(),
        "settings": spec.settings(),
        "searches": found,
    }
    atomic_write_json(folder / "search.json", meta)
    return folder


def load_search(
    spec: SearchSpec, folder: Path | None = None
) -> tuple[dict[str, Any], pd.DataFrame] | None:
    """The saved search and held-out table, or None where absent or stale."""
    folder = folder_of(spec) if folder is None else folder
    if not ((folder / "search.json").is_file() and (folder / "heldout.csv").is_file()):
        return None
    meta = json.loads((folder / "search.json").read_text())
    if meta.get("digest") != spec.digest():
        return None
    return meta, pd.read_csv(folder / "heldout.csv")


def sentence_numbers(meta: dict[str, Any], held: pd.DataFrame) -> list[dict[str, Any]]:
    """Per search: the training index of the best table and of FCM-CTC, and on the
    held-out plants its IAE per joint against CTC-best (better, worse, n, Hodges-Lehmann
    estimate and interval, verdict) and its peak torque's and Σ|Δτ|'s verdicts."""
    out = []
    flags = {}  # (regime, controller) -> its effort on the held-out plants, where judged
    if "FCM-CTC" in set(held["controller"]):
        flags = {
            (r["regime"], r["controller"]): r for r in effort.effort_flags(held).to_dict("records")
        }
    for f in meta["searches"]:
        name = controller_name(f["inference"])
        rows = held[
            (held["regime"] == f["regime"])
            & (held["controller"] == name)
            & (held["metric"] == "iae_rad_s")
        ]
        item = {
            "regime": f["regime"],
            "inference": f["inference"],
            "controller": name,
            "train_index": f["values"][4],
            "train_index_designed": f["designed"][4],
            "evaluations": f["evaluations"],
        }
        for r in rows.itertuples():
            for k in ("n", "better", "worse", "estimate", "ci_low", "ci_high", "verdict"):
                item[f"iae{r.joint}_{k}"] = getattr(r, k)
        mine = held[(held["regime"] == f["regime"]) & (held["controller"] == name)]
        for key, short in (("torque_peak_Nm", "peak"), ("torque_variation_Nm", "variation")):
            for r in mine[mine["metric"] == key].itertuples():
                item[f"{short}{r.joint}_verdict"] = r.verdict
        flag = flags.get((f["regime"], name))
        if flag is not None:  # the effort rule where the claim is judged (effort.py)
            item["within_effort"] = bool(flag["within"])
            item["variation"] = (flag["torque_variation_Nm1"], flag["torque_variation_Nm2"])
            item["variation_budget"] = (
                flag["FCM-CTC torque_variation_Nm1"],
                flag["FCM-CTC torque_variation_Nm2"],
            )
        out.append(item)
    return out


def conclusion_sentence(meta: dict[str, Any], held: pd.DataFrame, regime: str = "raw") -> str:
    """One sentence for the conclusions: can a fuzzy term of this structure beat the best
    linear loop at equal effort, and by how much (IAE on the held-out plants)."""
    items = [i for i in sentence_numbers(meta, held) if i["regime"] == regime]
    if not items:
        return ""
    # the better of the two inferences on the held-out plants: the larger count of wins
    best = max(
        items,
        key=lambda i: (
            (i.get("iae1_better", 0) + i.get("iae2_better", 0))
            - (i.get("iae1_worse", 0) + i.get("iae2_worse", 0))
        ),
    )
    wins = [best.get(f"iae{j}_verdict") for j in (1, 2)]
    beats = "better" in wins and "worse" not in wins
    verb = "yes" if beats else ("not outright" if "better" in wins else "no")
    parts = [_iae_text(best, j) for j in (1, 2)]
    evaluations = sum(i["evaluations"] for i in items)
    effort = ", ".join(
        f"{label} θ{j} {best[f'{short}{j}_verdict']}"
        for short, label in (("peak", "peak |τ|"), ("variation", "Σ|Δτ|"))
        for j in (1, 2)
        if f"{short}{j}_verdict" in best
    )
    return (
        f"Can a fuzzy term of this structure beat the best linear loop at equal effort? "
        f"{verb.capitalize()}: the best of {evaluations} rule tables searched ({best['inference']} "
        f"inference, {regime} regime) against CTC-best on the held-out plants: "
        + "; ".join(parts)
        + (f"; its effort against CTC-best's: {effort}" if effort else "")
        + "."
    )


def _iae_text(item: dict[str, Any], j: int) -> str:
    """θj's IAE verdict against CTC-best with its counts, shift and interval."""
    v = {k: item[f"iae{j}_{k}"] for k in ("verdict", "better", "worse", "n", "estimate")}
    lo, hi = item[f"iae{j}_ci_low"], item[f"iae{j}_ci_high"]
    return (
        f"θ{j} IAE {v['verdict']} ({v['better']} better / {v['worse']} worse of {v['n']} "
        f"plants, shift {v['estimate']:+.3g} rad·s, 95 % CI [{lo:.3g}, {hi:.3g}])"
    )


def report_section(manifest: Any, out: Path) -> list[str]:
    """The reproduction's section on the search: the shipped result where current, copied
    to ``out/search/`` (``search.json``, ``heldout.csv``, the tables' rule bases), its
    best tables' training numbers and the sentence per regime; a note where it is stale
    (the search is its own command, ``twolink search``: too slow for the reproduction)."""
    import shutil

    from twolink.foundation.io import atomic_path

    spec = load_spec(manifest.path.parent / DEFAULT_SPEC.name)
    saved = load_search(spec)
    head = ["", "## The strongest fuzzy term (the table search)", ""]
    if saved is None:
        return head + [
            f"The shipped search (`{folder_of(spec).name}/`) is stale or missing: run "
            '`twolink search --install` (docs/reproduction.md, "The strongest fuzzy term").'
        ]
    meta, held = saved
    target = out / "search"
    target.mkdir(parents=True, exist_ok=True)
    for f in sorted(folder_of(spec).iterdir()):
        if f.is_file():  # by twolink's writer: never through a link, listed as twolink's
            with atomic_path(target / f.name) as tmp:
                shutil.copyfile(f, tmp)
    s = meta["settings"]
    lines = head + [
        f"Differential evolution over FCM-CTC's odd-symmetric rule table (25 integers), "
        f"{s['popsize'] * len(BOUNDS)} tables a generation, at most {s['maxiter']} generations, "
        f"seed {s['seed']}, on {s['plants']} training plants, within FCM-CTC's effort "
        f"(feasibility first); `twolink search`, shipped in `{folder_of(spec).name}/` and current; "
        "`search/heldout.csv` judges each best table against CTC-best on the claims' 200 plants.",
        "",
        "Training index (median IAE₁ + IAE₂ [rad·s]) of the best table, FCM-CTC's designed",
        "table and the empty one (CTC):",
        "",
        "| regime | inference | tables | best | FCM-CTC | CTC | the best table |",
        "|---|---|---|---|---|---|---|",
    ]
    for f in meta["searches"]:
        rules = int((np.array(f["table"]) >= 0).sum())
        where = f"`search/{f['regime']}_{f['inference']}.toml`"
        lines.append(
            f"| {f['regime']} | {f['inference']} | {f['evaluations']} | {f['values'][4]:.4g} | "
            f"{f['designed'][4]:.4g} | {f['empty'][4]:.4g} | {rules} rules, {where} |"
        )
    lines.append("")
    lines += effort.effort_lines(held)
    for regime in spec.regimes:
        lines.append(f"- {regime}: {conclusion_sentence(meta, held, regime)}")
    return lines


def load_output(out: Path) -> tuple[dict[str, Any], pd.DataFrame] | None:
    """The search as a reproduction copied it into ``out/search/`` (None where absent): what
    the conclusions read for :func:`conclusion_sentence`."""
    folder = Path(out) / "search"
    if not ((folder / "search.json").is_file() and (folder / "heldout.csv").is_file()):
        return None
    return json.loads((folder / "search.json").read_text()), pd.read_csv(folder / "heldout.csv")


def search_closing(out: Path) -> list[str]:
    """The conclusions' one sentence on the search (both regimes,
    :func:`twolink.studies.judgments.conclusions.search_sentence`), from what the reproduction
    copied into ``out/search/``; none where it copied no current search."""
    from twolink.studies.judgments.conclusions import search_sentence

    saved = load_output(out)
    said = search_sentence(sentence_numbers(*saved)) if saved is not None else None
    return [said] if said else []


def conclusion_lines(out: Path) -> list[str]:
    """The conclusions' sentence per searched regime, from a reproduction's ``out/search/``
    (empty where the reproduction copied no current search): what the conclusions code
    calls. The numbers behind it are :func:`sentence_numbers`' (``search.json`` and
    ``heldout.csv`` in the same folder)."""
    saved = load_output(out)
    if saved is None:
        return []
    meta, held = saved
    regimes = list(dict.fromkeys(f["regime"] for f in meta["searches"]))
    return [s for r in regimes if (s := conclusion_sentence(meta, held, r))]
