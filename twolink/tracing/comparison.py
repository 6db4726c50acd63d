"""The reproduction's combined recording: one tab per experiment, its controllers side by
side (docs/tracing.md, "The reproduction's recording").

Each run's own ``trace.rrd`` has everything about it (both joints, phase plane with the
fired rules, the arm in 3D); the combined recording is for comparing. Per experiment
(variant and paper table) it holds, at 50 Hz, the experiment's joint under every
controller, one entity per view; each row of an entity holds one scalar per curve, and
its static ``SeriesLines`` name and colour them (the legend lists them in this order):

- ``P/angle``: θ of the proposed controller, its baseline and any other FCM variant (the
  *pair*), then of the baselines that stay on their scale, then the reference;
- ``P/error``: the pair's errors θd − θ, in a view of their own;
- ``P/difference``: each FCM variant's angle less the baseline's (FCM-CTC − CTC, ...),
  where the pair's difference shows at any size (3e-17 rad on the rigid arm's quintic
  moves, 0.1 rad on the raw steps); the view's title gives its largest value.

The tabs (:func:`order_experiments`): the experiment where the pair differ most comes
first, and the recording opens on it; then the rest of its variant, in the given order,
then the other variants, the one whose pair differ most first (the raw steps, in the
reproduction: within reach without scrolling the tab bar). Each controller has its one
colour, the figures' (:data:`twolink.simulation.vocabulary.CONTROLLER_STYLES`).

A baseline that leaves the pair's scale (fuzzy-PD's swings would flatten every other
curve) is left out, named in the angle view's title; torques are left out too (each
run's ``trace.rrd`` has both). Every view fits its y axis to its curves. A run cut short
is NaN past its end (its curve ends there); the runs of an experiment share one time
grid. The same split as the response figures
(:func:`twolink.simulation.vocabulary.split_by_scale`).

Light for the viewer: the web viewer ingests what arrives for about 10 ms per frame and
shows the layout only once all of it is in, and without a GPU a frame takes most of a
second; every view costs five chunks (three of the layout, two of the recording), so
an experiment has three views, each one entity in two chunks (its legend, then its
curves), the first tab's right after the layout, and the layout sets nothing the viewer
does by itself (no y ranges, no time panel). Earlier versions wrote each curve as an entity
of its own (``P/angle/CTC``); :func:`read_comparison` names its columns that way.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from twolink.foundation.io import atomic_path
from twolink.simulation.sim import Trajectory
from twolink.simulation.vocabulary import controller_styles, rgb, split_by_scale
from twolink.tracing.files import _read_curves, recording_id
from twolink.tracing.runs import REFERENCE_COLOR, _time_column, sample_indices

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "COMPARISON_EVERY",
    "ExperimentRuns",
    "order_experiments",
    "pair_difference",
    "read_comparison",
    "write_comparison",
]

COMPARISON_EVERY = 20  # 50 Hz of the 1 kHz loop: smooth at any zoom a screen shows


@dataclass(frozen=True)
class ExperimentRuns:
    """One experiment of the reproduction: its entity prefix (``rigid/table2``), tab
    title, the joint it judges (1 or 2), and each controller's trajectory."""

    prefix: str
    title: str
    joint: int
    runs: Mapping[str, Trajectory]


def _view(name: str, origin: str) -> rrb.TimeSeriesView:
    # The legend in a corner the curves leave free once settled. No y range: the viewer
    # fits each view to its curves, and every blueprint setting is one more chunk to load.
    return rrb.TimeSeriesView(
        name=name, origin=origin, plot_legend=rrb.PlotLegend(corner="RightBottom", visible=True)
    )


@dataclass(frozen=True)
class _Plot:
    """One view's entity: its curves (full-rate arrays), their legend names and colours,
    in the legend's order (the viewer draws the last on top)."""

    entity: str
    names: list[str]
    colours: list[tuple[int, int, int]]
    values: list[np.ndarray]


