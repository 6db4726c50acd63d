"""The typical plant's shift: the Hodges-Lehmann estimate of paired differences and its
distribution-free interval (the claims tables' ``estimate``, ``ci_low``, ``ci_high``), one
row or many at once."""

from __future__ import annotations

import math

import numpy as np
from scipy import stats


def hodges_lehmann(d: np.ndarray, confidence: float = 0.95) -> tuple[float, float, float]:
    """The Hodges-Lehmann estimate of the shift of paired differences ``d`` (the median of
    the Walsh averages (d_i + d_j)/2, i <= j) and its distribution-free ``confidence``
    interval: the Walsh averages at the ranks the signed-rank statistic's distribution
    gives (normal approximation, Hollander & Wolfe, *Nonparametric Statistical Methods*,
    3.6). NaN for fewer than 2 values."""
    d = np.asarray(d, dtype=float)
    estimate, low, high = _hodges_lehmann_rows(d[None, :], confidence)
    return float(estimate[0]), float(low[0]), float(high[0])


def _hodges_lehmann_rows(
    d: np.ndarray, confidence: float | np.ndarray = 0.95, budget: int = 4_000_000
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`hodges_lehmann` of every row of ``d`` (R, N) at once, NaN marking a plant a
    row does not have; ``confidence`` one for all rows or one per row. Rows with the same
    count n and confidence share the ranks they need (the median's and the interval's),
    so each such group is one ``np.partition`` of its Walsh averages at those ranks (its
    NaNs go last), in chunks of ``budget`` averages."""
    rows = d.shape[0]
    estimate, low, high = (np.full(rows, np.nan) for _ in range(3))
    finite = np.isfinite(d)
    n_all = finite.sum(axis=1)
    ordered = np.sort(np.where(finite, d, np.nan), axis=1)  # each row's values first
    level = np.broadcast_to(np.asarray(confidence, dtype=float), (rows,))
    groups = np.unique(np.stack([n_all, level], axis=1), axis=0)
    for n, conf in groups:
        n = int(n)
        members = np.flatnonzero((n_all == n) & (level == conf))
        z = stats.norm.ppf(0.5 + conf / 2.0)
        if n == 1:
            estimate[members] = ordered[members, 0]
        if n < 2:
            continue
        m = int(n * (n + 1) // 2)
        k = int(math.floor(m / 2.0 - z * math.sqrt(n * (n + 1) * (2 * n + 1) / 24.0)))
        # [min, max] of the Walsh averages covers with 1 - 2^(1-n): short of conf, n
        # plants cannot give the interval asked for (it is the whole line)
        unbounded = k < 0 and 1.0 - 2.0 ** (1 - n) < conf
        k = min(max(k, 0), m - 1)
        ranks = sorted({k, m - 1 - k, (m - 1) // 2, m // 2})
        step = max(1, budget // m)
        for start in range(0, members.size, step):
            part = members[start : start + step]
            walsh = _walsh(ordered[part, : int(n)])
            walsh.partition(ranks, axis=1)
            if m % 2:
                estimate[part] = walsh[:, (m - 1) // 2]
            else:  # np.median's mean of the two middle values
                estimate[part] = (walsh[:, m // 2 - 1] + walsh[:, m // 2]) / 2.0
            low[part], high[part] = walsh[:, k], walsh[:, m - 1 - k]
        if unbounded:
            low[members], high[members] = -np.inf, np.inf
    return estimate, low, high


def _walsh(values: np.ndarray) -> np.ndarray:
    """The Walsh averages (x_i + x_j) / 2, i <= j, of each row of ``values`` (R, n), in
    the order of ``np.triu_indices(n)``: one contiguous block per i (no gather)."""
    rows, n = values.shape
    out = np.empty((rows, n * (n + 1) // 2))
    at = 0
    for i in range(n):
        np.add(values[:, i : i + 1], values[:, i:], out=out[:, at : at + n - i])
        at += n - i
    out /= 2.0
    return out
