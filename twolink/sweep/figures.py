"""Figures of a sweep's results table: metric distributions, success rates, and every
metric against every swept parameter (matplotlib, headless)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from twolink.simulation.vocabulary import controller_styles, metric
from twolink.sweep.results import SUMMARY_METRICS, rows_of, summarize, sweep_meta

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["save_sweep_plots", "sweep_figures"]


def pyplot() -> Any:
    # Through twolink.figures.plots, which selects the headless Agg backend before pyplot loads.
    from twolink.figures import plots

    return plots.plt


def metric_grid(joints: tuple[int, ...]) -> list[tuple[str, str]]:
    """(column, axis label) of the summarised metrics of each moving joint."""
    return [(f"joint{j}_{m}", f"θ{j} {metric(m).label}") for j in joints
            for m in SUMMARY_METRICS]  # fmt: skip


def sweep_figures(results: pd.DataFrame) -> dict[str, Figure]:
    """Histograms and box plots of ess, Mp, Ts per controller, success rates, and
    every metric against every swept parameter."""
    plt = pyplot()
    meta = sweep_meta(results)
    controllers = list(meta.controllers)
    grid = metric_grid(meta.joints)
    figs: dict[str, Figure] = {}
    colours = {c: colour for c, (colour, _) in controller_styles(controllers).items()}

    def column(name: str) -> np.ndarray:
        return results[name].to_numpy(float)

    def finite(name: str, controller: str) -> np.ndarray:
        x = column(name)[rows_of(results, controller, ok_only=True)]
        return x[np.isfinite(x)]

    n = max(len(grid), 1)
    fig, axes = plt.subplots(n, 2, figsize=(11, 2.6 * n), squeeze=False, layout="constrained")
    for row, (col, label) in enumerate(grid):
        data = {c: finite(col, c) for c in controllers}
        every = np.concatenate([*data.values(), np.zeros(0)])
        bins = np.histogram_bin_edges(every, bins=30) if every.size else 10
        hist, box = axes[row]
        for c, x in data.items():
            hist.hist(x, bins=bins, alpha=0.5, color=colours[c], label=c)
        hist.set_xlabel(label)
        hist.set_ylabel("runs")
        hist.legend(fontsize=8)
        shown = [c for c, x in data.items() if x.size]
        if shown:
            box.boxplot([data[c] for c in shown])
            box.set_xticks(range(1, len(shown) + 1), shown)
        box.set_ylabel(label)
        for ax in (hist, box):
            ax.grid(alpha=0.3)
    fig.suptitle("Sweep metrics over the runs that completed (met spec or off target)")
    figs["metrics"] = fig

    summary = summarize(results)
    fig, ax = plt.subplots(figsize=(1.5 + 1.2 * len(controllers), 3.5), layout="constrained")
    rates = [100 * summary[c]["success_rate"] for c in controllers]
    ax.bar(controllers, rates, color=[colours[c] for c in controllers])
    for k, r in enumerate(rates):
        ax.annotate(f"{r:.1f} %", (k, r), ha="center", va="bottom", fontsize=8)
    ax.set_ylim(0, 110)
    ax.set_ylabel("met the spec [%]")
    ax.set_title("Runs that met the spec")
    figs["success_rate"] = fig

    if meta.parameters:
        np_ = len(meta.parameters)
        fig, axes = plt.subplots(
            n, np_, figsize=(3.2 * np_ + 1, 2.4 * n), squeeze=False, layout="constrained"
        )
        for row, (col, label) in enumerate(grid):
            for k, p in enumerate(meta.parameters):
                ax = axes[row][k]
                for c in controllers:
                    ok = rows_of(results, c, ok_only=True)
                    ax.plot(column(p)[ok], column(col)[ok], ".", ms=3,
                            color=colours[c], alpha=0.6, label=c)  # fmt: skip
                x = column(p)
                # Log axis for values spread over decades (a loguniform stiffness), not for
                # a uniform draw that merely starts near zero.
                if x.size and np.all(x > 0) and x.max() > 10 * np.median(x):
                    ax.set_xscale("log")
                if row == n - 1:
                    ax.set_xlabel(p)
                if k == 0:
                    ax.set_ylabel(label)
                ax.grid(alpha=0.3)
        axes[0][0].legend(fontsize=8)
        fig.suptitle("Metrics against the drawn parameters (runs that completed)")
        figs["metric_vs_parameter"] = fig
    return figs


def save_sweep_plots(out: str | Path, results: pd.DataFrame) -> list[Path]:
    """Write the :func:`sweep_figures` as PNG files under ``out/plots``."""
    from twolink.figures.plots import save_figure

    paths = []
    for name, fig in sweep_figures(results).items():
        path = Path(out) / "plots" / f"{name}.png"
        save_figure(fig, path)
        paths.append(path)
    return paths
