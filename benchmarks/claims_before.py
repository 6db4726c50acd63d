"""Paired statistics for claims such as the paper's "FCM-CTC lowers the overshoot against
CTC", judged on many plants: on each plant of a sweep both controllers ran, so a claim
rests on the *paired* differences d = metric(A) − metric(B), plant by plant (lower is
better for every metric judged here). Per metric (docs/statistics.md):

- **better / worse / equal**: plants where A is lower than B by more than the metric's
  practical tolerance δ (:data:`TOLERANCES`), higher by more, or within ±δ;
- **the paired test**: a two-sided sign test on better against worse (ties within ±δ
  dropped: zero-inflated data, e.g. 97 plants worse and 103 exactly equal, read as the
  97-to-0 they are, not as a median difference of 0), p-values Holm-corrected across the
  table's family (``p_adjusted``);
- **the estimate**: the Hodges-Lehmann estimate of the shift (the median of the Walsh
  averages), with its distribution-free 95 % interval from the signed-rank distribution
  (``ci_low``, ``ci_high``);
- **equivalence**: two one-sided signed-rank tests against ±δ (TOST; the tests the
  Hodges-Lehmann interval inverts), Holm-corrected across the family too;
- **the verdict**: ``better`` or ``worse`` where the sign test rejects "as often better
  as worse" after Holm; else ``equivalent`` where the equivalence test holds after Holm;
  else ``inconclusive``. A metric whose value is set by the reference for both
  controllers (Td and Tr of a smooth quintic move: on the typical plant every
  controller's are the move's own, within the tolerance) is ``set by the reference``,
  and one that neither controller has on any plant (Tp of a response with no peak) is
  ``undefined``: no verdict.

A plant counts for a metric only where both controllers have a value (a run that
diverged, or an undefined metric, such as a settling time never reached, leaves it out).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd
from scipy import stats

from twolink.simulation.vocabulary import CLAIMED_BETTER

__all__ = [
    "CLAIM_METRICS",
    "TOLERANCES",
    "VERDICTS",
    "count_wins",
    "hodges_lehmann",
    "holm",
    "judge",
    "paired_claims",
]

CLAIM_METRICS = CLAIMED_BETTER  # the paper's claims: FCM-CTC lowers Tp, Td, Ts, Tr, Mp, ess
VERDICTS = ("better", "worse", "equivalent", "inconclusive", "set by the reference", "undefined")
ALPHA = 0.05
SET_BY_REFERENCE = "set by the reference"

# The practical tolerances are the claims' own (one home: claims.TOLERANCES): the rule of
# before is judged against the same δ.
from twolink.studies.judgments.claims import TOLERANCES  # noqa: E402


def count_wins(a: np.ndarray, b: np.ndarray, tolerance: float) -> tuple[int, int, int]:
    """(better, worse, equal): where ``a`` is below ``b`` by more than ``tolerance``, above
    by more, or within it; pairs with a NaN are not counted. The one count of wins that the
    report, the claims tables and the summaries all use."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    both = np.isfinite(a) & np.isfinite(b)
    d = a[both] - b[both]
    better = int(np.sum(d < -tolerance))
    worse = int(np.sum(d > tolerance))
    return better, worse, int(d.size) - better - worse


def hodges_lehmann(d: np.ndarray, confidence: float = 0.95) -> tuple[float, float, float]:
    """The Hodges-Lehmann estimate of the shift of paired differences ``d`` (the median of
    the Walsh averages (d_i + d_j)/2, i <= j) and its distribution-free ``confidence``
    interval: the Walsh averages at the ranks the signed-rank statistic's distribution
    gives (normal approximation, Hollander & Wolfe, *Nonparametric Statistical Methods*,
    3.6). NaN for fewer than 2 values."""
    d = np.asarray(d, dtype=float)
    n = d.size
    if n < 2:
        value = float(d[0]) if n else math.nan
        return value, math.nan, math.nan
    i, j = np.triu_indices(n)
    walsh = np.sort((d[i] + d[j]) / 2.0)
    m = walsh.size  # n (n + 1) / 2
    z = stats.norm.ppf(0.5 + confidence / 2.0)
    k = int(math.floor(m / 2.0 - z * math.sqrt(n * (n + 1) * (2 * n + 1) / 24.0)))
    k = min(max(k, 0), m - 1)
    return float(np.median(walsh)), float(walsh[k]), float(walsh[m - 1 - k])


