"""The README's first figure: the experiment where the paper's pair differ most.

The reproduction draws one response figure per experiment and variant
(``figures/<variant>_<experiment>.png``). On the rigid arm's quintic moves FCM-CTC and CTC
coincide (3e-17 rad: the fuzzy term never acts), so a newcomer shown one of those sees
no difference. :func:`hero` picks the experiment whose pair differ most, the largest
``|θ_proposed − θ_baseline|`` of its judged joint over the samples both runs have, ties
to the first in report order; the reproduction draws it again as :data:`HERO_FIGURE`,
titled with that difference, and ``docs/images/`` keeps a copy for the README.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

__all__ = ["HERO_FIGURE", "hero", "pair_gap", "shortfall"]

SETTLED = 0.02  # a final error within 2 % of the move is on target (the outcome's band)

HERO_FIGURE = "figures/where_the_pair_differ.png"


def pair_gap(a: Any, b: Any, joint: int) -> float:
    """The largest ``|θa − θb|`` of ``joint`` (1 or 2) over the samples both trajectories
    have, NaN samples skipped; 0 where there are none."""
    n = min(len(a.t), len(b.t))
    d = np.abs(a.q[:n, joint - 1] - b.q[:n, joint - 1])
    return float(np.nanmax(d)) if np.isfinite(d).any() else 0.0


def shortfall(traj: Any, joint: int) -> float:
    """How far ``joint`` ends short of its target, in rad: target − θ at the end, signed
    along the move (positive: short, negative: past it); 0 where it ends within
    :data:`SETTLED` of the move."""
    j = joint - 1
    move = traj.q_ref[-1, j] - traj.q[0, j]  # from its start: a raw step's q_ref starts there
    error = float((traj.q_ref[-1, j] - traj.q[-1, j]) * np.sign(move))
    return error if abs(error) > SETTLED * abs(move) else 0.0


def shortfall_line(runs: Mapping[str, Any], joint: int, uncertain: bool) -> str:
    """The title's line where both controllers end short of the target, with why where the
    plant differs from the controllers' model; "" where either reaches it."""
    short = {name: shortfall(t, joint) for name, t in runs.items()}
    if not all(v > 0 for v in short.values()):
        return ""
    target = next(iter(runs.values())).q_ref[-1, joint - 1]
    said = " and ".join(f"{n} {v:.2g}" for n, v in short.items())
    why = " (model error, no integral action)" if uncertain else ""
    return f"\nboth end short of {target:.2g} rad: {said} rad{why}"


def hero(
    specs: Sequence[Any], trajectories: Mapping[str, Any], pair: tuple[str, str]
) -> tuple[dict[str, str], int, str] | None:
    """The hero figure's runs (controller → folder), joint and title, from the
    reproduction's ``specs`` and their ``trajectories`` (by folder); None where no
    experiment runs both controllers of ``pair``."""
    best = None
    groups: dict[tuple[int, int], list[Any]] = {}
    for sp in specs:
        groups.setdefault((id(sp.variant), id(sp.experiment)), []).append(sp)
    for members in groups.values():
        by_name = {sp.controller: sp for sp in members}
        if not all(n in by_name for n in pair):
            continue
        a, b = (trajectories[by_name[n].folder] for n in pair)
        exp = members[0].experiment
        gap = pair_gap(a, b, exp.joint)
        if best is None or gap > best[0]:
            best = (gap, members)
    if best is None:
        return None
    gap, members = best
    exp, variant = members[0].experiment, members[0].variant
    by_name = {sp.controller: trajectories[sp.folder] for sp in members}
    uncertain = "uncertain" in str(getattr(exp, "scenario", ""))
    title = (
        f"Where {pair[0]} and {pair[1]} differ most: largest |Δθ{exp.joint}| {gap:.2g} rad\n"
        f"{exp.label}: {exp.title.split(' (')[0]}\n({variant.title})"
        + shortfall_line({n: by_name[n] for n in pair}, exp.joint, uncertain)
    )
    return {sp.controller: sp.folder for sp in members}, exp.joint, title
