"""The regime map (``twolink regimes``): where the paper's fuzzy term acts, and where it
helps or hurts, against CTC and CTC with integral action.

One sweep file (``runs/sweeps/regimes.toml``: a grid of bandwidth ωn x mass mismatch x
tip payload, 100 plants per cell) runs twice: as written (2 s quintic moves) and with the
paper's raw steps (:func:`twolink.studies.judgments.claims_studies.raw_steps`). Per cell, the share
of
samples where the fuzzy term acts (``fuzzy_active_share``, mean over plants and joints)
and the paired verdicts of FCM-CTC, and of the continuous inference of its rules
(FCM-CTC-continuous, our extension: docs/fuzzy.md, "The relay")
(:func:`twolink.studies.judgments.claims.paired_claims_many`, all cells at once: the verdict rule
of docs/statistics.md, Holm across each cell's table) against each opponent on Ts to the target,
max|e| of both joints, IAE, peak torque and oscillation (docs/reproduction.md, "The
regime map").
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from twolink.foundation.shipped import runs_dir

__all__ = [
    "CELL",
    "FRICTION_AXIS",
    "OPPONENTS",
    "REGIME_METRICS",
    "cell_axes",
    "regime_table",
    "run_regimes",
    "summary",
]

DEFAULT_STUDY = runs_dir() / "sweeps" / "regimes.toml"  # package data
CELL = ("wn", "mass", "payload")
# The optional friction axis: a study that grids friction_level (both joints' Coulomb
# friction as a fraction of their holding torque, docs/sweeps.md) has it in its cells.
FRICTION_AXIS = "friction_level"
# The paper's FCM-CTC and our continuous inference of the same rules
PROPOSED = ("FCM-CTC", "FCM-CTC-continuous")
OPPONENTS = ("CTC", "CTC-I")
REGIME_METRICS = (
    "settling_time_target_s",
    "max_error_rad",
    "iae_rad_s",
    "torque_peak_Nm",
    "oscillation_rad",
)
REGIMES = ("quintic", "raw steps")


def run_regimes(
    study: Path = DEFAULT_STUDY,
    out: Path = Path("results/regimes"),
    samples: int | None = None,
    pool: Any = None,
    progress: bool = True,
    backend: str = "cpu",
) -> dict[str, pd.DataFrame]:
    """Run the study in both regimes into ``out/<regime>``; their results tables.
    ``backend``: run_sweep's (the CPU engine, or MJX)."""
    from twolink import sweep
    from twolink.simulation.config import read_toml
    from twolink.studies.judgments.claims_studies import raw_steps

    raw = {"reference": raw_steps(read_toml(study).get("reference", {})), "name": "regimes_raw"}
    sweeps = []
    for regime, overrides in zip(REGIMES, ({}, raw), strict=True):
        if samples is not None:
            overrides = {**overrides, "samples": samples}
        sweeps.append((sweep.load_sweep(study, overrides), out / regime.replace(" ", "_")))
    # both regimes on one pool at once: no worker waits for the first to end
    outcomes = sweep.run_sweeps(
        sweeps, pool=pool, plots=False, progress=progress, replace_other=True, backend=backend
    )
    return {regime: outcome.results for regime, outcome in zip(REGIMES, outcomes, strict=True)}


def cell_axes(frame: pd.DataFrame) -> tuple[str, ...]:
    """The axes of a map's cells: :data:`CELL`, and the friction axis where swept."""
    return (*CELL, FRICTION_AXIS) if FRICTION_AXIS in frame.columns else CELL


