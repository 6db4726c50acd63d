"""The reproduction's claims studies: the claims sweep of the manifest, as its file says
and again in each regime of a ``raw_steps`` variant (the paper's own references) and on
the lab arm (the manifest's ``lab_study``: the same plants with friction and a disturbance), judged
with :mod:`twolink.studies.judgments.claims`, each against the baseline and against the fair linear
opponent, CTC-best (:mod:`twolink.studies.designs.frontier`). The pieces of a regime (the raw steps,
the reference's own step metrics, the sweep in a regime) are
:mod:`twolink.studies.judgments.claims_plans`' (re-exported here)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from twolink.studies.designs.effort import EFFORT_KEYS  # judged against the fair opponent
from twolink.studies.designs.frontier import OPPONENT
from twolink.studies.judgments.claims_plans import (
    SMOOTH_KINDS,
    raw_steps,
    reference_values,
    regime_plan,
)
from twolink.studies.judgments.conclusions import ClaimsStudy
from twolink.studies.reproduction.manifest import Manifest, Variant

# The lab arm's regime (the manifest's lab_study): its files are claims_lab.csv and the like.
LAB = Variant("lab", "the lab arm, with joint friction and a load step", {})


__all__ = [
    "LAB",
    "SMOOTH_KINDS",
    "fair_opponent",
    "ranking",
    "raw_steps",
    "reference_values",
    "regime_plan",
    "run_claims",
    "tuned_opponents",
]


def run_claims(manifest: Manifest, out: Path, pool: Any, progress: bool) -> tuple[list[str], Any]:
    """The claims study on ``pool``: as its file says, and again in each regime of a
    ``raw_steps`` variant (the paper's own references, the variant's gains), each with the
    fair linear opponent beside the baseline (:mod:`twolink.studies.designs.frontier`). Returns the
    report's sections and, per study, its tables for the conclusions
    (:class:`twolink.studies.judgments.conclusions.ClaimsStudy`)."""
    from twolink import sweep
    from twolink.studies.designs import frontier, search

    # each regime: (the manifest it judges, the variant its moves come from, its label)
    regimes: list[tuple[Manifest, Any, Any]] = [(manifest, None, None)]
    regimes += [(manifest, v, v) for v in manifest.variants if v.raw_steps]
    if manifest.lab_study is not None:  # the lab arm: its own sweep file, quintic moves
        regimes.append((dataclasses.replace(manifest, claims_study=manifest.lab_study), None, LAB))
    variants = [label for _, _, label in regimes]
    plans = []
    tuned = []
    for judged, variant, _ in regimes:
        # the fair linear opponent: the best linear loop at the proposed controller's effort
        opponent = fair_opponent(manifest, variant, pool)
        # the laws of the field, tuned by the same rule (designs/opponent_search.py)
        laws = tuned_opponents(manifest, variant)
        overrides = {
            "controllers": {
                OPPONENT: opponent.controller(),
                **{t.name: t.controller() for t in laws},
            }
        }
        plans.append((opponent, regime_plan(judged, variant, overrides)))
        tuned.append(laws)
    try:
        # every regime's sweep at once on the pool, each into the reproduction's own
        # folder (a changed sweep file's results are replaced)
        outcomes = sweep.run_sweeps(
            [
                (plan, out / f"claims_study{_suffix(v)}")
                for v, (_, plan) in zip(variants, plans, strict=True)
            ],
            pool=pool,
            plots=False,
            progress=progress,
            replace_other=True,
        )
    except sweep.SweepInterrupted as exc:
        from twolink.foundation.interrupts import CTRL_C_RECEIVED

        CTRL_C_RECEIVED.append(exc.signum)  # the command ends as that signal asks (130/143)
        raise KeyboardInterrupt from None  # the reproduction's own stop
    sections: list[str] = []
    tables = []
    rankings = []
    for (judged, _, variant), (opponent, plan), laws, outcome in zip(
        regimes, plans, tuned, outcomes, strict=True
    ):
        more, studies = _claims_study(judged, out, variant, opponent, plan, outcome, laws)
        sections += more
        rankings.append(ranking(outcome.results, judged.proposed, variant, opponent, laws))
        tables += [dataclasses.replace(s, ranking=rankings[-1]) for s in studies]
    from twolink.foundation.io import atomic_write_text

    every = pd.concat(rankings, ignore_index=True)
    atomic_write_text(out / RANKING, every.to_csv(index=False))
    sections += ranking_section(every)
    # after the claims: where the fair opponent comes from, and the strongest fuzzy term
    sections += frontier.report_section(manifest, out, pool) + search.report_section(manifest, out)
    return sections, tables


def _suffix(variant: Any) -> str:
    return "" if variant is None else f"_{variant.name}"


def _claims_study(
    manifest: Manifest,
    out: Path,
    variant: Any,
    opponent: Any,
    plan: Any,
    outcome: Any,
    laws: list[Any] = (),  # type: ignore[assignment]
) -> tuple[list[str], Any]:
    """One claims study, its sweep ``outcome`` in ``out/claims_study[_VARIANT]``: the
    paper's claim judged on its plants (``claims[_VARIANT].csv``), every controller
    against the baseline (``claims_all[_VARIANT].csv``); the report's sections on them."""

    from twolink.foundation.io import atomic_write_text
    from twolink.studies.judgments.claims import (
        CLAIM_METRICS,
        paired_claims,
        paired_claims_many,
    )
    from twolink.studies.reproduction import report

    study = manifest.claims_study
    suffix, regime = _suffix(variant), "" if variant is None else variant.title
    refs = reference_values(plan.nominal_scenario(), plan.joints)
    table = paired_claims(
        outcome.results, manifest.proposed, manifest.baseline, joints=plan.joints,
        reference_values=refs,
    )  # fmt: skip
    atomic_write_text(out / f"claims{suffix}.csv", table.to_csv(index=False))
    # against the fair opponent, effort is judged too: both sides' peak |τ| and Σ|Δτ| on
    # these plants, where the opponent's budget must hold (docs/reproduction.md)
    fair = paired_claims(
        outcome.results, manifest.proposed, OPPONENT, joints=plan.joints, reference_values=refs,
        metrics=(*CLAIM_METRICS, *EFFORT_KEYS),
    )  # fmt: skip
    atomic_write_text(out / f"claims_matched{suffix}.csv", fair.to_csv(index=False))
    source = f"{study.parent.name}/{study.name}" + (f", {regime}" if regime else "")
    sensor = plan.nominal_scenario().sensor.describe()
    met = {name: outcome.summary[name]["met_spec"] for name in plan.controller_names}
    # Who wins on what: every controller of the sweep against the baseline, and the
    # controller with integral action against the proposed one and the opponents: one pass.
    base, proposed = manifest.baseline, manifest.proposed
    integral = next((n for n, over in plan.controllers if over.get("kind") == "ctc_integral"), None)
    names = {t.name for t in laws}  # judged in their own table below
    pairs = [(name, base) for name in plan.controller_names if name != base and name not in names]
    pairs += [(proposed, OPPONENT)]
    if integral is not None:
        pairs += [(integral, proposed), (integral, OPPONENT)]
    every = paired_claims_many(
        outcome.results, pairs, report.WINNER_METRICS, plan.joints, reference_values=refs
    )
    versus = {
        name: t.drop(columns=["proposed", "opponent"]).reset_index(drop=True)
        for name, t in every[every["opponent"] == base].groupby("proposed", sort=False)
    }
    atomic_write_text(out / f"claims_all{suffix}.csv", every.to_csv(index=False))
    sections = report.winners_section(versus, manifest.baseline, met, plan.samples, regime) + (
        report.claims_section(table, manifest, plan.samples, source, met, regime, sensor)
    )
    against = dataclasses.replace(manifest, baseline=OPPONENT)
    sections += opponent_section(opponent, manifest) + report.claims_section(
        fair, against, plan.samples, source, met, f"{regime or 'quintic moves'}, {OPPONENT}", sensor
    )
    tuned: dict[str, Any] = {}
    if laws:  # FCM-CTC against each tuned law, and each against CTC-best, effort judged too
        more, tuned = _tuned_study(manifest, out, suffix, plan, outcome, laws, refs, met, source,
                                   regime, sensor)  # fmt: skip
        sections += more
    if variant is LAB:
        sections += hunting_section()
    label = regime or "the claims study's quintic moves"
    study = ClaimsStudy(
        label=label,
        plants=plan.samples,
        met=met,
        proposed=proposed,
        baseline=base,
        claims={base: table, OPPONENT: fair},
        same_as={},
        every=every,
        integral=integral,
        lab=variant is LAB,
        tuned=tuned,
    )
    return sections, [study]


