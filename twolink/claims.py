"""Claims with confidence intervals: does controller A lower a metric against B?

A claim such as the paper's "FCM-CTC lowers the overshoot against CTC" is judged on many
plants, not one: on each plant of a sweep both controllers ran, so the claim rests on the
*paired* differences d = metric(A) - metric(B), plant by plant. We report their median
and a 95 % bootstrap confidence interval of that median (``scipy.stats.bootstrap``, BCa,
seeded so a claim table is reproducible), and a verdict:

- **holds**: the whole interval is below 0 (A lowers the metric);
- **fails**: the whole interval is above 0 (A raises it);
- **no difference**: every difference is 0, or so many are that the interval is [0, 0]
  (e.g. neither overshoots on most plants);
- **inconclusive**: the interval contains 0.

A plant counts for a metric only where both controllers have a value (a run that
diverged, or a metric that is undefined, such as a settling time never reached, leaves
it out); how many plants count is reported beside the verdict. Lower is better for every
metric judged here (times, overshoot, errors).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np
import pandas as pd
from scipy import stats

from twolink.report import CLAIMED_BETTER

__all__ = ["CLAIM_METRICS", "VERDICTS", "paired_claims"]

# The paper's claims: FCM-CTC lowers Tp, Td, Ts, Tr, Mp and ess (the report's own list).
CLAIM_METRICS = CLAIMED_BETTER
VERDICTS = ("holds", "fails", "no difference", "inconclusive")
CONFIDENCE = 0.95
RESAMPLES = 2000


def verdict(low: float, high: float, differences: np.ndarray) -> str:
    """The verdict of a confidence interval (see the module's docstring)."""
    if differences.size and (not differences.any() or low == high == 0):
        return "no difference"
    if high < 0:
        return "holds"
    if low > 0:
        return "fails"
    return "inconclusive"


def _median_interval(d: np.ndarray, method: str, seed: int) -> tuple[float, float]:
    """95 % bootstrap confidence interval of the median of ``d``."""
    with warnings.catch_warnings():  # a degenerate BCa gives NaN: the caller falls back
        warnings.simplefilter("ignore")
        ci = stats.bootstrap(
            (d,),
            np.median,
            confidence_level=CONFIDENCE,
            n_resamples=RESAMPLES,
            method=method,
            rng=np.random.default_rng(seed),
        ).confidence_interval
    return float(ci.low), float(ci.high)


def paired_claims(
    results: pd.DataFrame,
    proposed: str,
    baseline: str,
    metrics: Sequence[str] = CLAIM_METRICS,
    joints: Sequence[int] = (1, 2),
    seed: int = 0,
) -> pd.DataFrame:
    """Judge "``proposed`` lowers each metric against ``baseline``" on a sweep's plants.

    Parameters
    ----------
    results : DataFrame
        A sweep's results table (:func:`twolink.sweep.load_results`): one row per
        (sample, controller), metric columns ``joint{j}_{metric}``.
    proposed, baseline : str
        Controller names in the table.
    metrics, joints
        What to judge.
    seed : int
        Seed of the bootstrap resampling.

    Returns
    -------
    DataFrame
        One row per (joint, metric): ``n`` plants with both values, the median of the
        proposed and of the baseline, the median paired difference, its 95 % bootstrap
        interval ``ci_low``/``ci_high``, and the ``verdict``.
    """
    names = set(results["controller"])
    for name in (proposed, baseline):
        if name not in names:
            raise ValueError(f"no controller {name!r} in the results (have {sorted(names)})")
    a = results[results["controller"] == proposed].set_index("sample")
    b = results[results["controller"] == baseline].set_index("sample")
    rows = []
    for j in joints:
        for metric in metrics:
            column = f"joint{j}_{metric}"
            pair = pd.concat([a[column], b[column]], axis=1, keys=["a", "b"], join="inner")
            pair = pair[np.isfinite(pair["a"]) & np.isfinite(pair["b"])]
            d = (pair["a"] - pair["b"]).to_numpy(float)
            low = high = med = np.nan
            if d.size >= 2 and np.ptp(d) > 0:
                low, high = _median_interval(d, "BCa", seed)
                if not (np.isfinite(low) and np.isfinite(high)):  # BCa degenerate
                    low, high = _median_interval(d, "percentile", seed)
            elif d.size:
                low = high = float(d[0])  # every difference equal: no spread to resample
            if d.size:
                med = float(np.median(d))
            rows.append(
                {
                    "joint": j,
                    "metric": metric,
                    "n": int(d.size),
                    "proposed_median": float(pair["a"].median()) if d.size else np.nan,
                    "baseline_median": float(pair["b"].median()) if d.size else np.nan,
                    "median_difference": med,
                    "ci_low": low,
                    "ci_high": high,
                    "verdict": verdict(low, high, d) if d.size else "inconclusive",
                }
            )
    return pd.DataFrame(rows)
