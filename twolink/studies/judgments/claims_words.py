"""A claims table's verdicts in words (:mod:`twolink.studies.judgments.claims`): per row what
happens
on the typical plant and on how many plants the difference matters, e.g. "equivalent on
the typical plant; worse by more than 1 mrad on 29 of 200 (10-20 %)".

The words follow the table's columns and nothing else: ``typical`` (the shift's verdict),
the shares shown (``share_*_shown``: a share above
:data:`~twolink.studies.judgments.claims.MIN_SHARE`
by its exact test) and the plants only one controller reaches (``unreached_*``)."""

from __future__ import annotations

import functools
import math
from typing import Any

import pandas as pd

__all__ = [
    "BETTER",
    "CELL_EFFECTS",
    "EQUAL",
    "EQUIVALENT",
    "NOT_JUDGED",
    "PARTLY",
    "SPLIT",
    "SPLIT_SHARE",
    "TYPICAL_WORDS",
    "UNDECIDED",
    "VERDICT_WORDS",
    "WORSE",
    "amount",
    "named_side",
    "reading",
    "row_reading",
]

BETTER, WORSE, EQUAL, EQUIVALENT = "better", "worse", "equal", "equivalent"
SPLIT, UNDECIDED, NOT_JUDGED = "split", "undecided", "not judged"
PARTLY = {BETTER: "partly better", WORSE: "partly worse"}
# A side of the plants "goes" on a typical plant judged equivalent where more than one
# plant in ten lies beyond ±δ on it (the count, not its interval: docs/statistics.md).
SPLIT_SHARE = 0.10

# The one vocabulary of verdicts: the tables, the readings, the figure and the conclusions
# say these words and no others (docs/statistics.md, "The verdict words", has the same
# table). Every row gets exactly one, by the first line that holds, in this order.
VERDICT_WORDS = {
    NOT_JUDGED: "no plant compares: none has the metric for both, none is reached by one only",
    EQUAL: "no plant differs by more than δ, and none is reached by one controller only",
    BETTER: "the typical plant's interval lies wholly below −δ; or, that interval deciding "
    "nothing, more than half the plants both ran are better by more than δ (exact test) "
    "and the estimate is not above 0",
    WORSE: "the mirror of better",
    EQUIVALENT: "the typical plant's interval lies within ±δ, and at most 10 % of the "
    "plants lie beyond δ on each side",
    PARTLY[BETTER]: "the typical plant is not better or worse, but a share of plants is "
    "better: with the typical plant equivalent, more than 10 % beyond −δ and at most 10 % "
    "beyond +δ; else the share better shown above 5 %, the share worse shown below 5 %, "
    "and the estimate not above 0",
    PARTLY[WORSE]: "the mirror of partly better",
    SPLIT: "the typical plant is not better or worse, and shares go both ways: with the "
    "typical plant equivalent, more than 10 % beyond δ on each side; else both shares "
    "shown above 5 %",
    UNDECIDED: "plants compare, but none of the above holds",
}
# The typical plant's own verdict (the column ``typical``): read off its printed interval.
TYPICAL_WORDS = {
    BETTER: "its interval lies wholly below −δ",
    WORSE: "its interval lies wholly above +δ",
    EQUIVALENT: "its interval lies wholly within ±δ",
    UNDECIDED: "its interval reaches across a margin",
    NOT_JUDGED: "fewer than half the plants both ran have the metric for both",
}
# A regime map cell's effect, from its rows' verdicts (regimes.summary).
CELL_EFFECTS = {
    "helps": "better on some metric, worse on none",
    "hurts": "worse on some metric, better on none",
    "mixed": "better on some metric and worse on another",
    "no difference shown": "better and worse on none",
}

# Display units for small amounts: (unit, below, factor, shown unit)
_SMALL = {"rad": (0.1, 1e3, "mrad"), "s": (1.0, 1e3, "ms"), "rad·s": (0.1, 1e3, "mrad·s"),
          "m": (0.1, 1e3, "mm")}  # fmt: skip


@functools.cache
def _units() -> dict[str, str]:
    from twolink.simulation.vocabulary import METRICS, TIP_METRICS

    return {m.key: m.unit for m in METRICS + TIP_METRICS}


