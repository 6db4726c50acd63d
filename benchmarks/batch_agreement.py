"""How many arms of a sweep agree with the single-arm reference path, and from when not.

Every row of a sweep comes from the batch engine (one MuJoCo model per chunk of plants);
``twolink run`` of the same plant uses the single-arm loop. The two agree to rounding at
every instant (tests/test_batch.py: 1e-12 rad), but a closed loop can amplify rounding:
this script runs every (sample, controller) of a sweep both ways and reports, per
controller, how many runs keep every metric within 1e-9 and, for the others, when their
trajectories part (first |Δq| > 1e-9 rad) and by how much their metrics differ.

The yardstick, in the same run: the single-arm loop against itself with the plant's g
moved by one ulp (``np.nextafter``), a rounding-sized change with no batch involved. A
controller whose runs part as often under it amplifies rounding by itself.

    python benchmarks/batch_agreement.py                      # robustness.toml, 200 plants
    python benchmarks/batch_agreement.py -n 1000 --set overrides.duration=10.0
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from tqdm import tqdm

from twolink.simulation.config import merge, parse_set, scenario_from_dict
from twolink.simulation.experiment import iter_scenarios, measure, run_scenario
from twolink.sweep import load_sweep
from twolink.sweep.execution import _metric_values

ROOT = Path(__file__).resolve().parents[1]
TOLERANCE = 1e-9


def metrics(s, traj) -> np.ndarray:
    """A run's metrics as the sweep's row holds them."""
    return np.array(_metric_values(measure(s, traj)), float)


def difference(got: np.ndarray, want: np.ndarray) -> np.ndarray:
    """|got - want| per metric: 0 where both are NaN, inf where only one is."""
    diff = np.abs(got - want)
    both = np.isnan(got) & np.isnan(want)
    diff[both] = 0.0
    diff[np.isnan(diff)] = np.inf
    return diff


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sweep", nargs="?", default=ROOT / "runs/sweeps/robustness.toml")
    parser.add_argument("-n", "--samples", type=int, default=None)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    over = parse_set(args.set)
    if args.samples:
        over["samples"] = args.samples
    plan = load_sweep(args.sweep, over)
    names = list(plan.controller_names)
    print(f"{plan.file}: {plan.samples} plants x {names}, chunks of {plan.chunk_size}")
    report: dict[str, list] = {name: [] for name in plan.controller_names}
    for chunk in tqdm(range(plan.n_chunks), desc="chunks"):
        scenarios, nudged = [], []
        for i in plan.chunk_samples(chunk):
            values, seed = plan.draw(i)
            ulp = {**values, "g": float(np.nextafter(values.get("g", 1.0), np.inf))}
            for name in plan.controller_names:
                controller = plan.controller_data(name, values)["controller"]
                data = merge(plan.sample_data(values, seed), {"controller": controller})
                scenarios.append((name, scenario_from_dict(data, plan.file)))
                data = merge(plan.sample_data(ulp, seed), {"controller": controller})
                nudged.append(scenario_from_dict(data, plan.file))
        # One batch per chunk, as the sweep runs it (the controllers built per arm here:
        # the same objects' arithmetic, see twolink.sweep.execution.run_chunk).
        batch = dict(iter_scenarios([s for _, s in scenarios]))
        for k, (name, s) in enumerate(scenarios):
            single = run_scenario(s)
            b = batch[k]
            want = metrics(s, single)
            diff = difference(metrics(s, b), want)
            off = difference(metrics(nudged[k], run_scenario(nudged[k])), want)
            n = min(len(b.t), len(single.t))
            dq = np.abs(b.q[:n] - single.q[:n]).max(axis=1)
            parted = np.flatnonzero(dq > TOLERANCE)
            report[name].append(
                (
                    float(diff.max()) if diff.size else 0.0,
                    float(single.t[parted[0]]) if parted.size else np.nan,
                    float(dq.max()),
                    b.status == single.status,
                    float(off.max()) if off.size else 0.0,
                )
            )
    for name, rows in report.items():
        worst, parted_at, dq, same_status, ulp = (np.array(c) for c in zip(*rows, strict=True))
        agree = worst <= TOLERANCE
        print(
            f"{name:8s}: {agree.sum()}/{len(rows)} runs with every metric within {TOLERANCE:g}; "
            f"same status in {same_status.sum()}; max |Δq| over all runs {dq.max():.1e} rad"
        )
        print(
            f"          yardstick, the single loop with g one ulp higher: "
            f"{(ulp <= TOLERANCE).sum()}/{len(rows)} within {TOLERANCE:g}, "
            f"largest metric difference {ulp.max():.3g}"
        )
        if (~agree).any():
            at, off = parted_at[~agree], worst[~agree]
            print(
                f"          the others part at t = {np.nanmin(at):.2f} to {np.nanmax(at):.2f} s "
                f"(median {np.nanmedian(at):.2f}); largest metric difference {off.max():.3g} "
                f"(median {np.median(off):.2g})"
            )


if __name__ == "__main__":
    main()