def _tuned_study(
    manifest: Manifest,
    out: Path,
    suffix: str,
    plan: Any,
    outcome: Any,
    laws: list[Any],
    refs: Any,
    met: dict[str, int],
    source: str,
    regime: str,
    sensor: str,
) -> tuple[list[str], dict[str, Any]]:
    """``claims_tuned[_VARIANT].csv``: :func:`paired_claims_many`'s rows of the proposed
    controller against each tuned law and of each law against CTC-best, on the claim
    metrics and the effort metrics; the report's sections on them, and per law the
    proposed controller's rows against it."""
    from twolink.foundation.io import atomic_write_text
    from twolink.studies.judgments.claims import CLAIM_METRICS, paired_claims_many
    from twolink.studies.reproduction import report

    p = manifest.proposed
    pairs = [(p, t.name) for t in laws] + [(t.name, OPPONENT) for t in laws]
    table = paired_claims_many(
        outcome.results, pairs, (*CLAIM_METRICS, *EFFORT_KEYS), plan.joints,
        reference_values=refs,
    )  # fmt: skip
    atomic_write_text(out / f"claims_tuned{suffix}.csv", table.to_csv(index=False))

    def rows(mine: str, theirs: str) -> Any:
        t = table[(table["proposed"] == mine) & (table["opponent"] == theirs)]
        return t.drop(columns=["proposed", "opponent"]).reset_index(drop=True)

    label = regime or "quintic moves"
    sections: list[str] = []
    for t in laws:
        against = dataclasses.replace(manifest, baseline=t.name)
        sections += tuned_section(t, manifest) + report.claims_section(
            rows(p, t.name), against, plan.samples, source, met, f"{label}, {t.name}", sensor
        )
    versus = {t.name: rows(t.name, OPPONENT) for t in laws}
    mine = {t.name: rows(p, t.name) for t in laws}
    return sections + report.winners_section(versus, OPPONENT, met, plan.samples, label), mine


