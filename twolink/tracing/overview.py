"""The "all runs" overview of a recording of several runs: every run's angles as its own
series, named after the run, in its group's (controller's) colour family and its own
shade; each distinct reference once, grey and thinner."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from twolink.arm.params import ArmParams
from twolink.simulation.sim import Trajectory

if TYPE_CHECKING:
    pass

from twolink.tracing.runs import REFERENCE_COLOR, _path, sample_indices

# The "all runs" overview colours each run by its group (controller): each group a colour
# family, (dark, light) ends of a ramp, and each run of the group its own shade along it, so
# a family reads as one controller and its runs still tell apart. Reds and greens first, as
# in the report's figures (CTC red, FCM-CTC green); then blues, purples, browns, pinks.
GROUP_FAMILIES = (
    ((153, 0, 13), (252, 146, 114)),
    ((0, 90, 50), (116, 196, 118)),
    ((8, 48, 107), (107, 174, 214)),
    ((63, 0, 125), (188, 128, 189)),
    ((102, 51, 0), (204, 153, 102)),
    ((145, 0, 63), (241, 105, 180)),
)
# The controllers whose table colour (twolink.simulation.vocabulary.CONTROLLER_STYLES) each
# family above ramps: a controller keeps its hue here as in every figure. Another controller
# of the table gets a ramp through its own colour; a group the table does not know (a
# run's prefix, another name) the first family no group of the recording claims.
FAMILY_OF = {"CTC": 0, "FCM-CTC": 1, "PD-G": 2, "CTC-I": 3, "CTC-paper": 4, "fuzzy-PD": 5}
OVERVIEW = "all_runs"  # entity root of the overview's copies of every run's angles
RUN_WIDTH, REFERENCE_WIDTH = 1.5, 1.0  # overview line widths [ui points]: references thinner
LEGEND_ROOM = 1.4  # the overview's time axis runs to 1.4 x the runs' end: room for the legend


def overview_colors(groups: Sequence[str]) -> list[tuple[int, int, int]]:
    """The colour of each run in the "all runs" overview: its group's family, its own shade.

    A controller of the style table takes its hue's family (:data:`FAMILY_OF`, else a ramp
    through its table colour); other groups take the unclaimed families of
    :data:`GROUP_FAMILIES` in order of first appearance; the runs of one group are spread
    from the family's dark end to its light end, in order.

    Parameters
    ----------
    groups : sequence of str
        One group (e.g. the controller) per run.

    Returns
    -------
    list of (r, g, b)
    """
    from twolink.simulation.vocabulary import CONTROLLER_STYLES, STYLE_ALIASES, rgb

    ramps: dict[str, tuple[tuple[int, int, int], tuple[int, int, int]]] = {}
    unknown = []
    for g in dict.fromkeys(groups):
        name = STYLE_ALIASES.get(g, g)
        if name in FAMILY_OF:
            ramps[g] = GROUP_FAMILIES[FAMILY_OF[name]]
        elif name in CONTROLLER_STYLES:
            c = np.array(rgb(CONTROLLER_STYLES[name][0]), dtype=float)
            dark, light = np.round(0.6 * c), np.round(c + 0.5 * (255 - c))
            ramps[g] = (tuple(int(v) for v in dark), tuple(int(v) for v in light))  # type: ignore[assignment]
        else:
            unknown.append(g)
    free = [f for f in GROUP_FAMILIES if f not in ramps.values()] or list(GROUP_FAMILIES)
    for k, g in enumerate(unknown):
        ramps[g] = free[k % len(free)]
    size = {g: list(groups).count(g) for g in ramps}
    seen = dict.fromkeys(ramps, 0)
    colors = []
    for g in groups:
        dark, light = (np.array(c, dtype=float) for c in ramps[g])
        shade = seen[g] / (size[g] - 1) if size[g] > 1 else 0.0
        seen[g] += 1
        rgb = np.round(dark + shade * (light - dark)).astype(int)
        colors.append((int(rgb[0]), int(rgb[1]), int(rgb[2])))
    return colors


@dataclass(frozen=True)
class _Series:
    path: str
    joint: int
    t: np.ndarray
    values: np.ndarray
    name: str
    color: tuple[int, int, int]
    width: float


def _overview_series(
    runs: list[tuple[str, Trajectory, ArmParams, dict[str, Any]]],
    prefixes: list[str],
    titles: list[str],
    groups: list[str],
    every: int,
) -> list[_Series]:
    # Copies of every run's angles, each its own entity named after the run, in its group's
    # family and its own shade (a run's own entities keep the per-joint colours of its tab);
    # each distinct reference once, grey and thinner, under the first run that has it.
    if len(runs) < 2:
        return []
    colors = overview_colors(groups)
    curves: list[_Series] = []
    references: dict[bytes, list[Any]] = {}
    for (_, traj, _, extras), prefix, title, group, color in zip(
        runs, prefixes, titles, groups, colors, strict=True
    ):
        idx = sample_indices(len(traj.t), extras.get("every", every))
        t = traj.t[idx]
        # The group joins the name unless the name already says it (".../CTC").
        name = title if group == prefix or title.endswith(group) else f"{title} ({group})"
        for j in (1, 2):
            path = _path(OVERVIEW, f"joint{j}", prefix)
            curves.append(_Series(path, j, t, traj.q[idx, j - 1], name, color, RUN_WIDTH))
            ref = traj.q_ref[idx, j - 1]
            key = b"%d" % j + t.tobytes() + ref.tobytes()
            if key in references:  # an experiment's reference once, not per controller
                references[key][1] += 1
            else:
                references[key] = [
                    _Series(
                        f"{path}/reference", j, t, ref, title, REFERENCE_COLOR, REFERENCE_WIDTH
                    ),
                    0,
                ]
    for series, more in references.values():
        # "+3": three more runs share it (short: the legend's width is taken from the plot)
        name = f"reference of {series.name}" + (f" +{more}" if more else "")
        curves.append(replace(series, name=name))
    return curves


def _extent(series: list[_Series], joint: int) -> tuple[float, float]:
    # Lowest and highest finite value of one joint's overview curves.
    values = np.concatenate([s.values for s in series if s.joint == joint])
    values = values[np.isfinite(values)]
    return (float(values.min()), float(values.max())) if len(values) else (-1.0, 1.0)