def holm(p: Sequence[float]) -> np.ndarray:
    """Holm's step-down adjustment of a family of p-values (NaN stays NaN)."""
    p = np.asarray(p, dtype=float)
    out = np.full(p.shape, np.nan)
    ok = np.flatnonzero(np.isfinite(p))
    order = ok[np.argsort(p[ok], kind="stable")]
    running = 0.0
    for rank, idx in enumerate(order):
        running = max(running, (len(order) - rank) * p[idx])
        out[idx] = min(1.0, running)
    return out


def _sign_p(better: int, worse: int) -> float:
    n = better + worse
    return 1.0 if n == 0 else float(stats.binomtest(better, n, 0.5).pvalue)


def _tost_p(d: np.ndarray, tolerance: float) -> float:
    """p of two one-sided signed-rank tests (the tests the Hodges-Lehmann interval
    inverts) that the shift lies within ±``tolerance``: the larger of the two p-values."""
    return float(_tost_ps([np.asarray(d, dtype=float)], [tolerance])[0])


def _tost_ps(ds: Sequence[np.ndarray], tolerances: Sequence[float]) -> np.ndarray:
    """:func:`_tost_p` of several samples at once: one signed-rank call per sample size.

    "Shift above −δ" (``d + δ``, alternative "greater") is tested as "−(d + δ) lower"
    (alternative "less"): the same p, as the normal approximation is symmetric. Stacking
    both sides of every sample of one size makes a table of claims one scipy call, not
    one per test (each costs ~0.5 ms of scipy's own overhead)."""
    p = np.ones(len(ds))
    by_size: dict[int, list[tuple[int, np.ndarray, np.ndarray]]] = {}
    for k, (d, tolerance) in enumerate(zip(ds, tolerances, strict=True)):
        lower, upper = d - tolerance, -(d + tolerance)
        if d.size >= 2 and np.any(lower) and np.any(upper):  # else: no test, p = 1
            by_size.setdefault(d.size, []).append((k, lower, upper))
    for tests in by_size.values():
        sides = np.stack([side for _, lower, upper in tests for side in (lower, upper)])
        both = _signed_rank(sides, "less").reshape(len(tests), 2)
        p[[k for k, _, _ in tests]] = both.max(axis=1)
    return p


def _signed_rank(d: np.ndarray, side: str) -> np.ndarray:
    """One-sided Wilcoxon signed-rank p along the last axis, by the normal approximation
    (with ties and zeros split, scipy's exact path is a permutation test: ~0.1 s a call)."""
    try:
        result = stats.wilcoxon(
            d, alternative=side, zero_method="zsplit", method="asymptotic", axis=-1
        )
    except ValueError:  # scipy < 1.13 names it "approx"
        result = stats.wilcoxon(d, alternative=side, zero_method="zsplit", method="approx", axis=-1)
    return np.asarray(result.pvalue, dtype=float)


def judge(
    a: np.ndarray,
    b: np.ndarray,
    tolerance: float,
    reference: float | None = None,
) -> dict[str, float | int | str]:
    """The unadjusted statistics of one metric's pairs (``a`` proposed, ``b`` baseline,
    one value per plant): counts, estimate and interval, sign-test and equivalence p. With
    ``reference`` (the value the reference itself has), both controllers' medians within
    ``tolerance`` of it mark the metric as set by the reference: on the typical plant
    neither controller, the reference did."""
    return _judge_all([(a, b, tolerance, reference)])[0]


def _judge_all(
    pairs: Sequence[tuple[np.ndarray, np.ndarray, float, float | None]],
) -> list[dict[str, float | int | str]]:
    """:func:`judge` of several (a, b, tolerance, reference), the equivalence tests of
    all of them batched (:func:`_tost_ps`)."""
    rows, ds = [], []
    for a, b, tolerance, reference in pairs:
        a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
        both = np.isfinite(a) & np.isfinite(b)
        a, b = a[both], b[both]
        d = a - b
        better, worse, equal = count_wins(a, b, tolerance)
        estimate, low, high = hodges_lehmann(d)
        by_reference = (
            reference is not None
            and d.size > 0
            and abs(float(np.median(a)) - reference) <= tolerance
            and abs(float(np.median(b)) - reference) <= tolerance
        )
        ds.append(d)
        rows.append({
            "n": int(d.size),
            "better": better,
            "worse": worse,
            "equal": equal,
            "tolerance": tolerance,
            "proposed_median": float(np.median(a)) if d.size else math.nan,
            "baseline_median": float(np.median(b)) if d.size else math.nan,
            "estimate": estimate,
            "ci_low": low,
            "ci_high": high,
            "p_value": _sign_p(better, worse),
            "tost_p": math.nan,
            "set_by_reference": by_reference,
        })  # fmt: skip
    for row, p in zip(rows, _tost_ps(ds, [row["tolerance"] for row in rows]), strict=True):
        row["tost_p"] = float(p)
    return rows


