"""Links that bend on MuJoCo's accelerator backend, MJX: the time to compile one step and
the cost of a step, against N, beside MuJoCo's own step of the same model (the baseline,
timed in the same run).

Each N runs in its own process under a time limit, so a compile that does not end is a
result ("over the limit"), not a hang. Needs JAX and MJX (``pip install "twolink[mjx]"``).

    python benchmarks/bench_mjx_links.py                 # N = 1, 2, 3, 4; 120 s each
    python benchmarks/bench_mjx_links.py --segments 1 2 --limit 60
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time

ONE = """
import time, sys, numpy as np, mujoco, jax
jax.config.update("jax_enable_x64", True)
from mujoco import mjx
from twolink.arm.links import FlexibleLinks, LinkBeam, build_links_model
beam = LinkBeam(ei=800.0, hub_inertia=0.05)
m = build_links_model(FlexibleLinks(beam, beam, {n}), 9.81, 0.0, timestep=2e-4, visual=False,
                      motors=False)
d = mujoco.MjData(m)
t = time.perf_counter()
for _ in range(20000): mujoco.mj_step(m, d)
c_us = (time.perf_counter() - t) / 20000 * 1e6
mm, md = mjx.put_model(m), mjx.put_data(m, mujoco.MjData(m))
step = jax.jit(mjx.step)
t = time.perf_counter(); md = step(mm, md); jax.block_until_ready(md.qpos)
compile_s = time.perf_counter() - t
t = time.perf_counter()
for _ in range(20): md = step(mm, md)
jax.block_until_ready(md.qpos)
mjx_us = (time.perf_counter() - t) / 20 * 1e6
print(f"RESULT {{c_us}} {{compile_s}} {{mjx_us}}", flush=True)
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--segments", type=int, nargs="+", default=[1, 2, 3, 4])
    parser.add_argument("--limit", type=float, default=120.0, help="seconds per N")
    args = parser.parse_args()
    head = ("N", "nq", "MuJoCo step", "MJX compile", "MJX step", "x MuJoCo")
    print(" ".join(f"{h:>{w}}" for h, w in zip(head, (3, 4, 12, 12, 10, 9), strict=True)))
    for n in args.segments:
        start = time.perf_counter()
        try:
            out = subprocess.run([sys.executable, "-c", ONE.format(n=n)], capture_output=True,
                                 text=True, timeout=args.limit).stdout  # fmt: skip
        except subprocess.TimeoutExpired:
            wall = time.perf_counter() - start
            print(f"{n:>3} {2 * n + 2:>4} {'':>12} {'over ' + format(wall, '.0f') + ' s':>12}")
            continue
        line = next((x for x in out.splitlines() if x.startswith("RESULT")), None)
        if line is None:
            print(f"{n:>3} failed: {out[-300:]}")
            continue
        c_us, compile_s, mjx_us = map(float, line.split()[1:])
        print(f"{n:>3} {2 * n + 2:>4} {c_us:>9.1f} µs {compile_s:>10.1f} s {mjx_us:>7.0f} µs "
              f"{mjx_us / c_us:>9.0f}")  # fmt: skip


if __name__ == "__main__":
    main()