def _plots(
    e: ExperimentRuns, pair: Sequence[str], colours: Mapping[str, tuple[int, int, int]]
) -> tuple[Trajectory, list[tuple[_Plot, str]]]:
    """The experiment's longest run (its time grid and reference), and its views, each
    one's entity with the view's title: ``angle`` (the pair, the FCM variants, the
    baselines on their scale and the reference), ``error`` (the pair's and the
    variants') and, where the baseline ran, ``difference`` (each variant less it, titled
    with the first one's largest |difference|: the pair's). A baseline that leaves the
    pair's scale is named in the angle view's title and left out (each run's
    ``trace.rrd`` has it, and the response figures give it a panel of its own)."""
    j = e.joint - 1
    longest = max(e.runs.values(), key=lambda tr: len(tr.t))
    angles = {n: tr.q[:, j] for n, tr in e.runs.items()}
    pair_like, near, far, _ = split_by_scale(angles, longest.q_ref[:, j], pair)
    # the legend lists the curves in this order (the pair first: a view too short for
    # its legend cuts the last entries), and the viewer draws them in it
    order = _pair_first(pair)
    close = sorted(pair_like + near, key=order)
    pair_like = sorted(pair_like, key=order)
    far = sorted(far, key=order)

    def plot(leaf: str, names: list[str], values: list[np.ndarray], reference: bool) -> _Plot:
        if reference:
            names, values = [*names, "reference"], [*values, longest.q_ref[:, j]]
        paint = [REFERENCE_COLOR if n == "reference" else colours[n] for n in names]
        return _Plot(f"{e.prefix}/{leaf}", names, paint, values)

    errors = [e.runs[n].q_ref[:, j] - e.runs[n].q[:, j] for n in pair_like]
    base = pair[1] if len(pair) > 1 else None
    variants = [n for n in pair_like if base in e.runs and n != base]
    diffs = [_difference(e.runs[n], e.runs[base], j) for n in variants]
    sub = "₁₂"[j]
    title = f"θ{sub} [rad]: {', '.join(pair_like)} and the baselines on their scale"
    if far:
        title += f" ({', '.join(far)} {'leaves' if len(far) == 1 else 'leave'} it: not shown)"
    views = [
        (plot("angle", close, [angles[n] for n in close], True), title),
        (plot("error", pair_like, errors, False), f"error θ{sub}d − θ{sub} [rad]"),
    ]
    if variants:
        largest = pair_difference(e, (variants[0], base))
        names = [f"{n} − {base}" for n in variants]
        paint = [colours[n] for n in variants]
        views.append((
            _Plot(f"{e.prefix}/difference", names, paint, diffs),
            f"difference θ{sub} [rad]: largest |{variants[0]} − {base}| {largest:.2g} rad",
        ))  # fmt: skip
    return longest, views


def _difference(a: Trajectory, b: Trajectory, j: int) -> np.ndarray:
    """``a``'s angle less ``b``'s over the samples both have (NaN past the shorter)."""
    n = min(len(a.t), len(b.t))
    out = np.full(max(len(a.t), len(b.t)), np.nan)
    out[:n] = a.q[:n, j] - b.q[:n, j]
    return out


def pair_difference(e: ExperimentRuns, pair: Sequence[str] = ("FCM-CTC", "CTC")) -> float:
    """The largest ``|θ_pair[0] − θ_pair[1]|`` [rad] of the experiment's joint over the
    samples both runs have (0 where either is missing; NaN samples skipped)."""
    if len(pair) < 2 or not all(n in e.runs for n in pair[:2]):
        return 0.0
    d = np.abs(_difference(e.runs[pair[0]], e.runs[pair[1]], e.joint - 1))
    return float(np.nanmax(d)) if np.isfinite(d).any() else 0.0


def order_experiments(
    experiments: Sequence[ExperimentRuns], pair: Sequence[str] = ("FCM-CTC", "CTC")
) -> list[ExperimentRuns]:
    """The tabs' order: the variants (a prefix's first part) by their largest pair
    difference (:func:`pair_difference`), largest first; within a variant the experiment
    where the pair differ most first, then the others as given. Ties keep the given
    order, so experiments where the pair never differ stay as they came."""
    groups: dict[str, list[ExperimentRuns]] = {}
    for e in experiments:
        groups.setdefault(e.prefix.split("/")[0], []).append(e)
    size = {e.prefix: pair_difference(e, pair) for e in experiments}
    out = []
    for members in sorted(groups.values(), key=lambda g: -max(size[e.prefix] for e in g)):
        top = max(members, key=lambda e: size[e.prefix])  # the first of the largest
        out += [top, *(e for e in members if e is not top)]
    return out


