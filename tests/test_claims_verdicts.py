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
from twolink.studies.judgments.claims import judge as claims_judge

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


# The verdict rules no other unit test held (each on a case where its mutant changes the
# answer): the Bonferroni m, the half-of-plants quorum at exactly half, the distance to
# the move's own on the baseline's side and for Tp and Ts, Tr with Td beside (a pure lag),
# and claims.judge on the tables' own path.


def _family(columns: dict[str, tuple[np.ndarray, np.ndarray]]) -> pd.DataFrame:
    """One table of several metrics of joint 1: ``columns`` metric -> (CTC's, FCM-CTC's)."""
    rows = []
    for c, name in enumerate(("CTC", "FCM-CTC")):
        n = len(next(iter(columns.values()))[0])
        rows += [{"sample": i, "controller": name}
                 | {f"joint1_{k}": float(v[c][i]) for k, v in columns.items()}
                 for i in range(n)]  # fmt: skip
    return pd.DataFrame(rows)


def test_the_bonferroni_m_counts_the_rows_whose_typical_plant_is_judged():
    # Row A: 200 plants shifted so that the interval at 95 % (m = 1) clears +1 mrad and
    # the one at 97.5 % (m = 2) does not. Row B: a pair on 40 of the 200 plants only, its
    # typical plant not judged: it reads no interval and spends no α, so m = 1 and A is
    # worse. Counting every row with a plant (m = 2), A would be undecided.
    noise = stats.norm.ppf((np.arange(200) + 0.5) / 200) * 1.4 * MRAD
    low95, low975 = hodges_lehmann(noise, 0.95)[1], hodges_lehmann(noise, 0.975)[1]
    shift = MRAD - (low95 + low975) / 2
    d = shift + noise
    assert hodges_lehmann(d, 0.95)[1] > MRAD > hodges_lehmann(d, 0.975)[1]  # a real case
    few = np.full(200, np.nan)
    few[:40] = 0.01
    t = _family({"steady_state_error_rad": (np.full(200, 0.01), 0.01 + d),
                 "final_error_rad": (few, few + 2 * MRAD)})  # fmt: skip
    table = paired_claims(t, "FCM-CTC", "CTC", ["steady_state_error_rad", "final_error_rad"], [1])
    a, b = table.iloc[0], table.iloc[1]
    assert b["n"] == 40 and b["runs"] == 200 and b["typical"] == "not judged"
    assert a["ci_level"] == pytest.approx(0.95) and b["ci_level"] == pytest.approx(0.95)
    assert a["typical"] == "worse" and a["verdict"] == "worse"
    # with B judged (its pair on 100 of 200, exactly half), m = 2 and A is undecided
    few[:100] = 0.01
    t = _family({"steady_state_error_rad": (np.full(200, 0.01), 0.01 + d),
                 "final_error_rad": (few, few + 2 * MRAD)})  # fmt: skip
    table = paired_claims(t, "FCM-CTC", "CTC", ["steady_state_error_rad", "final_error_rad"], [1])
    assert table.iloc[0]["ci_level"] == pytest.approx(1 - 0.05 / 2)
    assert table.iloc[0]["typical"] == "undecided"


def test_the_typical_plant_is_judged_at_exactly_half_the_plants_not_below():
    for both, typical in ((100, "better"), (99, "not judged")):
        a, b = np.full(200, np.nan), np.full(200, np.nan)
        a[:both], b[:both] = 1.0, 1.5  # Ts→θd reached by both on `both` of 200, by neither else
        row = judge(a - b, "settling_time_target_s", base=b)
        assert row["n"] == both and row["runs"] == 200 and row["typical"] == typical
    assert row["verdict"] != "better"  # 99 of 200 better is not most plants


def _own(key: str, own: float, proposed: np.ndarray, baseline: np.ndarray) -> pd.Series:
    t = sweep(baseline, proposed, key)
    return paired_claims(t, "FCM-CTC", "CTC", [key], [1], reference_values={(1, key): own}).iloc[0]


def test_the_distance_to_the_moves_own_is_taken_on_the_baselines_side_too():
    # the move's own Td is 1 s: FCM-CTC 20 ms late, CTC 20 ms early: as far from the move
    # (equal); the baseline's raw Td against FCM-CTC's distance would read "better"
    rng = np.random.default_rng(6)
    jitter = rng.uniform(-2e-3, 2e-3, 200)
    row = _own("delay_time_s", 1.0, 1.02 + jitter, 0.98 - jitter)
    assert row["verdict"] == "equal" and row["baseline_median"] == pytest.approx(0.02, abs=3e-3)
    # on the move's own beside 50 ms early: better
    assert _own("delay_time_s", 1.0, 1.0 + jitter, 0.95 + jitter)["verdict"] == "better"


