"""The answer in plain words: per regime who wins against each opponent, by how much in
the metric's own unit, on how many plants; then whether the paper's claim holds.

Every word follows a claims table's columns (docs/statistics.md) by one rule each:

- **the same controller**: every row that some plant has differs by at most its
  tolerance on every plant (``difference_min`` and ``difference_max`` within it), and no
  time is reached by one side only;
- **beats**: the winner is better on the typical plant (``typical``: its interval lies
  wholly beyond the tolerance) on at least one step metric, and worse on none;
- **trade**: each is better on the typical plant on some step metric;
- **do not differ on the typical plant**: neither is better on any step metric;
- the effort (peak |τ|, Σ|Δτ| rows): **less** / **more** where the typical plant is
  better / worse on one effort row and the other way on none, **the same** where every
  effort row is equivalent, **mixed** or **undecided** else.

A size is the typical plant's shift (``estimate``) in the metric's own unit, with the
plants on which the winner is ahead by more than the tolerance. A time judged by its
distance to the moving reference's own (``reference``) is "closer to the move's own",
not "lower". Opponents are the tables' own: the words hold for any number of them.

Where a regime has its ranking (``ranking.csv``: per controller its ``index``, the median
IAE1 + IAE2 over the plants, and ``within``, its effort medians within the proposed
controller's), the words follow it by one rule each:

- **the ranking** (the conclusions'): the three lowest indices, in the index's order, and
  the proposed controller's place among all controllers;
- **the strongest opponent within the effort**: the judged opponent with the lowest index
  among those ``within``, with its index, the proposed controller's and its place;
- **lower still but spends more**: a judged opponent below it that is not ``within`` (one
  that failed on a plant "fails on k plants" instead); where no judged opponent is
  ``within``, "lower but spends more": one below the proposed controller.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from twolink.studies.designs.effort import EFFORT_KEYS

__all__ = [
    "Regime",
    "claim_line",
    "claim_word",
    "effort_words",
    "holds",
    "pair_sentences",
    "ranking_sentence",
    "regime_sentences",
    "same_controller",
    "strongest",
    "strongest_sentences",
    "over_budget",
]


# the typical plant's words (``typical``), as the tables spell them
EQUAL = ("equivalent", "equal")
NONE = ("none", "not judged")


@dataclass(frozen=True)
class Regime:
    """One regime's words' inputs: its short name, plants, the proposed controller,
    opponent -> claims table (the first: the paper's baseline); ``iae``: controller ->
    median IAE1 + IAE2 [rad·s] over the plants (empty: not known); ``effort``: opponent ->
    its peak |τ| and Σ|Δτ| rows (``paired_claims`` columns), where its claims table has none."""

    name: str
    plants: int
    proposed: str
    tables: Mapping[str, pd.DataFrame]
    iae: Mapping[str, float] = field(default_factory=dict)
    effort: Mapping[str, pd.DataFrame] = field(default_factory=dict)
    ranking: pd.DataFrame | None = None


def _name(r) -> str:
    from twolink.simulation.vocabulary import metric

    return f"θ{int(r.joint)} {metric(r.metric).symbol}"


def _amount(key: str, value: float) -> str:
    from twolink.studies.judgments.claims_words import amount

    return amount(key, value, 2)


def _has(table: pd.DataFrame) -> pd.DataFrame:
    """The rows some plant has (for both controllers)."""
    return table[table["n"].fillna(0) > 0]


def _step(table: pd.DataFrame) -> pd.DataFrame:
    return table[~table["metric"].isin(EFFORT_KEYS)]


def _typical(table: pd.DataFrame, side: str) -> pd.DataFrame:
    return table[table["typical"] == side]


def same_controller(table: pd.DataFrame) -> bool:
    """Every row some plant has lies within its tolerance on every plant, no time is
    reached by one side only, and at least one row is there to say so."""
    rows = _has(table)
    if rows.empty:
        return False
    reach = rows[["difference_min", "difference_max"]].abs().max(axis=1)
    alone = rows[["unreached_better", "unreached_worse"]].fillna(0).sum(axis=1)
    return bool(((reach <= rows["tolerance"]) & (alone == 0)).all())


def _largest(rows: pd.DataFrame):
    """The row whose typical shift is largest in tolerances."""
    size = (rows["estimate"].abs() / rows["tolerance"]).to_numpy(float)
    return list(rows.itertuples())[int(np.nanargmax(size))]


def _ahead(r, side: str) -> int:
    return int(getattr(r, side) + getattr(r, f"unreached_{side}"))


def how_much(r, winner_is_proposed: bool, plants: int) -> str:
    """'θ2 Tr is 80 ms lower on the typical plant, and lower by more than 10 ms on 188 of
    200 plants'; a time judged by its distance to the move's own is "closer" to it."""
    side = "better" if winner_is_proposed else "worse"
    moving = r.reference == r.reference  # judged by the distance to the move's own
    way = "closer to the move's own" if moving else "lower"
    again = "closer" if moving else "lower"
    return (
        f"{_name(r)} is {_amount(r.metric, abs(r.estimate))} {way} on the typical plant, "
        f"and {again} by more than {_amount(r.metric, r.tolerance)} on {_ahead(r, side)} of "
        f"{plants} plants"
    )


def effort(rows: pd.DataFrame, winner_is_proposed: bool) -> tuple[str, object]:
    """The effort rows (``proposed`` − opponent) from the winner's side: ("less", the
    largest row) where it is better on the typical plant on one and worse on none,
    ("more", row) the reverse, ("the same", None) where every one is equivalent, else
    ("", None): no effort rows, or mixed or undecided ones."""
    rows = rows[rows["metric"].isin(EFFORT_KEYS) & (rows["n"].fillna(0) > 0)]
    if rows.empty:
        return "", None
    better, worse = _typical(rows, "better"), _typical(rows, "worse")
    if not winner_is_proposed:
        better, worse = worse, better
    if len(better) and not len(worse):
        return "less", _largest(better)
    if len(worse) and not len(better):
        return "more", _largest(worse)
    return ("the same" if rows["typical"].isin(EQUAL).all() else ""), None


def _cost(r, way: str) -> str:
    return f"{_name(r)} {_amount(r.metric, abs(r.estimate))} {way}"


def effort_words(rows: pd.DataFrame, winner_is_proposed: bool) -> str:
    """ ", at less effort (θ1 Σ|Δτ| 24 N·m lower)", ", at more effort (... higher)",
    ", at the same effort", or "" (:func:`effort`)."""
    word, r = effort(rows, winner_is_proposed)
    if r is not None:
        return f", at {word} effort ({_cost(r, 'lower' if word == 'less' else 'higher')})"
    return f", at {word} effort" if word else ""


def pair_sentences(
    table: pd.DataFrame, proposed: str, opponent: str, plants: int,
    effort_rows: pd.DataFrame | None = None, called: str = "", what: str = "step metrics",
) -> list[str]:  # fmt: skip
    """Who wins between ``proposed`` and ``opponent`` on one claims table, in short
    sentences (the rules of this module's docstring). ``effort_rows``: the pair's effort
    rows where the table has none; ``called``: a sentence said first (what the opponent
    is); ``what``: what the table's rows other than the effort are."""
    p, o = proposed, opponent
    lead = [called] if called else []
    rows = _has(table)
    if same_controller(table):
        reach = rows[["difference_min", "difference_max"]].abs().max(axis=1)
        r = list(rows.itertuples())[int(np.argmax((reach / rows["tolerance"]).to_numpy()))]
        most = float(reach.loc[r.Index])
        size = f"at most {_amount(r.metric, most)}, {_name(r)}" if most else "every difference 0"
        return lead + [
            f"{p} and {o} are the same controller: no metric differs by more than its "
            f"tolerance on any of {plants} plants ({size})."
        ]
    step = _step(rows)
    judged = step[~step["typical"].isin(NONE)]
    better, worse = _typical(step, "better"), _typical(step, "worse")
    efforts = (
        table if effort_rows is None or table["metric"].isin(EFFORT_KEYS).any() else effort_rows
    )
    m = len(judged)
    if len(better) and not len(worse):
        return lead + [
            f"{p} beats {o} on {len(better)} of {m} {what} and loses on none"
            f"{effort_words(efforts, True)}.",
            f"{p}'s {how_much(_largest(better), True, plants)}.",
        ]
    if len(worse) and not len(better):
        return lead + [
            f"{o} beats {p} on {len(worse)} of {m} {what} and loses on none"
            f"{effort_words(efforts, False)}.",
            f"{o}'s {how_much(_largest(worse), False, plants)}.",
        ]
    if len(better) and len(worse):
        return lead + [
            f"{p} and {o} trade: {p} is better on {len(better)} and worse on "
            f"{len(worse)} of {m} {what}.",
            f"{p}'s {how_much(_largest(better), True, plants)}; {opponent}'s "
            f"{how_much(_largest(worse), False, plants)}.",
        ]
    equal = int(judged["typical"].isin(EQUAL).sum())
    same = f"{equal} of {m} {what} within their tolerance"
    if equal < m:
        same += f", {m - equal} undecided"
    said = [f"{p} and {o} do not differ on the typical plant ({same})."]
    word, r = effort(efforts, False)  # from the opponent's side
    if r is not None:
        said.append(f"{o if word == 'less' else p} needs less effort: {_cost(r, 'lower')}.")
    return lead + said + _shares(step, p, o, plants)


def _shares(step: pd.DataFrame, p: str, o: str, plants: int) -> list[str]:
    """Where the typical plant decides nothing: the largest share of plants shown on each
    side (``share_*_shown``), in plants."""
    out = []
    for side, who in (("better", p), ("worse", o)):
        shown = step[step[f"share_{side}_shown"].astype(bool)]
        if shown.empty:
            continue
        k = shown[side] + shown[f"unreached_{side}"]
        r = list(shown.itertuples())[int(np.argmax(k.to_numpy()))]
        out.append(
            f"{who} is ahead by more than {_amount(r.metric, r.tolerance)} on up to "
            f"{int(k.max())} of {plants} plants ({_name(r)})."
        )
    return out


def holds(table: pd.DataFrame) -> bool:
    """The paper's claim against this table's opponent: the proposed controller better on
    the typical plant on some step metric, worse on none."""
    step = _step(_has(table))
    return bool(len(_typical(step, "better"))) and not len(_typical(step, "worse"))


def _ranked(regime: Regime) -> pd.DataFrame:
    """The ranking's rows with an index, the lowest first (the index's order, not the
    table's)."""
    t = regime.ranking
    t = t[np.isfinite(t["index"].to_numpy(float))]
    return t.sort_values("index", kind="stable")


def _judged(regime: Regime) -> pd.DataFrame:
    """The ranked rows of the judged opponents."""
    t = _ranked(regime)
    return t[t["controller"].isin(list(regime.tables)) & (t["controller"] != regime.proposed)]


def strongest(regime: Regime) -> str | None:
    """The judged opponent with the lowest index within the proposed controller's effort
    (the ranking's ``within``); without a ranking, the lowest median IAE1 + IAE2."""
    if regime.ranking is not None:
        mine = _judged(regime)
        mine = mine[mine["within"].astype(bool)]
        return None if mine.empty else str(mine.iloc[0]["controller"])
    known = {o: regime.iae[o] for o in regime.tables if regime.iae and o in regime.iae}
    known = {o: v for o, v in known.items() if np.isfinite(v)}
    return min(known, key=known.get) if known else None


def over_budget(regime: Regime) -> pd.DataFrame:
    """The judged opponents not within the effort whose index is below the strongest
    within it (below the proposed controller's, where none is), the lowest first."""
    if regime.ranking is None:
        return pd.DataFrame(columns=["controller", "index", "within", "failed"])
    mine = _judged(regime)
    out = mine[~mine["within"].astype(bool)]
    ranked = _ranked(regime)
    below = ranked.loc[ranked["controller"] == (strongest(regime) or regime.proposed), "index"]
    return out[out["index"] < float(below.iloc[0])] if len(below) else out


def _values(pairs: Sequence[tuple[str, float]], key: str) -> str:
    """'SL-best 1.3 and CTC-I-best 3.3 mrad·s': each value in its unit, a unit said once at
    the end of a run of values that share it."""
    said = [(n, *_amount(key, v).rpartition(" ")[::2]) for n, v in pairs]
    words = [
        f"{n} {v}" + ("" if k + 1 < len(said) and said[k + 1][2] == u else f" {u}")
        for k, (n, v, u) in enumerate(said)
    ]
    return _names(words)


def ranking_sentence(regime: Regime, top: int = 3) -> str:
    """'Lowest median IAE1 + IAE2: SL-best 1.3, CTC-I-best 3.3 and CTC-DOB-best 5.5 mrad·s;
    FCM-CTC 81 mrad·s, 8th of 10.' (the index's order, ties at the same place; the proposed
    controller's place in brackets where it is among the three)."""
    t = _ranked(regime)
    lead = [(r.controller, float(r.index)) for r in t.head(top).itertuples()]
    mine = t[t["controller"] == regime.proposed]
    said = f"Lowest median IAE1 + IAE2: {_values(lead, 'iae_rad_s')}"
    if len(mine):
        index, place = _place(regime, regime.proposed)
        if regime.proposed in (n for n, _ in lead):  # its value said already
            return f"{said} ({regime.proposed} {place})."
        said += f"; {regime.proposed} {_amount('iae_rad_s', index)}, {place}"
    return said + "."


def _spends(regime: Regime) -> str:
    """What the opponents below the strongest within the effort do instead."""
    over = over_budget(regime)
    if over.empty:
        return ""
    failed = over["failed"].fillna(0).astype(int) if "failed" in over else 0 * over["index"]
    spend = [r.controller for r, k in zip(over.itertuples(), failed, strict=True) if not k]
    fail = [f"{r.controller} fails on {k} plants" for r, k in
            zip(over.itertuples(), failed, strict=True) if k]  # fmt: skip
    parts = []
    if spend:
        verb = "is" if len(spend) == 1 else "are"
        s = "s" if len(spend) == 1 else ""
        still = "lower still" if strongest(regime) is not None else "lower"
        parts.append(f"{_names(spend)} {verb} {still} but spend{s} more than "
                     f"{regime.proposed}")  # fmt: skip
    parts += fail
    return "; ".join(parts) + "."


def _place(regime: Regime, name: str) -> tuple[float, str]:
    """A controller's index and its place among the ranked ones ('8th of 10')."""
    t = _ranked(regime)
    index = float(t.loc[t["controller"] == name, "index"].iloc[0])
    k = 1 + int((t["index"] < index).sum())
    nth = "th" if k % 100 in (11, 12, 13) else {1: "st", 2: "nd", 3: "rd"}.get(k % 10, "th")
    return index, f"{k}{nth} of {len(t)}"


def strongest_sentences(
    regime: Regime, opponent: str | None = None, indices: bool = True
) -> list[str]:
    """Who the strongest opponent is (:func:`strongest`; with a ranking, its index against
    the proposed controller's and its place unless not ``indices``, and those below it
    that spend more, :func:`over_budget`) and who wins against it; ``opponent``: another
    judged opponent instead."""
    best = strongest(regime)
    o = opponent or best
    if o is None:
        return []
    p, ranked = regime.proposed, regime.ranking is not None
    if o != best:
        called = ""
    elif ranked:
        called = f"{o} is the strongest opponent within {p}'s effort."
        if indices and (_ranked(regime)["controller"] == p).any():
            (mine, place), (theirs, _) = _place(regime, p), _place(regime, o)
            iae = [_amount("iae_rad_s", x) for x in (theirs, mine)]
            called = f"{called[:-1]}: median IAE1 + IAE2 {iae[0]} against {p}'s {iae[1]}, {place}."
        called = " ".join(x for x in (called, _spends(regime)) if x)
    else:
        iae = [_amount("iae_rad_s", regime.iae[x]) for x in (o, p)]
        called = (
            f"{o} is the strongest opponent: median IAE1 + IAE2 {iae[0]} against {p}'s {iae[1]}."
        )
    return pair_sentences(regime.tables[o], p, o, regime.plants, regime.effort.get(o), called)


def regime_sentences(regime: Regime) -> list[str]:
    """One regime: who wins against the paper's baseline (the first table) and against the
    strongest opponent (:func:`strongest_sentences`; every opponent where no ranking nor
    IAE is known), in :func:`pair_sentences`' words."""
    names, p = list(regime.tables), regime.proposed
    best, ranked = strongest(regime), regime.ranking is not None
    out = []
    if ranked and best is None:
        none = f"No judged opponent is within {p}'s effort."
        out += [x for x in (none, _spends(regime)) if x]
    said = names if best is None and not ranked else list(dict.fromkeys([names[0], best]))
    for o in (o for o in said if o is not None):
        if o == best:
            out += strongest_sentences(regime)
        else:
            out += pair_sentences(regime.tables[o], p, o, regime.plants, regime.effort.get(o))
    return out


def _names(names: Sequence[str]) -> str:
    return ", ".join(names[:-1]) + f" and {names[-1]}" if len(names) > 1 else names[0]


def claim_line(regimes: Sequence[Regime]) -> str:
    """Whether the paper's claim holds (:func:`holds`), per opponent: in every regime, in
    none, or in the regimes named; opponents with the same answer said together."""
    proposed = regimes[0].proposed
    opponents = list(dict.fromkeys(o for r in regimes for o in r.tables))
    answers: dict[str, list[str]] = {}
    for o in opponents:
        where = [r for r in regimes if o in r.tables]
        held = [r.name for r in where if holds(r.tables[o])]
        if len(held) == len(where):
            said = "in every regime"
        elif not held:
            said = "in no regime"
        else:
            said = f"on {_names(held)} only"
        answers.setdefault(said, []).append(o)
    parts = [f"Against {_names(os)} it holds {said}." for said, os in answers.items()]
    word = claim_word(list(answers))
    head = f"**Does {proposed} lower the step metrics? {word}.**"
    return head + " " + " ".join(parts)


def claim_word(said: Sequence[str]) -> str:
    """The claim's answer in one word, from where it holds against each opponent: "Yes"
    where it holds in every regime against every opponent, "No" where it holds in none
    against any, "In part" otherwise."""
    if set(said) == {"in every regime"}:
        return "Yes"
    if set(said) == {"in no regime"}:
        return "No"
    return "In part"


def _flexible(variant) -> bool:
    return "flexibility" in variant.overrides.get("plant", {})


def runs_line(rows: Sequence[Mapping], manifest, summary_path: str) -> str:
    """The main job's first line: the runs by outcome, what "off target" counts, where the
    off-target runs are and whether each group is expected, and where the answer is.

    Expected: on a variant with flexible joints (the paper's laws model a rigid arm),
    with the paper's raw steps (a slow loop on raw steps), and, on the other variants, of
    controllers that are neither the proposed one nor its baseline (the weak baselines
    kept to show where they fail). Off target runs of the proposed controller or its
    baseline there are said as "unexpected"."""
    from twolink.simulation.config import FLEXIBLE_KINDS
    from twolink.simulation.outcome import SuccessSpec

    rigid_laws = {n for n, c in manifest.controllers.items() if c.get("kind") not in FLEXIBLE_KINDS}

    count = {o: sum(r["outcome"] == o for r in rows) for o in ("met spec", "off target")}
    diverged = sum(r["status"] != "ok" for r in rows)
    off = [r for r in rows if r["outcome"] == "off target"]
    groups, weak, claim = [], {}, {}
    for v in manifest.variants:
        mine = [r for r in off if r["variant"] == v.name]
        if not mine:
            continue
        if _flexible(v):
            laws = {r["controller"] for r in mine}
            said = ", which the laws model as rigid" if laws <= rigid_laws else ""
            groups.append(f"{len(mine)} on the {v.title}{said}")
            continue
        if v.raw_steps:
            groups.append(f"{len(mine)} on the {v.title} (a slow loop on raw steps)")
            continue
        for r in mine:
            two = r["controller"] in (manifest.proposed, manifest.baseline)
            side = claim if two else weak
            side[r["controller"]] = side.get(r["controller"], 0) + 1
        where = v.title
        if weak:
            names = ", ".join(f"{c} {n}" for c, n in sorted(weak.items(), key=lambda x: -x[1]))
            groups.append(f"{sum(weak.values())} of weak baselines on the {where} ({names})")
        if claim:
            names = ", ".join(f"{c} {n}" for c, n in claim.items())
            groups.append(f"unexpected: {names} on the {where}")
        weak, claim = {}, {}
    spec = SuccessSpec()
    band = f"{100 * spec.final_error:g} %"
    runs = f"{len(rows)} run{'s' * (len(rows) != 1)}"
    head = (
        f"{runs}: {count['met spec']} met the spec, {count['off target']} off target, "
        f"{diverged} diverged."
    )
    why = ""
    if off:
        unexpected = any(g.startswith("unexpected") for g in groups)
        why = (
            f" Off target (outside {band} of the target at the end, growing, or overshooting "
            f"{spec.max_overshoot_pct:g} %){'' if unexpected else ' is expected here'}: "
            + "; ".join(groups)
            + "."
        )
    return f"{head}{why} The answer: {summary_path}"
