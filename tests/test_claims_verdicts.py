"""The verdict rule on synthetic paired data whose answer is known (issue 37, "Must show"):
a practical size before "better"/"worse", a mixture read as a share, never a verdict
against its own estimate, the tolerance's edge, plants only one controller reaches, and
every table of a study at once equal to the per-table statistics of before."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from twolink.studies.judgments.claims import (
    MIN_SHARE,
    count_wins,
    hodges_lehmann,
    paired_claims,
    paired_claims_many,
    proportion_interval,
)

MRAD = 1e-3  # the tolerance of the angles


def sweep(baseline, proposed, metric="steady_state_error_rad"):
    rows = []
    for name, values in (("CTC", baseline), ("FCM-CTC", proposed)):
        rows += [
            {"sample": i, "controller": name, f"joint1_{metric}": v} for i, v in enumerate(values)
        ]
    return pd.DataFrame(rows)


def judge(d, metric="steady_state_error_rad", base=None):
    d = np.asarray(d, dtype=float)
    base = np.full(d.size, 0.01) if base is None else base
    return paired_claims(sweep(base, base + d, metric), "FCM-CTC", "CTC", [metric], [1]).iloc[0]


def test_a_tiny_consistent_shift_is_neither_better_nor_worse():
    # The ess case: −1.3 µrad on the typical plant, 10 plants beyond 1 mrad (all
    # one way): the sign test alone (10 to 0) once called it "better".
    rng = np.random.default_rng(0)
    d = -1.3e-6 + rng.normal(0, 1e-7, 200)
    d[:10] = -1.5 * MRAD
    row = judge(d)
    assert (row["better"], row["worse"]) == (10, 0) and row["p_adjusted"] < 0.01
    assert row["verdict"] == "equivalent" and row["typical"] == "equivalent"
    assert abs(row["estimate"]) < 1e-5 and not row["share_better_shown"]


def test_half_the_plants_worse_by_twice_the_tolerance_reads_worse():
    d = np.zeros(200)
    d[::2] = 2 * MRAD
    row = judge(d)
    # the typical plant on the margin (undecided); half the plants is not most of them
    assert row["typical"] == "undecided" and row["verdict"] == "partly worse"
    assert row["estimate"] > 0 and row["share_worse"] == 0.5 and row["share_worse_shown"]
    assert "worse by more than 1 mrad on 100 of 200" in row["reading"]


def test_a_limit_cycle_on_15_percent_of_plants_is_said_as_a_share():
    rng = np.random.default_rng(1)
    d = np.zeros(200)
    cycle = rng.choice(200, 30, replace=False)
    d[cycle] = rng.uniform(2, 6.5, 30) * MRAD  # oscillation, up to 6.5 mrad
    row = judge(d, "oscillation_rad")
    # 15 % of the plants oscillate, none the other way: one-sided, not a split
    assert row["typical"] == "equivalent" and row["estimate"] == pytest.approx(0, abs=1e-4)
    assert row["verdict"] == "partly worse"
    assert row["reading"].startswith(
        "equivalent on the typical plant; worse by more than 1 mrad on 30 of 200"
    )
    ci = stats.binomtest(30, 200).proportion_ci(0.95, method="exact")
    assert row["share_worse"] == 0.15
    assert (row["share_worse_low"], row["share_worse_high"]) == pytest.approx((ci.low, ci.high))


def test_a_count_against_the_estimate_never_makes_the_verdict():
    # The peak torque: "worse" at −0.23 N·m [−0.26, −0.11]: most plants a little
    # better (within the tolerance), a few worse beyond it.
    rng = np.random.default_rng(2)
    d = -0.23 + rng.normal(0, 0.05, 200)
    d[:20] = 1.0
    row = judge(d, "torque_peak_Nm", base=np.full(200, 20.0))
    assert row["worse"] == 20 and row["better"] == 0 and row["ci_high"] < 0
    assert row["verdict"] == "equivalent"
    assert "worse by more than 0.5 N·m on 20 of 200" in row["reading"]
    # beyond the margin on the typical plant, worse on a tenth: better, the tenth said
    d = np.r_[np.full(180, -1.5), np.full(20, 2.0)]
    row = judge(d, "torque_peak_Nm", base=np.full(200, 20.0))
    assert row["verdict"] == "better" and row["reading"] == (
        "better on the typical plant; better by more than 0.5 N·m on 180 of 200 (85-94 %); "
        "worse by more than 0.5 N·m on 20 of 200 (6-15 %)"
    )
    # a quarter worse: the typical plant (the interval reaches the quarter) undecided,
    # both shares said; three quarters better is most plants: better
    d = np.r_[np.full(150, -1.5), np.full(50, 2.0)]
    row = judge(d, "torque_peak_Nm", base=np.full(200, 20.0))
    assert row["typical"] == "undecided" and row["verdict"] == "better"
    assert "on 150 of 200" in row["reading"] and "on 50 of 200" in row["reading"]
    # half better, a third worse: neither most nor one way: split
    d = np.r_[np.full(100, -1.5), np.full(66, 2.0), np.zeros(34)]
    row = judge(d, "torque_peak_Nm", base=np.full(200, 20.0))
    assert row["typical"] == "undecided" and row["verdict"] == "split"


def test_no_verdict_points_against_its_estimate_on_random_mixtures():
    rng = np.random.default_rng(3)
    for _ in range(150):
        n = int(rng.integers(8, 200))
        k = int(rng.integers(0, n + 1))
        d = np.where(np.arange(n) < k, rng.normal(rng.uniform(-3, 3), rng.uniform(0, 2), n), 0)
        d += rng.normal(rng.uniform(-1.5, 1.5), rng.uniform(0, 1), n) * (rng.random() < 0.5)
        row = judge(d * MRAD)
        if row["verdict"] == "better":
            assert not row["estimate"] > 0
        if row["verdict"] == "worse":
            assert not row["estimate"] < 0


def test_twelve_plants_are_undecided():
    rng = np.random.default_rng(4)
    d = rng.normal(1.5, 1.5, 12) * MRAD
    row = judge(d)
    assert row["n"] == 12 and row["worse"] >= 6 and row["verdict"] == "undecided"
    assert row["ci_low"] < MRAD < row["ci_high"]


def test_a_difference_of_exactly_the_tolerance_is_equal():
    # 1.5 − 0.5 is exactly 1.0: "by more than" the tolerance is strictly more
    assert count_wins([1.5, -0.5], [0.5, 0.5], 1.0) == (0, 0, 2)
    base = np.full(200, 0.5)
    row = paired_claims(sweep(base, base + 1.0, "overshoot_pct"), "FCM-CTC", "CTC",
                        ["overshoot_pct"], [1]).iloc[0]  # fmt: skip
    assert (row["better"], row["worse"], row["equal"]) == (0, 0, 200)
    row = paired_claims(sweep(base + 1.0, base, "overshoot_pct"), "FCM-CTC", "CTC",
                        ["overshoot_pct"], [1]).iloc[0]  # fmt: skip
    assert (row["better"], row["worse"], row["equal"]) == (0, 0, 200)
    # on the margin itself no plant differs by more than δ: equal, never "worse"
    assert row["share_worse"] == 0 and row["verdict"] == "equal"


def test_a_time_only_one_controller_reaches_counts_against_the_other():
    rng = np.random.default_rng(5)
    base = rng.uniform(1.0, 1.5, 200)
    prop = base.copy()
    prop[:12] = np.nan  # FCM-CTC never settles on 12 plants where CTC does
    base[190:] = np.nan  # ... and CTC on 10 where FCM-CTC does
    table = sweep(base, prop, "settling_time_s")
    row = paired_claims(table, "FCM-CTC", "CTC", ["settling_time_s"], [1]).iloc[0]
    assert (row["n"], row["unreached_worse"], row["unreached_better"]) == (178, 12, 10)
    assert row["plants"] == 200 and row["share_worse"] == 12 / 200
    assert "FCM-CTC never reaches it on 12 where CTC does" in row["reading"]
    # no peak is no failure: Tp's NaN is not counted against anyone
    table = sweep(base, prop, "peak_time_s")
    row = paired_claims(table, "FCM-CTC", "CTC", ["peak_time_s"], [1]).iloc[0]
    assert (row["unreached_worse"], row["unreached_better"], row["plants"]) == (0, 0, 178)
    # a controller that never settles anywhere is worse, not "undefined"
    row = judge(np.full(200, np.nan), "settling_time_s", base=np.ones(200))
    assert row["n"] == 0 and row["verdict"] == "worse" and row["share_worse"] == 1
    assert row["reading"].startswith("worse by more than 10 ms or alone in reaching it on 200")


def test_the_share_intervals_are_binomtests_clopper_pearson():
    for k, n in [(0, 200), (29, 200), (200, 200), (3, 12), (97, 200), (1, 1)]:
        ci = stats.binomtest(k, n).proportion_ci(0.95, method="exact")
        low, high = proportion_interval(np.array([k]), np.array([n]))
        assert abs(low[0] - ci.low) < 1e-10 and abs(high[0] - ci.high) < 1e-10
    assert MIN_SHARE == 0.05


def _before():
    path = Path(__file__).resolve().parents[1] / "benchmarks" / "claims_before.py"
    spec = importlib.util.spec_from_file_location("claims_before", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_all_tables_at_once_equal_the_statistics_of_before_to_the_digit():
    # cells of a regime map with NaNs, ties at zero, unequal cells and a missing run
    rng = np.random.default_rng(6)
    metrics = ["settling_time_target_s", "max_error_rad", "torque_peak_Nm", "oscillation_rad"]
    names = ["CTC", "CTC-I", "FCM-CTC"]
    rows = []
    for s in range(150):
        for name in names:
            if s == 7 and name == "CTC-I":
                continue
            row = {"sample": s, "controller": name, "cell": s % 3, "status": "ok"}
            for j in (1, 2):
                for m in metrics:
                    v = rng.normal(1.0, 0.3) * (2 * MRAD if "rad" in m else 1.0)
                    v = 0.0 if (m == "oscillation_rad" and rng.random() < 0.5) else v
                    row[f"joint{j}_{m}"] = np.nan if rng.random() < 0.05 else v
            rows.append(row)
    table = pd.DataFrame(rows)
    before = _before()
    pairs = [("FCM-CTC", "CTC"), ("FCM-CTC", "CTC-I")]
    new = paired_claims_many(table, pairs, metrics, by=["cell"])
    old = pd.concat(
        [
            before.paired_claims(frame, p, o, metrics)
            for _, frame in table.groupby("cell")
            for p, o in pairs
        ],
        ignore_index=True,
    )
    columns = ["n", "better", "worse", "equal", "proposed_median", "baseline_median",
               "estimate", "p_value", "tost_p", "p_adjusted", "tost_p_adjusted"]  # fmt: skip
    for c in columns:
        assert np.array_equal(old[c].to_numpy(float), new[c].to_numpy(float), equal_nan=True), c
    # the interval is now the one the verdict reads: Bonferroni's over the family's judged
    # rows (8 here), each row's equal to the one-row function's at that level
    assert set(new["ci_level"]) == {1 - 0.05 / 8}
    for i, (cell, p, o, j, m) in enumerate(
        new[["cell", "proposed", "opponent", "joint", "metric"]].itertuples(index=False)
    ):
        mine = table[table["cell"] == cell].set_index(["sample", "controller"])[f"joint{j}_{m}"]
        d = (mine.xs(p, level=1) - mine.xs(o, level=1)).dropna().to_numpy()
        want = hodges_lehmann(d, 1 - 0.05 / 8)[1:]
        assert (new["ci_low"][i], new["ci_high"][i]) == pytest.approx(want, rel=1e-12), i


def test_the_sign_test_of_arrays_is_binomtest_to_the_bit():
    from twolink.studies.judgments.claims import _sign_ps

    pairs = [(k, n) for n in range(1, 61) for k in range(n + 1)]
    pairs += [(k, 200) for k in range(0, 201, 7)] + [(0, 0)]
    k, n = np.array(pairs).T
    expected = [stats.binomtest(a, b, 0.5).pvalue if b else 1.0 for a, b in pairs]
    assert np.array_equal(_sign_ps(k, n - k), np.array(expected))
