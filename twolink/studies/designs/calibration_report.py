"""The calibration's analysis and report (``twolink calibrate``'s summary and the
reproduction's "Calibrated against the paper" section, :mod:`twolink.studies.designs.calibrate` the
fit).

Per table row paper against calibrated, which metrics come within the study's tolerance,
the objective's profile figure, and the analytic check of which published numbers
contradict each other (a second-order response with the paper's Mp, and the model-free
bound T10 <= Tp - Tr).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from twolink.simulation.metrics import step_metrics
from twolink.studies.designs.calibrate import (
    CTC_PARAMS,
    FCM_PARAMS,
    STAGES,
    SYMBOLS,
    Calibration,
    Row,
    load_calibration,
    load_result,
    pinned,
    relative_errors,
    rerun,
    result_path,
)

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
    """The objective along each parameter (others held at the optimum: one-at-a-time
    slices, not re-fitted profiles), one panel each."""
    from twolink.figures.plots import plt, save_figure

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
    fig.suptitle(
        "Calibration objective along one-at-a-time slices (others held at the fit; red: fit)"
    )
    fig.tight_layout()
    save_figure(fig, path, dpi=100)  # atomic, as every output
    return path


def summary_lines(study: Calibration, result: dict[str, Any], rows) -> list[str]:
    """Parameters with how well the tables pin them, and the per-row comparison."""
    p = result["parameters"]
    share = {}
    for ctrl in STAGES:
        share.update(pinned(study, ctrl, result["profile"][ctrl], result["objective"][ctrl]))
    words = {n: f" ({'narrow' if v <= 0.3 else 'wide'}: {v:.0%})" for n, v in share.items()}
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
        "Parameters, each with the share of its bounds where the objective stays within "
        f"0.05 of the optimum along a one-at-a-time slice (the others held at the fit): "
        f"{params}. A slice is not a profile (the others re-fitted at each value): it "
        "cannot see a ridge along which two parameters trade off, so a narrow slice does "
        "not prove that the tables pin a parameter down; a wide one does show that they "
        "leave it free.",
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
    the report's calibrated column (:func:`twolink.studies.reproduction.report.render`)."""
    if shipped is None:
        return {}
    out: dict[int, dict[str, dict[str, float]]] = {}
    for r in shipped.study.rows:
        out.setdefault(r.table, {})[r.controller] = dict(shipped.rows[_key(r)])
    return out


def report_section(
    path: Path, out: Path, shipped: Shipped | None = None, draw: Any = None
) -> list[str]:
    """The calibration's part of the report: the shipped parameters rerun here (a few
    runs; ``shipped`` if already rerun), paper / calibrated per metric, the profile figure
    and the analytic check. ``draw(function, *args)`` draws the figure (the reproduction:
    a task of its pool); default: here."""
    path = Path(path)
    shipped = shipped or rerun_shipped(path)
    head = ["", "## Calibrated against the paper", ""]
    if shipped is None:
        return [*head, f"No calibration shipped: run `twolink calibrate --install` ({path.name})."]
    study, result, current, rows = shipped.study, shipped.result, shipped.current, shipped.rows
    figure = out / "figures" / "calibration_profile.png"
    if draw is None:
        profile_figure(study, result, figure)
    else:
        draw(profile_figure, study, result, figure)
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