def tuned_opponents(manifest: Manifest, variant: Any = None) -> list[Any]:
    """The regime's tuned laws shipped beside the manifest
    (:func:`twolink.studies.designs.searched_opponent.shipped_tuned`), in :data:`TUNED`'s
    order; the lab arm's are the quintic moves'. None where none is shipped."""
    from twolink.studies.designs import frontier
    from twolink.studies.designs.searched_opponent import shipped_tuned

    regime = frontier.QUINTIC if variant is None else variant.name
    return [by[regime] for by in shipped_tuned(manifest.path.parent).values() if regime in by]


def tuned_section(law: Any, manifest: Manifest) -> list[str]:
    """What a tuned law is, before its claims table."""
    p, mine, theirs = manifest.proposed, law.judged, law.judged_fcm
    return [
        "",
        f"### Against {law.name}, tuned by CTC-best's rule",
        "",
        f"{law.name} is {law.describe()}: the best of the same search as {OPPONENT} (its",
        "optimiser, seed, budget, training plants and objective;",
        '`runs/paper/tuned_opponents.json`, docs/reproduction.md, "The laws tuned by the same',
        f"rule\"). Its median Σ|Δτ| was {mine[2]:.4g} / {mine[3]:.4g} N·m against {p}'s",
        f"{theirs[2]:.4g} / {theirs[3]:.4g} on the judged plants when it was tuned; the",
        "table's torque rows judge both sides' effort on these plants, plant by plant.",
    ]


