"""Sections of the reproduction's report that read its runs: the runs that end in a
sustained oscillation (with the fuzzy rules firing over the window), and the FCM design
(designed rules beside the paper's Table 1, the held-out table, downward steps beside
upward ones). :mod:`twolink.studies.reproduction.reproduce` assembles them with
:mod:`twolink.studies.reproduction.report`."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from twolink.simulation.config import Scenario
from twolink.simulation.experiment import build_controller
from twolink.simulation.sim import Trajectory

if TYPE_CHECKING:
    from twolink.studies.reproduction.manifest import RunSpec

OSCILLATING = 0.05  # rad: a sustained oscillation worth explaining in the report


def oscillation_section(
    specs: list[RunSpec],
    scenarios: dict[str, Scenario],
    trajectories: dict[str, Trajectory],
    rows: list[dict[str, Any]],
) -> list[str]:
    """The runs that end in a sustained oscillation (``oscillation_rad`` above
    :data:`OSCILLATING` on the experiment's joint), and for fuzzy ones which rules fire
    over that window (the dominant rule per sample; "none": the CTC term alone acts)."""
    import numpy as np

    from twolink.controllers.fuzzy import fired_rule_labels
    from twolink.simulation.metrics import OSCILLATION_WINDOW
    from twolink.simulation.vocabulary import format_value

    lines = []
    for spec, row in zip(specs, rows, strict=True):
        if not row["oscillation_rad"] > OSCILLATING:
            continue
        traj, j = trajectories[spec.folder], spec.experiment.joint - 1
        tail = traj.t >= traj.t[-1] * (1 - OSCILLATION_WINDOW)
        rules = "(no fuzzy term)"
        controller = build_controller(scenarios[spec.folder])
        engine = getattr(controller, "engine", None)
        if engine is not None:
            labels = fired_rule_labels(
                engine, controller.ke * traj.e[tail, j], controller.kde * traj.de[tail, j]
            )
            names, counts = np.unique(labels, return_counts=True)
            order = np.argsort(-counts)
            rules = ", ".join(
                f"{names[k]} {100 * counts[k] / counts.sum():.0f} %" for k in order[:4]
            )
        lines.append(
            f"| {spec.folder} | θ{j + 1} | {format_value(row['oscillation_rad'])} | "
            f"{format_value(row['steady_state_error_rad'])} | {rules} |"
        )
    if not lines:
        return []
    return [
        "",
        "## Sustained oscillations",
        "",
        f"Runs whose error still swings by more than {OSCILLATING} rad (half peak-to-peak)",
        f"over the last {100 * OSCILLATION_WINDOW:.0f} % of the run, and for the fuzzy ones",
        'the dominant fuzzy rule over that window (share of samples; "none": no rule',
        'fires). Reading it: where a fuzzy CTC\'s window is mostly "none" (CTC alone, which',
        "keeps the model mismatch's offset) cut by a rule or two, those rules switch on",
        "while the error is large, push θ by at most ku (the fuzzy term's scale, rad/s²),",
        "and switch off as the error leaves their support: an on-off correction that keeps",
        "the cycle going instead of settling. A fuzzy term without the model cannot hold",
        "the arm up at these scalings (docs/control.md); an integrator at low gains may not",
        "settle within the run.",
        "",
        "| run | joint | osc [rad] | ess [rad] | rules firing over the window |",
        "|---|---|---|---|---|",
        *lines,
    ]


def design_section(
    result: Any,
    specs: list[RunSpec] = (),
    scenarios: dict[str, Scenario] | None = None,
    rows: list[dict[str, Any]] = (),
    validity: Any = None,
) -> list[str]:
    """The report's section on the FCM design (``validity``: the cluster-validity sweep
    if already computed, else computed here): the designed rules beside the paper's
    Table 1, the data, the symmetry check and the held-out table (docs/fuzzy.md), and each
    downward step's overshoot beside its mirrored upward one (:func:`up_and_down`)."""
    from twolink.studies.designs.design import design_evidence, design_markdown
    from twolink.studies.designs.validity import validity_markdown

    return [
        "",
        "## The FCM design (the paper's Table 1 and Figure 2)",
        "",
        "Our design procedure (docs/fuzzy.md; runs/paper/design.toml) in our convention,",
        "e = θd − θ (the paper's own definition, its section 1) and u > 0 pushes θ up, beside",
        "the paper's Table 1 as printed and as we read it: read with that e and u, Table 1",
        "is positive feedback (u ~ −(e + ė)), so we infer that its inputs carry the opposite",
        "sign and mirror its input labels (an inferred sign, not one the paper states).",
        "",
        *design_markdown(result.rules, design_evidence(result)),
        *up_and_down(specs, scenarios or {}, rows),
        *validity_markdown(result, validity),
        "",
        "![phase plane](figures/design_phase_plane.png)",
        "",
        "![control surfaces](figures/control_surfaces.png)",
    ]


