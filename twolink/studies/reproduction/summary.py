"""``summary.md``: the question, the answer in plain sentences
(:mod:`twolink.studies.judgments.plain`), the scoreboard and answer figures, the terms,
the verdicts counted, and where each number comes from. Written from the claims tables by
code (the report's first section and the README's answer block).

The verdicts counted below the terms are the tables' own words (``verdict`` column).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import pandas as pd

from twolink.studies.judgments.plain import Regime, claim_line, regime_sentences

__all__ = [
    "ANSWER_FIGURE",
    "MAX_WORDS",
    "PROFILES_FIGURE",
    "SCOREBOARD_FIGURE",
    "Judged",
    "answer",
    "summary",
]

ANSWER_FIGURE = "figures/answer.png"
PROFILES_FIGURE = "figures/profiles.png"
SCOREBOARD_FIGURE = "figures/scoreboard.png"
MAX_WORDS = 460  # the answer's words: three regimes, the baseline and the strongest each


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
    iae: Mapping[str, float] = field(default_factory=dict)  # controller -> median IAE1+IAE2
    effort: Mapping[str, pd.DataFrame] = field(default_factory=dict)  # opponent -> its rows
    ranking: pd.DataFrame | None = None  # its ranking.csv rows (the strongest opponent)

    def regime(self) -> Regime:
        """The plain words' view of this regime."""
        tables = {o: t for o, (_, t) in self.tables.items()}
        name = self.name or self.label
        return Regime(name, self.plants, self.proposed, tables, self.iae, self.effort, self.ranking)


def sentence(study: Judged) -> str:
    """The verdicts counted, per regime: its plants, and per opponent the verdict words of
    its rows (:func:`~twolink.studies.judgments.conclusions.describe`: each word counted,
    better and worse with their shifts in the metric's unit), in the tables' order."""
    from twolink.studies.judgments.conclusions import describe

    against = "; ".join(
        f"against {opp} ({len(table)} rows), {describe(table)}"
        for opp, (_, table) in study.tables.items()
    )
    name = study.name or study.label
    return f"{name[:1].upper()}{name[1:]} ({study.plants} plants): {against}."


def answer(studies: Sequence[Judged]) -> list[str]:
    """The answer's paragraphs: first whether the paper's claim holds, in a word and per
    opponent (:func:`~twolink.studies.judgments.plain.claim_line`), then one per regime, in
    the tables' order, who wins and by how much
    (:func:`~twolink.studies.judgments.plain.regime_sentences`)."""
    out = [claim_line([s.regime() for s in studies])]
    for s in studies:
        name = s.name or s.label
        head = f"**{name[:1].upper()}{name[1:]}, {s.plants} plants.**"
        out.append(" ".join([head, *regime_sentences(s.regime())]))
    return out


def terms(proposed: str, opponents: Mapping[str, str], studies: Sequence[Judged]) -> str:
    """The terms of the answer, one short sentence each."""
    return " ".join([
        "**Terms.** A *metric* is one joint's step metric (Tp, Td, Ts, Tr, Mp, ess) or effort "
        "(peak |τ|, Σ|Δτ|).",
        "Its *tolerance* is the smallest difference that matters (docs/statistics.md).",
        f"The *typical plant* is the Hodges-Lehmann shift {proposed} − opponent over the "
        "plants, with its interval.",
        "*Better on the typical plant*: the interval lies wholly beyond the tolerance.",
        "*Beats*: better on the typical plant on some step metric, worse on none.",
        "*Trade*: each is better on some step metric.",
        "*Do not differ on the typical plant*: neither is better on any step metric.",
        "*Undecided*: the interval reaches past the tolerance, or too few plants have it.",
        "*The same controller*: every plant within the tolerance on every metric.",
        "*Less effort*: better on the typical plant on a torque metric, worse on none.",
        "*Lower by more than the tolerance on k plants*: the plants where the difference "
        "matters.",
        "*IAE1 + IAE2*: the integral of |error| over both joints, per plant.",
        "The opponents: " + "; ".join(f"*{n}*, {w}" for n, w in opponents.items()) + ".",
        "The regimes: "
        + "; ".join(f"*{s.name}*, {s.defined or s.label}" for s in studies if s.name)
        + ".",
    ])  # fmt: skip


def summary(studies: Sequence[Judged], opponents: Mapping[str, str], metrics: str) -> str:
    """summary.md: the question, the answer (at most :data:`MAX_WORDS` words, checked by
    the tests), the figures, the terms, the verdicts counted, and each number's source
    (file and column). ``opponents``: opponent -> what it is; ``metrics``: the claim's
    metrics in words."""
    proposed = studies[0].proposed
    lines = [
        "## The answer at a glance",
        "",
        f"**The question.** The paper claims {proposed} lowers {metrics} against its "
        "opponents. Does it, on plants that differ from the controllers' model?",
        "",
        "**The answer.**",
        "",
        *(f"- {s}" for s in answer(studies)),
        "",
        f"![Every controller per regime: median IAE and effort per joint]({SCOREBOARD_FIGURE})",
        "",
        f"![The answer: typical shift and shares per row]({ANSWER_FIGURE})",
        "",
        f"![Performance profiles of every controller]({PROFILES_FIGURE})",
        "",
        terms(proposed, opponents, studies),
        "",
        "**The verdicts, counted.** Per table, each verdict word of docs/statistics.md with "
        "its rows. Brackets: the typical plant's shift, or the plants beyond the tolerance.",
        "",
        *(f"- {sentence(s)}" for s in studies),
        "",
        "**Where the numbers come from.** Per row, the columns `typical`, `verdict`, "
        "`estimate`, `tolerance`, `ci_low`, `ci_high`, `difference_min`, `difference_max`, "
        "`better`, `worse`, `share_better`, `share_worse` of "
        + ", ".join(
            dict.fromkeys(
                f"`{file}` ({opp})" for s in studies for opp, (file, _) in s.tables.items()
            )
        )  # fmt: skip
        + "; the effort rows against the baseline from `claims_all*.csv`"
        + "; the plants: each sweep folder's `results.parquet` ("
        + ", ".join(f"`{s.sweep}`" for s in studies if s.sweep)
        + "), also the scoreboard's medians and the profiles' (Dolan & Moré 2002: the "
        "share of plants on which a controller's `joint1_<metric>` + `joint2_<metric>` is "
        "within τ times the best's).",
    ]
    return "\n".join(lines) + "\n"