def regime_table(results: dict[str, pd.DataFrame]) -> pd.DataFrame:
    """One row per (regime, cell, proposed, opponent, joint, metric): the proposed
    controller's paired statistics against the opponent on the cell's plants, and the
    share of samples where its fuzzy term acts. A proposed controller the study does not
    run is left out. Every cell's table in one pass
    (:func:`twolink.studies.judgments.claims.paired_claims_many`)."""
    from twolink.studies.judgments.claims import paired_claims_many

    regimes = list(results)
    frame = pd.concat(
        [
            r.assign(regime=pd.Categorical([g] * len(r), categories=regimes))
            for g, r in results.items()
        ],
        ignore_index=True,
    )
    ran = set(frame["controller"])
    pairs = [(p, o) for p in PROPOSED if p in ran for o in OPPONENTS]
    by = ["regime", *cell_axes(frame)]
    table = paired_claims_many(frame, pairs, REGIME_METRICS, (1, 2), by)
    active = ["joint1_fuzzy_active_share", "joint2_fuzzy_active_share"]
    fuzzy = frame[frame["controller"].isin(PROPOSED)]
    values = fuzzy[active].to_numpy(float)
    share = {  # per cell and proposed controller, over its runs in the table's order
        key: float(np.nanmean(np.asfortranarray(values[rows])))  # pandas stores columns
        for key, rows in fuzzy.groupby([*by, "controller"], observed=True).indices.items()
    }
    keys = zip(*(table[c] for c in [*by, "proposed"]), strict=True)
    table["fuzzy_active_share"] = [share[tuple(k)] for k in keys]
    table["regime"] = table["regime"].astype(str)
    first = [*by, "proposed", "opponent", "fuzzy_active_share", "joint", "metric"]
    return table[first + [c for c in table.columns if c not in first]]


def _effect(verdicts: pd.Series) -> str:
    """The cell's effect, one of :data:`~twolink.studies.judgments.claims_words.CELL_EFFECTS`."""
    better, worse = (verdicts == "better").sum(), (verdicts == "worse").sum()
    effect = {(True, False): "helps", (False, True): "hurts", (True, True): "mixed"}
    return effect.get((bool(better), bool(worse)), "no difference shown")


def summary(table: pd.DataFrame) -> pd.DataFrame:
    """One row per (regime, cell, proposed, opponent): the fuzzy term's share, the
    proposed controller's metrics judged better and worse, the metrics that show no
    verdict but a share of plants practically better or worse (``better_share``,
    ``worse_share``: "θ2 osc 29/100"), and the effect of the verdicts: ``helps`` (better
    on some, worse on none), ``hurts`` (the reverse), ``mixed``, or ``no difference
    shown``."""
    keys = ["regime", *cell_axes(table), "proposed", "opponent"]
    groups: dict[tuple, list[dict]] = {}  # one pass over plain rows (pandas' per-group
    for r in table.to_dict("records"):  # itertuples took seconds on the regime map)
        groups.setdefault(tuple(r[k] for k in keys), []).append(r)
    rows = []
    for key, t in groups.items():
        named = [(r["verdict"], f"θ{r['joint']} {_symbol(r['metric'])}") for r in t]
        better = [name for verdict, name in named if verdict == "better"]
        worse = [name for verdict, name in named if verdict == "worse"]
        shares = {}
        for side in ("better", "worse"):
            shown = f"share_{side}_shown"
            mine = [r for r in t if r.get(shown) and r["verdict"] not in ("better", "worse")]
            shares[f"{side}_share"] = ", ".join(
                f"θ{r['joint']} {_symbol(r['metric'])} "
                f"{r[side] + r[f'unreached_{side}']}/{r['plants']}"
                for r in mine
            )
        rows.append(
            {
                **dict(zip(keys, key, strict=True)),
                "fuzzy_active_share": float(t[0]["fuzzy_active_share"]),
                "plants": int(max(r["n"] for r in t)),
                "better": ", ".join(better),
                "worse": ", ".join(worse),
                **shares,
                "effect": _effect(pd.Series([r["verdict"] for r in t])),
            }
        )
    return pd.DataFrame(rows)


def _cell(text: str) -> str:
    """A markdown table cell: "—" for none, a literal "|" (max|e|) escaped."""
    return text.replace("|", "\\|") if text else "—"


def _symbol(key: str) -> str:
    from twolink.simulation.vocabulary import metric

    return metric(key).symbol


