"""The regime map's statistics, per table as before (``claims_before.py``: one
``paired_claims`` per cell, proposed and opponent, pandas indexing per table) against all
tables at once (``twolink.studies.judgments.regimes.regime_table`` on ``paired_claims_many``), in
the same run, on a regime-map-sized input: 2 regimes x 30 cells x 100 plants x 4
controllers, 240 tables of 10 rows (issue 41). Checks that both give the same numbers to
the digit, then prints the times and their ratio old/new.

    python benchmarks/bench_claims.py                    # a synthetic map of that size
    python benchmarks/bench_claims.py /tmp/regimes_out   # a real one (twolink regimes --out)
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import claims_before  # this folder is on the path when run as a script
import numpy as np
import pandas as pd

from twolink.studies.judgments.regimes import (
    CELL,
    OPPONENTS,
    PROPOSED,
    REGIME_METRICS,
    regime_table,
)

NUMBERS = ["n", "better", "worse", "equal", "tolerance", "proposed_median", "baseline_median",
           "estimate", "ci_low", "ci_high", "p_value", "tost_p", "p_adjusted",
           "tost_p_adjusted", "fuzzy_active_share"]  # fmt: skip


def synthetic(seed: int = 0) -> dict[str, pd.DataFrame]:
    """Results tables shaped as the regime map's: the grid's cells repeat every 30
    samples; metrics with zero-inflated differences, ties and never-reached times."""
    rng = np.random.default_rng(seed)
    grid = [(w, m, p) for w in (2.0, 4.0, 5.0, 10.0, 15.0) for m in (1.0, 1.2, 1.5)
            for p in (0.0, 0.5)]  # fmt: skip
    out = {}
    for regime in ("quintic", "raw steps"):
        frames = []
        base = {k: rng.gamma(2.0, 1.0, 3000) for k in REGIME_METRICS}
        for name in ("CTC", "CTC-I", "FCM-CTC", "FCM-CTC-continuous"):
            cells = np.array([grid[s % 30] for s in range(3000)])
            f = pd.DataFrame({"sample": np.arange(3000), "controller": name, "status": "ok"})
            for c, col in zip(CELL, cells.T, strict=True):
                f[c] = col
            for j in (1, 2):
                for k in REGIME_METRICS:
                    v = base[k] * 1e-2 + rng.normal(0, 1e-3, 3000) * (rng.random(3000) < 0.4)
                    v[rng.random(3000) < 0.03] = np.nan
                    f[f"joint{j}_{k}"] = v
                f[f"joint{j}_fuzzy_active_share"] = rng.random(3000) * name.startswith("FCM")
            frames.append(f)
        out[regime] = pd.concat(frames, ignore_index=True)
    return out


def real(folder: Path) -> dict[str, pd.DataFrame]:
    from twolink.sweep import load_results

    return {r: load_results(folder / r.replace(" ", "_")) for r in ("quintic", "raw steps")}


def before(results: dict[str, pd.DataFrame]) -> pd.DataFrame:
    """The regime map's table as regimes.regime_table computed it before: per cell."""
    frames = []
    for regime, r in results.items():
        for cell, frame in r.groupby(list(CELL)):
            keys = dict(zip(CELL, cell, strict=True))
            for proposed in (p for p in PROPOSED if (frame["controller"] == p).any()):
                fcm = frame[frame["controller"] == proposed]
                active = fcm[["joint1_fuzzy_active_share", "joint2_fuzzy_active_share"]]
                share = float(np.nanmean(active.to_numpy(float)))
                for opponent in OPPONENTS:
                    t = claims_before.paired_claims(frame, proposed, opponent, REGIME_METRICS)
                    frames.append(t.assign(regime=regime, proposed=proposed, opponent=opponent,
                                           fuzzy_active_share=share, **keys))  # fmt: skip
    return pd.concat(frames, ignore_index=True)


def main() -> None:
    source = Path(sys.argv[1]) if len(sys.argv) > 1 else None
    results = real(source) if source else synthetic()
    start = time.perf_counter()
    old = before(results)
    t_old = time.perf_counter() - start
    start = time.perf_counter()
    new = regime_table(results)
    t_new = time.perf_counter() - start
    assert len(old) == len(new), (len(old), len(new))
    keys = ["regime", *CELL, "proposed", "opponent", "joint", "metric"]
    for c in keys:
        assert (old[c].astype(str).to_numpy() == new[c].astype(str).to_numpy()).all(), c
    for c in NUMBERS:
        same = np.array_equal(old[c].to_numpy(float), new[c].to_numpy(float), equal_nan=True)
        assert same, f"{c} differs"
    changed = pd.crosstab(old["verdict"], new["verdict"])
    print(f"input: {'the regime map in ' + str(source) if source else 'synthetic'}, "
          f"{len(old) // 10} tables, {len(old)} rows")  # fmt: skip
    print(f"numbers equal to the digit: {', '.join(NUMBERS)}")
    print(f"per table (before): {t_old:.2f} s; all at once: {t_new:.2f} s; "
          f"ratio old/new {t_old / t_new:.1f}x")  # fmt: skip
    print("verdicts, before (rows) against now (columns):")
    print(changed.to_string())


if __name__ == "__main__":
    main()
