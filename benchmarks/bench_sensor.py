"""What a sensor costs: the same runs with and without the studies' sensor, as ratios.

- Single arm: CTC and FCM-CTC, 10 s at 1 kHz, with the true state and behind a 17-bit
  encoder with a 50 Hz filtered rate (docs/sensors.md). Target: <= 1.3x.
- Batch engine: 100 arms of CTC for 4 s, per arm-step, with and without the sensor, and
  the batch without a sensor against a bare mj_step loop of the same arms (the yardstick
  docs/batch.md's figures use). Target: the sensor adds <= 10 % per arm-step.

Best of several repeats, interleaved, in one process: absolute times here are noisy.

    python benchmarks/bench_sensor.py
"""

from __future__ import annotations

import time

import mujoco

from twolink.simulation.config import load_scenario
from twolink.simulation.experiment import build_controller, build_plant, run_scenarios
from twolink.simulation.sensor import Sensor
from twolink.simulation.sim import simulate

REPEATS = 5
SENSOR = {"resolution_rad": Sensor.encoder().resolution_rad, "velocity": "filtered"}
STEP = "runs/paper/theta1_step.toml"


def single(kind: str, sensor: dict) -> float:
    s = load_scenario(
        STEP, {"sensor": sensor, "controller": {"kind": kind, "rule_base": "designed"}}
    )
    plant, controller = build_plant(s), build_controller(s)
    start = time.perf_counter()
    traj = simulate(plant, controller, s.duration, sensor=s.sensor)
    elapsed = time.perf_counter() - start
    assert traj.ok
    return elapsed


def batch(sensor: dict, arms: int = 100) -> float:
    scenarios = [
        load_scenario(
            STEP,
            {"duration": 4.0, "sensor": sensor, "plant": {"scale": {"m2": 1.0 + 0.002 * i}}},
        )
        for i in range(arms)
    ]
    start = time.perf_counter()
    runs = run_scenarios(scenarios)
    elapsed = time.perf_counter() - start
    assert all(r.ok for r in runs)
    return elapsed


def bare_batch(arms: int = 100) -> float:
    from twolink.simulation.batch import Arm, BatchPlant

    s = load_scenario(STEP)
    plant = BatchPlant([Arm(s.plant_params)] * arms)
    model, data = plant.model, plant.data
    start = time.perf_counter()
    for _ in range(4000):
        mujoco.mj_step(model, data)
    return time.perf_counter() - start


def main() -> None:
    times: dict[str, list[float]] = {}
    for _ in range(REPEATS):
        for kind in ("ctc", "fcm_ctc"):
            times.setdefault(f"{kind} ideal", []).append(single(kind, {}))
            times.setdefault(f"{kind} sensor", []).append(single(kind, SENSOR))
        times.setdefault("batch ideal", []).append(batch({}))
        times.setdefault("batch sensor", []).append(batch(SENSOR))
        times.setdefault("bare batch", []).append(bare_batch())
    best = {k: min(v) for k, v in times.items()}
    for kind in ("ctc", "fcm_ctc"):
        ratio = best[f"{kind} sensor"] / best[f"{kind} ideal"]
        print(f"single arm, {kind}: sensor / ideal = {ratio:.2f}x (target <= 1.3x)")
    print(
        f"batch of 100 arms: sensor / ideal per arm-step = "
        f"{best['batch sensor'] / best['batch ideal']:.3f}x (target <= 1.10x)"
    )
    bare = best["bare batch"]
    print(
        f"batch / bare mj_step of the same arms: ideal {best['batch ideal'] / bare:.2f}x, "
        f"sensor {best['batch sensor'] / bare:.2f}x"
    )
    print({k: round(v, 4) for k, v in sorted(best.items())}, "(s, best of", REPEATS, ")")


if __name__ == "__main__":
    main()