def _verdicts(table: pd.DataFrame) -> pd.DataFrame:
    """Holm across the table's family (its rows), then the verdicts (on the columns'
    arrays: this runs once per cell of the regime map)."""
    n, better, worse = (table[c].to_numpy() for c in ("n", "better", "worse"))
    by_reference = table["set_by_reference"].to_numpy(dtype=bool)
    judged = ~by_reference & (n > 0)
    p_adjusted, tost_adjusted = np.full(len(table), np.nan), np.full(len(table), np.nan)
    p_adjusted[judged] = holm(table["p_value"].to_numpy(dtype=float)[judged])
    tost_adjusted[judged] = holm(table["tost_p"].to_numpy(dtype=float)[judged])
    verdict = np.full(len(table), "inconclusive", dtype=object)
    differ = judged & (p_adjusted < ALPHA)
    verdict[differ & (better > worse)] = "better"
    verdict[differ & (worse > better)] = "worse"
    verdict[judged & ~differ & (tost_adjusted < ALPHA)] = "equivalent"
    verdict[by_reference] = SET_BY_REFERENCE
    verdict[n == 0] = "undefined"
    table["p_adjusted"] = p_adjusted
    table["tost_p_adjusted"] = tost_adjusted
    table["verdict"] = verdict
    return table.drop(columns=["set_by_reference"])


def paired_claims(
    results: pd.DataFrame,
    proposed: str,
    baseline: str,
    metrics: Sequence[str] = CLAIM_METRICS,
    joints: Sequence[int] = (1, 2),
    reference_values: Mapping[tuple[int, str], float] | None = None,
    tolerances: Mapping[str, float] | None = None,
) -> pd.DataFrame:
    """Judge ``proposed`` against ``baseline`` on a sweep's plants, per joint and metric.

    Parameters
    ----------
    results : DataFrame
        A sweep's results table (:func:`twolink.sweep.load_results`): one row per
        (sample, controller), metric columns ``joint{j}_{metric}``.
    proposed, baseline : str
        Controller names in the table.
    metrics, joints
        What to judge: the table's family, Holm-corrected together.
    reference_values : mapping, optional
        ``(joint, metric) -> value`` of the reference itself (e.g. Td of the quintic move):
        where both controllers have it on every plant, the verdict is "set by the
        reference".
    tolerances : mapping, optional
        Practical tolerance per metric (default :data:`TOLERANCES`).

    Returns
    -------
    DataFrame
        One row per (joint, metric): ``n``, ``better``, ``worse``, ``equal``,
        ``tolerance``, the two medians, ``estimate`` (Hodges-Lehmann) with ``ci_low`` and
        ``ci_high`` (95 %), ``p_value`` (sign test) and ``p_adjusted`` (Holm),
        ``tost_p`` and ``tost_p_adjusted``, and the ``verdict``.
    """
    names = set(results["controller"])
    for name in (proposed, baseline):
        if name not in names:
            raise ValueError(f"no controller {name!r} in the results (have {sorted(names)})")
    tol = {**TOLERANCES, **(tolerances or {})}
    a = results[results["controller"] == proposed].set_index("sample")
    b = results[results["controller"] == baseline].set_index("sample")
    plants = a.index.intersection(b.index, sort=False)  # the plants both ran
    keys = [(j, key) for j in joints for key in metrics]
    columns = [f"joint{j}_{key}" for j, key in keys]
    values_a = a.loc[plants, columns].to_numpy(dtype=float)
    values_b = b.loc[plants, columns].to_numpy(dtype=float)
    refs = reference_values or {}
    judged = _judge_all([
        (values_a[:, k], values_b[:, k], tol[key], refs.get((j, key)))
        for k, (j, key) in enumerate(keys)
    ])  # fmt: skip
    rows = [{"joint": j, "metric": key, **row} for (j, key), row in zip(keys, judged, strict=True)]
    return _verdicts(pd.DataFrame(rows))
