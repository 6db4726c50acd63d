"""The answer at a glance (issue 46): performance profiles against their definition, the
summary's words on cases where each word would be wrong, and the answer figure drawn from
the tables' own columns and verdict words."""

import numpy as np
import pandas as pd
import pytest

from twolink.studies.reproduction.profiles import costs, performance_profile
from twolink.studies.reproduction.summary import MAX_WORDS, Judged, answer, sentence, summary

KEYS = ("peak_time_s", "delay_time_s", "settling_time_s", "rise_time_s", "overshoot_pct",
        "steady_state_error_rad")  # fmt: skip


def _table(verdicts, estimate, low, high, tolerance=0.01):
    """A claims table of len(verdicts) rows with docs/statistics.md's columns."""
    n = len(verdicts)
    rows = []
    for i, v in enumerate(verdicts):
        rows.append({
            "joint": 1 + i // len(KEYS), "metric": KEYS[i % len(KEYS)], "tolerance": tolerance,
            "estimate": estimate[i], "ci_low": low[i], "ci_high": high[i],
            "share_better": 0.1, "share_better_low": 0.05, "share_better_high": 0.2,
            "share_worse": 0.3, "share_worse_low": 0.2, "share_worse_high": 0.4, "verdict": v,
        })  # fmt: skip
    assert len(rows) == n
    return pd.DataFrame(rows)


def test_the_profile_is_the_share_of_plants_within_tau_of_the_best_by_its_definition():
    """Dolan & Moré's ρ, computed by a plain loop over plants here; a plant a controller
    has no value on never counts for it; ρ(1) is the share of plants it is best on."""
    rng = np.random.default_rng(3)
    cost = pd.DataFrame(rng.lognormal(size=(40, 3)), columns=["A", "B", "C"])
    cost.iloc[5, 1] = np.nan
    taus = np.array([1.0, 1.3, 2.0, 5.0])
    rho = performance_profile(cost, taus)
    for name in cost.columns:
        for tau in taus:
            within = [
                np.isfinite(row[name]) and row[name] <= tau * np.nanmin(row.to_numpy())
                for _, row in cost.iterrows()
            ]
            assert rho.loc[tau, name] == pytest.approx(np.mean(within))
    best = cost.idxmin(axis=1).value_counts(normalize=True)
    assert rho.loc[1.0].to_numpy() == pytest.approx(best.reindex(cost.columns).to_numpy())
    # by hand: A [1, 2, —], B [2, 2, 3] -> ratios A [1, 1, ∞], B [2, 1, 1]
    small = pd.DataFrame({"A": [1.0, 2.0, np.nan], "B": [2.0, 2.0, 3.0]})
    hand = performance_profile(small, np.array([1.0, 1.99, 2.0]))
    assert hand["A"].tolist() == pytest.approx([2 / 3, 2 / 3, 2 / 3])
    assert hand["B"].tolist() == pytest.approx([2 / 3, 2 / 3, 1.0])
    # by default τ reaches the largest finite ratio: every curve ends where it can
    assert performance_profile(small)["B"].iloc[-1] == 1.0


def test_costs_sum_both_joints_per_plant_and_controller_from_the_sweeps_columns():
    results = pd.DataFrame({
        "sample": [0, 0, 1, 1], "controller": ["B", "A", "B", "A"],
        "joint1_iae_rad_s": [1.0, 2.0, 3.0, 4.0], "joint2_iae_rad_s": [0.5, 0.25, np.nan, 1.0],
    })  # fmt: skip
    table = costs(results, "iae_rad_s")
    assert list(table.columns) == ["B", "A"]  # the sweep's order
    assert table.loc[0, "B"] == 1.5 and table.loc[0, "A"] == 2.25
    assert np.isnan(table.loc[1, "B"]) and table.loc[1, "A"] == 5.0


def _study(tables):
    return Judged("quintic moves", 200, "FCM-CTC", {n: (f"{n}.csv", t) for n, t in tables.items()})