RANKING = "ranking.csv"  # every controller's index and effort per regime (docs/reproduction.md)


def ranking(results: Any, proposed: str, variant: Any, opponent: Any, laws: list[Any]) -> Any:
    """One regime's ranking: per controller of the sweep, its index (the median over the
    judged plants of IAE₁ + IAE₂) and its four effort medians there, whether that effort is
    within the proposed controller's (:func:`twolink.studies.designs.effort.within_budget`),
    its rank by index; and, for a searched or tuned one, its numbers on the training plants
    it was chosen on and whether the effort rule admitted it."""
    from twolink.studies.designs import effort, frontier

    table = frontier.summarise(results)
    table = table[["controller", "failed", "index", *effort.EFFORT_COLUMNS]].copy()
    own = table[table["controller"] == proposed].iloc[0]
    budget = {c: float(own[c]) for c in effort.EFFORT_COLUMNS}
    table["within"] = effort.within_budget(table, budget) & (table["failed"] == 0)
    table["rank"] = table["index"].rank(method="min").astype("Int64")
    train: dict[str, tuple[tuple[float, ...], bool | None]] = {}
    if hasattr(opponent, "train"):  # the searched CTC-best (the grid's has no training row)
        train[OPPONENT] = (opponent.train, True)
        train[proposed] = (opponent.train_fcm, None)
    for t in laws:
        train[t.name] = (t.train, t.within)
    names = ("train_index", *(f"train_{c}" for c in effort.EFFORT_COLUMNS))
    for k, name in enumerate(names):
        pick = (4, 0, 1, 2, 3)[k]
        table[name] = [train[c][0][pick] if c in train else np.nan for c in table["controller"]]
    table["admitted"] = [train[c][1] if c in train else None for c in table["controller"]]
    regime = frontier.QUINTIC if variant is None else variant.name
    table.insert(0, "regime", regime)
    table.insert(2, "plants", int(results["sample"].nunique()))
    return table.sort_values(["rank", "controller"], kind="stable").reset_index(drop=True)


def ranking_section(table: Any) -> list[str]:
    """The reproduction's ranking (``ranking.csv``) as a table per regime."""
    out = [
        "",
        "## Every controller by its index, per regime",
        "",
        "The index is the median over the judged plants of IAE₁ + IAE₂ [rad·s]; effort: the",
        "median peak |τ| and Σ|Δτ| per joint [N·m]; within: each at most FCM-CTC's plus the",
        'tolerance there (`ranking.csv`, docs/reproduction.md, "The ranking").',
    ]
    for regime, t in table.groupby("regime", sort=False):
        out += ["", f"{regime}:", "", "| rank | controller | index | peak τ₁ / τ₂ | Σ|Δτ|₁ / ₂ "
                "| within | training index |", "|---|---|---|---|---|---|---|"]  # fmt: skip
        for r in t.itertuples():
            train = "—" if r.train_index != r.train_index else f"{r.train_index:.4g}"
            out.append(
                f"| {r.rank} | {r.controller} | {r.index:.4g} | {r.torque_peak_Nm1:.1f} / "
                f"{r.torque_peak_Nm2:.1f} | {r.torque_variation_Nm1:.1f} / "
                f"{r.torque_variation_Nm2:.1f} | {'yes' if r.within else 'no'} | {train} |"
            )
    return out