def up_and_down(
    specs: list[RunSpec], scenarios: dict[str, Scenario], rows: list[dict[str, Any]]
) -> list[str]:
    """Overshoot (and final error) of every run whose joint steps down, beside the run
    that makes the same move upward: same variant, controller, joint, plant and
    reference shape with the opposite target."""

    from twolink.foundation.references import reference_params
    from twolink.simulation.vocabulary import format_value

    def shape(sp: RunSpec) -> tuple[Any, ...]:
        """The run's move without its target, and the signed size of the move."""
        s = scenarios[sp.folder]
        j = sp.experiment.joint - 1
        refs = [reference_params(r) for r in (s.reference.joint1, s.reference.joint2)]
        size = refs[j].pop("final") - s.q0[j]
        key = (sp.variant.name, sp.controller, j, repr(s.plant), s.q0, s.qd0, repr(refs))
        return key, size

    moves = {
        sp.folder: (*shape(sp), sp, row)
        for sp, row in zip(specs, rows, strict=True)
        if sp.folder in scenarios
    }
    ups = {key: (sp, row) for key, size, sp, row in moves.values() if size > 0}
    lines = []
    for key, size, sp, row in moves.values():
        up = ups.get(key) if size < 0 else None
        if up is None or shape(up[0])[1] != -size:
            continue
        up_spec, up_row = up
        lines.append(
            f"| {sp.variant.name} | {up_spec.experiment.label} / {sp.experiment.key} | "
            f"{sp.controller} | {format_value(up_row['overshoot_pct'])} | "
            f"{format_value(row['overshoot_pct'])} | {format_value(up_row['final_error_rad'])} "
            f"| {format_value(row['final_error_rad'])} |"
        )
    if not lines:
        return []
    return [
        "",
        "Up and down: each downward step beside the same move upward (same plant, same",
        "controller). An odd-symmetric rule base treats both alike on a symmetric loop;",
        "gravity and a wrong model of it do not.",
        "",
        "| variant | experiments (up / down) | controller | Mp up [%] | Mp down [%] "
        "| e(T) up [rad] | e(T) down [rad] |",
        "|---|---|---|---|---|---|---|",
        *lines,
    ]


def links_section(rows: list[dict[str, Any]], manifest: Any) -> list[str]:
    """The tip's measures on each variant whose links bend (rows with ``tip_error_m``):
    the paper's pair per experiment (distances in mm, times in s), and how often the proposed law is
    better or worse than the baseline beyond the tip's tolerances
    (:data:`twolink.studies.judgments.link_claims.TIP_TOLERANCES`; a tip that never
    settled counts against its law, as in the link claims)."""
    import math

    from twolink.studies.judgments.link_claims import REACHED, TIP_TOLERANCES

    P, B = manifest.proposed, manifest.baseline
    lines: list[str] = []
    for variant in manifest.variants:
        pair = {
            (r["experiment"], r["controller"]): r
            for r in rows
            if r["variant"] == variant.name and "tip_error_m" in r
        }
        if not pair:
            continue
        keys = [e.key for e in manifest.experiments if (e.key, P) in pair and (e.key, B) in pair]
        table, counts = [], {m: [0, 0, 0] for m in TIP_TOLERANCES}
        for key in keys:
            cells = []
            for m, tol in TIP_TOLERANCES.items():
                a, b = pair[key, P][m], pair[key, B][m]
                cells += [_shown(b, m), _shown(a, m)]
                if math.isfinite(a) and math.isfinite(b):
                    counts[m][0 if a < b - tol else 1 if a > b + tol else 2] += 1
                elif m in REACHED and math.isfinite(a) != math.isfinite(b):
                    counts[m][0 if math.isfinite(a) else 1] += 1  # never settled: worse
            table.append(f"| {key} | " + " | ".join(cells) + " |")
        said = "; ".join(
            f"{name} better in {c[0]}, worse in {c[1]}, within {_shown(TIP_TOLERANCES[m], m)} "
            f"{'s' if m.endswith('_s') else 'mm'} in {c[2]}"
            for (m, c), name in zip(
                counts.items(), ("tip error", "final tip error", "residual", "tip settling"),
                strict=True,
            )
        )  # fmt: skip
        lines += [
            "",
            f"## Beyond the paper: {variant.title}",
            "",
            f"The links bend; the laws still read the hub angles and model the rigid rods. "
            f"The links start at rest in their sag. The tip's measures (docs/flexible_links.md, "
            f'"Measures at the tip"), {B} then {P}, distances in mm, times in s. '
            f"Against {B}, {P} is: {said} "
            f"(of {len(keys)} experiments).",
            "",
            f"| experiment | max\\|Δtip\\| {B} | {P} | \\|Δtip\\|(T) {B} | {P} | w res {B} | {P} "
            f"| Ts tip {B} | {P} |",
            "|---|---|---|---|---|---|---|---|---|",
            *table,
        ]
    if lines:
        from twolink.studies.judgments.link_claims import shipped_section

        lines += shipped_section()
    return lines


def _shown(value: float, key: str) -> str:
    """A tip measure ``key``'s value: a distance in mm, a time in s, 3 digits; "—" where
    undefined."""
    from twolink.simulation.vocabulary import format_value

    scale = 1.0 if key.endswith("_s") else 1e3
    return format_value(value * scale if isinstance(value, float) else value)
