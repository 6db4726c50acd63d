"""A sweep's results table: its columns, Parquet files, and the summary per controller.

The table is a pandas DataFrame with one row per (sample, controller): ``sample``,
``controller``, the drawn parameters, the metrics of both joints (``joint1_overshoot_pct``,
..., keys of :mod:`twolink.simulation.vocabulary`), ``status`` ("ok", "diverged" or "error") and
``message``. What it was computed from (the controllers in the sweep file's order, the
swept parameters, the joints that move) travels in ``DataFrame.attrs``, which Parquet
keeps, so ``pandas.read_parquet`` on a ``results.parquet`` gives the same frame as
:func:`load_results`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from twolink.foundation.io import atomic_path, atomic_write_json, atomic_write_text
from twolink.simulation.outcome import OUTCOMES
from twolink.simulation.vocabulary import METRICS, format_value

__all__ = [
    "METRIC_COLUMNS",
    "STATUS_ERROR",
    "SweepMeta",
    "format_summary",
    "load_results",
    "read_table",
    "results_frame",
    "summarize",
    "sweep_meta",
    "write_summary",
    "write_table",
]

METRIC_COLUMNS = tuple(f"joint{j}_{m.key}" for j in (1, 2) for m in METRICS)
SUMMARY_METRICS = ("steady_state_error_rad", "overshoot_pct", "settling_time_s")
STATUS_ERROR = "error"  # a sample that raised (the simulation's own are "ok", "diverged")
# outcome (twolink.simulation.outcome) -> its count's key in the summary
OUTCOME_KEYS = {o: o.replace(" ", "_") for o in OUTCOMES}
_TEXT_COLUMNS = ("controller", "status", "message")
_NOT_PARAMETERS = ("sample", "outcome", *_TEXT_COLUMNS)


@dataclass(frozen=True)
class SweepMeta:
    """What a results table was computed from (kept in ``DataFrame.attrs``).

    Attributes
    ----------
    controllers : tuple of str
        Controller names, in the sweep file's order.
    parameters : tuple of str
        Swept parameter names (columns of the table).
    joints : tuple of int
        Joints (1, 2) whose reference is a move, i.e. that have step metrics.
    """

    controllers: tuple[str, ...]
    parameters: tuple[str, ...]
    joints: tuple[int, ...]


def results_frame(
    rows: Iterable[Sequence[Any]], columns: Sequence[str], meta: SweepMeta
) -> pd.DataFrame:
    """The results table of ``rows`` (tuples in ``columns`` order), with ``meta`` attached."""
    df = pd.DataFrame.from_records(list(rows), columns=list(columns))
    dtypes = {c: ("int64" if c == "sample" else "float64") for c in columns}
    for c in _TEXT_COLUMNS:
        dtypes[c] = "str"
    df = df.astype(dtypes)
    df.attrs.update(
        controllers=list(meta.controllers),
        parameters=list(meta.parameters),
        joints=list(meta.joints),
    )
    return df


def sweep_meta(df: pd.DataFrame) -> SweepMeta:
    """The :class:`SweepMeta` of a results table; derived from its columns when the frame
    carries none (one built by hand)."""
    attrs = df.attrs
    if "controllers" in attrs:
        return SweepMeta(
            tuple(attrs["controllers"]), tuple(attrs["parameters"]), tuple(attrs["joints"])
        )
    controllers = tuple(dict.fromkeys(df["controller"]))
    skip = {*_NOT_PARAMETERS, *METRIC_COLUMNS}
    parameters = tuple(c for c in df.columns if c not in skip)
    joints = tuple(j for j in (1, 2) if f"joint{j}_rise_time_s" in df.columns)
    return SweepMeta(controllers, parameters, joints)


def rows_of(df: pd.DataFrame, controller: str, ok_only: bool = False) -> np.ndarray:
    """Boolean mask of the rows of ``controller`` (only status "ok" if ``ok_only``)."""
    mask = (df["controller"] == controller).to_numpy(bool)
    return mask & (df["status"] == "ok").to_numpy(bool) if ok_only else mask


def met_spec(df: pd.DataFrame, controller: str) -> np.ndarray:
    """Boolean mask of the rows of ``controller`` whose outcome is "met spec"."""
    return rows_of(df, controller) & (df["outcome"] == "met spec").to_numpy(bool)


def write_table(path: Path, df: pd.DataFrame) -> Path:
    """Write ``df`` as Parquet, atomically (a reader never sees half a file)."""
    with atomic_path(path, suffix=".parquet") as tmp:
        df.to_parquet(tmp, index=False)
    return path


def read_table(path: str | Path) -> pd.DataFrame:
    """Read a table written by :func:`write_table` (its ``attrs`` included); a ValueError
    naming the file where its metadata is nested past Python's recursion limit."""
    try:
        return pd.read_parquet(path)
    except RecursionError:  # pandas reads the attrs with json.loads
        raise ValueError(f"{path}: not a table twolink wrote (nested too deep)") from None


