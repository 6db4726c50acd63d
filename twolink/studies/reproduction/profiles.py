"""Performance profiles (Dolan & Moré 2002, "Benchmarking optimization software with
performance profiles", *Math. Program.* 91:201) of every controller over a sweep's plants.

Per plant p and controller s the ratio r(p, s) = cost(p, s) / min over s of cost(p, ·);
the profile ρ_s(τ) is the share of plants with r(p, s) ≤ τ. ρ_s(1) is the share of plants
on which s is the best; the curve that stays highest is the better controller over the
plants; where it reaches 1 says how far from the best it ever is. A plant where a
controller has no value (a run that raised) counts as never within any τ (r = ∞). The
costs are read from the sweep's own table (``results.parquet``), not computed again.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

__all__ = [
    "PROFILE_COSTS",
    "SCOREBOARD_KEYS",
    "costs",
    "median_interval",
    "performance_profile",
    "ratios",
    "scoreboard",
]

# The costs profiled, per joint summed: tracking (IAE) and effort (Σ|Δτ|): one each.
PROFILE_COSTS = ("iae_rad_s", "torque_variation_Nm")


def costs(results: pd.DataFrame, key: str, joints=(1, 2)) -> pd.DataFrame:
    """Per plant (row, by ``sample``) and controller (column): ``key`` summed over
    ``joints`` (``joint1_<key>`` + ``joint2_<key>``), NaN where any joint lacks it."""
    total = sum(results[f"joint{j}_{key}"] for j in joints)
    table = results.assign(cost=total).pivot(index="sample", columns="controller", values="cost")
    return table[list(dict.fromkeys(results["controller"]))]  # the sweep's order


def ratios(cost: pd.DataFrame) -> np.ndarray:
    """r(p, s): each plant's cost over that plant's best (∞ where a controller has no value,
    or the best is 0 and its cost is not); plants no controller has are left out."""
    values = cost.to_numpy(dtype=float)
    values = values[np.isfinite(values).any(axis=1)]
    best = np.nanmin(values, axis=1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(values == best, 1.0, values / best)
    return np.where(np.isfinite(ratio), ratio, np.inf)


def performance_profile(cost: pd.DataFrame, taus: np.ndarray | None = None) -> pd.DataFrame:
    """ρ_s(τ) of each controller (column of ``cost``, one row per plant) at each τ of
    ``taus`` (≥ 1), a table indexed by τ. By default τ runs from 1 to the largest finite
    ratio (at least 2, where every curve has reached its end), 400 points evenly on a log
    scale."""
    ratio = ratios(cost)
    if taus is None:
        finite = ratio[np.isfinite(ratio)]
        taus = np.geomspace(1.0, max(2.0, float(finite.max(initial=1.0)) * 1.05), 400)
    taus = np.asarray(taus, dtype=float)
    rho = (ratio[None, :, :] <= taus[:, None, None]).mean(axis=1)
    return pd.DataFrame(rho, index=pd.Index(taus, name="tau"), columns=cost.columns)


# The scoreboard's columns: tracking (IAE) and effort (peak |τ|, Σ|Δτ|), per joint.
SCOREBOARD_KEYS = ("iae_rad_s", "torque_peak_Nm", "torque_variation_Nm")


def median_interval(values: np.ndarray, level: float = 0.95) -> tuple[float, float, float]:
    """The median and its distribution-free interval from order statistics (Conover,
    *Practical Nonparametric Statistics*, 3rd ed., §3.2): ``[x_(j), x_(n−j+1)]`` with
    ``j`` the smallest count at which Bin(n, ½)'s CDF reaches (1 − level) / 2, so that
    it covers the median with at least ``level``. NaN values are left out; NaN bounds
    where too few values are left for one."""
    from scipy.stats import binom

    x = np.sort(np.asarray(values, dtype=float)[np.isfinite(values)])
    n = len(x)
    if n == 0:
        return math.nan, math.nan, math.nan
    j = int(binom.ppf((1 - level) / 2, n, 0.5))
    if j < 1:
        return float(np.median(x)), math.nan, math.nan
    return float(np.median(x)), float(x[j - 1]), float(x[n - j])


def scoreboard(results: pd.DataFrame, keys=SCOREBOARD_KEYS) -> pd.DataFrame:
    """Per controller (the sweep's order), joint and metric of ``keys``: the median over
    the plants its run completed on (``status`` "ok"), its interval
    (:func:`median_interval`) and the plants; plus ``iae_sum``, the median of IAE1 + IAE2
    per plant, the scoreboard's order (the lowest first: the best)."""
    ok = results[results["status"] == "ok"] if "status" in results else results
    rows = []
    for name in dict.fromkeys(results["controller"]):
        mine = ok[ok["controller"] == name]
        total = (mine["joint1_iae_rad_s"] + mine["joint2_iae_rad_s"]).to_numpy(float)
        for key in keys:
            for j in (1, 2):
                values = mine[f"joint{j}_{key}"].to_numpy(float)
                median, low, high = median_interval(values)
                rows.append({
                    "controller": name, "joint": j, "metric": key, "median": median,
                    "low": low, "high": high, "plants": int(np.isfinite(values).sum()),
                    "iae_sum": float(np.nanmedian(total)) if len(total) else math.nan,
                })  # fmt: skip
    return pd.DataFrame(rows).sort_values("iae_sum", kind="stable").reset_index(drop=True)
