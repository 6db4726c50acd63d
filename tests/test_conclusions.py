"""The report's conclusions in sentences (twolink/studies/judgments/conclusions.py), written from
the
tables and checked against them on synthetic studies whose answer is known: the limit
cycle said with its count, an opponent that is another said once, any opponent's name,
integral action beating both, the flexible line naming every loop, at most 8."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from twolink.studies.judgments.claims import CLAIM_METRICS, paired_claims, paired_claims_many
from twolink.studies.judgments.conclusions import (
    MOST,
    ClaimsStudy,
    lab_sentence,
    limit_cycle_sentence,
    sentences,
    study_sentence,
    variant_sentence,
)
from twolink.studies.reproduction.report import WINNER_METRICS

METRICS = list(dict.fromkeys([*CLAIM_METRICS, *WINNER_METRICS]))


def results(opponent: str = "CTC-matched", plants: int = 200, seed: int = 0) -> pd.DataFrame:
    """CTC, CTC-I, FCM-CTC and a linear ``opponent`` on the same plants: FCM-CTC is CTC
    but for a limit cycle on θ2 on 29 plants (2-6.5 mrad more oscillation); CTC-I has
    3 mrad less ess than everyone; the opponent settles 50 ms
    sooner than CTC."""
    rng = np.random.default_rng(seed)
    base = {m: rng.uniform(0.5, 1.5, (plants, 2)) * (1e-2 if "rad" in m else 1) for m in METRICS}
    cycle = rng.choice(plants, 29, replace=False)
    rows = []
    for name in ("CTC", "CTC-I", "FCM-CTC", opponent):
        for s in range(plants):
            row = {"sample": s, "controller": name, "status": "ok"}
            for m in METRICS:
                for j in (1, 2):
                    v = base[m][s, j - 1]
                    if name == "FCM-CTC" and m == "oscillation_rad" and j == 2 and s in cycle:
                        v += (2.0 + 4.5 * (s % 7) / 6) * 1e-3
                    if name == "CTC-I" and m in ("steady_state_error_rad", "max_error_rad"):
                        v -= 3e-3 if m == "steady_state_error_rad" else 5e-3
                    if name == opponent and m == "settling_time_s":
                        v -= 0.05
                    row[f"joint{j}_{m}"] = v
            rows.append(row)
    return pd.DataFrame(rows)


def study(opponent: str = "CTC-matched", same: bool = True) -> ClaimsStudy:
    r = results(opponent)
    pairs = [("CTC-I", "CTC"), ("FCM-CTC", "CTC"), ("CTC-I", "FCM-CTC")]
    if not same:
        pairs += [("FCM-CTC", opponent), ("CTC-I", opponent)]
    every = paired_claims_many(r, pairs, WINNER_METRICS)
    table = paired_claims(r, "FCM-CTC", "CTC")
    fair = table if same else paired_claims(r, "FCM-CTC", opponent)
    return ClaimsStudy(
        label="quintic moves",
        plants=200,
        met={"CTC": 180, "FCM-CTC": 171, opponent: 180, "CTC-I": 200},
        proposed="FCM-CTC",
        baseline="CTC",
        claims={"CTC": table, opponent: fair},
        same_as={opponent: "CTC"} if same else {},
        every=every,
        integral="CTC-I",
    )


def test_the_limit_cycle_is_said_with_its_joint_count_and_size():
    s = study()
    line = limit_cycle_sentence([s])
    row = s.every[(s.every["proposed"] == "FCM-CTC") & (s.every["opponent"] == "CTC")]
    row = row[(row["metric"] == "oscillation_rad") & (row["joint"] == 2)].iloc[0]
    # a share, not a shift: 29 of 200 beyond 1 mrad, more than a tenth, one way: partly worse
    assert row["worse"] == 29 and row["typical"] == "equivalent"
    assert row["verdict"] == "partly worse"
    assert "on quintic moves: θ2 on 29 of 200 plants (10-20 %" in line
    assert "up to 6.5 mrad more" in line and "θ1" not in line


def test_an_opponent_that_is_another_is_said_once():
    line = study_sentence(study())
    assert line.count("CTC-matched") == 1 and "FCM-CTC and CTC (= CTC-matched here)" in line
    # on the claim's metrics FCM-CTC is CTC on every plant: the same controller
    assert line.endswith(
        "are the same controller: no metric differs by more than its tolerance on any of "
        "200 plants (every difference 0)."
    )
    assert line.startswith(
        "**The paper's claim (FCM-CTC lowers Tp, Td, Ts, Tr, Mp, ess) on quintic moves, 200 "
        "plants.** Met the spec: FCM-CTC 171, CTC 180."
    )


def test_any_opponents_name_works_and_its_words_come_from_its_table():
    s = study("CTC-strong", same=False)
    line = study_sentence(s)
    assert "FCM-CTC and CTC are the same controller" in line
    fair = s.claims["CTC-strong"]
    # the stronger opponent settles 50 ms sooner on every plant: it beats FCM-CTC on Ts
    ts = fair[fair["metric"] == "settling_time_s"]
    assert (ts["typical"] == "worse").all()
    assert "CTC-strong beats FCM-CTC on 2 of 12 step metrics and loses on none." in line
    assert ("CTC-strong's θ1 Ts is 50 ms lower on the typical plant, and lower by more than "
            "10 ms on 200 of 200 plants.") in line  # fmt: skip


def test_integral_action_beating_both_is_said_and_counted():
    (line,) = [x for x in sentences([], [study()]) if x.startswith("**Integral")]
    assert line.startswith("**Integral action:** CTC-I beats FCM-CTC and CTC on quintic moves")
    # better on ess of both joints, worse on nothing, against each
    counts = "(metrics better/worse on the typical plant, of 14: FCM-CTC 2/0, CTC 2/0"
    assert f"{counts}; e.g. θ1 ess −3 mrad" in line
    # an opponent it does not beat turns the word
    s = study("CTC-strong", same=False)
    every = s.every.copy()
    hit = (every["proposed"] == "CTC-I") & (every["opponent"] == "CTC-strong")
    every.loc[hit & (every["metric"] == "iae_rad_s"), "typical"] = "worse"
    s = ClaimsStudy(**{**s.__dict__, "every": every})
    (line,) = [x for x in sentences([], [s]) if x.startswith("**Integral")]
    assert "CTC-I beats FCM-CTC and CTC but not CTC-strong on" in line and "CTC-strong 2/2" in line
    # and one it beats none of
    every.loc[hit & (every["opponent"] != "CTC-strong"), "typical"] = "worse"
    every.loc[(every["proposed"] == "CTC-I") & (every["metric"] == "iae_rad_s"), "typical"] = (
        "worse"
    )
    s = ClaimsStudy(**{**s.__dict__, "every": every})
    (line,) = [x for x in sentences([], [s]) if x.startswith("**Integral")]
    assert "CTC-I beats none of FCM-CTC, CTC and CTC-strong on" in line


def test_the_papers_experiments_sentence_names_every_unstable_loop():
    counts = {"settling_time_s": (0, 0, 10), "overshoot_pct": (0, 0, 10)}
    line = variant_sentence("rigid arm", 10, counts, {"FCM-CTC": 10, "CTC": 10},
                            {"CTC": None, "FCM-CTC": None}, "FCM-CTC", "CTC")  # fmt: skip
    assert "FCM-CTC equals CTC within tolerance in all 20 comparisons" in line
    assert "both met the spec in 10" in line and "unstable" not in line
    counts = {"settling_time_s": (3, 5, 10), "overshoot_pct": (0, 0, 10)}
    for growth, said in (
        ({"CTC": 10, "FCM-CTC": None}, "CTC's in 10 and FCM-CTC's not linearised"),
        ({"CTC": 10, "FCM-CTC": 10}, "CTC's in 10 and FCM-CTC's in 10"),
        ({"CTC": 10, "FCM-CTC": 0}, "CTC's in 10."),
    ):
        line = variant_sentence("flexible joints", 10, counts, {"FCM-CTC": 0, "CTC": 0},
                                growth, "FCM-CTC", "CTC",
                                ("settling_time_s", -0.62, "Table 4"))  # fmt: skip
        assert line.endswith(said.rstrip(".") + ".")
        assert "neither met the spec in any of them" in line
        assert "lower than CTC beyond the tolerance in 3 and higher in 5 of 20" in line
        assert "of 20 comparisons (Ts 3/5 of 10), the largest Ts −620 ms (Table 4)" in line


def test_at_most_eight_sentences_and_none_twice():
    s = study()
    lines = [variant_sentence("rigid arm", 10, {"overshoot_pct": (0, 0, 10)}, {}, {}, "F", "C")]
    out = sentences(lines * 3, [s, s])
    assert len(out) == len(set(out)) <= MOST
    with pytest.raises(ValueError, match=f"at most {MOST}"):
        sentences([f"line {k}" for k in range(MOST + 1)], [])


def _search_item(regime, inference, v1, v2, b1=0, w1=0, b2=0, w2=0, est=(0.0, 0.0)):
    item = {"regime": regime, "inference": inference, "evaluations": 650}
    for j, v, b, w, e in ((1, v1, b1, w1, est[0]), (2, v2, b2, w2, est[1])):
        item |= {f"iae{j}_verdict": v, f"iae{j}_better": b, f"iae{j}_worse": w}
        item |= {f"iae{j}_n": 200, f"iae{j}_estimate": e}
    return item


def test_the_search_sentence_answers_yes_only_where_every_regime_is_better_and_none_worse():
    from twolink.studies.judgments.conclusions import search_sentence

    assert search_sentence([]) is None
    better = _search_item("raw", "mamdani", "better", "equivalent", b1=150, est=(-0.1, 0.0))
    mixed = _search_item("raw", "mamdani", "worse", "better", 0, 159, 181, 0, (0.045, -0.34))
    worse = _search_item("quintic", "mamdani", "equivalent", "worse", w2=137, est=(0, 0.0039))
    assert search_sentence([better]).startswith(
        "**Can a fuzzy term of this structure beat the best linear loop at equal effort?** Yes:"
    )
    said = search_sentence([mixed, worse])
    assert "** Not outright: the best of 1300 rule tables" in said
    assert "worse on θ1 IAE (+0.045 rad·s, 159 of 200 plants)" in said
    assert "better on θ2 IAE (−0.34 rad·s, 181 of 200 plants)" in said
    assert "with quintic moves, equivalent on θ1 IAE" in said
    assert "** No:" in search_sentence([worse])
    # per regime the inference with more plants better than worse speaks
    other = _search_item("raw", "continuous", "better", "better", 120, 0, 130, 0, (-0.2, -0.3))
    assert "** Yes:" in search_sentence([mixed, other])
    assert "(−0.2 rad·s, 120 of 200 plants)" in search_sentence([mixed, other])


def test_a_table_over_the_effort_where_judged_is_no_yes():
    """A searched table better on every IAE but over FCM-CTC's effort on the judged plants
    (the effort rule, docs/reproduction.md) answers nothing at equal effort: not "Yes", and
    the sentence says it is over, with both sides' Σ|Δτ|."""
    from twolink.studies.judgments.conclusions import search_sentence

    over = _search_item("raw", "mamdani", "better", "better", 150, 0, 160, 0, (-0.1, -0.2))
    over |= {"within_effort": False, "variation": (262.9, 83.0), "variation_budget": (234.5, 76.9)}
    said = search_sentence([over])
    assert "** No:" in said
    assert "over FCM-CTC's effort there (Σ|Δτ| 262.9 / 83 N·m against 234.5 / 76.9)" in said
    within = over | {"within_effort": True}
    assert "** Yes:" in search_sentence([within]) and "over FCM" not in search_sentence([within])


