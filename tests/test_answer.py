"""The answer at a glance (issue 46): performance profiles against their definition, the
summary's words on cases where each word would be wrong, and the answer figure drawn from
the tables' own columns and verdict words."""

import dataclasses

import numpy as np
import pandas as pd
import pytest

from twolink.studies.judgments.plain import (
    Regime,
    claim_line,
    claim_word,
    effort_words,
    pair_sentences,
    regime_sentences,
    same_controller,
)
from twolink.studies.reproduction.profiles import (
    costs,
    median_interval,
    performance_profile,
    scoreboard,
)
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


def test_the_verdicts_counted_are_the_conclusions_words_per_opponent_in_order():
    """Below the terms, per regime and opponent, the table's verdict words counted
    (conclusions.describe: sizes in the metric's unit, never in tolerances)."""
    from twolink.studies.judgments.conclusions import describe

    t = _plain_table(["better"] + ["equal"] * 11, [-0.05] + [0.0] * 11)
    b = _plain_table(["worse"] * 2 + ["equal"] * 10, [0.02, 0.003] + [0.0] * 10)
    said = sentence(_study({"CTC": t, "CTC-best": b}))
    assert said == (
        f"Quintic moves (200 plants): against CTC (12 rows), {describe(t)}; against CTC-best "
        f"(12 rows), {describe(b)}."
    )
    assert "better on θ1 Tp (−50 ms)" in said and "tolerance" not in said


def test_the_summary_opens_with_the_plain_answer_and_defines_each_word_it_uses():
    """The answer first (one paragraph per regime, then the claim), within its words for
    three regimes of two opponents each; then the terms, defining every word the answer
    uses; the verdicts counted below, in tolerances."""
    words = ["better", "worse", "equivalent", "split", "inconclusive", "set by the reference"]
    words = words * 2
    est = [-0.05, 0.05, 0.0, 0.002, 0.02, 0.0] * 2
    t = _plain_table(
        typical=["better", "worse", "equivalent", "equivalent", "undecided", "none"] * 2,
        estimate=est,
        verdict=words,
    )
    long = "rigid arm, the paper's raw steps at ωn = 3 rad/s"  # a regime without a short name
    tables = {n: (f"{n}.csv", t) for n in ("CTC", "CTC-best")}
    studies = [Judged(long, 200, "FCM-CTC", tables)] * 3
    said = answer(studies)
    assert len(said) == 4 and said[0].startswith("**Does FCM-CTC lower the step metrics?")
    assert sum(len(s.split()) for s in said) <= MAX_WORDS
    text = summary(studies, {"CTC": "the baseline", "CTC-best": "the fair one"}, "its metrics")
    assert text.index("**The answer.**") < text.index("**Terms.**") < text.index("counted.**")
    terms = text[text.index("**Terms.**") :]
    defined = ("*tolerance*", "*typical plant*", "*Beats*", "*Trade*", "*Undecided*",
               "*Do not differ on the typical plant*", "*The same controller*", "*CTC-best*",
               "*IAE1 + IAE2*", "*Less effort*")  # fmt: skip
    for word in defined:
        assert word in terms, word
    assert "tolerances" not in text  # sizes in the metrics' own units
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


STEP = ("peak_time_s", "delay_time_s", "settling_time_s", "rise_time_s", "overshoot_pct",
        "steady_state_error_rad")  # fmt: skip
TOL = {"overshoot_pct": 1.0, "steady_state_error_rad": 0.001, "torque_peak_Nm": 0.5,
       "torque_variation_Nm": 1.0}  # fmt: skip


