"""Scaling: the serial part of the commands, and MuJoCo's accelerator backend per arm-step.

Every figure is a ratio to something timed in the same run:

* ``--workers``: ``twolink regimes`` (``-n``, default 600) and
  ``twolink sweep runs/sweeps/robustness.toml`` with 1, 2, 4, ... all cores' workers, each
  a fresh process (start-up included); the fit T(W) = S + P/W (least squares) gives the
  serial part S and its share S / T(1) of the one-worker time, the speed-up T(1)/T(W)
  and the efficiency T(1) / (W T(W)). Times are also given in yardsticks: 10^6 bare
  single-arm ``mj_step`` calls timed in the same run (issue 41).
* ``--mjx``: the MJX backend's time per arm-step (float64 and float32, N arms of the
  robustness sweep's drawn plants under CTC and FCM-CTC, ideal sensor) against the CPU
  engine's (:func:`twolink.simulation.batch.simulate_batch`, one process, so per core) on
  the same arms, and against MuJoCo's own step of the same batch model. The compiled
  loop is timed on its second call (the first compiles, reported apart).

    python benchmarks/bench_scale.py --workers [--samples 600] [--max-workers 16]
    python benchmarks/bench_scale.py --mjx [--arms 1000 10000] [--duration 0.5]
    python benchmarks/bench_scale.py --limits [--repeats 2] [--only regimes]

* ``--limits``: issue 41's three commands (``regimes -n 30 --workers 2``, ``reproduce
  --no-trace`` into a new folder, the full ``regimes``), each in yardsticks timed just
  before and after it, beside its limit.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_batch  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = {"CTC": "runs/paper/theta1_step.toml", "FCM-CTC": "runs/theta1_step_fcm.toml"}


def yardstick_s(calls: int = 1_000_000) -> float:
    """10^6 bare single-arm mj_step calls [s], from the median of a shorter loop."""
    return bench_batch.bare_step_us(repeats=5, steps=20_000) * calls * 1e-6


def command_s(args: list[str]) -> float:
    """Wall time of a fresh ``python -m twolink ...`` [s]."""
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "twolink", *args], check=True, capture_output=True)
    return time.perf_counter() - start


def fit_serial(workers: list[int], times: list[float]) -> tuple[float, float]:
    """Least-squares S, P of T(W) = S + P / W."""
    a = np.column_stack([np.ones(len(workers)), 1.0 / np.asarray(workers, float)])
    (s, p), *_ = np.linalg.lstsq(a, np.asarray(times), rcond=None)
    return float(s), float(p)


def scaling(samples: int, max_workers: int) -> None:
    counts = sorted({1, *(2**k for k in range(1, 8) if 2**k < max_workers), max_workers})
    yard = yardstick_s()
    print(f"yardstick: 10^6 bare mj_step calls = {yard:.2f} s (this run)\n")
    jobs = {
        f"twolink regimes -n {samples}": lambda w, out: ["regimes", "-n", str(samples),
                                                         "--workers", str(w), "--out", out],
        "twolink sweep robustness.toml": lambda w, out: [
            "sweep", "runs/sweeps/robustness.toml", "--workers", str(w), "--out", out,
            "--no-plots", "--no-progress"],
    }  # fmt: skip
    for name, argv in jobs.items():
        times = []
        for w in counts:
            with tempfile.TemporaryDirectory() as tmp:
                times.append(command_s(argv(w, str(Path(tmp) / "out"))))
            t = times[-1]
            print(f"{name}, {w:>2} workers: {t:7.1f} s  {t / yard:5.2f} yardsticks", flush=True)
        s, p = fit_serial(counts, times)
        print(f"  fit T = S + P/W: S = {s:.1f} s ({s / yard:.2f} yardsticks), P = {p:.1f} s;")
        print(f"  serial share S / T(1) = {s / times[0]:.1%}")
        for w, t in zip(counts, times, strict=True):
            print(f"  W={w:>2}: speed-up {times[0] / t:5.2f}, efficiency {times[0] / (w * t):.2f}")
        print()


# Issue 41's limits, in yardsticks, on a quiet 2-core machine (--limits)
LIMITS = {
    "regimes -n 30 --workers 2": (["regimes", "-n", "30", "--workers", "2"], 0.75),
    "reproduce --no-trace": (["reproduce", "--no-trace"], 5.0),
    "regimes (the full map)": (["regimes"], 15.0),
}


def limits(repeats: int, only: list[str] | None) -> None:
    """Each command of :data:`LIMITS` ``repeats`` times into a new folder, a yardstick timed
    just before and just after each run (their mean is that run's unit)."""
    print(f"{'command':<28} {'wall [s]':>8} {'yardstick [s]':>13} {'yardsticks':>10} {'limit':>6}")
    for name, (argv, limit) in LIMITS.items():
        if only and not any(o in name for o in only):
            continue
        for _ in range(repeats):
            before = yardstick_s()
            with tempfile.TemporaryDirectory() as tmp:
                took = command_s([*argv, "--out", str(Path(tmp) / "out")])
            unit = (before + yardstick_s()) / 2
            print(f"{name:<28} {took:8.2f} {unit:13.2f} {took / unit:10.2f} {limit:6.2f}",
                  flush=True)  # fmt: skip


def arms_and_controllers(n: int, name: str):
    from twolink.simulation.config import load_scenario
    from twolink.simulation.experiment import build_controller

    s = load_scenario(ROOT / SCENARIOS[name])
    arms = bench_batch.drawn_arms(n, np.random.default_rng(0), s.arm)  # first m: any n
    return s, arms, [build_controller(s) for _ in range(n)]


def cpu_us(n: int, name: str, duration: float):
    """The CPU engine, one process: µs per arm-step."""
    from twolink.simulation.batch import BatchPlant, simulate_batch

    s, arms, controllers = arms_and_controllers(n, name)
    plant = BatchPlant(arms, s.timestep)
    simulate_batch(plant, controllers, [0.02] * n, s.control_dt)  # warm (kernels, caches)
    start = time.perf_counter()
    run = simulate_batch(plant, controllers, [duration] * n, s.control_dt)
    steps = round(duration / s.control_dt) + 1
    return (time.perf_counter() - start) / (n * steps) * 1e6, run


def mjx_us(n: int, name: str, duration: float, precision: str):
    """MJX: (µs per arm-step of the compiled loop, seconds of its first call, the run)."""
    import jax

    from twolink.simulation.mjx_engine import prepare_batch_mjx

    s, arms, controllers = arms_and_controllers(n, name)
    run, carry, finish = prepare_batch_mjx(
        arms, s.timestep, controllers, [duration] * n, s.control_dt, precision=precision
    )
    start = time.perf_counter()
    jax.block_until_ready(run(carry))
    first = time.perf_counter() - start
    start = time.perf_counter()
    out = jax.block_until_ready(run(carry))
    elapsed = time.perf_counter() - start
    result = finish(out)
    assert all(st == "ok" for st in result.status), "a benchmark arm diverged"
    steps = round(duration / s.control_dt) + 1
    return elapsed / (n * steps) * 1e6, first, result


def accelerator(sizes: list[int], duration: float, precisions: list[str], cpu_max: int) -> None:
    import jax

    print(f"jax {jax.__version__}, devices: {jax.devices()}")
    print(f"CPU cores here: {os.cpu_count()}; duration {duration} s per arm\n")
    print(f"{'N':>7}  {'law':<8}  {'engine':<14}  {'µs/arm-step':>11}  {'CPU/this':>8}  first call")
    for n in sizes:
        floor = bench_batch.mujoco_step_us(min(n, cpu_max))
        print(f"{min(n, cpu_max):>7}  {'':<8}  {'mj_step alone':<14}  {floor:>11.4f}", flush=True)
        for name in SCENARIOS:
            m = min(n, cpu_max)
            cpu, cpu_run = cpu_us(m, name, duration)
            print(f"{m:>7}  {name:<8}  {'CPU engine':<14}  {cpu:>11.4f}", flush=True)
            runs = {}
            for precision in precisions:
                us, first, runs[precision] = mjx_us(n, name, duration, precision)
                print(
                    f"{n:>7}  {name:<8}  {'MJX ' + precision:<14}  {us:>11.4f}  "
                    f"{cpu / us:>7.1f}x  {first:.1f} s",
                    flush=True,
                )
            for precision, run in runs.items():  # the first m arms are the CPU engine's
                dq = np.abs(run.q[:, :m] - cpu_run.q).max()
                print(f"{'':9}max |q - q_CPU|, first {m} arms, {precision}: {dq:.2e} rad")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", action="store_true", help="time the commands' scaling")
    parser.add_argument("--samples", type=int, default=600, help="regimes -n")
    parser.add_argument("--max-workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--mjx", action="store_true", help="time the MJX backend")
    parser.add_argument("--limits", action="store_true", help="issue 41's three commands")
    parser.add_argument("--only", nargs="+", help="--limits: the commands naming these words")
    parser.add_argument("--repeats", type=int, default=2, help="--limits: runs of each")
    parser.add_argument("--arms", type=int, nargs="+", default=[1000, 10000])
    parser.add_argument("--duration", type=float, default=0.5, help="s per arm (--mjx)")
    parser.add_argument("--precision", nargs="+", default=["float64", "float32"])
    parser.add_argument(
        "--cpu-max", type=int, default=1000, help="CPU engine batch size (per core)"
    )
    args = parser.parse_args()
    if not (args.workers or args.mjx or args.limits):
        parser.error("choose --workers, --mjx and/or --limits")
    if args.limits:
        limits(args.repeats, args.only)
    if args.mjx:
        accelerator(args.arms, args.duration, args.precision, args.cpu_max)
    if args.workers:
        scaling(args.samples, args.max_workers)


if __name__ == "__main__":
    main()