def lab_study(every: pd.DataFrame | None = None) -> ClaimsStudy:
    """The synthetic study as the lab arm's, with a controller the sentence leaves out."""
    s = study("CTC-best", same=False)
    r = results("CTC-best")
    more = r[r["controller"] == "CTC"].assign(controller="PD-G")
    pd_g = paired_claims_many(pd.concat([r, more]), [("PD-G", "CTC")], WINNER_METRICS)
    every = pd.concat([s.every, pd_g]) if every is None else every
    return ClaimsStudy(**{**s.__dict__, "every": every, "lab": True, "label": "the lab arm"})


def _clause(sentence: str, pair: str) -> str:
    """What the brackets after ``pair`` say."""
    return sentence.split(f"{pair} (", 1)[1].split(")", 1)[0]


def test_the_lab_sentence_says_who_beats_whom_with_sizes_and_counts():
    """In the plain words: "beats" on the typical plant, its size in mrad and its plants;
    a row only its share calls better is no win; one row lost makes a trade."""
    s = lab_study()
    said = lab_sentence(s)
    assert said.startswith("**The lab arm, 200 plants.** ")
    assert "PD-G" not in said  # only the claim's controllers, the integral one, opponents
    # only pairs with the proposed controller on one side: CTC-I against CTC is the tables'
    assert "CTC-I beats CTC" not in said and "FCM-CTC " in said
    row = s.every[(s.every["proposed"] == "CTC-I") & (s.every["opponent"] == "FCM-CTC")]
    better = row[row["typical"] == "better"]
    assert len(better) and not (row["typical"] == "worse").any()
    best = better.loc[(better["estimate"].abs() / better["tolerance"]).idxmax()]
    assert f"CTC-I beats FCM-CTC on {len(better)} of 10 metrics and loses on none" in said
    size = f"{-best['estimate'] * 1e3:.2g}"  # mrad, the 3 mrad less ess it was given
    assert (f"CTC-I's θ{best['joint']} ess is {size} mrad lower on the typical plant, and "
            f"lower by more than 1 mrad on {best['better']} of 200 plants") in said  # fmt: skip
    # the same tables with one metric worse on the typical plant: a trade, not a win
    every = s.every.copy()
    mine = (every["proposed"] == "CTC-I") & (every["opponent"] == "FCM-CTC")
    worst = every[mine & (every["typical"] != "better") & ~every["metric"].str.startswith(
        "torque")].index[0]  # fmt: skip
    every.loc[worst, ["typical", "verdict", "worse", "estimate"]] = ["worse", "worse", 150, 0.5]
    traded = lab_sentence(lab_study(every.reset_index(drop=True)))
    assert "CTC-I and FCM-CTC trade: CTC-I is better on" in traded
    assert "CTC-I beats FCM-CTC" not in traded
    # a verdict "better" carried by shares alone, the typical plant undecided: no win
    shares = s.every.copy()
    shares.loc[mine, "typical"] = shares.loc[mine, "typical"].replace("better", "undecided")
    undecided = lab_sentence(lab_study(shares.reset_index(drop=True)))
    assert "CTC-I beats" not in undecided
    assert "CTC-I and FCM-CTC do not differ on the typical plant" in undecided


