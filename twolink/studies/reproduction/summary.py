"""``summary.md``: the question, the answer in plain sentences, the answer figure, and where
each number comes from. Written from the claims tables by code (the report's first section
and the README's conclusions block), every term defined before it is used.

Verdicts are the tables' own words (``verdict`` column), counted as they come: a new word
in the tables is a new group here, not an error.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

__all__ = ["ANSWER_FIGURE", "PROFILES_FIGURE", "MAX_WORDS", "Judged", "answer", "summary"]

ANSWER_FIGURE = "figures/answer.png"
PROFILES_FIGURE = "figures/profiles.png"
MAX_WORDS = 150  # the answer's words: read in a minute


@dataclass(frozen=True)
class Judged:
    """One regime's claims: its label, plants, the proposed controller, per opponent the
    claims table's file name and the table (docs/statistics.md's columns), and the sweep's
    folder (its per-plant ``results.parquet``)."""

    label: str
    plants: int
    proposed: str
    tables: Mapping[str, tuple[str, pd.DataFrame]]
    sweep: str = ""
    name: str = ""  # the regime's short name in the answer (defined in the terms); "" label
    defined: str = ""  # what the short name means (the terms); "" the label


def _number(x: float) -> str:
    return f"{x:+.2g}" if abs(x) < 10 else f"{x:+.0f}"


def _size(rows: pd.DataFrame) -> str:
    """A verdict's size, in tolerances: its typical shift, "+1.6 to +7.7 tolerances"; rows
    inside the band say how equal instead, their intervals' largest bound, "within 0.4
    tolerance" ("exactly 0" only where every bound is 0); "" where no row has an estimate."""
    shift = (rows["estimate"] / rows["tolerance"]).to_numpy(float)
    bound = (rows[["ci_low", "ci_high"]].abs().max(axis=1) / rows["tolerance"]).to_numpy(float)
    if not np.isfinite(shift).any():
        return ""
    lo, hi = np.nanmin(shift), np.nanmax(shift)
    reach = np.nanmax(bound) if np.isfinite(bound).any() else np.inf  # none: no bound known
    if reach == 0:
        return "exactly 0"
    if np.nanmax(np.abs(shift)) <= 1 and np.isfinite(reach):  # inside the band: how far
        return f"within {reach:.2g} tolerance"
    return f"{_number(lo) if lo == hi else f'{_number(lo)} to {_number(hi)}'} tolerances"


SIZED = 2  # verdicts per clause given with their size, at most (the rest: the figure)
NOT_JUDGED = ("undefined", "set by the reference")  # counted together as "not judged"


def clause(table: pd.DataFrame, sized: int = SIZED) -> str:
    """Every verdict of a table with its count, the most frequent first ("undefined" and
    "set by the reference" together as "not judged"); the ``sized`` most frequent that
    have an estimate also with their size (:func:`_size`)."""
    words = table["verdict"].map(lambda v: v if isinstance(v, str) else "undefined")
    words = words.where(~words.isin(NOT_JUDGED), "not judged")
    groups = sorted(table.groupby(words, sort=False), key=lambda g: -len(g[1]))
    parts, done = [], 0
    for verdict, rows in groups:
        size = _size(rows) if done < sized and verdict != "not judged" else ""
        done += bool(size)
        parts.append(f"{len(rows)} {verdict}" + (f" ({size})" if size else ""))
    return ", ".join(parts[:-1]) + (" and " if len(parts) > 1 else "") + parts[-1]


def sentence(study: Judged, sized: int = SIZED) -> str:
    """One plain sentence per regime: its plants, and per opponent the verdicts of its rows
    (:func:`clause`), in the tables' order."""
    against = "; ".join(
        f"against {opp} ({len(table)} rows), {clause(table, sized)}"
        for opp, (_, table) in study.tables.items()
    )
    name = study.name or study.label
    return f"{name[:1].upper()}{name[1:]} ({study.plants} plants): {against}."


def answer(studies: Sequence[Judged]) -> list[str]:
    """The answer's sentences, one per regime in the tables' order, within
    :data:`MAX_WORDS`: each verdict's size is given for the :data:`SIZED` most frequent
    verdicts of a table, fewer where that would pass the limit (the figure has them all)."""
    for sized in range(SIZED, -1, -1):
        said = [sentence(s, sized) for s in studies]
        if sum(len(s.split()) for s in said) <= MAX_WORDS:
            break
    return said


def summary(studies: Sequence[Judged], opponents: Mapping[str, str], metrics: str) -> str:
    """summary.md: the question, its terms, the answer (at most :data:`MAX_WORDS` words,
    checked by the tests), the figures, and each number's source (file and column).
    ``opponents``: opponent -> what it is; ``metrics``: the claim's metrics in words."""
    proposed = studies[0].proposed
    lines = [
        "## The answer at a glance",
        "",
        f"**The question.** The paper claims {proposed} lowers {metrics} against its "
        f"opponents. Does it, on plants that differ from the controllers' model?",
        "",
        "**Terms.** A *row*: one joint and metric; its *tolerance*: the smallest difference "
        "that matters (docs/statistics.md). The *typical shift*: the typical plant's "
        f"{proposed} − opponent (Hodges-Lehmann), in tolerances; negative is better. "
        "*better* / *worse*: its interval (1 − 5 %/m over a table's m rows) lies beyond one "
        "tolerance; *equivalent*: within it, and at most 10 % of plants beyond it either "
        "side; *split*: within it, more beyond on a side; *inconclusive*: neither; *not "
        "judged*: no plant compares, or both take the reference's value. Brackets: the "
        "shift, or how far inside the band equal rows reach. "
        "The opponents: "
        + "; ".join(f"*{name}*, {what}" for name, what in opponents.items())
        + ". The regimes: "
        + "; ".join(f"*{s.name}*, {s.defined or s.label}" for s in studies if s.name)
        + ".",
        "",
        "**The answer.**",
        "",
        *(f"- {s}" for s in answer(studies)),
        "",
        f"![The answer: typical shift and shares per row]({ANSWER_FIGURE})",
        "",
        f"![Performance profiles of every controller]({PROFILES_FIGURE})",
        "",
        "**Where the numbers come from.** Per row, the columns `verdict`, `estimate`, "
        "`tolerance`, `ci_low`, `ci_high`, `share_better`, `share_worse` of "
        + ", ".join(
            dict.fromkeys(
                f"`{file}` ({opp})" for s in studies for opp, (file, _) in s.tables.items()
            )
        )  # fmt: skip
        + "; the plants: each sweep folder's `results.parquet` ("
        + ", ".join(f"`{s.sweep}`" for s in studies if s.sweep)
        + "), also the profiles' (Dolan & Moré 2002: the share of plants on which a "
        "controller's `joint1_<metric>` + `joint2_<metric>` is within τ times the best's).",
    ]
    return "\n".join(lines) + "\n"
