"""`twolink compare` with few plants (issue 46): the least number of plants any verdict
needs, derived from the tests the verdicts use and checked here against the judge itself,
and the "too few plants" line only where it is true."""

import numpy as np
import pytest

from twolink.studies.judgments.claims import judge_rows
from twolink.studies.judgments.compare import minimum_plants, too_few


def _verdicts(d: np.ndarray, rows: int) -> set:
    """The judge's typical plants on ``rows`` equal rows of differences ``d`` (tolerance 1)."""
    n = len(d)
    a = np.tile(np.asarray(d, float), (rows, 1))
    out = judge_rows(a, np.zeros((rows, n)), np.ones(rows), np.zeros(rows),
                     np.zeros(rows, bool))  # fmt: skip
    return set(out["typical"])


@pytest.mark.parametrize("rows", [1, 12, 24])
def test_the_minimum_is_where_the_judge_first_says_equivalent_and_better(rows):
    """Identical plants (every difference 0): one plant fewer than the minimum is
    "undecided" on the typical plant, the minimum "equivalent"; plants all far better: one
    fewer is "undecided", the minimum "better". Bonferroni over ``rows`` rows raises both."""
    equivalent, differ = minimum_plants(rows)
    assert _verdicts(np.zeros(equivalent - 1), rows) == {"undecided"}
    assert _verdicts(np.zeros(equivalent), rows) == {"equivalent"}
    far = -2.0 - np.arange(differ) / differ
    assert _verdicts(far[:-1], rows) == {"undecided"}
    assert _verdicts(far, rows) == {"better"}
    assert minimum_plants(24) > minimum_plants(1)


def test_too_few_is_said_only_where_true_and_says_how_many_would_do():
    """Enough identical plants are "equivalent", not "too few"; the line names both
    minima so a user knows what --plants to give."""
    equivalent, differ = minimum_plants(12)
    assert too_few(equivalent - 1, 12).startswith("too few plants for any verdict")
    assert f'"equivalent" needs at least {equivalent} plants' in too_few(equivalent - 1, 12)
    # the printed interval decides both: the n that bounds it decides "better" too
    assert equivalent == differ
    assert too_few(differ, 12) == ""
    assert too_few(200, 12) == ""


def test_the_docs_give_the_minima_the_code_derives():
    from pathlib import Path

    text = " ".join((Path(__file__).parents[1] / "docs" / "compare.md").read_text().split())
    six, twelve = minimum_plants(6)[0], minimum_plants(12)[0]
    assert f"over six rows {six} plants for either, over twelve {twelve}" in text
