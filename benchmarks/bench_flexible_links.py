"""The cost of links that bend: one MuJoCo step of the flexible-link arm against N, as
a ratio to one step of the rigid arm timed in the same run, and the cost of a simulated
second (the stable RK4 step shrinks with N: twolink.arm.links.stable_timestep). With
``--batch``, the cost per arm-step of B arms in one model (the batch engine for links,
twolink.simulation.links_sim.LinkBatch), against N and B.

    python benchmarks/bench_flexible_links.py            # N = 1 to 64, 20 000 steps each
    python benchmarks/bench_flexible_links.py --steps 5000 --zeta 0
    python benchmarks/bench_flexible_links.py --batch 1 8 64 --segments 4 8 16 --steps 2000
"""

from __future__ import annotations

import argparse
import time

from twolink.arm.links import FlexibleLinks, LinkBeam, build_links_model, stable_timestep
from twolink.arm.params import ArmParams
from twolink.arm.plant import build_model, mujoco


def per_step(model, steps: int, repeats: int = 3) -> float:
    """Best of ``repeats`` mean seconds per ``mj_step`` from rest, torques off."""
    data = mujoco.MjData(model)
    best = float("inf")
    for _ in range(repeats):
        mujoco.mj_resetData(model, data)
        data.qvel[0] = 0.5  # a moving arm, as in a run
        start = time.perf_counter()
        for _ in range(steps):
            mujoco.mj_step(model, data)
        best = min(best, (time.perf_counter() - start) / steps)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20_000)
    parser.add_argument("--zeta", type=float, default=0.01, help="material damping ratio")
    parser.add_argument("--segments", type=int, nargs="+", default=[1, 2, 4, 8, 16, 32, 64])
    parser.add_argument("--batch", type=int, nargs="+", default=[], help="arms per model")
    args = parser.parse_args()
    rigid = build_model(ArmParams(), timestep=1e-3)
    base = per_step(rigid, args.steps)
    print(f"rigid arm: {base * 1e6:.2f} us a step (RK4), 1000 steps a simulated second")
    if args.batch:
        batch_table(args, base)
        return
    print(
        f"{'N':>4} {'nq':>4} {'us/step':>9} {'x rigid':>8} {'dt [s]':>10} {'x rigid per sim s':>18}"
    )
    beam = LinkBeam(damping_ratio=args.zeta)
    for n in args.segments:
        links = FlexibleLinks(beam, beam, n)
        dt = stable_timestep(links)
        model = build_links_model(links, timestep=dt, visual=False)
        cost = per_step(model, args.steps)
        per_second = cost / dt / (base / 1e-3)
        print(
            f"{n:>4} {model.nq:>4} {cost * 1e6:>9.2f} {cost / base:>8.2f} {dt:>10.3g}"
            f" {per_second:>18.3g}"
        )


def batch_table(args, base: float) -> None:
    """Seconds per arm-step of B arms in one model, and its ratio to the rigid arm's step."""
    from twolink.simulation.links_sim import LinkBatch

    beam = LinkBeam(damping_ratio=args.zeta)
    first = f"x B = {args.batch[0]}"
    print(f"{'N':>4} {'B':>5} {'us/arm-step':>12} {'x rigid':>8} {first:>15}")
    for n in args.segments:
        links = FlexibleLinks(beam, beam, n)
        alone = None
        for b in args.batch:
            model = LinkBatch([(links, 0.0)] * b, 0.0, stable_timestep(links)).model
            cost = per_step(model, max(1, args.steps // b)) / b
            alone = alone or cost
            print(f"{n:>4} {b:>5} {cost * 1e6:>12.2f} {cost / base:>8.2f} {cost / alone:>15.2f}")


if __name__ == "__main__":
    main()