def amount(key: str, value: float, digits: int = 3) -> str:
    """``value`` of metric ``key`` with its unit (``digits`` significant), small angles in
    mrad and times in ms."""
    known = _units()
    if key not in known:  # a metric of the caller's own: no unit known
        return f"{value:.{digits}g}"
    unit = known[key]
    if unit in _SMALL and abs(value) < _SMALL[unit][0]:
        _, factor, unit = _SMALL[unit]
        value = value * factor
    sep = "" if unit == "%" else " "
    text = f"{value:.0f}" if abs(value) >= 10**digits else f"{value:.{digits}g}"  # no 1e+02
    return f"{text}{sep}{unit}"


def _share(
    direction: str, k: int, plants: int, low: float, high: float, tol: str, alone: int = 0
) -> str:
    """'worse by more than 1 mrad on 29 of 200 (10-20 %)'; ``alone``: of the ``k``, plants
    where only one controller reaches the time (counted in the share)."""
    how = f"by more than {tol}" + (" or alone in reaching it" if alone else "")
    return f"{direction} {how} on {k} of {plants} ({100 * low:.0f}-{100 * high:.0f} %)"


def named_side(r: Any, side: str) -> bool:
    """Whether the reading names the share of plants on ``side``: shown above 5 %, or the
    side that makes the verdict partly that way or split."""
    k = getattr(r, side) + getattr(r, f"unreached_{side}")
    goes = r.verdict in (PARTLY[side], SPLIT) and r.typical == EQUIVALENT
    return bool(getattr(r, f"share_{side}_shown")) or (goes and k > SPLIT_SHARE * r.plants)


def row_reading(r: Any, proposed: str = "", opponent: str = "") -> str:
    """One row's words (``r`` a row of the table, e.g. from ``itertuples``)."""
    if r.verdict == NOT_JUDGED:
        return "no plant has it for both"
    tol = amount(r.metric, r.tolerance)
    parts = []
    if r.verdict == EQUAL:
        parts.append(f"equal on all {r.plants}: none differs by more than {tol}")
    if r.typical in (BETTER, WORSE) or (r.typical == EQUIVALENT and r.verdict != EQUAL):
        parts.append(f"{r.typical} on the typical plant")
    elif r.typical == NOT_JUDGED and r.n > 0:
        parts.append(f"the typical plant not judged: both have it on only {r.n} of {r.runs}")
    elif r.typical == UNDECIDED:
        parts.append("the typical plant undecided")
    for side in (BETTER, WORSE):
        if named_side(r, side):
            k = getattr(r, side) + getattr(r, f"unreached_{side}")
            low, high = getattr(r, f"share_{side}_low"), getattr(r, f"share_{side}_high")
            alone = getattr(r, f"unreached_{side}")
            parts.append(_share(side, k, r.plants, low, high, tol, alone))
    who = proposed or "the proposed"
    other = opponent or "the opponent"
    if r.unreached_worse:
        parts.append(f"{who} never reaches it on {r.unreached_worse} where {other} does")
    if r.unreached_better:
        parts.append(f"{other} never reaches it on {r.unreached_better} where {who} does")
    reference = getattr(r, "reference", math.nan)
    if reference == reference:  # a time on a moving reference: judged by its distance
        own = amount(r.metric, reference)
        if r.metric == "rise_time_s" and reference > 0:  # Td beside it (move_times)
            parts.append(f"judged by the distance of the rise to the move's own ({own}, Td beside)")
        else:
            parts.append(f"judged by the distance to the reference's own {own}")
    return "; ".join(parts)


def reading(table: pd.DataFrame) -> list[str]:
    """Every row's words (the table of
    :func:`~twolink.studies.judgments.claims.paired_claims_many`)."""
    names = table.get("proposed", pd.Series([""] * len(table), index=table.index))
    others = table.get("opponent", pd.Series([""] * len(table), index=table.index))
    return [
        row_reading(r, p, o)
        for r, p, o in zip(table.itertuples(index=False), names, others, strict=True)
    ]