def _plain_table(typical, estimate=None, metrics=STEP, **columns):
    """A claims table (docs/statistics.md's columns) of len(typical) rows over ``metrics``
    per joint, every plant equal unless a column says otherwise."""
    n = len(typical)
    keys = [(1 + i // len(metrics), metrics[i % len(metrics)]) for i in range(n)]
    tol = [TOL.get(k, 0.01) for _, k in keys]
    est = np.asarray(estimate if estimate is not None else [0.0] * n, float)
    t = pd.DataFrame({
        "joint": [j for j, _ in keys], "metric": [k for _, k in keys], "n": 200, "plants": 200,
        "tolerance": tol, "typical": typical, "estimate": est, "ci_low": est - 0.1 * np.abs(est),
        "ci_high": est + 0.1 * np.abs(est), "difference_min": -0.5 * np.array(tol),
        "difference_max": 0.5 * np.array(tol), "better": 0, "worse": 0, "unreached_better": 0,
        "unreached_worse": 0, "share_better_shown": False, "share_worse_shown": False,
        "reference": np.nan, "verdict": typical,
    })  # fmt: skip
    for name, value in columns.items():
        t[name] = value
    return t


def test_the_same_controller_only_where_every_plant_is_within_every_tolerance():
    """ "the same controller" would be wrong with one plant beyond one row's tolerance, or
    one time that only one side reaches."""
    t = _plain_table(["equivalent"] * 12)
    said = " ".join(pair_sentences(t, "FCM-CTC", "CTC", 200))
    assert said.startswith(
        "FCM-CTC and CTC are the same controller: no metric differs by more than its "
        "tolerance on any of 200 plants (at most 5 ms"
    )
    assert same_controller(t)
    one = t.copy()
    one.loc[11, "difference_max"] = 0.0011  # one plant 1.1 mrad off, past 1 mrad
    assert not same_controller(one)
    assert "same controller" not in " ".join(pair_sentences(one, "FCM-CTC", "CTC", 200))
    alone = t.copy()
    alone.loc[3, "unreached_worse"] = 1
    assert not same_controller(alone)
    assert not same_controller(t.assign(n=0))  # nothing compared: nothing the same


def test_beats_needs_the_typical_plant_beyond_the_tolerance_and_no_loss():
    """ "beats" would be wrong where the typical plant's interval crosses zero (a verdict
    carried by a share), and where the winner also loses a metric ("trade")."""
    typical = ["equivalent"] * 12
    typical[9] = "better"  # θ2 Tr: 80 ms lower on the typical plant
    est = [0.0] * 12
    est[9] = -0.08
    t = _plain_table(typical, est, better=[0] * 9 + [188] + [0] * 2,
                     difference_min=[-0.005] * 9 + [-0.2] + [-0.0005] * 2)  # fmt: skip
    said = pair_sentences(t, "FCM-CTC", "CTC", 200)
    assert said[0] == "FCM-CTC beats CTC on 1 of 12 step metrics and loses on none."
    assert said[1] == ("FCM-CTC's θ2 Tr is 80 ms lower on the typical plant, and lower by "
                       "more than 10 ms on 188 of 200 plants.")  # fmt: skip
    # the same row called "better" by its share, its typical plant undecided (crossing 0)
    shares = t.copy()
    crossing = ["undecided", "better", -0.1, 0.02]
    shares.loc[9, ["typical", "verdict", "ci_low", "ci_high"]] = crossing
    shares.loc[9, "share_better_shown"] = True
    said = " ".join(pair_sentences(shares, "FCM-CTC", "CTC", 200))
    assert "beats" not in said
    assert said.startswith(
        "FCM-CTC and CTC do not differ on the typical plant (11 of 12 step metrics within "
        "their tolerance, 1 undecided)."
    )
    assert "FCM-CTC is ahead by more than 10 ms on up to 188 of 200 plants (θ2 Tr)." in said
    lost = t.copy()
    lost.loc[11, ["typical", "estimate", "worse"]] = ["worse", 0.004, 150]
    said = " ".join(pair_sentences(lost, "FCM-CTC", "CTC", 200))
    assert "beats" not in said
    assert said.startswith(
        "FCM-CTC and CTC trade: FCM-CTC is better on 1 and worse on 1 of 12 step metrics."
    )
    assert (
        "CTC's θ2 ess is 4 mrad lower on the typical plant, and lower by more than 1 mrad on 150"
        in said
    )
    flipped = t.assign(typical=["worse" if x == "better" else x for x in t["typical"]],
                       estimate=-t["estimate"], worse=t["better"], better=0)  # fmt: skip
    said = pair_sentences(flipped, "FCM-CTC", "CTC-best", 200)
    assert said[0] == "CTC-best beats FCM-CTC on 1 of 12 step metrics and loses on none."
    assert "on 188 of 200 plants" in said[1]


def test_a_time_judged_against_the_move_is_closer_to_it_not_lower():
    typical = ["equivalent"] * 12
    typical[1] = "better"
    t = _plain_table(typical, [0.0, -0.03] + [0.0] * 10, better=[0, 120] + [0] * 10,
                     reference=[np.nan, 1.0] + [np.nan] * 10,
                     difference_min=[-0.005, -0.05] + [-0.0005] * 10)  # fmt: skip
    said = pair_sentences(t, "FCM-CTC", "CTC", 200)[1]
    assert "θ1 Td is 30 ms closer to the move's own on the typical plant" in said
    assert "lower" not in said


def test_effort_is_less_more_the_same_or_unsaid_by_its_typical_plant():
    """From the winner's side; "the same" would be wrong with one undecided row, "less"
    with one row worse."""
    effort = ("torque_peak_Nm", "torque_variation_Nm")
    rows = _plain_table(["equivalent", "better", "equivalent", "equivalent"],
                        [0.0, -24.0, 0.0, 0.0], metrics=effort)  # fmt: skip
    assert effort_words(rows, True) == ", at less effort (θ1 Σ|Δτ| 24 N·m lower)"
    assert effort_words(rows, False) == ", at more effort (θ1 Σ|Δτ| 24 N·m higher)"
    assert effort_words(rows.assign(typical="equivalent"), True) == ", at the same effort"
    undecided = rows.assign(typical=["equivalent", "equivalent", "undecided", "equivalent"])
    assert effort_words(undecided, True) == ""
    mixed = rows.assign(typical=["worse", "better", "equivalent", "equivalent"])
    assert effort_words(mixed, True) == ""
    assert effort_words(_plain_table(["equivalent"] * 12), True) == ""  # no effort rows


def _regime(name, tables, iae=None):
    return Regime(name, 200, "FCM-CTC", tables, iae or {})


def test_the_strongest_opponent_is_the_tables_lowest_median_iae_and_only_an_opponent():
    """Named by median IAE1 + IAE2 among the tables' opponents: a controller of the sweep
    that is no opponent (CTC-I here, lower still) is not named, nor the proposed one."""
    t = _plain_table(["equivalent"] * 12)
    tables = {"CTC": t, "CTC-best": t, "SMC": t}
    iae = {"CTC": 0.08, "CTC-best": 0.019, "SMC": 0.03, "CTC-I": 0.01, "FCM-CTC": 0.081}
    said = regime_sentences(_regime("quintic moves", tables, iae))
    named = [s for s in said if "strongest" in s]
    assert named == ["CTC-best is the strongest opponent: median IAE1 + IAE2 19 mrad·s "
                     "against FCM-CTC's 81 mrad·s."]  # fmt: skip
    assert not any("SMC" in s for s in said)  # the baseline and the strongest only
    # unknown medians: every opponent is said
    assert sum("same controller" in s for s in regime_sentences(_regime("x", tables))) == 3


def test_the_claim_holds_where_it_beats_the_opponent_and_says_where():
    """ "holds" would be wrong where the proposed loses a metric (a trade) or wins none."""
    win = _plain_table(["better"] + ["equivalent"] * 11, [-0.05] + [0.0] * 11)
    trade = win.assign(typical=["better"] + ["equivalent"] * 10 + ["worse"])
    none = _plain_table(["equivalent"] * 12)
    regimes = [
        _regime("quintic moves", {"CTC": none, "CTC-best": trade}),
        _regime("raw steps", {"CTC": win, "CTC-best": trade}),
        _regime("lab arm", {"CTC": none, "CTC-best": none}),
    ]
    assert claim_line(regimes) == (
        "**Does FCM-CTC lower the step metrics? In part.** Against CTC it holds on "
        "raw steps only. Against CTC-best it holds in no regime."
    )
    every = [_regime(n, {"CTC": win, "SMC": win}) for n in ("a", "b")]
    assert claim_line(every) == (
        "**Does FCM-CTC lower the step metrics? Yes.** Against CTC and SMC it holds in every "
        "regime."
    )
    nowhere = [_regime(n, {"CTC": trade, "SMC": none}) for n in ("a", "b")]
    assert claim_line(nowhere).startswith("**Does FCM-CTC lower the step metrics? No.**")


def test_the_claims_word_is_yes_only_everywhere_and_no_only_nowhere():
    """ "Yes" would be wrong where one opponent or regime fails it, "No" where one holds."""
    assert claim_word(["in every regime"]) == "Yes"
    assert claim_word(["in every regime", "on raw steps only"]) == "In part"
    assert claim_word(["in every regime", "in no regime"]) == "In part"
    assert claim_word(["in no regime"]) == "No"
    assert claim_word(["in no regime", "on raw steps only"]) == "In part"


def test_the_medians_interval_is_the_order_statistics_binomial_interval():
    """Against its definition: [x_(j), x_(n−j+1)] with P(Bin(n, ½) < j) ≤ 2.5 %; n = 200
    gives j = 86 (Conover's table: the 86th and 115th values); its coverage checked on
    draws from a known median."""
    from scipy.stats import binom

    x = np.arange(1.0, 201.0)
    median, low, high = median_interval(x[::-1])
    assert (median, low, high) == (100.5, 86.0, 115.0)
    assert binom.cdf(85, 200, 0.5) <= 0.025 < binom.cdf(86, 200, 0.5)
    rng = np.random.default_rng(5)
    bounds = [median_interval(rng.normal(size=60))[1:] for _ in range(4000)]
    covered = np.mean([lo <= 0 <= hi for lo, hi in bounds])
    j = int(binom.ppf(0.025, 60, 0.5))
    exact = 1 - 2 * binom.cdf(j - 1, 60, 0.5)  # the coverage of [x_(j), x_(n−j+1)]
    assert 0.95 <= exact < 0.98 and abs(covered - exact) < 0.01
    assert np.isnan(median_interval(np.ones(4))[1])  # too few values for a 95 % interval


def test_the_scoreboard_ranks_by_median_iae_and_names_a_best_only_where_it_is_clear():
    from twolink.figures.scoreboard import best_in, scoreboard_figure

    rng = np.random.default_rng(2)
    rows = []
    keys = [f"joint{j}_{k}" for j in (1, 2) for k in ("iae_rad_s", "torque_peak_Nm",
                                                      "torque_variation_Nm")]  # fmt: skip
    for name, scale in (("slow", 3.0), ("fast", 1.0), ("same", 1.02)):
        for sample in range(100):
            values = {k: scale * rng.lognormal() for k in keys}
            rows.append({"sample": sample, "controller": name, "status": "ok", **values})
    board = scoreboard(pd.DataFrame(rows))
    order = list(dict.fromkeys(board["controller"]))
    assert order[2] == "slow" and set(order[:2]) == {"fast", "same"}
    panel = board[(board["metric"] == "iae_rad_s") & (board["joint"] == 1)]
    assert best_in(panel) is None  # "fast" and "same" overlap: no clear best
    clear = panel[panel["controller"] != "same"]
    assert best_in(clear) == "fast"
    fig = scoreboard_figure([("quintic moves", board)])
    assert len(fig.axes) == 6 and "best: none clear" in fig.axes[0].get_title()
    # every controller of the sweep is drawn; "(over effort)" only beside those named so
    fig = scoreboard_figure([("quintic moves", board)], over={"quintic moves": {"fast"}})
    names = [t.get_text() for t in fig.axes[0].get_yticklabels()]
    assert sorted(names) == ["fast (over effort)", "same", "slow"]
    fig = scoreboard_figure([("quintic moves", board)], over={"lab arm": {"fast"}})
    assert "fast" in [t.get_text() for t in fig.axes[0].get_yticklabels()]


def test_the_first_line_says_what_off_target_counts_and_whether_it_is_expected():
    """ "is expected here" would be wrong where the proposed controller or its baseline
    misses its target on the plain rigid arm; "which the laws model as rigid" where a
    flexible-joint law is among the off-target runs."""
    from twolink.studies.judgments.plain import runs_line
    from twolink.studies.reproduction.manifest import load_manifest

    m = load_manifest()
    rows = [
        {"variant": "rigid", "controller": "fuzzy-PD", "outcome": "off target", "status": "ok"},
        {"variant": "rigid", "controller": "CTC", "outcome": "met spec", "status": "ok"},
        {"variant": "raw", "controller": "CTC", "outcome": "off target", "status": "ok"},
        {"variant": "flexible", "controller": "FCM-CTC", "outcome": "off target", "status": "ok"},
    ]
    line = runs_line(rows, m, "out/summary.md")
    assert line.startswith("4 runs: 1 met the spec, 3 off target, 0 diverged. Off target ")
    assert "(outside 2 % of the target at the end, growing, or overshooting 20 %)" in line
    assert " is expected here: 1 of weak baselines on the rigid arm (fuzzy-PD 1); " in line
    assert "1 on the rigid arm, the paper's raw steps" in line
    assert (
        "1 on the flexible joints (Spong, k = 500 N·m/rad), which the laws model as rigid" in line
    )
    assert line.endswith("The answer: out/summary.md")
    bad = [*rows, {"variant": "rigid", "controller": "FCM-CTC", "outcome": "off target",
                   "status": "ok"}]  # fmt: skip
    line = runs_line(bad, m, "out/summary.md")
    assert "expected here" not in line and "unexpected: FCM-CTC 1 on the rigid arm" in line
    flexible = dataclasses.replace(
        m, controllers={**m.controllers, "FCM-CTC": {"kind": "flexible_fl"}}
    )
    assert "model as rigid" not in runs_line(rows, flexible, "s.md")
    clean = [r for r in rows if r["outcome"] == "met spec"]
    assert (
        runs_line(clean, m, "s.md")
        == "1 run: 1 met the spec, 0 off target, 0 diverged. The answer: s.md"
    )


def test_the_readme_is_a_front_door():
    """At most 120 lines; the two commands as .ci/run runs the test one; one library
    block; the answer block and its two pictures; links to the docs that exist."""
    import re
    from pathlib import Path

    repo = Path(__file__).resolve().parents[1]
    readme = (repo / "README.md").read_text()
    assert len(readme.splitlines()) <= 120
    venv = "python3 -m venv .venv && .venv/bin/pip install -q -e"
    tests = f'{venv} ".[test]" && .venv/bin/python -m pytest'
    assert readme.count("```bash") == 2 and tests in readme
    assert f"\n{tests}\n" in (repo / ".ci" / "run").read_text()
    assert (
        "python3 -m venv .venv && .venv/bin/pip install -q -e . && .venv/bin/twolink reproduce"
        in readme
    )
    assert readme.count("```python") == 1
    assert readme.index("<!-- answer: start -->") < readme.index("docs/images/scoreboard.png")
    for link in re.findall(r"\]\((docs/[^)#]+)", readme):
        assert (repo / link).is_file(), link


def _ranking(rows):
    """ranking.csv's columns the words read: (controller, index, within[, failed])."""
    cols = ["controller", "index", "within", "failed"]
    return pd.DataFrame([(*r, 0)[:4] for r in rows], columns=cols)


def _ranked_regime(rows, names=("CTC", "CTC-best", "SL-best", "SMC-best")):
    typical, est = ["equivalent"] * 11 + ["better"], [0.0] * 11 + [-0.05]
    t = _plain_table(typical, est, difference_min=-1.0, difference_max=1.0)
    tables = dict.fromkeys(names, t)
    return Regime("lab arm", 200, "FCM-CTC", tables, ranking=_ranking(rows))


# in the table's order on purpose: the words must follow the index, not the rows
OVER = [("FCM-CTC", 0.08, True), ("CTC", 0.09, True), ("CTC-best", 0.02, True),
        ("SL-best", 0.005, False), ("SMC-best", 0.01, False)]  # fmt: skip


def test_an_opponent_over_the_effort_is_never_the_strongest_at_equal_effort():
    """The lowest index is SL-best's, but its effort is over FCM-CTC's: CTC-best is the
    strongest within the effort, and SL-best and SMC-best are "lower still but spend
    more"."""
    from twolink.studies.judgments.plain import over_budget, strongest

    regime = _ranked_regime(OVER)
    assert strongest(regime) == "CTC-best"
    assert list(over_budget(regime)["controller"]) == ["SL-best", "SMC-best"]
    said = " ".join(regime_sentences(regime))
    assert (
        "CTC-best is the strongest opponent within FCM-CTC's effort: median IAE1 + IAE2 "
        "20 mrad·s against FCM-CTC's 80 mrad·s, 4th of 5."
    ) in said
    assert "SL-best and SMC-best are lower still but spend more than FCM-CTC." in said
    assert "SL-best is the strongest" not in said
    assert "FCM-CTC beats CTC-best on 1 of 12 step metrics" in said  # against the strongest


def test_the_ranking_follows_the_index_and_places_the_proposed_one_among_all():
    from twolink.studies.judgments.plain import ranking_sentence

    said = ranking_sentence(_ranked_regime(OVER))
    assert said == (
        "Lowest median IAE1 + IAE2: SL-best 5, SMC-best 10 and CTC-best 20 mrad·s; "
        "FCM-CTC 80 mrad·s, 4th of 5."
    )
    # a unit is said once per run of values that share it, never dropped where it changes
    mixed = _ranked_regime([("FCM-CTC", 2.4, True), ("SL-best", 0.0013, True)])
    assert ranking_sentence(mixed).startswith("Lowest median IAE1 + IAE2: SL-best 1.3 mrad·s")


def test_a_law_that_failed_on_plants_is_said_to_fail_not_to_spend_more():
    rows = [("FCM-CTC", 0.08, True), ("CTC", 0.09, True), ("CTC-best", 0.02, True),
            ("SL-best", 0.005, False, 3)]  # fmt: skip
    said = " ".join(regime_sentences(_ranked_regime(rows, ("CTC", "CTC-best", "SL-best"))))
    assert "SL-best fails on 3 plants." in said and "spend" not in said


def test_with_no_opponent_within_the_effort_none_is_the_strongest():
    rows = [("FCM-CTC", 0.08, True), ("CTC", 0.09, False), ("SL-best", 0.005, False)]
    from twolink.studies.judgments.plain import ranking_sentence

    regime = _ranked_regime(rows, ("CTC", "SL-best"))
    said = " ".join(regime_sentences(regime))
    assert "No judged opponent is within FCM-CTC's effort." in said
    # FCM-CTC among the three: its value said once
    assert ranking_sentence(regime).endswith(
        "SL-best 5, FCM-CTC 80 and CTC 90 mrad·s (FCM-CTC 2nd of 3)."
    )
    assert "SL-best is lower but spends more than FCM-CTC." in said
    assert "strongest" not in said and "lower still" not in said


def test_a_controller_the_answer_does_not_judge_is_ranked_but_never_the_strongest():
    """PD-G has the lowest index but no claims table: it heads the ranking, and the
    strongest opponent is the lowest judged one."""
    from twolink.studies.judgments.plain import ranking_sentence, strongest

    regime = _ranked_regime([*OVER, ("PD-G", 0.001, True)])
    assert strongest(regime) == "CTC-best"
    assert ranking_sentence(regime).startswith("Lowest median IAE1 + IAE2: PD-G 1, SL-best 5")


def test_three_ranked_regimes_with_five_opponents_stay_within_the_answers_words():
    t = _plain_table(["better", "worse"] + ["equivalent"] * 10, [-0.05, 0.05] + [0.0] * 10)
    names = ("CTC", "CTC-best", "SL-best", "SMC-best")
    tables = {n: (f"{n}.csv", t) for n in names}
    studies = [Judged("lab arm", 200, "FCM-CTC", tables, ranking=_ranking(OVER))] * 3
    said = answer(studies)
    assert sum(len(s.split()) for s in said) <= MAX_WORDS
    assert all("lower still but spend more" in s for s in said[1:])


def test_the_proposed_controllers_place_is_an_english_ordinal():
    from twolink.studies.judgments.plain import ranking_sentence

    for k, nth in ((1, "1st"), (2, "2nd"), (3, "3rd"), (11, "11th"), (12, "12th"), (21, "21st")):
        rows = [(f"L{i}", 0.001 * i, True) for i in range(1, k)] + [("FCM-CTC", 0.5, True)]
        said = ranking_sentence(_ranked_regime(rows, ("L1",) if k > 1 else ("CTC",)))
        assert f" {nth} of {k}" in said, said
