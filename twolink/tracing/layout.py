"""The layout (rerun blueprint) a recording carries: one tab per run, and for several
runs the "all runs" overview first; the time panel on the runs' timeline."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import rerun as rr
import rerun.blueprint as rrb

if TYPE_CHECKING:
    pass

from twolink.tracing.overview import LEGEND_ROOM, OVERVIEW
from twolink.tracing.runs import TIMELINE, _path


def _run_layout(prefix: str, title: str) -> rrb.Container:
    def series(name: str, *parts: tuple[str, ...]) -> rrb.TimeSeriesView:
        return rrb.TimeSeriesView(name=name, contents=[_path(prefix, *p) for p in parts])

    j1, j2 = "joint1", "joint2"
    plots = rrb.Vertical(
        series("θ₁ vs reference", (j1, "angle"), (j1, "reference"), (j1, "motor_angle")),
        series("θ₂ vs reference", (j2, "angle"), (j2, "reference"), (j2, "motor_angle")),
        series("errors e", (j1, "error"), (j2, "error")),
        series("error rates ė", (j1, "error_rate"), (j2, "error_rate")),
        series("torques τ", (j1, "torque"), (j2, "torque")),
    )
    log = [_path(prefix, "status")] + [_path(prefix, "phase", j, "fired_rule") for j in (j1, j2)]
    spaces = rrb.Vertical(
        rrb.Spatial2DView(
            name="phase plane: e →, ė ↓ (units on its axes)", origin=_path(prefix, "phase")
        ),
        rrb.Spatial3DView(name="arm", origin=_path(prefix, "arm")),
        rrb.TextLogView(name="status and fired rules", contents=log),
        row_shares=[3, 3, 2],  # room for the log of fired-rule changes
    )
    return rrb.Horizontal(plots, spaces, column_shares=[3, 2], name=title)


def time_panel() -> rrb.TimePanel:
    """The time panel on this module's timeline (the viewer would open on ``log_time``,
    where nothing is logged, and show empty plots)."""
    return rrb.TimePanel(timeline=TIMELINE)


def blueprint(
    prefixes: Sequence[str],
    titles: Sequence[str] | None = None,
    *,
    overview_extent: Sequence[tuple[float, float]] | None = None,
    overview_duration: float | None = None,
) -> rrb.Blueprint:
    """The ready layout for runs logged by :func:`log_run` under ``prefixes``.

    One run: time series (angles with references, errors, error rates, torques) beside
    the phase plane, the arm in 3D and the status and fired rules. Several runs: an
    overview tab overlaying every run's joint angles and references (the entities
    ``all_runs/joint{j}/P`` and ``all_runs/joint{j}/P/reference`` of each prefix ``P``,
    written by :func:`write_recording`), then one tab per run.

    Parameters
    ----------
    prefixes : sequence of str
        The runs' entity-path prefixes, as given to :func:`log_run`.
    titles : sequence of str, optional
        Tab titles, one per prefix; default the prefix.
    overview_extent : ((low, high), (low, high)), optional
        Lowest and highest value of the overview's θ1 and θ2 curves: each plot's y axis
        spans its pair with a margin, so no curve is cut off. Default: the viewer fits.
    overview_duration : float, optional
        The runs' last time [s]: the overview's time axis goes on past it, to leave the
        legend (top right) a strip without curves. Default: the viewer fits.

    Returns
    -------
    rerun.blueprint.Blueprint
    """
    prefixes = [p.strip("/") for p in prefixes]
    if not prefixes:
        raise ValueError("blueprint needs at least one prefix")
    titles = list(titles) if titles is not None else [p or "run" for p in prefixes]
    if len(titles) != len(prefixes):
        raise ValueError(f"{len(titles)} titles for {len(prefixes)} prefixes")
    if len(prefixes) == 1:
        return rrb.Blueprint(_run_layout(prefixes[0], titles[0]), time_panel())
    if overview_extent is not None and len(overview_extent) != 2:
        raise ValueError(
            f"overview_extent needs one (low, high) per joint, got {overview_extent!r}"
        )
    views = []
    for j, sub in ((1, "₁"), (2, "₂")):
        axis_y = None
        if overview_extent is not None:
            lo, hi = (float(v) for v in overview_extent[j - 1])
            margin = 0.05 * (hi - lo) or 0.1
            axis_y = rrb.ScalarAxis(range=(lo - margin, hi + margin), zoom_lock=False)
        axis_x = None
        if overview_duration is not None:
            end = rr.TimeRangeBoundary.absolute(seconds=LEGEND_ROOM * float(overview_duration))
            start = rr.TimeRangeBoundary.absolute(seconds=0.0)
            axis_x = rrb.TimeAxis(link="Independent", view_range=rr.TimeRange(start=start, end=end))
        views.append(
            rrb.TimeSeriesView(
                name=f"θ{sub} of every run (colour: controller, a shade per run; grey: references)",
                contents=[
                    _path(OVERVIEW, f"joint{j}", p, *leaf)
                    for p in prefixes
                    for leaf in ((), ("reference",))
                ],
                axis_x=axis_x,
                axis_y=axis_y,
                plot_legend=rrb.PlotLegend(corner="RightTop", visible=True),
            )
        )
    overview = rrb.Vertical(*views, name="all runs")
    tabs = [_run_layout(p, title) for p, title in zip(prefixes, titles, strict=True)]
    return rrb.Blueprint(rrb.Tabs(overview, *tabs, active_tab=0), time_panel())