@pytest.mark.parametrize("key", ["peak_time_s", "settling_time_s", "settling_time_target_s"])
def test_an_early_time_on_a_moving_reference_is_worse_not_better(key):
    # Tp: FCM-CTC peaks 50 ms before the move's own 2 s, CTC on it. Ts: FCM-CTC "settles"
    # 21 ms before the quintic's own 1.73 s because it ends short of the target, CTC at it
    rng = np.random.default_rng(7)
    own, early = (2.0, 0.05) if key == "peak_time_s" else (1.73, 0.021)
    jitter = rng.uniform(-2e-3, 2e-3, 200)
    row = _own(key, own, own - early + jitter, own + jitter)
    assert row["verdict"] == "worse" and row["estimate"] == pytest.approx(early, abs=3e-3)
    assert row["reference"] == own
    assert f"judged by the distance to the reference's own {own:g} s" in row["reading"]


def _quintic_move(t: np.ndarray, start: float = 0.0, duration: float = 2.0) -> np.ndarray:
    s = np.clip((t - start) / duration, 0.0, 1.0)
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def test_a_pure_lag_is_worse_on_tr_not_equal():
    # A 2 s quintic move 0 -> 1 rad; FCM-CTC follows it 100 ms late (a pure lag), CTC on
    # it. The lag leaves the length of the rise as it is (|ΔTr| = 0: "equal" by the
    # distance of Tr alone); the rise, Td beside it, is 100 ms from the move's own.
    from twolink.simulation.metrics import step_metrics

    t = np.arange(0.0, 4.0, 1e-3)
    own = step_metrics(t, _quintic_move(t), 1.0)
    rng = np.random.default_rng(8)
    lagged, on = [], []
    for _ in range(40):
        lagged.append(step_metrics(t, _quintic_move(t, 0.1 + rng.uniform(0, 2e-3)), 1.0))
        on.append(step_metrics(t, _quintic_move(t, rng.uniform(0, 2e-3)), 1.0))
    tr = np.array([m.rise_time for m in lagged]), np.array([m.rise_time for m in on])
    td = np.array([m.delay_time for m in lagged]), np.array([m.delay_time for m in on])
    assert np.abs(tr[0] - own.rise_time).max() <= 2e-3  # the lag keeps Tr
    assert np.all(td[0] - own.delay_time > 0.099)
    t_ = pd.DataFrame(
        [{"sample": i, "controller": name, "joint1_rise_time_s": r[i], "joint1_delay_time_s": d[i]}
         for name, r, d in (("FCM-CTC", tr[0], td[0]), ("CTC", tr[1], td[1]))
         for i in range(40)]
    )  # fmt: skip
    refs = {(1, "rise_time_s"): own.rise_time, (1, "delay_time_s"): own.delay_time}
    row = paired_claims(t_, "FCM-CTC", "CTC", ["rise_time_s"], [1], reference_values=refs).iloc[0]
    assert row["verdict"] == "worse" and row["estimate"] == pytest.approx(0.1, abs=3e-3)
    assert "judged by the distance of the rise to the move's own" in row["reading"]
    # the same by claims.judge, the tables' own path
    one = claims_judge(tr[0], tr[1], "rise_time_s", own.rise_time,
                       delay=(td[0], td[1], own.delay_time))  # fmt: skip
    assert one["verdict"] == "worse" and one["estimate"] == row["estimate"]
    # Tr on a moving reference without Td is refused, not judged by |ΔTr|
    with pytest.raises(ValueError, match="is judged with Td beside it"):
        claims_judge(tr[0], tr[1], "rise_time_s", own.rise_time)


def test_claims_judge_applies_the_distance_rule_the_tables_apply():
    rng = np.random.default_rng(9)
    jitter = rng.uniform(-2e-3, 2e-3, 200)
    early, on = 1.95 + jitter, 2.0 + jitter  # an early peak against one on the move's own 2 s
    one = claims_judge(early, on, "peak_time_s", reference=2.0)
    row = _own("peak_time_s", 2.0, early, on)
    assert one["verdict"] == row["verdict"] == "worse"
    assert one["estimate"] == row["estimate"] and one["reference"] == 2.0
    # without the move's own, the raw times: earlier is lower
    assert claims_judge(early, on, "peak_time_s")["verdict"] == "better"
