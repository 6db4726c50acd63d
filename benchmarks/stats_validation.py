"""Simulated operating characteristics of twolink.studies.judgments.claims (docs/statistics.md):
the type I
error of the paired sign test and of the equivalence test (TOST) under their nulls, their
power under known shifts, and the Hodges-Lehmann interval's coverage, on paired
differences drawn as the sweeps produce them (continuous, heavy-tailed, zero-inflated);
then the verdict rule's own rates (judge_rows, all simulated sweeps at once): on the
margin, off it, and on mixtures around MIN_SHARE.

    python benchmarks/stats_validation.py [--reps 2000]
"""

from __future__ import annotations

import argparse

import numpy as np

from twolink.studies.judgments.claims import (
    _sign_p,
    _tost_p,
    count_wins,
    hodges_lehmann,
    judge_rows,
)

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

    verdict_rates(n, reps)


# The verdict rule's cases (tolerance δ = 0.3, noise scale 1 unless said): name -> draw
MARGIN = 0.3
CASES = {
    "normal, shift 0": lambda rng, n: rng.normal(0, 1, n),
    "normal, shift δ (on the margin)": lambda rng, n: rng.normal(MARGIN, 1, n),
    "normal, shift 2δ": lambda rng, n: rng.normal(2 * MARGIN, 1, n),
    "tight, shift δ/2": lambda rng, n: rng.normal(MARGIN / 2, 0.1, n),
    "15 % of plants +4δ, rest 0": lambda rng, n: np.where(rng.random(n) < 0.15, 4 * MARGIN, 0.0),
    "5 % of plants +4δ, rest 0": lambda rng, n: np.where(rng.random(n) < 0.05, 4 * MARGIN, 0.0),
    "half +2δ, half 0": lambda rng, n: np.where(rng.random(n) < 0.5, 2 * MARGIN, 0.0),
}


def verdict_rates(n: int, reps: int) -> None:
    """Share of simulated sweeps per verdict, and how often a worse share is said."""
    print()
    print(f"verdict rule, tolerance {MARGIN}, n = {n}, {reps} sweeps per row (each its own family)")
    head = ("better", "worse", "equivalent", "partly worse", "split", "undecided")
    print(f"{'differences':32s} " + " ".join(f"{h:>12s}" for h in head) + f" {'worse said':>11s}")
    for k, (name, draw) in enumerate(CASES.items()):
        rng = np.random.default_rng(10 + k)
        d = np.stack([draw(rng, n) for _ in range(reps)])
        out = judge_rows(d, np.zeros_like(d), np.full(reps, MARGIN), np.arange(reps),
                         np.zeros(reps, bool))  # fmt: skip
        shares = [np.mean(out["verdict"] == h) for h in head]
        said = np.mean(out["share_worse_shown"])
        print(f"{name:32s} " + " ".join(f"{x:12.3f}" for x in shares) + f" {said:11.3f}")


if __name__ == "__main__":
    main()
