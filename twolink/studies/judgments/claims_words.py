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
    "CELL_EFFECTS",
    "SET_BY_REFERENCE",
    "SPLIT",
    "SPLIT_SHARE",
    "VERDICT_WORDS",
    "amount",
    "reading",
    "row_reading",
]

SET_BY_REFERENCE = "set by the reference"
SPLIT = "split"
# "equivalent" says that at most one plant in ten lies practically beyond ±δ on either
# side (the count, not its interval: docs/statistics.md); more is a split.
SPLIT_SHARE = 0.10

# The one vocabulary of verdicts: tables, readings and conclusions say these words and
# no others (docs/statistics.md, "The verdict words", has the same list).
VERDICT_WORDS = {
    "better": "the typical plant's shift lies below −δ (its printed interval wholly "
    "below), or, the typical plant undecided, a share of plants practically better is "
    "shown above 5 %, the share worse shown below it, and the estimate not above 0",
    "worse": "the mirror of better",
    "equivalent": "the typical plant's interval lies within ±δ and at most 10 % of the "
    "plants lie beyond ±δ on either side",
    SPLIT: "the typical plant's interval lies within ±δ but more than 10 % of the plants "
    "lie beyond ±δ on a side: the reading names them",
    "inconclusive": "none of the above",
    SET_BY_REFERENCE: "both controllers take the reference's own value on the typical plant",
    "undefined": "no plant compares",
}
# A regime map cell's effect, from its rows' verdicts (regimes.summary).
CELL_EFFECTS = {
    "helps": "better on some metric, worse on none",
    "hurts": "worse on some metric, better on none",
    "mixed": "better on some metric and worse on another",
    "no difference shown": "better and worse on none",
}

# Display units for small amounts: (unit, below, factor, shown unit)
_SMALL = {"rad": (0.1, 1e3, "mrad"), "s": (1.0, 1e3, "ms"), "rad·s": (0.1, 1e3, "mrad·s")}


@functools.cache
def _units() -> dict[str, str]:
    from twolink.simulation.vocabulary import METRICS

    return {m.key: m.unit for m in METRICS}


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


def row_reading(r: Any, proposed: str = "", opponent: str = "") -> str:
    """One row's words (``r`` a row of the table, e.g. from ``itertuples``)."""
    if r.verdict == "undefined":
        return "no plant has it for both"
    if r.verdict == "set by the reference":
        return "set by the reference: both take the move's own value on the typical plant"
    tol = amount(r.metric, r.tolerance)
    parts = []
    if r.typical in ("better", "worse", "equivalent"):
        parts.append(f"{r.typical} on the typical plant")
    elif r.n > 0 and 2 * r.n < getattr(r, "runs", r.n):
        parts.append(f"the typical plant not judged: both have it on only {r.n} of {r.runs}")
    elif r.n > 0:
        parts.append("the typical plant undecided")
    for side in ("better", "worse"):
        named = r.verdict == SPLIT and getattr(r, side) + getattr(r, f"unreached_{side}") > (
            SPLIT_SHARE * r.plants
        )
        if getattr(r, f"share_{side}_shown") or named:
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
        parts.append(f"judged by the distance to the reference's own {amount(r.metric, reference)}")
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