def load_results(out: str | Path) -> pd.DataFrame:
    """A finished sweep's table (``results.parquet`` in its output folder) as a DataFrame.

    Examples
    --------
    >>> df = load_results("results/sweeps/robustness")            # doctest: +SKIP
    >>> df.groupby("controller")["joint2_steady_state_error_rad"].median()  # doctest: +SKIP
    """
    return read_table(Path(out) / "results.parquet")


def _stats(x: np.ndarray) -> dict[str, float]:
    x = x[np.isfinite(x)]
    if x.size == 0:
        return {"mean": math.nan, "median": math.nan, "p95": math.nan, "n": 0}
    return {
        "mean": float(np.mean(x)),
        "median": float(np.median(x)),
        "p95": float(np.percentile(x, 95)),
        "n": int(x.size),
    }


def summarize(df: pd.DataFrame) -> dict[str, Any]:
    """Per controller: how many runs met the spec, missed it, diverged or raised, the
    success rate (met spec / runs), and stats of ess, Mp and Ts.

    The outcomes are the table's ``outcome`` column (:mod:`twolink.simulation.outcome`). The metric
    statistics (mean, median, 95th percentile, and ``n`` finite values) are over the runs
    that completed (met spec or off target), so a sag shows in them.
    """
    meta = sweep_meta(df)
    outcome = df["outcome"].to_numpy(object)
    out: dict[str, Any] = {}
    for c in meta.controllers:
        rows = rows_of(df, c)
        n = int(rows.sum())
        counts = {key: int((rows & (outcome == o)).sum()) for o, key in OUTCOME_KEYS.items()}
        completed = rows_of(df, c, ok_only=True)
        metrics = {
            f"joint{j}_{m}": _stats(df[f"joint{j}_{m}"].to_numpy(float)[completed])
            for j in meta.joints
            for m in SUMMARY_METRICS
        }
        out[c] = {
            "runs": n,
            **counts,
            "success_rate": counts["met_spec"] / n if n else math.nan,
            "metrics": metrics,
        }
    return out


def summary_frame(summary: Mapping[str, Any]) -> pd.DataFrame:
    """The summary as a flat table: one row per controller, ``<metric>_<stat>`` columns."""
    rows = []
    for c, s in summary.items():
        row = {k: s[k] for k in ("runs", *OUTCOME_KEYS.values(), "success_rate")}
        for metric, st in s["metrics"].items():
            row |= {f"{metric}_{k}": st[k] for k in ("mean", "median", "p95")}
        rows.append({"controller": c, **row})
    return pd.DataFrame(rows)


def write_summary(out: Path, summary: Mapping[str, Any]) -> None:
    """``summary.json`` and the human-readable ``summary.csv`` of a sweep folder."""
    atomic_write_json(out / "summary.json", summary)
    atomic_write_text(out / "summary.csv", summary_frame(summary).to_csv(index=False))


def format_summary(summary: Mapping[str, Any]) -> str:
    """A short plain-text table of the summary (what the command prints)."""
    lines = []
    for c, s in summary.items():
        lines.append(
            f"{c}: {s['met_spec']}/{s['runs']} met the spec ({100 * s['success_rate']:.1f} %), "
            f"{s['off_target']} off target, {s['diverged']} diverged, {s['error']} errors"
            + (f", {s['undecided']} undecided (run longer)" if s.get("undecided") else "")
        )
        for metric, st in s["metrics"].items():
            mean, median, p95 = (format_value(st[k], 4) for k in ("mean", "median", "p95"))
            lines.append(
                f"    {metric:32s} mean {mean:>9s}  median {median:>9s}  p95 {p95:>9s}  "
                f"(n={st['n']})"
            )
    return "\n".join(lines)
