"""The scoreboard: every controller of each regime on one page, ranked.

Per regime one row of panels, one per joint and column of the scoreboard table
(:func:`twolink.studies.reproduction.profiles.scoreboard`: tracking IAE, effort peak |τ|
and Σ|Δτ|): each controller's median over the plants with its interval; the lowest
median of a panel filled and named where its interval is clear of every other's.
Controllers run down each row in the table's order (the lowest median IAE1 + IAE2 per
plant on top). Every controller of the sweep is drawn, the tuned laws included; one whose
effort is over the proposed controller's (``ranking.csv``'s ``within``) is named
"(over effort)" beside its name. Drawn from the tables, never recomputed.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from twolink.simulation.vocabulary import controller_styles, metric

__all__ = ["OVER", "best_in", "scoreboard_figure"]


def best_in(panel: pd.DataFrame) -> str | None:
    """The controller with the lowest median of one panel (joint and metric), where its
    interval lies wholly below every other's; None where another's interval reaches it
    (no clear best), where its interval is unknown, or where every median is NaN."""
    finite = panel[np.isfinite(panel["median"].to_numpy(float))]
    if finite.empty:
        return None
    k = finite["median"].idxmin()
    others = finite.drop(index=k)
    high = finite.loc[k, "high"]
    if not np.isfinite(high) or (others["low"].to_numpy(float) <= high).any():
        return None
    return str(finite.loc[k, "controller"])


OVER = " (over effort)"  # beside a controller whose effort is over the proposed one's


def scoreboard_figure(
    regimes: Sequence[tuple[str, pd.DataFrame]],
    title: str = "",
    over: Mapping[str, Collection[str]] | None = None,
) -> Figure:
    """One row of panels per (label, scoreboard table); ``over``: label -> the controllers
    whose effort is over the proposed controller's there (named :data:`OVER`)."""
    keys = list(dict.fromkeys(k for _, t in regimes for k in t["metric"]))
    columns = [(k, j) for k in keys for j in (1, 2)]
    n = max(t["controller"].nunique() for _, t in regimes)
    size = (2.0 * len(columns) + 1.2, 0.9 + (0.6 + 0.28 * n) * len(regimes))
    fig, axes = plt.subplots(len(regimes), len(columns), figsize=size, squeeze=False)
    names = list(dict.fromkeys(c for _, t in regimes for c in t["controller"]))
    styles = controller_styles(names)
    for (label, table), row in zip(regimes, axes, strict=True):
        order = list(dict.fromkeys(table["controller"]))
        y = np.arange(len(order))[::-1].astype(float)
        for c, ((key, joint), ax) in enumerate(zip(columns, row, strict=True)):
            panel = table[(table["metric"] == key) & (table["joint"] == joint)]
            panel = panel.set_index("controller").reindex(order).reset_index()
            best = best_in(panel)
            for yy, r in zip(y, panel.itertuples(), strict=True):
                colour = styles[r.controller][0]
                lo, hi = r.median - r.low, r.high - r.median
                err = None if np.isnan(lo) else [[lo], [hi]]
                ax.errorbar(r.median, yy, xerr=err, fmt="o", ms=5, color=colour, lw=1.4,
                            mfc=colour if r.controller == best else "white")  # fmt: skip
            m = metric(key)
            ax.set_title(
                f"θ{joint} {m.symbol} [{m.unit}]\nbest: {best or 'none clear'}", fontsize=8
            )
            spends = (over or {}).get(label, ())
            names = [f"{n}{OVER}" if n in spends else n for n in order]
            ax.set_yticks(y, names if c == 0 else [], fontsize=8)
            ax.set_ylim(-0.6, len(order) - 0.4)
            ax.tick_params(axis="x", labelsize=7)
            ax.grid(axis="x", alpha=0.3)
        leader = order[0] if order else "—"
        row[0].set_ylabel(f"{label}\nlowest IAE1 + IAE2: {leader}", fontsize=9)
    fig.text(0.5, 0.004, "median over the plants, with its 95 % order-statistic interval; "
             "filled (best): lowest, its interval clear of every other's; top of a row: the "
             "lowest median IAE1 + IAE2 per plant",
             ha="center", va="bottom", fontsize=8)  # fmt: skip
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    return fig
