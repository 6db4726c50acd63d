"""The effort rule's one home (twolink.studies.designs.effort): each plant set is judged
against FCM-CTC's own effort on that set, never the other's; the frontier's table and the
searches' arrays read the same rule."""

from __future__ import annotations

import numpy as np
import pandas as pd

from twolink.studies.designs import effort

# FCM-CTC's Σ|Δτ|₁ differs between the plant sets: 240 N·m on training, 230 where judged
BUDGET_TRAIN = np.array([28.5, 8.0, 240.0, 76.0])
BUDGET_JUDGED = np.array([28.5, 8.0, 230.0, 76.0])


def test_each_plant_set_is_judged_against_fcm_ctcs_effort_on_that_set():
    train = np.array(
        [
            [28.0, 7.9, 239.0, 75.0],  # A: 239 within 240 + 1 on training ...
            [28.0, 7.9, 230.0, 75.0],  # B: within on training
        ]
    )
    judged = np.array(
        [
            [28.0, 7.9, 229.0, 75.0],  # A: ... and 229 within 230 + 1 where judged: admitted
            [28.0, 7.9, 236.0, 75.0],  # B: 236 over 230 + 1 where judged: refused
        ]
    )
    ok = effort.admissible(train, judged, BUDGET_TRAIN, BUDGET_JUDGED)
    assert ok.tolist() == [True, False]
    # the wrong budgets give other answers, so this test tells them apart:
    swapped = effort.admissible(train, judged, BUDGET_JUDGED, BUDGET_TRAIN)
    assert swapped.tolist() == [False, True]
    training_only = effort.admissible(train, judged, BUDGET_TRAIN, BUDGET_TRAIN)
    assert training_only.tolist() == [True, True]
    judged_only = effort.admissible(train, judged, BUDGET_JUDGED, BUDGET_JUDGED)
    assert judged_only.tolist() == [False, False]


def test_a_table_and_its_arrays_read_the_same_rule():
    """The frontier's summary table (columns named by metric and joint, a budget mapping)
    and the searches' (n, 4) arrays give the same answer, the tolerance included."""
    values = np.array(
        [[28.9, 8.0, 240.9, 76.0], [29.1, 8.0, 240.0, 76.0], [28.0, 8.0, 241.1, 76.0]]
    )
    table = pd.DataFrame(values, columns=list(effort.EFFORT_COLUMNS)).assign(index=1.0)
    budget = dict(zip(effort.EFFORT_COLUMNS, BUDGET_TRAIN, strict=True))
    assert effort.within_budget(table, budget).tolist() == [True, False, False]
    assert effort.within_budget(values, BUDGET_TRAIN).tolist() == [True, False, False]
    assert effort.tolerances().tolist() == [0.5, 0.5, 1.0, 1.0]
