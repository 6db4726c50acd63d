"""Simulated operating characteristics of twolink.studies.claims (docs/statistics.md): the type I
error of the paired sign test and of the equivalence test (TOST) under their nulls, their
power under known shifts, and the Hodges-Lehmann interval's coverage, on paired
differences drawn as the sweeps produce them (continuous, heavy-tailed, zero-inflated).

    python benchmarks/stats_validation.py [--reps 2000]
"""

from __future__ import annotations

import argparse

import numpy as np

from twolink.studies.claims import _sign_p, _tost_p, count_wins, hodges_lehmann

DRAWS = {
    "normal": lambda rng, n: rng.normal(0.0, 1.0, n),
    "t3 (heavy tails)": lambda rng, n: rng.standard_t(3, n),
    "60 % exact zeros": lambda rng, n: np.where(rng.random(n) < 0.6, 0.0, rng.normal(0, 1, n)),
}


SIGN_TOL, TOST_MARGIN = 0.0, 0.3


def rates(draw, n: int, shift: float, reps: int, seed: int) -> dict[str, float]:
    rng = np.random.default_rng(seed)
    sign = tost = covered = 0
    for _ in range(reps):
        d = draw(rng, n) + shift
        better, worse, _ = count_wins(d, np.zeros(n), SIGN_TOL)
        sign += _sign_p(better, worse) < 0.05
        tost += _tost_p(d, TOST_MARGIN) < 0.05
        _, low, high = hodges_lehmann(d)
        covered += low <= shift <= high
    return {"sign": sign / reps, "tost": tost / reps, "coverage": covered / reps}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--reps", type=int, default=2000)
    parser.add_argument("-n", type=int, default=200, help="plants per sweep")
    args = parser.parse_args()
    n, reps = args.n, args.reps
    print(f"n = {n} plants, {reps} simulated sweeps per row; sign test with δ = {SIGN_TOL}")
    print(f"(type I at shift 0, power above), TOST with margin {TOST_MARGIN} (type I at")
    print(f"shift {TOST_MARGIN}, power below); the differences' scale is 1")
    print(
        f"{'differences':18s} {'shift':>6s} {'sign rejects':>13s} {'TOST rejects':>13s} "
        f"{'HL 95% covers':>14s}"
    )
    for name, draw in DRAWS.items():
        for shift in (0.0, 0.1, 0.2, 0.3):
            if name.startswith("60") and shift:
                continue  # the shift would move the zeros too: not the zero-inflated null
            r = rates(draw, n, shift, reps, seed=1)
            print(
                f"{name:18s} {shift:6.2f} {r['sign']:13.3f} {r['tost']:13.3f} {r['coverage']:14.3f}"
            )
    rng = np.random.default_rng(2)
    worse = np.zeros(n)
    worse[rng.choice(n, 97, replace=False)] = rng.uniform(0.6, 5.0, 97)
    b, w, e = count_wins(worse, np.zeros(n), 0.5)
    print(f"zero-inflated case: better {b}, worse {w}, equal {e}, sign p = {_sign_p(b, w):.2g}")


if __name__ == "__main__":
    main()
