"""Claims with confidence intervals, on synthetic sweeps whose true answer is known."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from twolink.claims import paired_claims


def sweep(baseline: np.ndarray, proposed: np.ndarray, metric: str = "overshoot_pct"):
    """A results table of two controllers on the same plants (joint 1 only)."""
    n = len(baseline)
    rows = []
    for name, values in (("CTC", baseline), ("FCM-CTC", proposed)):
        rows += [
            {"sample": i, "controller": name, f"joint1_{metric}": v} for i, v in enumerate(values)
        ]
    assert len(rows) == 2 * n
    return pd.DataFrame(rows)


def judge(table, metric="overshoot_pct", seed=0):
    out = paired_claims(table, "FCM-CTC", "CTC", metrics=[metric], joints=[1], seed=seed)
    return out.iloc[0]


def test_a_real_improvement_holds_and_its_interval_holds_the_true_shift():
    rng = np.random.default_rng(1)
    base = rng.uniform(5, 15, 300)  # plant-to-plant spread much larger than the effect
    row = judge(sweep(base, base - 0.5 + rng.normal(0, 0.3, 300)))
    assert row["verdict"] == "holds" and row["n"] == 300
    assert row["ci_low"] < -0.5 < row["ci_high"] < 0


def test_a_real_degradation_fails():
    rng = np.random.default_rng(2)
    base = rng.uniform(5, 15, 250)
    assert judge(sweep(base, base + 0.4 + rng.normal(0, 0.3, 250)))["verdict"] == "fails"


def test_no_effect_is_inconclusive_not_a_win():
    rng = np.random.default_rng(3)
    base = rng.uniform(5, 15, 300)
    row = judge(sweep(base, base + rng.normal(0, 0.3, 300)))
    assert row["verdict"] == "inconclusive" and row["ci_low"] < 0 < row["ci_high"]


def test_identical_metrics_are_no_difference():
    zeros = np.zeros(200)
    row = judge(sweep(zeros, zeros))
    assert row["verdict"] == "no difference" and row["median_difference"] == 0


def test_mostly_equal_metrics_with_an_interval_of_zero_are_no_difference():
    rng = np.random.default_rng(7)
    base = np.zeros(200)
    prop = np.where(rng.uniform(size=200) < 0.1, rng.uniform(-1, 1, 200), 0.0)
    row = judge(sweep(base, prop))
    assert (row["ci_low"], row["ci_high"]) == (0, 0) and row["verdict"] == "no difference"


def test_plants_without_both_values_do_not_count():
    rng = np.random.default_rng(4)
    base = rng.uniform(1, 2, 220)
    prop = base - 0.2
    base[:10] = np.nan  # the baseline diverged there
    prop[10:30] = np.inf  # never settled
    assert judge(sweep(base, prop))["n"] == 190


def test_the_interval_covers_the_true_median_about_95_percent_of_the_time():
    # An independent check of the interval itself: draws from a known distribution.
    rng = np.random.default_rng(5)
    covered = 0
    trials = 60
    for t in range(trials):
        d = rng.standard_t(4, 80) + 0.3  # skewless, heavy-tailed; true median 0.3
        row = judge(sweep(np.zeros(80), d), seed=t)
        covered += row["ci_low"] <= 0.3 <= row["ci_high"]
    assert 0.85 <= covered / trials <= 1.0


def test_same_seed_same_interval_and_unknown_names_refused():
    rng = np.random.default_rng(6)
    table = sweep(rng.uniform(0, 1, 100), rng.uniform(0, 1, 100))
    a, b = judge(table, seed=7), judge(table, seed=7)
    assert (a["ci_low"], a["ci_high"]) == (b["ci_low"], b["ci_high"])
    with pytest.raises(ValueError, match="no controller 'PID'"):
        paired_claims(table, "PID", "CTC")