def fair_opponent(manifest: Manifest, variant: Any = None, pool: Any = None) -> Any:
    """The regime's fair opponent: the searched per-joint loop shipped beside the manifest
    (:mod:`twolink.studies.designs.opponent_search`: within FCM-CTC's effort on the training
    and on the judged plants), else the best loop of the linear frontier's grid
    (:mod:`twolink.studies.designs.frontier`: its shipped table where current, else run
    here)."""
    from twolink.studies.designs import frontier, opponent_search

    regime = frontier.QUINTIC if variant is None else variant.name
    searched = opponent_search.shipped_opponents(manifest.path.parent)
    if regime in searched:
        return searched[regime]
    spec = frontier.load_spec(manifest.path.parent / frontier.DEFAULT_SPEC.name)
    _, chosen, _ = frontier.opponents(spec, pool)
    return chosen[regime]


def opponent_section(opponent: Any, manifest: Manifest) -> list[str]:
    """What the fair linear opponent is, before its claims table."""
    from twolink.studies.designs.opponent_search import SearchedOpponent

    p = manifest.proposed
    if isinstance(opponent, SearchedOpponent):
        mine, theirs = opponent.judged, opponent.judged_fcm
        return [
            "",
            f"### Against the best linear loop at {p}'s effort ({OPPONENT})",
            "",
            f"{OPPONENT} is {opponent.describe()}: the best of a search per joint (the",
            "table search's optimiser, budget and training plants;",
            '`runs/paper/frontier_per_joint.json`, docs/reproduction.md, "The linear opponent',
            'by search, per joint") among the loops whose median peak |τ| and Σ|Δτ| per joint',
            f"stay within {p}'s on the training plants and on these judged plants. Its",
            f"median Σ|Δτ| was {mine[2]:.4g} / {mine[3]:.4g} N·m against {p}'s {theirs[2]:.4g} /",
            f"{theirs[3]:.4g} when it was searched; the table's torque rows (peak |τ|, Σ|Δτ|)",
            f"judge both sides' effort on these plants, plant by plant. Does {p} beat the best",
            "linear loop given the same effort?",
        ]
    ratio = f"{opponent.effort_ratio:.3g}"
    return [
        "",
        f"### Against the best linear loop at {p}'s effort ({OPPONENT})",
        "",
        f"{OPPONENT} is {opponent.describe()}: of the linear frontier's loops (CTC on a grid",
        "of ωn and ζ, and CTC clipped at FCM-CTC's peak torques; `runs/paper/frontier.toml`,",
        "docs/reproduction.md) the one with the lowest median IAE₁ + IAE₂ on the training",
        f"plants ({opponent.index:.4g} rad·s; {p}: {opponent.proposed_index:.4g}) among those",
        f"whose median peak |τ| and Σ|Δτ| per joint stay within {p}'s (its largest ratio to",
        f"{p}'s: {ratio}). Does {p} beat the best linear loop given the same effort?",
    ]


def hunting_section() -> list[str]:
    """The lab arm's figure: integral action hunting against friction beside CTC's clean
    stop (:mod:`twolink.figures.hunting`)."""
    from twolink.figures.hunting import HUNTING_FIGURE, HUNTING_FRICTION

    f = HUNTING_FRICTION
    return [
        "",
        "### Stick-slip hunting on one plant",
        "",
        "The nominal arm with friction at the harsh end of the lab arm's ranges",
        f"(F_c = {f['coulomb']} N·m, F_s = {f['breakaway']} N·m, v_s = {f['stribeck_velocity']}",
        "rad/s), the base gains, θ1 stepping 0.5 rad: CTC stops short of the target by its",
        "dead band and stays; CTC-I's integrator winds up to breakaway, the joint slips past",
        'the target and sticks again, over and over (docs/model.md, "Friction").',
        "",
        f"![stick-slip hunting]({HUNTING_FIGURE})",
    ]
