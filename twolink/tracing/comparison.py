"""The reproduction's combined recording: one tab per experiment, its controllers side by
side (docs/tracing.md, "The reproduction's recording").

Each run's own ``trace.rrd`` has everything about it (both joints, phase plane with the
fired rules, the arm in 3D); the combined recording is for comparing. Per experiment
(variant and paper table) it holds, at 50 Hz, the experiment's joint under every
controller:

- ``P/angle/<controller>`` and ``P/angle/reference``: θ of the proposed controller, its
  baseline and any other FCM variant (the *pair*), and of the baselines that stay on
  their scale, on a y axis fitted to them;
- ``P/error/<controller>``: the pair's errors θd − θ, on their own fitted axis (where a
  1e-5 rad difference shows);
- ``P/torque/<controller>``: the pair's torques;
- ``P/baselines/<controller>`` (and its reference): the baselines that leave the pair's
  scale (fuzzy-PD's swings would flatten every other curve), in a view of their own.

The same split as the response figures (:func:`twolink.simulation.vocabulary.split_by_scale`).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from twolink.interface.io import atomic_path
from twolink.simulation.sim import Trajectory
from twolink.simulation.vocabulary import split_by_scale
from twolink.tracing.files import recording_id
from twolink.tracing.layout import time_panel
from twolink.tracing.runs import REFERENCE_COLOR, _time_column, sample_indices

__all__ = ["COMPARISON_EVERY", "ExperimentRuns", "write_comparison"]

COMPARISON_EVERY = 20  # 50 Hz of the 1 kHz loop: smooth at any zoom a screen shows
# Controller colours, as in the report's figures: the pair first (green, red, teal), then
# the baselines.
PALETTE = (
    (44, 160, 44),
    (214, 39, 40),
    (23, 190, 207),
    (31, 119, 180),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
)


@dataclass(frozen=True)
class ExperimentRuns:
    """One experiment of the reproduction: its entity prefix (``rigid/table2``), tab
    title, the joint it judges (1 or 2), and each controller's trajectory."""

    prefix: str
    title: str
    joint: int
    runs: Mapping[str, Trajectory]


def _view(name: str, origin: str, y: tuple[float, float]) -> rrb.TimeSeriesView:
    # the legend in a corner the curves leave free once settled
    return rrb.TimeSeriesView(
        name=name,
        origin=origin,
        axis_y=rrb.ScalarAxis(range=y, zoom_lock=False),
        plot_legend=rrb.PlotLegend(corner="RightBottom", visible=True),
    )


def _range(values: list[np.ndarray]) -> tuple[float, float]:
    finite = np.concatenate([v[np.isfinite(v)] for v in values])
    if not finite.size:
        return -1.0, 1.0
    lo, hi = float(finite.min()), float(finite.max())
    pad = 0.08 * (hi - lo) or 1e-6
    return lo - pad, hi + pad


def write_comparison(
    path: str | os.PathLike,
    experiments: Sequence[ExperimentRuns],
    pair: Sequence[str] = ("FCM-CTC", "CTC"),
    every: int = COMPARISON_EVERY,
) -> Path:
    """Write the combined recording of ``experiments`` to ``path`` atomically (see the
    module's docstring); ``pair`` names the proposed controller and its baseline."""
    if not experiments:
        raise ValueError("write_comparison needs at least one experiment")
    names = sorted({n for e in experiments for n in e.runs}, key=_pair_first(pair))
    colours = {n: PALETTE[k % len(PALETTE)] for k, n in enumerate(names)}
    ids = [(f"{e.prefix}/{n}", t, None, {}) for e in experiments for n, t in e.runs.items()]
    rec = rr.RecordingStream("twolink", recording_id=recording_id("twolink-comparison", ids))
    if not rec.is_enabled():
        raise RuntimeError("rerun logging is disabled (RERUN=off?); no recording written")
    tabs = []
    logs = []
    for e in experiments:
        j = e.joint - 1
        first = next(iter(e.runs.values()))
        angles = {n: tr.q[:, j] for n, tr in e.runs.items()}
        pair_like, near, far, scale = split_by_scale(angles, first.q_ref[:, j], pair)
        close = pair_like + near
        series = [(f"{e.prefix}/angle/reference", first.t, first.q_ref[:, j], "reference")]
        for n in close:
            series.append((f"{e.prefix}/angle/{n}", e.runs[n].t, angles[n], n))
        errors = {n: e.runs[n].q_ref[:, j] - e.runs[n].q[:, j] for n in pair_like}
        torques = {n: e.runs[n].tau[:, j] for n in pair_like}
        series += [(f"{e.prefix}/error/{n}", e.runs[n].t, v, n) for n, v in errors.items()]
        series += [(f"{e.prefix}/torque/{n}", e.runs[n].t, v, n) for n, v in torques.items()]
        if far:
            series.append(
                (f"{e.prefix}/baselines/reference", first.t, first.q_ref[:, j], "reference")
            )
            series += [(f"{e.prefix}/baselines/{n}", e.runs[n].t, angles[n], n) for n in far]
        logs += series
        sub = "₁₂"[j]

        views = [
            _view(f"θ{sub} [rad]: {', '.join(pair_like)} and the baselines on their scale",
                 f"{e.prefix}/angle", scale),
            _view(f"error θ{sub}d − θ{sub} [rad]", f"{e.prefix}/error",
                 _range(list(errors.values()))),
            _view(f"torque τ{sub} [N·m]", f"{e.prefix}/torque", _range(list(torques.values()))),
        ]  # fmt: skip
        if far:
            views.append(
                _view(
                    f"θ{sub} [rad] of the baselines that leave that scale ({', '.join(far)})",
                    f"{e.prefix}/baselines",
                    _range([first.q_ref[:, j], *(angles[n] for n in far)]),
                )
            )
        tabs.append(rrb.Vertical(*views, name=e.title))
    layout = rrb.Blueprint(rrb.Tabs(*tabs, active_tab=0), time_panel())
    path = Path(path)
    with atomic_path(path, suffix=".rrd") as tmp:
        try:
            rec.save(tmp, default_blueprint=layout)
            for entity, t, values, name in logs:
                idx = sample_indices(len(t), every)  # a run cut short has fewer samples
                colour = REFERENCE_COLOR if name == "reference" else colours[name]
                rec.log(entity, rr.SeriesLines(names=name, colors=[colour]), static=True)
                rec.send_columns(
                    entity,
                    indexes=[_time_column(t[idx])],
                    columns=rr.Scalars.columns(scalars=values[idx]),
                )
            rec.flush()
        finally:
            rec.disconnect()
    return path


def _pair_first(pair: Sequence[str]):
    order = {n: k for k, n in enumerate(pair)}
    return lambda n: (order.get(n, len(pair) + (0 if n.startswith("FCM") else 1)), n)
