"""The reproduction's claims studies: the claims sweep of the manifest, as its file says
and again in each regime of a ``raw_steps`` variant (the paper's own references), judged
with :mod:`twolink.studies.claims`; and the two pieces of a regime, the raw steps that replace
smooth moves (:func:`raw_steps`) and the reference's own step metrics
(:func:`reference_values`), where no controller decides a metric."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from twolink.simulation.config import Scenario, read_toml
from twolink.simulation.vocabulary import metric
from twolink.studies.conclusions import ClaimsStudy
from twolink.studies.manifest import Manifest
from twolink.studies.matching import MATCHED, Matched, match_peak_torque

__all__ = ["SMOOTH_KINDS", "raw_steps", "reference_values", "run_claims"]

SMOOTH_KINDS = ("quintic", "septic")


def raw_steps(source: Path | Mapping[str, Any]) -> dict[str, Any]:
    """Reference overrides that make a scenario's (or a sweep's) smooth moves the raw steps
    between the same angles at the same start: the paper's own references (``replace``:
    a step takes no ``duration``). Other references (ramps, holds) are left as they are."""
    tables = read_toml(source).get("reference", {}) if isinstance(source, Path) else source
    out = {}
    for joint, ref in tables.items():
        if isinstance(ref, dict) and ref.get("kind") in SMOOTH_KINDS:
            step = {k: ref[k] for k in ("initial", "final", "t0") if k in ref}
            out[joint] = {"replace": True, "kind": "step", **step}
    return out


def reference_values(scenario: Scenario, joints: Any) -> dict[tuple[int, str], float]:
    """The step metrics of the reference itself, per moving joint: where both controllers
    have the reference's own value (a smooth move's Td and Tr), no controller set it."""
    from twolink.simulation.metrics import step_metrics

    t = np.arange(0.0, scenario.duration + 1e-12, scenario.control_dt)
    q_ref = scenario.reference.sample(t)[0]  # (N, 2)
    out = {}
    for j in joints:
        target, start = scenario.reference.final[j - 1], scenario.q0[j - 1]
        m = step_metrics(t, q_ref[:, j - 1], target, y0=start)
        for key in ("delay_time_s", "rise_time_s", "peak_time_s"):
            value = getattr(m, metric(key).source.split(".")[1])
            if np.isfinite(value):
                out[(j, key)] = float(value)
    return out


def run_claims(manifest: Manifest, out: Path, pool: Any, progress: bool) -> tuple[list[str], Any]:
    """The claims study on ``pool``: as its file says, and again in each regime of a
    ``raw_steps`` variant (the paper's own references, the variant's gains), each with the
    fair linear opponent beside the baseline (:mod:`twolink.studies.matching`). Returns the
    report's sections and, per study, its tables for the conclusions
    (:class:`twolink.studies.conclusions.ClaimsStudy`)."""
    sections: list[str] = []
    tables = []
    for variant in (None, *(v for v in manifest.variants if v.raw_steps)):
        more, studies = _claims_study(manifest, out, pool, progress, variant)
        sections += more
        tables += studies
    return sections, tables


def _claims_study(
    manifest: Manifest, out: Path, pool: Any, progress: bool, variant: Any = None
) -> tuple[list[str], Any]:
    """One claims study into ``out/claims_study[_VARIANT]``: the paper's claim judged on
    its plants (``claims[_VARIANT].csv``), every controller against the baseline
    (``claims_all[_VARIANT].csv``); the report's sections on them."""

    from twolink import sweep
    from twolink.foundation.io import atomic_write_text
    from twolink.studies import report
    from twolink.studies.claims import paired_claims, paired_claims_many

    study = manifest.claims_study
    plan = sweep.load_sweep(study)
    suffix, regime, overrides = "", "", {}
    if variant is not None:  # the same study in the variant's regime
        suffix, regime = f"_{variant.name}", variant.title
        overrides = {
            "name": f"{plan.name}{suffix}",
            "overrides": variant.overrides,
            "reference": raw_steps(read_toml(study).get("reference", {})),
        }
        plan = sweep.load_sweep(study, overrides)
    # the fair linear opponent: CTC retuned to the proposed controller's peak torque
    matched = match_peak_torque(plan, manifest.proposed, manifest.baseline)
    if matched.scale != 1.0:  # else the baseline is its own match: not run twice
        retuned = matched.controller(dict(plan.controllers)[manifest.baseline])
        plan = sweep.load_sweep(study, {**overrides, "controllers": {MATCHED: retuned}})
    try:
        # the reproduction's own folder: a changed sweep file's results are replaced
        outcome = sweep.run_sweep(
            plan,
            out / f"claims_study{suffix}",
            pool=pool,
            plots=False,
            progress=progress,
            replace_other=True,
        )
    except sweep.SweepInterrupted as exc:
        from twolink.foundation.interrupts import CTRL_C_RECEIVED

        CTRL_C_RECEIVED.append(exc.signum)  # the command ends as that signal asks (130/143)
        raise KeyboardInterrupt from None  # the reproduction's own stop
    refs = reference_values(plan.nominal_scenario(), plan.joints)
    table = paired_claims(
        outcome.results, manifest.proposed, manifest.baseline, joints=plan.joints,
        reference_values=refs,
    )  # fmt: skip
    atomic_write_text(out / f"claims{suffix}.csv", table.to_csv(index=False))
    fair = table
    if matched.scale != 1.0:
        fair = paired_claims(
            outcome.results, manifest.proposed, MATCHED, joints=plan.joints, reference_values=refs
        )
    atomic_write_text(out / f"claims_matched{suffix}.csv", fair.to_csv(index=False))
    source = f"{study.parent.name}/{study.name}" + (f", {regime}" if regime else "")
    sensor = plan.nominal_scenario().sensor.describe()
    met = {name: outcome.summary[name]["met_spec"] for name in plan.controller_names}
    met.setdefault(MATCHED, met[manifest.baseline])  # the baseline as its own match
    # Who wins on what: every controller of the sweep against the baseline, and the
    # controller with integral action against the proposed one and the opponents: one pass.
    base, proposed = manifest.baseline, manifest.proposed
    distinct = matched.scale != 1.0  # else the matched opponent is the baseline itself
    integral = next((n for n, over in plan.controllers if over.get("kind") == "ctc_integral"), None)
    pairs = [(name, base) for name in plan.controller_names if name != base]
    pairs += [(proposed, MATCHED)] if distinct else []
    if integral is not None:
        pairs += [(integral, proposed)] + ([(integral, MATCHED)] if distinct else [])
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
    against = dataclasses.replace(manifest, baseline=MATCHED)
    sections += matched_section(matched, manifest) + report.claims_section(
        fair, against, plan.samples, source, met, f"{regime or 'quintic moves'}, {MATCHED}", sensor
    )
    label = regime or "the claims study's quintic moves"
    study = ClaimsStudy(
        label=label,
        plants=plan.samples,
        met=met,
        proposed=proposed,
        baseline=base,
        claims={base: table, MATCHED: fair},
        same_as={} if distinct else {MATCHED: base},
        every=every,
        integral=integral,
    )
    return sections, [study]


def matched_section(matched: Matched, manifest: Manifest) -> list[str]:
    """What the fair linear opponent is, before its claims table."""
    p, b = manifest.proposed, manifest.baseline
    peaks = " / ".join(f"{v:.1f}" for v in matched.proposed_peak)
    mine = " / ".join(f"{v:.1f}" for v in matched.matched_peak)
    return [
        "",
        f"### Against a fair linear opponent ({MATCHED})",
        "",
        f"{MATCHED} is {b} with its natural frequency scaled by {matched.scale:.3g} (ζ kept:",
        f"Kp {matched.kp[0]:.4g}, Kd {matched.kd[0]:.4g}), the largest scale at which its peak",
        f"torque on the nominal plant stays within {p}'s on every joint ({p}: {peaks} N·m;",
        f"{MATCHED}: {mine} N·m; `twolink/studies/matching.py`). Does {p} beat a linear loop",
        "given the same torque?",
    ] + (
        [
            "",
            f"Here the scale is 1: {p} spends no more torque than {b} (on smooth moves the",
            f"feedforward sets the peak), so {MATCHED} is {b} itself and its table is the one",
            "above.",
        ]
        if matched.scale == 1.0
        else []
    )
