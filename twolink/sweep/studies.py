"""Studies built on sweeps: the flexible-joint stiffness study's table and figure."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from twolink.simulation.vocabulary import controller_styles, metric
from twolink.sweep.figures import metric_grid, pyplot
from twolink.sweep.results import SUMMARY_METRICS, load_results, met_spec, rows_of, sweep_meta

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["flexible_study_figure", "flexible_study_table"]


def _as_results(results: pd.DataFrame | str | Path, parameter: str) -> pd.DataFrame:
    r = results if isinstance(results, pd.DataFrame) else load_results(results)
    varied = sweep_meta(r).parameters
    if parameter not in varied:
        raise ValueError(f"the sweep did not vary {parameter!r}; it varied {list(varied)}")
    return r


def _stiffness_bins(k: np.ndarray, bins: int | None) -> list[tuple[float, float]]:
    values = np.unique(k[np.isfinite(k)])
    if values.size == 0:
        return []
    if bins is None and values.size <= 20:  # a grid: one row per stiffness
        return [(v, v) for v in values]
    edges = np.geomspace(values[0], values[-1], (bins or 6) + 1)
    return list(zip(edges[:-1], edges[1:], strict=True))


def _in_bin(k: np.ndarray, lo: float, hi: float, last: bool) -> np.ndarray:
    if lo == hi:
        return k == lo
    return (k >= lo) & ((k <= hi) if last else (k < hi))


def flexible_study_table(
    results: pd.DataFrame | str | Path, parameter: str = "k", bins: int | None = None
) -> str:
    """Markdown table of the flexible-joint study: metrics by stiffness and controller.

    Parameters
    ----------
    results : DataFrame or path of a sweep's output folder
        A sweep over joint stiffness (``k``, or ``k1``/``k2``).
    parameter : str
        The stiffness column.
    bins : int, optional
        Number of log-spaced stiffness bins. Default: one row per value when there are
        at most 20 distinct values (a grid), else 6 bins.

    Returns
    -------
    str
        Rows from stiff to soft; per controller the runs, the share that met the spec
        (``twolink.simulation.outcome``) and the medians of ess, Mp and Ts of each moving joint over
        the runs that completed.
    """
    r = _as_results(results, parameter)
    meta = sweep_meta(r)
    k = r[parameter].to_numpy(float)
    head = ["stiffness [N·m/rad]", "controller", "runs", "met spec"]
    metrics = [(f"joint{j}_{m}", f"θ{j} median {metric(m).label}") for j in meta.joints
               for m in SUMMARY_METRICS]  # fmt: skip
    head += [label for _, label in metrics]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    ranges = _stiffness_bins(k, bins)
    for b, (lo, hi) in reversed(list(enumerate(ranges))):
        in_bin = _in_bin(k, lo, hi, last=b == len(ranges) - 1)
        label = f"{lo:.4g}" if lo == hi else f"{lo:.4g} – {hi:.4g}"
        for c in meta.controllers:
            rows = in_bin & rows_of(r, c)
            ok = in_bin & rows_of(r, c, ok_only=True)
            met = in_bin & met_spec(r, c)
            cells = [label, c, str(int(rows.sum()))]
            cells.append(f"{100 * met.sum() / rows.sum():.0f} %" if rows.sum() else "–")
            for col, _ in metrics:
                x = r[col].to_numpy(float)[ok]
                x = x[np.isfinite(x)]
                cells.append(f"{np.median(x):.3g}" if x.size else "–")
            lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def flexible_study_figure(
    results: pd.DataFrame | str | Path, parameter: str = "k", bins: int | None = None
) -> Figure:
    """Success rate, ess, Mp and Ts against joint stiffness, per controller.

    Each successful run is a dot; the line joins the medians per stiffness bin (as in
    :func:`flexible_study_table`). The stiffness axis is logarithmic.
    """
    plt = pyplot()
    r = _as_results(results, parameter)
    meta = sweep_meta(r)
    k = r[parameter].to_numpy(float)
    ranges = _stiffness_bins(k, bins)
    centres = np.array([math.sqrt(lo * hi) for lo, hi in ranges])
    grid = metric_grid(meta.joints)
    ncols = min(4, 1 + len(grid))
    nrows = -(-(1 + len(grid)) // ncols)
    fig, all_axes = plt.subplots(nrows, ncols, figsize=(3.4 * ncols, 3.0 * nrows),
                                 squeeze=False, layout="constrained")  # fmt: skip
    axes = all_axes.ravel()[: 1 + len(grid)]
    for ax in all_axes.ravel()[1 + len(grid) :]:
        ax.set_visible(False)
    styles = controller_styles(meta.controllers)  # each controller's colour, as everywhere
    for c in meta.controllers:
        colour = styles[c][0]
        rows, ok, met = rows_of(r, c), rows_of(r, c, ok_only=True), met_spec(r, c)
        masks = [_in_bin(k, lo, hi, b == len(ranges) - 1) for b, (lo, hi) in enumerate(ranges)]
        rate = [100 * (m & met).sum() / (m & rows).sum() if (m & rows).sum() else np.nan
                for m in masks]  # fmt: skip
        axes[0].plot(centres, rate, "o-", color=colour, label=c)
        for ax, (col, label) in zip(axes[1:], grid, strict=True):
            y = r[col].to_numpy(float)
            ax.plot(k[ok], y[ok], ".", ms=3, alpha=0.4, color=colour)
            med = []
            for m in masks:
                x = y[m & ok]
                x = x[np.isfinite(x)]
                med.append(np.median(x) if x.size else np.nan)
            ax.plot(centres, med, "-", color=colour, lw=1.5, label=c)
            ax.set_ylabel(label)
    axes[0].set_ylabel("met the spec [%]")
    axes[0].set_ylim(-5, 105)
    axes[0].legend(fontsize=8)
    for ax in axes:
        ax.set_xscale("log")
        ax.set_xlabel(f"joint stiffness {parameter} [N·m/rad]")
        ax.grid(alpha=0.3, which="both")
    fig.suptitle("Flexible joints: controllers designed on the rigid model")
    return fig