def markdown(summ: pd.DataFrame) -> list[str]:
    """The regime map as markdown: per regime, proposed controller and opponent, the
    cells where it helps and hurts, then every cell's line."""
    out = ["# The regime map: where the FCM term acts, helps and hurts", ""]
    friction = FRICTION_AXIS in summ.columns
    groups = summ.groupby(["regime", "proposed", "opponent"], sort=False)
    for (regime, proposed, opponent), t in groups:
        counts = t["effect"].value_counts()
        out += [
            f"## {regime}, {proposed} against {opponent}",
            "",
            f"Cells: {len(t)}; helps in {counts.get('helps', 0)}, hurts in "
            f"{counts.get('hurts', 0)}, mixed in {counts.get('mixed', 0)}, no difference "
            f"shown in {counts.get('no difference shown', 0)}. The fuzzy term acts on "
            f"{100 * t['fuzzy_active_share'].min():.0f}-{100 * t['fuzzy_active_share'].max():.0f} "
            "% of samples.",
            "",
            "Better / worse: the verdicts; on a share: no verdict, but a share of plants",
            "practically better / worse shown above 5 % (plants of the cell; docs/statistics.md).",
            "",
            "| ωn [rad/s] | mass × | payload [kg] | "
            + ("F_c [% of G] | " if friction else "")
            + "fuzzy on | plants | effect | better | worse "
            "| better on a share | worse on a share |",
            "|---|---|---|---|---|---|---|---|---|---|" + ("---|" if friction else ""),
        ]
        for r in t.itertuples():
            level = f"{100 * getattr(r, FRICTION_AXIS):g} | " if friction else ""
            out.append(
                f"| {r.wn:g} | {r.mass:g} | {r.payload:g} | {level}"
                f"{100 * r.fuzzy_active_share:.1f} % "
                f"| {r.plants} | {r.effect} | {_cell(r.better)} | {_cell(r.worse)} "
                f"| {_cell(getattr(r, 'better_share', ''))} "
                f"| {_cell(getattr(r, 'worse_share', ''))} |"
            )
        out.append("")
    return out


def figure(summ: pd.DataFrame) -> Any:
    """Heatmaps, one per regime and proposed controller: the fuzzy term's share of samples
    per cell (rows ωn, columns mass x payload), each cell marked with its effect against
    CTC."""
    from twolink.figures.plots import fixed_layout, plt

    regimes = list(dict.fromkeys(summ["regime"]))
    proposed_names = list(dict.fromkeys(summ["proposed"]))
    rows, cols = len(regimes), len(proposed_names)  # a row per regime, a column per variant
    fig, axes = plt.subplots(rows, cols, figsize=(5.5 * cols, 4.0 * rows), squeeze=False)
    fixed_layout(fig, left=0.08, right=0.88, top=0.92, bottom=0.1, wspace=0.3, hspace=0.5)
    panels = [(r, p) for r in regimes for p in proposed_names]
    marks = {"helps": "+", "hurts": "−", "mixed": "±", "no difference shown": ""}
    image = None
    for ax, (regime, proposed) in zip(axes.ravel(), panels, strict=True):
        mine = (summ["regime"] == regime) & (summ["proposed"] == proposed)
        t = summ[mine & (summ["opponent"] == OPPONENTS[0])]
        wns = sorted(set(t["wn"]))
        level = t[FRICTION_AXIS] if FRICTION_AXIS in t.columns else [0.0] * len(t)
        cols = sorted(set(zip(t["mass"], t["payload"], level, strict=True)))
        grid = np.full((len(wns), len(cols)), np.nan)
        for r, f in zip(t.itertuples(), level, strict=True):
            i, j = wns.index(r.wn), cols.index((r.mass, r.payload, f))
            grid[i, j] = 100 * r.fuzzy_active_share
            colour = "white" if grid[i, j] < 25 else "black"  # readable on viridis
            ax.text(j, i, marks[r.effect], ha="center", va="center", fontsize=12, color=colour)
        image = ax.imshow(grid, origin="lower", aspect="auto", cmap="viridis", vmin=0, vmax=50)
        names = [f"m×{m:g}\n+{p:g} kg" + (f"\nF {100 * f:g}%" if f else "") for m, p, f in cols]
        ax.set_xticks(range(len(cols)), names, fontsize=7)
        ax.set_yticks(range(len(wns)), [f"{w:g}" for w in wns])
        ax.set_ylabel("ωn [rad/s]")
        ax.set_title(
            f"{regime}, {proposed}: fuzzy term on [% of samples]\n+ helps, − hurts vs CTC",
            fontsize=9,
        )
    if image is not None:
        fig.colorbar(image, ax=list(axes.ravel()), fraction=0.03)
    return fig