def _grid(e: ExperimentRuns, longest: Trajectory, every: int) -> np.ndarray:
    """The experiment's kept samples: every ``every``-th of the longest run and the last
    of each run (a run cut short ends where it stopped). The runs share one time grid."""
    for name, tr in e.runs.items():
        if not np.array_equal(tr.t, longest.t[: len(tr.t)]):
            raise ValueError(
                f"{e.prefix}: run {name!r} is not on the experiment's time grid (its "
                "runs must share their time step and start)"
            )
    ends = [len(tr.t) - 1 for tr in e.runs.values() if len(tr.t)]
    return np.union1d(sample_indices(len(longest.t), every), ends).astype(int)


def _columns(values: list[np.ndarray], idx: np.ndarray) -> np.ndarray:
    """``(len(idx), len(values))`` scalars: each series at the kept samples, NaN past its
    end (a run cut short: the viewer ends its curve there)."""
    out = np.full((len(idx), len(values)), np.nan)
    for k, v in enumerate(values):
        have = idx < len(v)
        out[have, k] = v[idx[have]]
    return out


def write_comparison(
    path: str | os.PathLike,
    experiments: Sequence[ExperimentRuns],
    pair: Sequence[str] = ("FCM-CTC", "CTC"),
    every: int = COMPARISON_EVERY,
) -> Path:
    """Write the combined recording of ``experiments`` to ``path`` atomically (see the
    module's docstring; the tabs in :func:`order_experiments`' order, the first open);
    ``pair`` names the proposed controller and its baseline."""
    if not experiments:
        raise ValueError("write_comparison needs at least one experiment")
    experiments = order_experiments(experiments, pair)
    names = sorted({n for e in experiments for n in e.runs}, key=_pair_first(pair))
    colours = {n: rgb(c) for n, (c, _) in controller_styles(names).items()}
    ids = [(f"{e.prefix}/{n}", t, None, {}) for e in experiments for n, t in e.runs.items()]
    rec = rr.RecordingStream("twolink", recording_id=recording_id("twolink-comparison", ids))
    if not rec.is_enabled():
        raise RuntimeError("rerun logging is disabled (RERUN=off?); no recording written")
    tabs = []
    logs = []
    for e in experiments:
        longest, views = _plots(e, pair, colours)
        idx = _grid(e, longest, every)
        logs += [(plot, longest.t[idx], _columns(plot.values, idx)) for plot, _ in views]
        tabs.append(rrb.Vertical(*(_view(t, p.entity) for p, t in views), name=e.title))
    # no time panel setting: "time" is the file's only timeline, so the viewer opens on it
    # (setting it makes the viewer warn "Timeline 'time' not found" until the data is in)
    layout = rrb.Blueprint(rrb.Tabs(*tabs, active_tab=0))
    path = Path(path)
    with atomic_path(path, suffix=".rrd") as tmp:
        try:
            rec.save(tmp, default_blueprint=layout)
            for plot, t, scalars in logs:
                # the legend's names and colours first, then the curves: sent in this
                # order (not batched), the first tab's entities come right after the layout
                style = rr.SeriesLines.columns(names=plot.names, colors=plot.colours)
                rec.send_columns(plot.entity, [], style.partition([len(plot.names)]))
                rec.send_columns(
                    plot.entity,
                    indexes=[_time_column(t)],
                    columns=rr.Scalars.columns(scalars=scalars),
                )
            rec.flush()
        finally:
            rec.disconnect()
    return path


def read_comparison(path: str | os.PathLike) -> pd.DataFrame:
    """The combined recording's curves, one column per curve, indexed by ``time_s``.

    A column is named by its view's entity and the curve's legend name:
    ``rigid/table2/angle/CTC``, ``rigid/table2/angle/reference``,
    ``rigid/table2/error/FCM-CTC``; a run cut short is NaN past its end, as is every
    curve where another experiment has samples and its own has none.
    (:func:`twolink.tracing.read_recording` reads this file the same way.)

    Parameters
    ----------
    path : path-like
        A ``.rrd`` file written by :func:`write_comparison`.

    Returns
    -------
    pandas.DataFrame
    """
    from rerun.chunk import RrdReader

    return _read_curves(RrdReader(path).store())


def _pair_first(pair: Sequence[str]):
    order = {n: k for k, n in enumerate(pair)}
    return lambda n: (order.get(n, len(pair) + (0 if n.startswith("FCM") else 1)), n)
