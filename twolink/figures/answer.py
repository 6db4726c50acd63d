"""The answer at a glance: the paper's claim as a forest plot, and the performance profiles.

Drawn from the claims tables' columns (docs/statistics.md: ``estimate``, ``ci_low``,
``ci_high``, ``tolerance``, ``share_better``/``share_worse`` with ``_low``/``_high``,
``verdict``) and the sweeps' per-plant tables, never recomputed. Verdict words are read
from the tables, not from a fixed list.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter

from twolink.simulation.vocabulary import controller_styles, metric

__all__ = ["answer_figure", "profiles_figure"]

OFFSET = 0.36  # the opponents' rows of one joint and metric, spread over this height
BAND_COLOUR = "0.88"  # the ±tolerance band
FEW = "not judged"  # the ``typical`` of a row whose typical plant is of too few plants
FEW_NOTE = "hollow, pale: the typical plant not judged (fewer than half the plants compare)"


def _row_label(joint: int, key: str) -> str:
    return f"θ{joint} {metric(key).symbol}"


def answer_figure(
    studies: Sequence[tuple[str, Mapping[str, pd.DataFrame]]], proposed: str, question: str = ""
) -> Figure:
    """Per study (its label, and opponent -> claims table) one row of panels: left, each
    joint and metric's typical shift (Hodges-Lehmann estimate, ``proposed`` − opponent)
    with its printed interval (at 1 − 5 %/m over a table's m rows), in tolerances, against
    the ±1 tolerance band; middle, the shares of plants practically better (left) and
    worse (right) with their intervals; right, each opponent's verdict, the table's word.
    A row whose typical plant is not judged (``typical`` "not judged": fewer than half the
    plants both ran compare) is drawn hollow and pale, its word in italics."""
    rows = max(len(_rows(tables)) for _, tables in studies)
    fig, axes = plt.subplots(
        len(studies), 3, figsize=(8.2, 1.15 + len(studies) * (0.62 + 0.27 * rows)),
        gridspec_kw={"width_ratios": (3.2, 2.2, 1.6)}, squeeze=False,
    )  # fmt: skip
    names = [n for _, tables in studies for n in tables]
    styles = controller_styles(list(dict.fromkeys(names)))
    for (label, tables), (shift, shares, words) in zip(studies, axes, strict=True):
        _study_row(label, tables, styles, shift, shares, words, proposed)
    handles = [
        plt.Line2D([], [], color=styles[n][0], marker="o", ls="-", label=f"{proposed} − {n}")
        for n in dict.fromkeys(names)
    ]
    handles.append(plt.Line2D([], [], color="0.4", marker="o", mfc="none", ls="-", alpha=0.5,
                              label=FEW_NOTE))  # fmt: skip
    fig.legend(handles=handles, loc="upper center", ncol=min(len(handles), 4), frameon=False,
               fontsize=8, bbox_to_anchor=(0.5, 1 - 0.32 / fig.get_figheight()))  # fmt: skip
    if question:
        fig.suptitle(question, fontsize=10, y=1 - 0.05 / fig.get_figheight(), va="top")
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.62 / fig.get_figheight()))
    return fig


def _rows(tables: Mapping[str, pd.DataFrame]) -> list[tuple[int, str]]:
    """Every (joint, metric) of the tables, in the order they first appear (an opponent
    may be judged on more rows: CTC-best on the effort too)."""
    keys: dict[tuple[int, str], None] = {}
    for table in tables.values():
        keys.update(dict.fromkeys(zip(table["joint"], table["metric"], strict=True)))
    return list(keys)


def _study_row(label, tables, styles, shift, shares, words, proposed) -> None:
    keys = _rows(tables)
    y0 = np.arange(len(keys))[::-1].astype(float)
    shift.axvspan(-1, 1, color=BAND_COLOUR, zorder=0)
    shift.axvline(0, color="0.5", lw=0.8)
    k = len(tables)
    for i, (name, table) in enumerate(tables.items()):
        colour = styles[name][0]
        t = table.set_index(["joint", "metric"]).reindex(keys)
        y = y0 + (OFFSET / 2 - i * OFFSET / max(k - 1, 1) if k > 1 else 0.0)
        tol = t["tolerance"].to_numpy(float)
        est, lo, hi = (t[c].to_numpy(float) / tol for c in ("estimate", "ci_low", "ci_high"))
        few = (t["typical"] == FEW).to_numpy() if "typical" in t else np.zeros(len(t), bool)
        for mask, face, alpha in ((~few, colour, 1.0), (few, "none", 0.45)):
            e, a, b = est[mask], lo[mask], hi[mask]
            shift.errorbar(e, y[mask], xerr=[e - a, b - e], fmt="o", ms=4, color=colour,
                           mfc=face, lw=1.4, alpha=alpha)  # fmt: skip
        for sign, col in ((-1, "share_better"), (1, "share_worse")):
            s = t[col].to_numpy(float)
            err = [s - t[f"{col}_low"].to_numpy(float), t[f"{col}_high"].to_numpy(float) - s]
            for mask, alpha in ((~few, 0.75), (few, 0.25)):
                shares.barh(y[mask], sign * s[mask], height=OFFSET / k * 1.6, color=colour,
                            alpha=alpha)  # fmt: skip
            shares.errorbar(sign * s, y, xerr=err, fmt="none", ecolor="0.2", lw=0.8)
        for yy, verdict, pale in zip(y, t["verdict"], few, strict=True):
            if isinstance(verdict, str):  # no row: the opponent is not judged on it
                look = {"style": "italic", "alpha": 0.6} if pale else {}
                words.text(0.02, yy, verdict, color=colour, va="center", fontsize=7.5, **look)
    shift.set_xscale("symlog", linthresh=1, linscale=1.5)
    reach = max(1.0, *np.abs(shift.get_xlim()))  # ticks at ±1, ±10, ... within the data
    ticks = [s * 10**e for e in range(int(np.log10(reach)) + 1) for s in (-1, 1)] + [0]
    shift.set_xticks(ticks, [f"{t:+g}" if t else "0" for t in ticks])
    shift.set_yticks(y0, [_row_label(j, m) for j, m in keys], fontsize=8)
    shift.set_title(f"{label}\ntypical plant's shift, in tolerances", fontsize=9, loc="left")
    band = "grey: within ±1 tolerance"
    shift.set_xlabel(f"← {proposed} lower (better)   {band}   higher →", fontsize=7)
    shares.axvline(0, color="0.3", lw=0.8)
    shares.set_xlim(-1.05, 1.05)
    shares.set_xticks([-1, -0.5, 0, 0.5, 1], ["100 %", "50", "0", "50", "100 %"], fontsize=7)
    shares.set_yticks(y0, [])
    shares.set_title("share of plants practically\n← better | worse →", fontsize=9)
    words.set_axis_off()
    words.set_title("verdict\n(the table's)", fontsize=9, loc="left")
    for ax in (shift, shares, words):
        ax.set_ylim(-0.7, len(keys) - 0.3)
        ax.tick_params(axis="x", labelsize=7)
        ax.grid(axis="x", alpha=0.3)


def _two_and_five(v: float, _: Any) -> str:
    """Minor log ticks labelled at 2 and 5 of each decade: a profile may span less than one."""
    lead = v / 10 ** np.floor(np.log10(v)) if v > 0 else 0
    return f"{v:g}" if np.isclose(lead, 2) or np.isclose(lead, 5) else ""


def profiles_figure(profiles: Sequence[tuple[str, pd.DataFrame]], styles: Any = None) -> Figure:
    """One panel per (title, ρ table of :func:`twolink.studies.reproduction.profiles.
    performance_profile`): each controller's share of plants within τ of the best."""
    cols = min(len(profiles), 2)
    rows = -(-len(profiles) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(8.2, 2.9 * rows), squeeze=False)
    names = list(dict.fromkeys(n for _, rho in profiles for n in rho.columns))
    styles = styles or controller_styles(names)
    for ax, (title, rho) in zip(axes.flat, profiles, strict=False):
        for name in rho.columns:
            colour, dash = styles[name]
            ax.step(rho.index, rho[name], where="post", color=colour, ls=dash, lw=1.5, label=name)
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))  # 2, not 2 × 10⁰
        ax.xaxis.set_minor_formatter(FuncFormatter(_two_and_five))
        ax.set_ylim(-0.02, 1.02)
        ax.set_title(title, fontsize=9, loc="left")
        ax.set_xlabel("τ: within τ × the best controller's cost on that plant", fontsize=8)
        ax.set_ylabel("share of plants", fontsize=8)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(profiles) :]:
        ax.set_axis_off()
    axes.flat[0].legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    return fig