def test_the_lab_arm_has_its_own_sentence_after_the_regimes():
    s, lab = study(), lab_study()
    out = sentences(["a line"], [s, lab])
    assert out[-1] == lab_sentence(lab)
    assert sum("The lab arm" in x for x in out) == 1  # not among the regimes' claims


def _ranked_study(ranking: pd.DataFrame | None) -> ClaimsStudy:
    """The study with CTC-best as its other opponent and a tuned law SL-best, which
    settles 50 ms sooner than CTC (the data of :func:`results`)."""
    import dataclasses

    s = study("CTC-best", same=False)
    tuned = {"SL-best": paired_claims(results("SL-best"), "FCM-CTC", "SL-best")}
    return dataclasses.replace(s, tuned=tuned, ranking=ranking)


def test_the_ranking_conclusion_names_the_strongest_within_the_effort_and_the_lower_law():
    """SL-best has the lowest index but spends more: CTC-best is the strongest at the
    proposed controller's effort; SL-best is said apart, with who wins against it."""
    from twolink.studies.judgments.conclusions import ranking_conclusion

    ranking = pd.DataFrame({
        "controller": ["FCM-CTC", "CTC", "CTC-best", "SL-best"],
        "index": [0.08, 0.09, 0.02, 0.005], "within": [True, True, True, False],
        "failed": 0,
    })  # fmt: skip
    said = ranking_conclusion([_ranked_study(ranking)])
    assert said.startswith("**Which law wins where**")
    assert "*Quintic moves.* Lowest median IAE1 + IAE2: SL-best 5, CTC-best 20" in said
    assert "CTC-best is the strongest opponent within FCM-CTC's effort." in said
    assert "effort: median IAE1 + IAE2" not in said  # the indices said once, in the ranking
    assert "SL-best is lower still but spends more than FCM-CTC." in said
    assert "SL-best beats FCM-CTC on 2 of" in said  # Ts 50 ms sooner on both joints
    assert "on the typical plant" not in said  # the sizes: the answer's and the tables'
    assert "SL-best is the strongest" not in said
    # within the effort, SL-best is the strongest and nothing is said apart
    within = ranking.assign(within=True)
    said = ranking_conclusion([_ranked_study(within)])
    assert "SL-best is the strongest opponent within FCM-CTC's effort." in said
    assert "spend" not in said
    assert ranking_conclusion([_ranked_study(None)]) is None
    assert said in sentences([], [_ranked_study(within)])
