"""Paired statistics for claims such as the paper's "FCM-CTC lowers the overshoot against
CTC", judged on many plants: on each plant of a sweep both controllers ran, so a claim
rests on the *paired* differences d = metric(A) − metric(B), plant by plant (lower is
better for every metric judged here). Per metric (docs/statistics.md has the rule, its
sources and its choices):

- **better / worse / equal** (the counts): plants where A is lower than B by more than the
  metric's practical tolerance δ (:data:`TOLERANCES`), higher by more, or within ±δ (a
  difference of exactly δ is equal);
- **the typical plant**: the Hodges-Lehmann estimate of the shift (the median of the
  Walsh averages) with its distribution-free interval (``ci_low``, ``ci_high``) at
  ``ci_level`` = 1 − 5 %/m, m the rows of the family whose typical plant is judged (both
  have the metric on at least half the plants both ran, ``runs``): better, worse or
  equivalent where that printed interval lies wholly below −δ, above +δ or within ±δ,
  else undecided; ``typical`` says it, "not judged" where the quorum fails. The
  signed-rank tests against the margins (``margin_p``, ``tost_p``, Holm-corrected) stay
  as evidence;
- **the shares**: the shares of plants practically better and practically worse (beyond
  ±δ, with the plants that only one controller reaches, below), each with its exact
  (Clopper-Pearson) 95 % interval, and exact binomial tests that a share exceeds
  :data:`MIN_SHARE` (Holm across the family) or stays below it;
- **the verdict**: one of claims_words.VERDICT_WORDS, by the first that holds (not judged,
  equal, better/worse, equivalent, partly better/worse, split, undecided; :func:`_verdict`).
  It never points against its own estimate. The times of :data:`TIMES_OF_THE_MOVE` on a
  moving reference are judged by their distance to the move's own (:func:`move_distances`;
  docs/metrics.md). ``reading`` says it in words, with every share shown ("equivalent on
  the typical plant; worse by more than 1 mrad on 29 of 200 (10-20 %)").
- **the sign test** of better against worse (``p_value``, Holm ``p_adjusted``) stays in
  the tables as a count's evidence; the verdict does not follow it.

Missing values: a time that one controller reaches and the other never does
(:data:`REACHED`: Td, Tr, Ts, Ts→θd never reached) counts against the second
(``unreached_better``, ``unreached_worse``, apart from the numeric comparison, inside the
shares). Elsewhere a plant counts only where both controllers have a value.

All tables of a study are judged at once (:func:`paired_claims_many`): one pass over the
results, numpy over cells, controllers and metrics.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd
from scipy import stats

from twolink.simulation.vocabulary import CLAIMED_BETTER
from twolink.studies.judgments.claims_words import (
    BETTER,
    EQUAL,
    EQUIVALENT,
    NOT_JUDGED,
    PARTLY,
    SPLIT,
    SPLIT_SHARE,
    UNDECIDED,
    VERDICT_WORDS,
    WORSE,
)
from twolink.studies.judgments.move_times import TIMES_OF_THE_MOVE, move_distances
from twolink.studies.judgments.shift import _hodges_lehmann_rows, hodges_lehmann

__all__ = [
    "CLAIM_METRICS",
    "MIN_SHARE",
    "REACHED",
    "TIMES_OF_THE_MOVE",
    "TOLERANCES",
    "VERDICTS",
    "count_wins",
    "hodges_lehmann",
    "holm",
    "judge",
    "move_distances",
    "paired_claims",
    "paired_claims_many",
    "proportion_interval",
]

CLAIM_METRICS = CLAIMED_BETTER  # the paper's claims: FCM-CTC lowers Tp, Td, Ts, Tr, Mp, ess
VERDICTS = tuple(VERDICT_WORDS)
ALPHA = 0.05
# The smallest share of plants worth a word: one plant in 20 (docs/statistics.md).
MIN_SHARE = 0.05
# Most plants: more than one half of the plants both ran, shown by an exact test (Holm
# across the family). Where the typical plant's interval decides nothing, most plants
# beyond −δ (+δ) make the row better (worse).
MOST = 0.5
# Times a response may never reach (NaN): a plant where one controller reaches it and the
# other does not counts against the second. Tp is not one: no peak is no failure.
REACHED = ("delay_time_s", "rise_time_s", "settling_time_s", "settling_time_target_s")
# Practical tolerance per metric: a difference smaller than this is no difference a user
# of the arm would act on. Times: 10 control periods; overshoot: 1 percentage point;
# angles: 1 mrad (0.1 % of the 1 rad moves; an encoder of 17 bits resolves 0.05 mrad);
# integrals of |e|: 1 mrad over 1 s; torques: 0.5 N·m (under 1 % of the 60 N·m limit);
# torque variation: 1 N·m summed over the run; growth: 0.05.
TOLERANCES: dict[str, float] = {
    "peak_time_s": 0.01,
    "delay_time_s": 0.01,
    "rise_time_s": 0.01,
    "settling_time_s": 0.01,
    "settling_time_target_s": 0.01,
    "overshoot_pct": 1.0,
    "steady_state_error_rad": 1e-3,
    "final_error_rad": 1e-3,
    "tail_error_rad": 1e-3,
    "oscillation_rad": 1e-3,
    "max_error_rad": 1e-3,
    "iae_rad_s": 1e-3,
    "ise_rad2_s": 1e-6,
    "itae_rad_s2": 1e-3,
    "torque_rms_Nm": 0.5,
    "torque_peak_Nm": 0.5,
    "torque_variation_Nm": 1.0,
    "tail_growth": 0.05,
}


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


def _row_medians(x: np.ndarray) -> np.ndarray:
    """The median of each row's finite values (NaN for none), as ``np.median`` of them."""
    n = np.isfinite(x).sum(axis=1)
    s = np.sort(np.where(np.isfinite(x), x, np.nan), axis=1)
    r = np.arange(x.shape[0])
    mid = np.maximum(n - 1, 0) // 2
    upper = s[r, np.minimum(n // 2, x.shape[1] - 1)]
    out = np.where(n % 2 == 1, s[r, mid], (s[r, mid] + upper) / 2)
    return np.where(n > 0, out, np.nan)


def _row_extreme(d: np.ndarray, which: np.ufunc) -> np.ndarray:
    """The smallest (``np.fmin``) or largest (``np.fmax``) finite value of each row, NaN
    for none: how far the plant that differs most differs."""
    if d.shape[1] == 0:
        return np.full(d.shape[0], np.nan)
    return which.reduce(d, axis=1)


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


def _holm_families(p: np.ndarray, family: np.ndarray) -> np.ndarray:
    """:func:`holm` within each family (rows with the same label)."""
    out = np.full(p.shape, np.nan)
    order = np.argsort(family, kind="stable")
    bounds = np.flatnonzero(np.diff(family[order])) + 1
    for members in np.split(order, bounds):
        out[members] = holm(p[members])
    return out


def proportion_interval(
    k: np.ndarray, n: np.ndarray, confidence: float = 0.95
) -> tuple[np.ndarray, np.ndarray]:
    """The exact (Clopper-Pearson) interval of a proportion ``k`` of ``n``: what
    ``scipy.stats.binomtest(k, n).proportion_ci(confidence, method="exact")`` gives (it
    finds the same bounds by root search: tests/test_claims.py checks them to 1e-10),
    here in closed form by the beta quantiles, for arrays. NaN where ``n`` is 0."""
    k, n = np.asarray(k, dtype=float), np.asarray(n, dtype=float)
    a = (1.0 - confidence) / 2.0
    with np.errstate(invalid="ignore", divide="ignore"):
        low = np.where(k > 0, stats.beta.ppf(a, np.maximum(k, 1), n - k + 1), 0.0)
        high = np.where(k < n, stats.beta.ppf(1 - a, k + 1, np.maximum(n - k, 1)), 1.0)
    bad = n <= 0
    return np.where(bad, np.nan, low), np.where(bad, np.nan, high)


def _sign_p(better: int, worse: int) -> float:
    """Two-sided sign test of ``better`` against ``worse`` (``binomtest(better, better +
    worse, 0.5)``); 1 where there is neither."""
    return float(_sign_ps(np.array([better]), np.array([worse]))[0])


def _sign_ps(better: np.ndarray, worse: np.ndarray) -> np.ndarray:
    """:func:`_sign_p` of arrays: scipy's ``binomtest`` two-sided p-value, its own steps
    for p = 1/2 (``scipy/stats/_binomtest.py``: the other tail from the terms no more
    likely than the observed one, found by a search on the monotone side of the pmf,
    here by counting), computed once per distinct (k, n); equal to ``binomtest``'s to the
    bit (tests/test_claims_verdicts.py checks every k of every n up to 60 and more)."""
    better, worse = np.asarray(better, dtype=int), np.asarray(worse, dtype=int)
    n_all = better + worse
    out = np.ones(better.shape)
    pairs, where = np.unique(np.stack([better, n_all], axis=1), axis=0, return_inverse=True)
    values = np.ones(len(pairs))
    rerr = 1 + 1e-7
    for n in np.unique(pairs[:, 1]):
        if n == 0:
            continue
        rows = np.flatnonzero(pairs[:, 1] == n)
        k = pairs[rows, 0]
        pmf = stats.binom.pmf(np.arange(n + 1), n, 0.5)
        d = pmf[k] * rerr
        half = 0.5 * n
        p = np.ones(k.size)
        low = k < half  # the other tail lies above the mode
        if low.any():
            start = int(np.ceil(half))
            ix = start - 1 + (pmf[start:][None, :] >= d[low, None]).sum(axis=1)
            y = n - ix + (d[low] == pmf[np.minimum(ix, n)]).astype(int)
            p[low] = stats.binom.cdf(k[low], n, 0.5) + stats.binom.sf(n - y, n, 0.5)
        high = k > half  # the other tail lies below the mode
        if high.any():
            stop = int(np.floor(half))
            ix = -1 + (pmf[: stop + 1][None, :] <= d[high, None]).sum(axis=1)
            y = ix + 1
            p[high] = stats.binom.cdf(y - 1, n, 0.5) + stats.binom.sf(k[high] - 1, n, 0.5)
        values[rows] = np.minimum(1.0, p)
    out[:] = values[where.ravel()]
    return out


def _tost_p(d: np.ndarray, tolerance: float) -> float:
    """p of two one-sided signed-rank tests (the tests the Hodges-Lehmann interval
    inverts) that the shift lies within ±``tolerance``: the larger of the two p-values."""
    return float(_margin_tests([np.asarray(d, dtype=float)], [tolerance])[0][0])


def _margin_tests(
    ds: Sequence[np.ndarray] | np.ndarray, tolerances: Sequence[float] | np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per sample, the one-sided signed-rank p-values against the margins ±δ: (TOST's p
    that the shift lies within ±δ, p that it lies below −δ, p that it lies above +δ).
    ``ds``: samples, or an (R, N) array whose NaNs are no values. One scipy call per
    sample size (each call costs ~0.5 ms of scipy's own overhead); the test does not
    depend on the order of a sample's values.

    "Shift above −δ" (``d + δ``, alternative "greater") is tested as "−(d + δ) lower"
    (alternative "less"): the same p, as the normal approximation is symmetric. A side
    whose differences are all zero has no test: p = 1."""
    if not isinstance(ds, np.ndarray):
        width = max((x.size for x in ds), default=0)
        ds = np.array([np.pad(np.asarray(x, float), (0, width - x.size), constant_values=np.nan)
                       for x in ds]).reshape(len(ds), width)  # fmt: skip
    tol = np.asarray(tolerances, dtype=float)
    count = ds.shape[0]
    tost, below, above = np.ones(count), np.ones(count), np.ones(count)
    sizes = np.isfinite(ds).sum(axis=1)
    ordered = np.sort(ds, axis=1)  # NaNs last
    for n in np.unique(sizes[sizes >= 2]):
        members = np.flatnonzero(sizes == n)
        d, t = ordered[members, : int(n)], tol[members, None]
        # shift < δ; shift > −δ (TOST's two); shift < −δ; shift > δ
        sides = np.stack([d - t, -(d + t), d + t, t - d], axis=1)  # (rows, 4, n)
        p = _signed_rank(sides.reshape(-1, int(n)), "less").reshape(-1, 4)
        p = np.where(np.any(sides != 0, axis=2), p, 1.0)
        live = np.any(sides[:, :2] != 0, axis=2).all(axis=1)
        tost[members] = np.where(live, np.maximum(p[:, 0], p[:, 1]), 1.0)
        below[members], above[members] = p[:, 2], p[:, 3]
    return tost, below, above


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


def judge_rows(
    a: np.ndarray,
    b: np.ndarray,
    tolerance: np.ndarray,
    family: np.ndarray,
    reached: np.ndarray,
    runs: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """The statistics and verdicts of R metrics' pairs at once: ``a``, ``b`` (R, N) the
    proposed and the opponent's values (NaN: none, or a plant the row does not have; on a
    moving reference already the distances of :func:`move_distances`), per row its
    ``tolerance``, ``family`` (the label of its Holm and Bonferroni family), whether a NaN
    is a time never ``reached``, and the ``runs``: plants both controllers ran (default:
    those where either has a value). The columns of :func:`paired_claims`, as arrays."""
    tol = np.asarray(tolerance, dtype=float)
    c = _counts(a, b, tol, np.asarray(reached, dtype=bool))
    runs = c["plants"] if runs is None else np.asarray(runs)
    medians_a = _row_medians(np.where(c["both"], a, np.nan))
    medians_b = _row_medians(np.where(c["both"], b, np.nan))
    tested = c["n"] > 0  # a pair: its tests and its interval exist
    judged = tested & (2 * c["n"] >= runs)  # the typical plant of at least half the runs
    compared = c["plants"] > 0
    family = np.asarray(family)
    level = interval_level(judged, family)
    estimate, ci_low, ci_high = _hodges_lehmann_rows(c["d"], level)
    tests = _tests(c, tol, tested, family)
    shares = _shares(c, compared, family, runs)
    typical = np.where(judged, _typical(estimate, ci_low, ci_high, tol), NOT_JUDGED)
    typical = typical.astype(object)
    verdict = _verdict(typical, estimate, shares, c)
    return {
        "n": c["n"],
        "better": c["better"],
        "worse": c["worse"],
        "equal": c["n"] - c["better"] - c["worse"],
        "tolerance": tol,
        "proposed_median": medians_a,
        "baseline_median": medians_b,
        "estimate": estimate,
        "ci_low": ci_low,
        "ci_high": ci_high,
        "ci_level": np.where(tested, level, np.nan),
        "difference_min": _row_extreme(c["d"], np.fmin),
        "difference_max": _row_extreme(c["d"], np.fmax),
        **tests,
        "unreached_better": c["unreached_better"],
        "unreached_worse": c["unreached_worse"],
        "plants": c["plants"],
        "runs": runs,
        **{k: v for k, v in shares.items() if not k.startswith("_")},
        "typical": typical,
        "verdict": verdict,
    }


def _counts(
    a: np.ndarray, b: np.ndarray, tol: np.ndarray, reached: np.ndarray
) -> dict[str, np.ndarray]:
    """The paired differences ``d`` (NaN where a pair lacks a value) and the counts: ``n``
    pairs, ``better``/``worse`` beyond ±δ, the plants only one controller reaches, and
    ``plants``, the plants the shares are of."""
    fa, fb = np.isfinite(a), np.isfinite(b)
    both = fa & fb
    d = np.where(both, a - b, np.nan)
    with np.errstate(invalid="ignore"):
        better = (d < -tol[:, None]).sum(axis=1)
        worse = (d > tol[:, None]).sum(axis=1)
    unreached_worse = np.where(reached, (fb & ~fa).sum(axis=1), 0)
    unreached_better = np.where(reached, (fa & ~fb).sum(axis=1), 0)
    n = both.sum(axis=1)
    return {
        "d": d, "both": both, "n": n, "better": better, "worse": worse,
        "unreached_better": unreached_better, "unreached_worse": unreached_worse,
        "plants": n + unreached_better + unreached_worse,
        "k_better": better + unreached_better, "k_worse": worse + unreached_worse,
    }  # fmt: skip


def interval_level(judged: np.ndarray, family: np.ndarray) -> np.ndarray:
    """The confidence of each row's printed interval, the one its verdict reads:
    Bonferroni's 1 − α/m, m the rows of its family whose typical plant is judged (``judged``:
    at least half the plants both ran have the metric for both; docs/statistics.md). A row
    whose typical plant is not judged reads no interval and spends none of α."""
    family = np.asarray(family)
    labels, where = np.unique(family, return_inverse=True)
    m = np.bincount(where.ravel(), weights=np.asarray(judged, float), minlength=len(labels))
    return 1.0 - ALPHA / np.maximum(m[where.ravel()], 1.0)


def _typical(
    estimate: np.ndarray, low: np.ndarray, high: np.ndarray, tol: np.ndarray
) -> np.ndarray:
    """The typical plant read off its printed interval: better where it lies wholly below
    −δ, worse wholly above +δ, equivalent wholly within ±δ, else undecided."""
    out = np.full(len(estimate), UNDECIDED, dtype=object)
    with np.errstate(invalid="ignore"):
        out[high < -tol] = BETTER
        out[low > tol] = WORSE
        out[(low > -tol) & (high < tol)] = EQUIVALENT  # a bound on the margin: not inside
    return out


def _tests(
    c: dict[str, np.ndarray], tol: np.ndarray, tested: np.ndarray, family: np.ndarray
) -> dict[str, np.ndarray]:
    """The p-values kept beside the verdict as evidence (the sign test, TOST, the margin
    tests), each with its Holm adjustment across the family's ``tested`` rows (a pair)."""
    sign_p = _sign_ps(c["better"], c["worse"])
    tost_p, below_p, above_p = _margin_tests(c["d"], tol)
    margin_p = np.minimum(1.0, 2.0 * np.minimum(below_p, above_p))
    return {
        "p_value": np.where(c["n"] > 0, sign_p, 1.0),
        "tost_p": tost_p,
        "margin_p": margin_p,
        "p_adjusted": _holm_families(np.where(tested, sign_p, np.nan), family),
        "tost_p_adjusted": _holm_families(np.where(tested, tost_p, np.nan), family),
        "margin_p_adjusted": _holm_families(np.where(tested, margin_p, np.nan), family),
    }


def _shares(
    c: dict[str, np.ndarray], compared: np.ndarray, family: np.ndarray, runs: np.ndarray
) -> dict[str, np.ndarray]:
    """The shares of plants practically better and worse with their exact 95 % intervals,
    whether each is shown above :data:`MIN_SHARE` (Holm across the family), as ``_most_*``
    its count shown above :data:`MOST` of the ``runs`` (Holm likewise) and, as ``_none_*``,
    shown below 5 %."""
    plants, k_better, k_worse = c["plants"], c["k_better"], c["k_worse"]
    with np.errstate(invalid="ignore", divide="ignore"):
        share_better = np.where(plants > 0, k_better / np.maximum(plants, 1), np.nan)
        share_worse = np.where(plants > 0, k_worse / np.maximum(plants, 1), np.nan)
    better_low, better_high = proportion_interval(k_better, plants)
    worse_low, worse_high = proportion_interval(k_worse, plants)
    # exact binomial tests of a share against MIN_SHARE: above it (shown), below (none)
    shown_p = np.concatenate([stats.binom.sf(k_better - 1, plants, MIN_SHARE),
                              stats.binom.sf(k_worse - 1, plants, MIN_SHARE)])  # fmt: skip
    shown_p[np.concatenate([plants, plants]) == 0] = np.nan
    rows = np.concatenate([compared, compared])
    shown = _holm_families(np.where(rows, shown_p, np.nan), np.tile(family, 2)) < ALPHA / 2
    # and that most of the plants both ran are beyond ±δ one way (more than one half of
    # ``runs``, as the typical plant's quorum), Holm across the family as well
    most_p = np.concatenate([stats.binom.sf(k_better - 1, runs, MOST),
                             stats.binom.sf(k_worse - 1, runs, MOST)])  # fmt: skip
    most_p[np.concatenate([plants, plants]) == 0] = np.nan
    most = _holm_families(np.where(rows, most_p, np.nan), np.tile(family, 2)) < ALPHA / 2
    return {
        "share_better": share_better,
        "share_better_low": better_low,
        "share_better_high": better_high,
        "share_worse": share_worse,
        "share_worse_low": worse_low,
        "share_worse_high": worse_high,
        "share_better_shown": shown[: len(plants)] & compared,
        "share_worse_shown": shown[len(plants) :] & compared,
        "_most_better": most[: len(plants)] & compared,
        "_most_worse": most[len(plants) :] & compared,
        "_none_better": stats.binom.cdf(k_better, plants, MIN_SHARE) < ALPHA / 2,
        "_none_worse": stats.binom.cdf(k_worse, plants, MIN_SHARE) < ALPHA / 2,
    }


def _verdict(
    typical: np.ndarray,
    estimate: np.ndarray,
    shares: dict[str, np.ndarray],
    c: dict[str, np.ndarray],
) -> np.ndarray:
    """The one-word verdict (claims_words.VERDICT_WORDS; docs/statistics.md, "The verdict
    rule"), by the first line that holds: not judged (no plant compares), equal (no plant
    beyond ±δ), the typical plant's better or worse; where it is equivalent, the sides
    with more than :data:`SPLIT_SHARE` of the plants beyond ±δ (none: equivalent, one:
    partly that way, both: split); where it is undecided or not judged, the shares (one
    shown above 5 %, the other shown below it, the estimate not on the other side of 0:
    partly that way; both shown: split; a share shown above one half, the estimate not
    against it: better or worse, as most plants are); else undecided."""
    plants, k = c["plants"], {BETTER: c["k_better"], WORSE: c["k_worse"]}
    verdict = np.full(len(typical), UNDECIDED, dtype=object)
    with np.errstate(invalid="ignore"):
        beyond = {side: k[side] > SPLIT_SHARE * plants for side in k}
        against = {BETTER: estimate > 0, WORSE: estimate < 0}  # NaN: never against
    equivalent = typical == EQUIVALENT
    open_ = (typical == UNDECIDED) | (typical == NOT_JUDGED)
    shown = {BETTER: shares["share_better_shown"], WORSE: shares["share_worse_shown"]}
    none = {BETTER: shares["_none_better"], WORSE: shares["_none_worse"]}
    verdict[equivalent] = EQUIVALENT
    for side, other in ((BETTER, WORSE), (WORSE, BETTER)):
        one_way = equivalent & beyond[side] & ~beyond[other]
        one_way |= open_ & shown[side] & none[other] & ~against[side]
        verdict[one_way] = PARTLY[side]
    both_ways = (equivalent & beyond[BETTER] & beyond[WORSE]) | (
        open_ & shown[BETTER] & shown[WORSE]
    )
    verdict[both_ways] = SPLIT
    for side in (BETTER, WORSE):  # most plants that way: the median plant is, by the counts
        most = shares[f"_most_{side}"]
        verdict[(typical == side) | (open_ & most & ~against[side])] = side
    verdict[(k[BETTER] == 0) & (k[WORSE] == 0)] = EQUAL
    verdict[plants == 0] = NOT_JUDGED
    return verdict


def judge(
    a: np.ndarray,
    b: np.ndarray,
    metric: str,
    reference: float | None = None,
    tolerance: float | None = None,
    delay: tuple[np.ndarray, np.ndarray, float] | None = None,
) -> dict[str, float | int | str]:
    """One metric's pairs (``a`` proposed, ``b`` baseline, one value per plant) judged as
    a family of one, by the same path as every table (:func:`paired_claims`): counts,
    estimate and interval, shares, p-values and the verdict. ``reference``: the move's own
    value of ``metric`` (a time of :data:`TIMES_OF_THE_MOVE`: judged by its distance to
    it); ``tolerance``: default :data:`TOLERANCES`; ``delay``: the proposed's and the
    baseline's Td and the move's own, which Tr on a moving reference is judged with."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    columns = {f"joint1_{metric}": (a, b)}
    own = {} if reference is None else {(1, metric): float(reference)}
    if delay is not None:
        columns["joint1_delay_time_s"] = (np.asarray(delay[0], float), np.asarray(delay[1], float))
        own[(1, "delay_time_s")] = float(delay[2])
    rows = [
        {"sample": i, "controller": name, **{k: v[side][i] for k, v in columns.items()}}
        for side, name in enumerate(("proposed", "baseline"))
        for i in range(a.size)
    ]
    tol = None if tolerance is None else {metric: float(tolerance)}
    table = paired_claims(pd.DataFrame(rows), "proposed", "baseline", [metric], [1], own, tol)
    return {k: getattr(v, "item", lambda v=v: v)() for k, v in table.iloc[0].items()}


def _dense(
    results: pd.DataFrame, names: Sequence[str], columns: Sequence[str], by: Sequence[str]
) -> tuple[np.ndarray, np.ndarray, pd.DataFrame]:
    """The results as one array: (controller, group, plant, column) values, NaN where a
    plant did not run that controller, with the (controller, group, plant) mask of runs
    and the groups' keys. Plants are the samples of a group, in order; a run that raised
    (``status`` "error") did not run."""
    frame = results
    if "status" in frame.columns:
        frame = frame[frame["status"].to_numpy(object) != "error"]
    frame = frame[frame["controller"].isin(names)]
    if by:
        group = frame.groupby(list(by), sort=True, observed=True, dropna=False).ngroup().to_numpy()
        keys = frame[list(by)].drop_duplicates().sort_values(list(by)).reset_index(drop=True)
    else:
        group, keys = np.zeros(len(frame), int), pd.DataFrame(index=[0])
    sample = frame["sample"].to_numpy()
    plant_key = pd.MultiIndex.from_arrays([group, sample])
    codes, uniques = pd.factorize(plant_key, sort=True)
    ugroup = np.asarray(uniques.get_level_values(0))
    first = np.searchsorted(ugroup, np.arange(len(keys)))
    slot = np.arange(len(uniques)) - first[ugroup]
    size = int(slot.max()) + 1 if len(slot) else 0
    who = pd.Categorical(frame["controller"], categories=list(names)).codes
    values = np.full((len(names), len(keys), size, len(columns)), np.nan)
    ran = np.zeros((len(names), len(keys), size), bool)
    at = (who, ugroup[codes], slot[codes])
    values[at] = frame[list(columns)].to_numpy(dtype=float)
    ran[at] = True
    return values, ran, keys


def paired_claims_many(
    results: pd.DataFrame,
    pairs: Sequence[tuple[str, str]],
    metrics: Sequence[str] = CLAIM_METRICS,
    joints: Sequence[int] = (1, 2),
    by: Sequence[str] = (),
    reference_values: Mapping[tuple[int, str], float] | None = None,
    tolerances: Mapping[str, float] | None = None,
) -> pd.DataFrame:
    """Every (proposed, opponent) of ``pairs`` judged in every group of plants (``by``: the
    columns that name a group, e.g. a regime map's cell), per joint and metric, in one
    pass: the rows of :func:`paired_claims` of each table, stacked, with the group's keys,
    ``proposed`` and ``opponent`` first. Each (group, pair) is its own family (Holm). A
    pair of which either controller has no plant in a group is left out there."""
    tol = {**TOLERANCES, **(tolerances or {})}
    own = dict(reference_values or {})
    names = list(dict.fromkeys(name for pair in pairs for name in pair))
    keys_ = [(j, key) for j in joints for key in metrics]
    beside = [(j, "delay_time_s") for j, key in keys_  # Td for Tr on a moving reference
              if key == "rise_time_s" and own.get((j, key), 0) > 0]  # fmt: skip
    read = list(dict.fromkeys(keys_ + beside))
    columns = [f"joint{j}_{key}" for j, key in read]
    missing = [c for c in columns if c not in results.columns]
    if missing:
        why = " (Tr on a moving reference is judged with Td beside it)" if beside else ""
        raise ValueError(f"the results have no column {', '.join(missing)}{why}")
    values, ran, groups = _dense(results, names, columns, by)
    where = {name: k for k, name in enumerate(names)}
    blocks = []  # (group, proposed, opponent) families in output order
    for g in range(len(groups)):
        for proposed, opponent in pairs:
            p, o = where[proposed], where[opponent]
            if ran[p, g].any() and ran[o, g].any():
                blocks.append((g, p, o))
    count, width = len(blocks), len(keys_)
    if not count:
        return pd.DataFrame()
    g_, p_, o_ = (np.array([b[i] for b in blocks]) for i in range(3))
    both = ran[p_, g_] & ran[o_, g_]  # (family, plant)
    # (side, family, plant) per key; plants neither ran stay NaN in both: no pair, no count
    sides = np.stack([values[p_, g_], values[o_, g_]])
    sides = np.where(both[None, :, :, None], sides, np.nan)
    judged = move_distances({k: sides[..., i] for i, k in enumerate(read)}, own)
    a = np.stack([judged[k][0] for k in keys_], axis=1)  # (family, metric, plant)
    b = np.stack([judged[k][1] for k in keys_], axis=1)
    out = judge_rows(
        a.reshape(count * width, -1),
        b.reshape(count * width, -1),
        np.tile([tol[key] for _, key in keys_], count),
        np.repeat(np.arange(count), width),
        np.tile([key in REACHED for _, key in keys_], count),
        np.repeat(both.sum(axis=1), width),
    )
    # the move's own value where the row judges a distance to it (a step's own 0: T itself)
    own_values = [own.get(k, math.nan) if k[1] in TIMES_OF_THE_MOVE else math.nan for k in keys_]
    out["reference"] = np.tile(own_values, count)
    table = pd.DataFrame({
        **{c: groups[c].to_numpy()[np.repeat(g_, width)] for c in by},
        "proposed": np.repeat(np.array(names, dtype=object)[p_], width),
        "opponent": np.repeat(np.array(names, dtype=object)[o_], width),
        "joint": np.tile([j for j, _ in keys_], count),
        "metric": np.tile([key for _, key in keys_], count),
        **out,
    })  # fmt: skip
    from twolink.studies.judgments.claims_words import reading

    table["reading"] = reading(table)
    return table


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
        ``(joint, metric) -> value`` of the reference itself (e.g. Td of the quintic move,
        :func:`~twolink.studies.judgments.claims_plans.reference_values`): a time of
        :data:`TIMES_OF_THE_MOVE` whose own value is above 0 is judged by its distance to
        it (:func:`move_distances`; Tr needs Td of its joint in ``results``).
    tolerances : mapping, optional
        Practical tolerance per metric (default :data:`TOLERANCES`).

    Returns
    -------
    DataFrame
        One row per (joint, metric): ``n``, ``better``, ``worse``, ``equal``,
        ``tolerance``, the two medians, ``estimate`` (Hodges-Lehmann) with ``ci_low`` and
        ``ci_high`` (at ``ci_level``), the shares (``share_better``, ``share_worse`` with their
        ``_low``/``_high`` 95 % bounds, of ``plants``), ``unreached_better`` and
        ``unreached_worse``, the p-values (sign test ``p_value``, TOST ``tost_p``,
        margins ``margin_p``, each with its Holm ``_adjusted``), ``typical``, the
        ``verdict`` and its ``reading``.
    """
    names = set(results["controller"])
    for name in (proposed, baseline):
        if name not in names:
            raise ValueError(f"no controller {name!r} in the results (have {sorted(names)})")
    table = paired_claims_many(
        results, [(proposed, baseline)], metrics, joints, (), reference_values, tolerances
    )
    return table.drop(columns=["proposed", "opponent"]).reset_index(drop=True)
