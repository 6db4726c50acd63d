"""The linear frontier's two rules (issue 48), on the current public functions: the
performance index is the median over the plants (not the mean), and the effort budget
carries the metric's practical tolerance."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from twolink.studies.designs.effort import within_budget
from twolink.studies.designs.frontier import summarise


def test_the_index_is_the_median_of_the_plants_iae_totals():
    # three plants with IAE₁ + IAE₂ = 1, 1, 10: the median is 1.0, the mean 4.0
    iae1, iae2 = np.array([0.4, 0.6, 7.0]), np.array([0.6, 0.4, 3.0])
    rows = pd.DataFrame({
        "controller": "CTC-wn4", "status": "ok", "sample": range(3),
        "joint1_iae_rad_s": iae1, "joint2_iae_rad_s": iae2,
    })  # fmt: skip
    from twolink.simulation.vocabulary import METRICS

    for m in METRICS:  # every other metric a summary may read: the same on every plant
        for j in (1, 2):
            if f"joint{j}_{m.key}" not in rows:
                rows[f"joint{j}_{m.key}"] = 1.0
    row = summarise(rows).iloc[0]
    assert row["index"] == pytest.approx(1.0)


def test_the_effort_budget_carries_the_practical_tolerance():
    # FCM-CTC's peak |τ| 20 N·m and Σ|Δτ| 50 N·m per joint: a loop over by less than the
    # tolerance (0.5 N·m, 1 N·m) is within, over by more is not
    budget = {"torque_peak_Nm1": 20.0, "torque_peak_Nm2": 20.0,
              "torque_variation_Nm1": 50.0, "torque_variation_Nm2": 50.0}  # fmt: skip
    over = [(0.4, 0.9, True), (0.6, 0.0, False), (0.0, 1.1, False), (0.5, 1.0, True)]
    table = pd.DataFrame([
        {"torque_peak_Nm1": 20.0 + p, "torque_peak_Nm2": 20.0,
         "torque_variation_Nm1": 50.0, "torque_variation_Nm2": 50.0 + v}
        for p, v, _ in over
    ])  # fmt: skip
    assert within_budget(table, budget).tolist() == [w for _, _, w in over]
