"""Paired statistics of claims, on synthetic sweeps whose true answer is known: verdicts,
the zero-inflated case, Holm's correction, equivalence, and the statistics' own error
rates by simulation (the full table: benchmarks/stats_validation.py, docs/statistics.md)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from twolink.studies.judgments.claims import (
    _sign_p,
    _tost_p,
    count_wins,
    hodges_lehmann,
    holm,
    paired_claims,
)

COLUMNS = ("better", "worse", "equal", "estimate", "ci_low", "ci_high", "p_adjusted", "verdict")


def sweep(baseline: np.ndarray, proposed: np.ndarray, metric: str = "overshoot_pct"):
    """A results table of two controllers on the same plants (joint 1 only)."""
    rows = []
    for name, values in (("CTC", baseline), ("FCM-CTC", proposed)):
        rows += [
            {"sample": i, "controller": name, f"joint1_{metric}": v} for i, v in enumerate(values)
        ]
    return pd.DataFrame(rows)


def judge(table, metric="overshoot_pct", **kw):
    return paired_claims(table, "FCM-CTC", "CTC", metrics=[metric], joints=[1], **kw).iloc[0]


def test_the_tables_have_the_columns_a_statistician_reads():
    rng = np.random.default_rng(0)
    out = paired_claims(sweep(rng.uniform(0, 9, 50), rng.uniform(0, 9, 50)), "FCM-CTC", "CTC",
                        metrics=["overshoot_pct"], joints=[1])  # fmt: skip
    assert set(COLUMNS) <= set(out.columns)


def test_zero_inflated_97_worse_0_better_reads_worse():
    # The case: FCM-CTC's peak torque higher on 97 plants, equal (exactly) on 103;
    # the median paired difference is 0, which once read as "rounding".
    rng = np.random.default_rng(1)
    base = rng.uniform(20, 30, 200)
    prop = base.copy()
    hit = rng.choice(200, 97, replace=False)
    prop[hit] += rng.uniform(0.6, 5.0, 97)
    assert np.median(prop - base) == 0
    row = judge(sweep(base, prop, "torque_peak_Nm"), "torque_peak_Nm")
    assert (row["better"], row["worse"], row["equal"]) == (0, 97, 103)
    assert row["p_adjusted"] < 1e-25 and row["verdict"] == "worse"
    assert row["estimate"] > 0 and row["ci_low"] > 0  # Hodges-Lehmann sees the shift


def test_a_real_improvement_is_better_and_its_interval_holds_the_true_shift():
    rng = np.random.default_rng(1)
    base = rng.uniform(5, 15, 300)  # plant-to-plant spread much larger than the effect
    row = judge(sweep(base, base - 3.0 + rng.normal(0, 1.0, 300)))
    assert row["verdict"] == "better" and row["n"] == 300
    assert row["ci_low"] < -3.0 < row["ci_high"] < 0


def test_no_effect_is_split_or_equivalent_never_a_win():
    rng = np.random.default_rng(3)
    base = rng.uniform(5, 15, 300)
    row = judge(sweep(base, base + rng.normal(0, 10.0, 300)))  # noisy: ±1 % either way
    assert row["verdict"] == "split" and row["ci_low"] < 0 < row["ci_high"]
    assert row["share_better_shown"] and row["share_worse_shown"]
    d = rng.normal(0, 0.3, 300)
    row = judge(sweep(base, base + d))  # tight: within ±1 % of Mp on every plant: equal
    assert row["verdict"] == "equal" and row["typical"] == "equivalent"
    d[:5] = 1.5  # 5 of 300 beyond: equivalent
    row = judge(sweep(base, base + d))
    assert row["verdict"] == "equivalent" and (row["better"], row["worse"]) == (0, 5)


def test_identical_metrics_are_equal_with_no_wins():
    zeros = np.zeros(200)
    row = judge(sweep(zeros, zeros))
    assert (row["better"], row["worse"], row["equal"]) == (0, 0, 200)
    assert row["verdict"] == "equal" and row["typical"] == "equivalent" and row["estimate"] == 0


def test_a_value_both_take_from_the_reference_is_judged_by_its_distance():
    td = np.full(100, 1.0)  # both controllers' delay time is the quintic move's own
    row = judge(sweep(td, td + 1e-4, "delay_time_s"), "delay_time_s",
                reference_values={(1, "delay_time_s"): 1.0})  # fmt: skip
    assert row["verdict"] == "equal" and row["reference"] == 1.0
    assert row["proposed_median"] == pytest.approx(1e-4) and row["baseline_median"] == 0
    # the move's own value on the typical plant hides no share: 48 of 200 farther by 20 ms
    td = np.full(200, 1.0)
    late = td.copy()
    late[:48] += 0.02
    row = judge(sweep(td, late, "delay_time_s"), "delay_time_s",
                reference_values={(1, "delay_time_s"): 1.0})  # fmt: skip
    assert row["verdict"] == "partly worse" and row["typical"] != "worse"
    assert "worse by more than 10 ms on 48 of 200" in row["reading"]


def test_a_metric_no_plant_has_is_not_judged():
    nan = np.full(50, np.nan)
    row = judge(sweep(nan, nan, "peak_time_s"), "peak_time_s")
    assert row["n"] == 0 and row["verdict"] == "not judged" and row["typical"] == "not judged"


def test_holm_against_statsmodels_formula_and_across_a_family():
    p = [0.01, 0.04, 0.03, 0.005, np.nan]
    # Holm by hand: sorted 0.005, 0.01, 0.03, 0.04 times 4, 3, 2, 1, running maximum
    assert holm(p)[:4] == pytest.approx([0.03, 0.06, 0.06, 0.02]) and np.isnan(holm(p)[4])
    # one real effect among 20 metrics of noise: still found after correction, the
    # noise stays unflagged
    rng = np.random.default_rng(11)
    frames = []
    for k in range(20):
        base = rng.uniform(0, 10, 200)
        shift = -2.0 if k == 0 else 0.0
        frames.append(sweep(base, base + shift + rng.normal(0, 3, 200), f"m{k}"))
    table = frames[0]
    for f in frames[1:]:
        table = table.merge(f, on=["sample", "controller"])
    out = paired_claims(table, "FCM-CTC", "CTC", metrics=[f"m{k}" for k in range(20)],
                        joints=[1], tolerances={f"m{k}": 0.0 for k in range(20)})  # fmt: skip
    assert out["verdict"].iloc[0] == "better"
    assert (out["verdict"].iloc[1:] != "better").all() and (
        out["verdict"].iloc[1:] != "worse"
    ).all()


def test_plants_without_both_values_do_not_count():
    rng = np.random.default_rng(4)
    base = rng.uniform(1, 2, 220)
    prop = base - 0.2
    base[:10] = np.nan  # the baseline diverged there
    prop[10:30] = np.inf  # never settled
    assert judge(sweep(base, prop))["n"] == 190


def test_count_wins_is_the_tolerance_rule():
    assert count_wins([1.0, 2.0, 3.0, np.nan], [1.5, 2.0, 2.0, 1.0], 0.4) == (1, 1, 1)


def test_hodges_lehmann_against_its_definition():
    d = np.array([0.3, -1.2, 2.0, 0.7, 0.1])
    walsh = [(d[i] + d[j]) / 2 for i in range(5) for j in range(i, 5)]
    assert hodges_lehmann(d)[0] == pytest.approx(np.median(walsh))


def test_type_i_error_near_nominal_and_power_under_known_shifts():
    # The sign test's and TOST's rejection rates by simulation (200 sweeps of 200 plants
    # each; the full table with 1000 sweeps is in docs/statistics.md).
    rng = np.random.default_rng(5)
    reps, n = 200, 200
    null = shift = tost_null = tost_power = covered = 0
    for _ in range(reps):
        d = rng.standard_t(3, n)
        null += _sign_p(*count_wins(d, np.zeros(n), 0.0)[:2]) < 0.05
        covered += (lambda r: r[1] <= 0 <= r[2])(hodges_lehmann(d))
        shift += _sign_p(*count_wins(d + 0.3, np.zeros(n), 0.0)[:2]) < 0.05
        tost_null += _tost_p(d + 0.3, 0.3) < 0.05  # on the margin: equivalence is false
        tost_power += _tost_p(d, 0.3) < 0.05
    # a binomial 99 % band around 5 % for 200 draws is [1.5 %, 10 %]
    band = stats.binom.interval(0.99, reps, 0.05)
    assert null <= band[1] and tost_null <= band[1]
    assert shift / reps > 0.7 and tost_power / reps > 0.8
    assert 0.9 <= covered / reps <= 0.99


def test_unknown_names_refused():
    rng = np.random.default_rng(6)
    table = sweep(rng.uniform(0, 1, 100), rng.uniform(0, 1, 100))
    with pytest.raises(ValueError, match="no controller 'PID'"):
        paired_claims(table, "PID", "CTC")


def test_the_docs_tolerance_table_is_the_one_home_of_the_tolerances():
    import re
    from pathlib import Path

    from twolink.studies.judgments.claims import TOLERANCES

    text = (Path(__file__).parents[1] / "docs" / "statistics.md").read_text()
    section = text[text.index("## Practical tolerances") : text.index("## Operating")]
    documented = {}
    for line in section.splitlines():
        if line.startswith("| `"):
            keys, delta = line.split("|")[1:3]
            value = float(re.match(r"\s*([0-9.e+-]+)", delta).group(1))
            documented |= dict.fromkeys(re.findall(r"`([A-Za-z0-9_]+)`", keys), value)
    assert documented == TOLERANCES
