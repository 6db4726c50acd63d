"""The report's conclusions in short sentences: which law wins where, by how much in the
metric's own unit, on how many plants, at what effort. At most :data:`MOST` items, written
from the tables and nothing else, in the plain words of
:mod:`twolink.studies.judgments.plain` ("beats": better on the typical plant on some
metric, worse on none):

- per plant variant, the paper's own experiments: whether the proposed controller equals
  the baseline (no metric beyond its tolerance), how often it is lower or higher, how many
  met the spec, and for whom the loop linearised at the target is unstable;
- per claims study (its regime), who wins between the proposed controller and each
  distinct opponent of the study (an opponent that is another by construction, as
  CTC-matched is CTC on smooth moves, is said once, with the alias), with the plants
  each met the spec on;
- where the proposed controller makes a limit cycle its baseline does not, and on how
  many plants;
- whether the controller with integral action beats the proposed controller and every
  opponent (on the typical plant);
- on the lab arm (friction and a disturbance), who beats whom among the proposed
  controller, the baseline, the integral one and the opponents;
- per regime with a ranking (``ranking.csv``), which law wins there: the strongest
  opponent within the proposed controller's effort, its index and who wins against it,
  and against the lowest one that spends more, at its effort (:func:`ranking_conclusion`).

The opponents are whatever the study names (:class:`ClaimsStudy`), so the sentences keep
working when a stronger linear opponent replaces CTC-matched.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from typing import Any

import pandas as pd

__all__ = [
    "MOST",
    "ClaimsStudy",
    "lab_sentence",
    "ranking_conclusion",
    "limit_cycle_sentence",
    "search_sentence",
    "study_sentence",
    "variant_sentence",
]

LISTED = 3  # better or worse rows named in a clause; beyond, counted and the largest named
MOST = 12  # items: one per plant variant, the claims', the lab arm's, the ranking's, the search's


@dataclasses.dataclass(frozen=True)
class ClaimsStudy:
    """One claims study's tables, as the report shows them.

    Attributes
    ----------
    label : str
        Its regime in words ("quintic moves", "the paper's raw steps at ωn = 3 rad/s").
    plants : int
    met : mapping
        Controller -> plants on which it met the spec.
    proposed, baseline : str
    claims : mapping
        Opponent -> the paper's claim judged against it (``paired_claims``), in order; an
        opponent in ``same_as`` is not judged again.
    same_as : mapping
        Opponent -> the opponent it is on these plants (CTC-matched -> CTC on smooth moves).
    every : DataFrame
        ``paired_claims_many`` rows of every pair the report compares on its winner
        metrics (each other controller against the baseline, the integral one against
        the proposed and the opponents).
    integral : str or None
        The controller with integral action, if the study runs one.
    lab : bool
        The lab arm's study (friction and a disturbance): said in its own sentence
        (:func:`lab_sentence`), apart from the claim's regimes.
    tuned : mapping
        Tuned law -> the proposed controller against it (``claims_tuned*.csv``'s rows,
        effort included), in the ranking's words (:func:`tuned_sentence`).
    ranking : DataFrame or None
        The regime's ``ranking.csv`` rows (index, effort, within, rank), or None.
    """

    label: str
    plants: int
    met: Mapping[str, int]
    proposed: str
    baseline: str
    claims: Mapping[str, pd.DataFrame]
    same_as: Mapping[str, str]
    every: pd.DataFrame
    integral: str | None = None
    lab: bool = False
    tuned: Mapping[str, pd.DataFrame] = dataclasses.field(default_factory=dict)
    ranking: pd.DataFrame | None = None


def _name(r: Any) -> str:
    from twolink.simulation.vocabulary import metric

    return f"θ{r.joint} {metric(r.metric).symbol}"


def _signed(key: str, value: float) -> str:
    from twolink.studies.judgments.claims_words import amount

    return ("+" if value > 0 else "") + amount(key, value, 2).replace("-", "−")


def _rows(table: pd.DataFrame, verdict: str) -> list[Any]:
    return [r for r in table.itertuples() if r.verdict == verdict]


def _typical(table: pd.DataFrame, side: str) -> list[Any]:
    """The rows better (or worse) on the typical plant: their interval beyond the tolerance."""
    return [r for r in table.itertuples() if r.typical == side]


def _count(r: Any, side: str) -> int:
    return getattr(r, side) + getattr(r, f"unreached_{side}")


def _shares_said(r: Any) -> list[str]:
    """'θ2 Tr better on 33 of 200' for each share the reading names (shown, or the side
    that makes a row partly one way or split): plants beyond the row's tolerance that way
    (its size is the table's; "better" here is a plant's difference, not a verdict)."""
    from twolink.studies.judgments.claims_words import named_side

    said = []
    for side in ("better", "worse"):
        if named_side(r, side):
            alone = " or alone in reaching it" if getattr(r, f"unreached_{side}") else ""
            said.append(f"{_name(r)} {side}{alone} on {_count(r, side)} of {r.plants}")
    return said


def _sized(r: Any) -> str:
    return f"{_name(r)} ({_signed(r.metric, r.estimate)})"


def describe(table: pd.DataFrame) -> str:
    """A claims table in one clause, in the verdict words of the table
    (:data:`~twolink.studies.judgments.claims_words.VERDICT_WORDS`): better and worse with
    their estimates (over :data:`LISTED` rows: counted, the largest in tolerances named);
    partly better, partly worse and split with the plants beyond the tolerance; equal and
    equivalent counted (equivalent with the shares shown beside it); undecided counted
    and named (its shares are the table's); not judged counted. Short on purpose: the
    tables hold the intervals and shares."""
    from twolink.studies.judgments.claims_words import (
        EQUAL,
        NOT_JUDGED,
        PARTLY,
        SPLIT,
        UNDECIDED,
    )

    parts = []
    for verdict in ("better", "worse"):
        rows = _rows(table, verdict)
        if len(rows) > LISTED:  # counted, and the largest (in tolerances) named
            rows = sorted(rows, key=lambda r: -abs(r.estimate) / r.tolerance)
            named = ", ".join(_sized(r) for r in rows[:LISTED])
            parts.append(f"{verdict} on {len(rows)}, the largest {named}")
        elif rows:
            parts.append(f"{verdict} on {', '.join(_sized(r) for r in rows)}")
    for verdict in (PARTLY["better"], PARTLY["worse"], SPLIT):
        rows = _rows(table, verdict)
        if rows:  # a share of the plants beyond the tolerance, the typical plant not
            shares = ", ".join(x for r in rows for x in _shares_said(r))
            parts.append(f"{verdict} on {len(rows)} ({shares} beyond the tolerance)")
    equal = _rows(table, EQUAL)
    if equal:
        parts.append(f"{EQUAL} on {len(equal)}")
    equivalent = _rows(table, "equivalent")
    if equivalent:
        shares = [x for r in equivalent for x in _shares_said(r)]
        more = f", but {', '.join(shares)} beyond the tolerance" if shares else ""
        parts.append(f"equivalent on {len(equivalent)}{more}")
    undecided = _rows(table, UNDECIDED)
    if undecided:
        parts.append(f"{UNDECIDED} on {len(undecided)} ({', '.join(_name(r) for r in undecided)})")
    not_judged = len(_rows(table, NOT_JUDGED))
    if not_judged:
        parts.append(f"{not_judged} {NOT_JUDGED}")
    return "; ".join(parts) or "nothing judged"


def study_sentence(study: ClaimsStudy, first: bool = True) -> str:
    """Who wins on a study's plants between the proposed controller and each distinct
    opponent (:func:`~twolink.studies.judgments.plain.pair_sentences`), with the plants
    each met the spec on; ``first`` names the claim."""
    from twolink.studies.judgments.plain import pair_sentences

    p = study.proposed
    said = []
    for opponent, table in study.claims.items():
        if opponent in study.same_as:
            continue
        alias = [a for a, b in study.same_as.items() if b == opponent]
        name = f"{opponent} (= {', '.join(alias)} here)" if alias else opponent
        said += pair_sentences(table, p, name, study.plants)
    met = ", ".join(
        f"{n} {study.met.get(n, 0)}"
        for n in dict.fromkeys([p, *(o for o in study.claims if o not in study.same_as)])
    )
    claim = f" ({p} lowers Tp, Td, Ts, Tr, Mp, ess)" if first else ""
    return (
        f"**The paper's claim{claim} on {study.label}, {study.plants} plants.** Met the "
        f"spec: {met}. " + " ".join(said)
    )


def _pair(every: pd.DataFrame, proposed: str, opponent: str) -> pd.DataFrame:
    mine = (every["proposed"] == proposed) & (every["opponent"] == opponent)
    return every[mine]


def limit_cycle_sentence(studies: Sequence[ClaimsStudy]) -> str | None:
    """Where the proposed controller oscillates more than its baseline beyond the
    tolerance (a verdict or a share shown), on how many plants, by up to how much."""
    from twolink.studies.judgments.claims_words import amount

    if not studies:
        return None
    p, b = studies[0].proposed, studies[0].baseline
    found, tol = [], None
    for s in studies:
        rows = _pair(s.every, s.proposed, s.baseline)
        said = []
        for r in rows[rows["metric"] == "oscillation_rad"].itertuples():
            tol = amount(r.metric, r.tolerance)
            if r.worse and (r.share_worse_shown or r.verdict == "worse"):  # not noise
                said.append(
                    f"θ{r.joint} on {r.worse} of {r.n} plants "
                    f"({100 * r.share_worse_low:.0f}-{100 * r.share_worse_high:.0f} %, up to "
                    f"{amount(r.metric, r.difference_max)} more)"
                )
        if said:
            found.append(f"on {s.label}: " + ", ".join(said))
    if tol is None:
        return None
    if not found:
        return f"**Limit cycles:** {p} oscillates no more than {b} (by {tol}) on any plant."
    return f"**Limit cycles:** {p} oscillates more than {b} by over {tol} " + "; ".join(found) + "."


def _names(names: Sequence[str]) -> str:
    return ", ".join(names[:-1]) + f" and {names[-1]}" if len(names) > 1 else names[0]


def integral_sentence(studies: Sequence[ClaimsStudy]) -> str | None:
    """Which of the proposed controller and the opponents the controller with integral
    action beats (better on some metrics, worse on none) and which not, per study: how
    many metrics better and worse of how many, the largest gain against the proposed
    controller."""
    name = next((s.integral for s in studies if s.integral), None)
    if name is None:
        return None
    parts = []
    for s in studies:
        if s.integral is None:
            continue
        against = [s.proposed] + [o for o in s.claims if o not in s.same_as]
        counts, beaten, not_beaten = [], [], []
        for other in against:
            t = _pair(s.every, s.integral, other)
            better, worse = _typical(t, "better"), _typical(t, "worse")
            (beaten if better and not worse else not_beaten).append(other)
            counts.append(f"{other} {len(better)}/{len(worse)}")
        t = _pair(s.every, s.integral, s.proposed)
        best = min(_typical(t, "better"), key=lambda r: r.estimate / r.tolerance, default=None)
        largest = f"; e.g. {_name(best)} {_signed(best.metric, best.estimate)}" if best else ""
        if not not_beaten:
            verb = f"beats {_names(beaten)}"
        elif not beaten:
            verb = f"beats none of {_names(not_beaten)}"
        else:
            verb = f"beats {_names(beaten)} but not {_names(not_beaten)}"
        parts.append(
            f"{verb} on {s.label} (metrics better/worse on the typical plant, of {len(t)}: "
            f"{', '.join(counts)}{largest} against {s.proposed})"
        )
    return f"**Integral action:** {name} " + "; it ".join(parts) + "."


def lab_sentence(study: ClaimsStudy) -> str:
    """The lab arm: for each pair its tables judge with the proposed controller on one side
    (against the baseline, the opponents, the integral one), who wins on the winner
    metrics, in :func:`~twolink.studies.judgments.plain.pair_sentences`' words (its
    rules: "beats" on the typical plant, the size in the metric's unit, the plants)."""
    from twolink.studies.judgments.plain import pair_sentences

    named = {study.proposed, study.baseline, study.integral, *study.claims}
    said = []
    for (a, b), t in study.every.groupby(["proposed", "opponent"], sort=False):
        if a not in named or b not in named or study.proposed not in (a, b):
            continue  # the others among themselves are the tables', not the claim's
        said += pair_sentences(t, a, b, study.plants, what="metrics")
    label = study.label[0].upper() + study.label[1:]
    return f"**{label}, {study.plants} plants.** " + " ".join(said)


def ranking_conclusion(studies: Sequence[ClaimsStudy]) -> str | None:
    """Which law wins where, per study with a ranking, in
    :mod:`twolink.studies.judgments.plain`'s words: the three lowest indices and the
    proposed controller's place; the strongest opponent within its effort, those lower
    that spend more, and who wins against it and against the lowest that spends more (on
    how many metrics, at what effort). None where no study has a ranking."""
    from twolink.studies.judgments.plain import (
        Regime,
        over_budget,
        ranking_sentence,
        strongest_sentences,
    )

    parts = []
    for s in studies:
        if s.ranking is None:
            continue
        tables = {**s.claims, **s.tuned}
        effort = {s.baseline: _pair(s.every, s.proposed, s.baseline)}
        regime = Regime(s.label, s.plants, s.proposed, tables, ranking=s.ranking, effort=effort)
        # the three lowest, who the strongest is and who wins: the sizes are the answer's
        said = [ranking_sentence(regime), *strongest_sentences(regime, indices=False)[:2]]
        over = over_budget(regime)
        if len(over):
            said += strongest_sentences(regime, str(over.iloc[0]["controller"]))[:1]
        label = s.label[0].upper() + s.label[1:]
        parts.append(f"*{label}.* " + " ".join(said))
    if not parts:
        return None
    head = "**Which law wins where** (`ranking.csv`, `claims_tuned*.csv`)."
    return " ".join([head, *parts])


def variant_sentence(
    title: str,
    experiments: int,
    counts: Mapping[str, tuple[int, ...]],
    met: Mapping[str, int],
    unstable: Mapping[str, int | None],
    proposed: str,
    baseline: str,
    largest: tuple[str, float, str] | None = None,
) -> str:
    """The paper's own experiments in one plant variant: ``counts`` (metric -> lower,
    higher, of n, ...), ``met`` (controller -> experiments that met the spec),
    ``unstable`` (controller -> experiments whose loop, linearised at the target, is
    unstable; None where it was not linearised) and the ``largest`` difference beyond
    its tolerance (metric, proposed − baseline, experiment)."""
    from twolink.simulation.vocabulary import metric

    p, b = proposed, baseline
    lower = sum(c[0] for c in counts.values())
    higher = sum(c[1] for c in counts.values())
    total = sum(c[2] for c in counts.values())
    head = f"**{title[0].upper()}{title[1:]}, the paper's {experiments} experiments:** "
    if lower == higher == 0:
        said = f"{p} equals {b} within tolerance in all {total} comparisons"
    else:
        each = ", ".join(
            f"{metric(k).symbol} {c[0]}/{c[1]} of {c[2]}" for k, c in counts.items() if c[0] or c[1]
        )
        said = (
            f"{p} is lower than {b} beyond the tolerance in {lower} and higher in {higher} "
            f"of {total} comparisons ({each})"
        )
        if largest is not None:
            key, d, where = largest
            said += f", the largest {metric(key).symbol} {_signed(key, d)} ({where})"
    if met.get(p, 0) == met.get(b, 0):
        spec = (
            "neither met the spec in any of them" if met.get(p, 0) == 0
            else f"both met the spec in {met.get(p, 0)}"
        )  # fmt: skip
    else:
        spec = f"{p} met the spec in {met.get(p, 0)}, {b} in {met.get(b, 0)}"
    loops = []
    for name in (b, p):
        n = unstable.get(name)
        if n is None:
            loops.append(f"{name}'s not linearised")
        elif n:
            loops.append(f"{name}'s in {n}")
    why = ""
    if any(unstable.get(name) for name in (b, p)):
        why = "; the loop linearised at the target is unstable: " + " and ".join(loops)
    return head + said + "; " + spec + why + "."


_REGIME_WORDS = {"raw": "with the paper's raw steps", "quintic": "with quintic moves"}


def search_sentence(items: Sequence[Mapping[str, Any]]) -> str | None:
    """The table search's answer (:func:`twolink.studies.designs.search.sentence_numbers`' items:
    per regime and inference the best table's IAE against the best linear loop on the
    held-out plants): can a fuzzy term of this structure beat the best linear loop at
    equal effort? Per regime the better inference (more plants better less worse), each
    joint's verdict with its typical-plant shift and its plants. None without a search."""
    if not items:
        return None
    tables = sum(int(i["evaluations"]) for i in items)
    parts, beats, helps = [], [], []
    for regime in dict.fromkeys(i["regime"] for i in items):
        mine = [i for i in items if i["regime"] == regime]
        best = max(
            mine,
            key=lambda i: sum(
                i.get(f"iae{j}_better", 0) - i.get(f"iae{j}_worse", 0) for j in (1, 2)
            ),
        )
        verdicts = [best.get(f"iae{j}_verdict") for j in (1, 2)]
        # a table over FCM-CTC's effort where it is judged is no answer at equal effort
        fair = best.get("within_effort", True)
        beats.append(fair and "better" in verdicts and "worse" not in verdicts)
        helps.append(fair and "better" in verdicts)
        said = []
        for j in (1, 2):
            v = verdicts[j - 1]
            if v is None:
                continue
            size = f"{best[f'iae{j}_estimate']:+.2g} rad·s".replace("-", "−")
            if v in ("better", "worse"):
                size += f", {best[f'iae{j}_{v}']} of {best[f'iae{j}_n']} plants"
            said.append(f"{v} on θ{j} IAE ({size})")
        over = ""
        if not fair:
            (a, b), (c, d) = best["variation"], best["variation_budget"]
            over = (
                f", but over FCM-CTC's effort there (Σ|Δτ| {a:.4g} / {b:.4g} N·m against "
                f"{c:.4g} / {d:.4g}): not at equal effort"
            )
        parts.append(f"{_REGIME_WORDS.get(regime, regime)}, {' and '.join(said)}{over}")
    answer = "Yes" if all(beats) else ("Not outright" if any(helps) else "No")
    return (
        "**Can a fuzzy term of this structure beat the best linear loop at equal effort?** "
        f"{answer}: the best of {tables} rule tables searched within FCM-CTC's effort on the "
        "training plants, "
        "judged against CTC-best on held-out plants, is " + "; ".join(parts) + "."
    )


def sentences(
    variant_lines: Sequence[str], studies: Sequence[ClaimsStudy], closing: Sequence[str] = ()
) -> list[str]:
    """The conclusions, in order: the paper's experiments, the claims per study, limit
    cycles, integral action, the lab arm, then ``closing`` (the table search's); at most
    :data:`MOST`, no sentence twice."""
    out = list(variant_lines)
    lab = [s for s in studies if s.lab]
    studies = [s for s in studies if not s.lab]
    out += [study_sentence(s, first=k == 0) for k, s in enumerate(studies)]
    out += [x for x in (limit_cycle_sentence(studies), integral_sentence(studies)) if x]
    out += [lab_sentence(s) for s in lab]
    out += [x for x in (ranking_conclusion([*studies, *lab]),) if x]
    out += list(closing)
    out = list(dict.fromkeys(out))
    if len(out) > MOST:
        raise ValueError(f"{len(out)} conclusions, at most {MOST}")
    return out
