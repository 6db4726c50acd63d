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
    "raw_steps",
    "reference_values",
    "regime_plan",
    "run_claims",
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
    for judged, variant, _ in regimes:
        # the fair linear opponent: the best linear loop at the proposed controller's effort
        opponent = fair_opponent(manifest, variant, pool)
        overrides = {"controllers": {OPPONENT: opponent.controller()}}
        plans.append((opponent, regime_plan(judged, variant, overrides)))
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
    for (judged, _, variant), (opponent, plan), outcome in zip(
        regimes, plans, outcomes, strict=True
    ):
        more, studies = _claims_study(judged, out, variant, opponent, plan, outcome)
        sections += more
        tables += studies
    # after the claims: where the fair opponent comes from, and the strongest fuzzy term
    sections += frontier.report_section(manifest, out, pool) + search.report_section(manifest, out)
    return sections, tables


def _suffix(variant: Any) -> str:
    return "" if variant is None else f"_{variant.name}"


def _claims_study(
    manifest: Manifest, out: Path, variant: Any, opponent: Any, plan: Any, outcome: Any
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
    pairs = [(name, base) for name in plan.controller_names if name != base]
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
    )
    return sections, [study]


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