def test_equivalent_rows_say_how_equal_and_only_an_all_zero_interval_is_exactly_0():
    """ "exactly 0" would be wrong where an interval is not 0 (1e-7 of a tolerance here);
    "within" would be wrong for rows beyond the band (they state their shift)."""
    zero = _table(["equivalent"] * 12, [0.0] * 12, [0.0] * 12, [0.0] * 12)
    assert "(12 rows), 12 equivalent (exactly 0)" in sentence(_study({"CTC": zero}))
    tiny = _table(["equivalent"] * 12, [0.0] * 12, [-1e-9] * 12, [0.0] * 12)
    said = sentence(_study({"CTC": tiny}))
    assert "exactly 0" not in said and "12 equivalent (within 1e-07 tolerance)" in said
    worse = _table(["worse"] * 3 + ["equivalent"] * 9, [0.05, 0.2, 0.3] + [0.001] * 9,
                   [0.02, 0.1, 0.2] + [-0.004] * 9, [0.1, 0.3, 0.4] + [0.005] * 9)  # fmt: skip
    said = sentence(_study({"CTC-best": worse}))
    assert said.startswith("Quintic moves (200 plants): against CTC-best (12 rows), 9 equivalent")
    assert "3 worse (+5 to +30 tolerances)" in said
    assert "9 equivalent (within 0.5 tolerance)" in said


def test_the_verdict_words_are_the_tables_own_a_new_word_is_its_own_group():
    """Another engineer's vocabulary ("equivalent except a subset") counts as it comes;
    "undefined" and "set by the reference" count together as "not judged"."""
    words = ["equivalent except on a subset"] * 2 + ["better"] * 10
    t = _table(words, [0.0] * 2 + [-0.05] * 10, [-0.001] * 2 + [-0.06] * 10,
               [0.001] * 2 + [-0.04] * 10)  # fmt: skip
    said = sentence(_study({"CTC": t}))
    assert "10 better (-5 tolerances)" in said
    assert "and 2 equivalent except on a subset (within 0.1 tolerance)" in said
    undefined = _table([np.nan] * 11 + ["set by the reference"], [np.nan] * 11 + [0.0],
                       [np.nan] * 11 + [0.0], [np.nan] * 11 + [0.0])  # fmt: skip
    assert sentence(_study({"CTC": undefined})).endswith("(12 rows), 12 not judged.")


def test_the_answer_stays_within_its_words_with_every_verdict_in_every_table():
    """The worst case: three regimes, two opponents each, every verdict in every table:
    sizes give way (the figure keeps them) before the answer passes its words; the real
    tables keep theirs where they fit (both cases below)."""
    words = ["better", "worse", "equivalent", "split", "inconclusive", "set by the reference"]
    words = words * 2
    est = [-0.05, 0.05, 0.0, 0.002, 0.02, 0.0] * 2
    t = _table(words, est, [e - 0.01 for e in est], [e + 0.01 for e in est])
    long = "rigid arm, the paper's raw steps at ωn = 3 rad/s"  # a regime without a short name
    tables = {n: (f"{n}.csv", t) for n in ("CTC", "CTC-best")}
    studies = [Judged(long, 200, "FCM-CTC", tables)] * 3
    said = answer(studies)
    assert len(said) == 3
    assert sum(len(s.split()) for s in said) <= MAX_WORDS
    assert sum(len(s.split()) for s in (sentence(x) for x in studies)) > MAX_WORDS  # it bit
    one = answer(studies[:1])  # one regime fits with its sizes
    assert one == [sentence(studies[0])] and "tolerances)" in one[0]
    text = summary(studies, {"CTC": "the baseline", "CTC-best": "the fair one"}, "its metrics")
    # every term is defined before the answer uses it
    terms = text.index("**Terms.**")
    for word in ("*row*", "*tolerance*", "*typical shift*", "*equivalent*", "*split*",
                 "*not judged*", "*CTC-best*"):  # fmt: skip
        assert terms < text.index(word) < text.index("**The answer.**"), word
    assert "`CTC-best.csv` (CTC-best)" in text


def test_the_answer_figure_draws_the_tables_columns_and_prints_their_verdicts():
    from twolink.figures.answer import answer_figure, profiles_figure

    words = ["better", "worse", "equivalent except on a subset"] * 4
    est = [-0.05, 0.2, 0.0] * 4
    t = _table(words, est, [e - 0.01 for e in est], [e + 0.01 for e in est])
    fig = answer_figure([("raw steps", {"CTC": t})], "FCM-CTC", "the question")
    shift, shares, verdicts = fig.axes[:3]
    assert [x.get_text() for x in verdicts.texts] == words  # the table's words, in its order
    markers = next(line for line in shift.lines if line.get_marker() == "o")
    drawn = markers.get_xdata()  # the estimates, in tolerances
    assert np.asarray(drawn) == pytest.approx(np.array(est) / 0.01)
    labels = [x.get_text() for x in shift.get_yticklabels()]
    assert labels[0] == "θ1 Tp" and labels[-1] == "θ2 ess"
    rho = performance_profile(pd.DataFrame({"A": [1.0, 2.0], "B": [2.0, 1.0]}))
    assert len(profiles_figure([("IAE", rho)]).axes) == 1
