"""Where each flexible-joint law holds: sensor, payload and model error, as measured.

``python -m twolink.studies.judgments.flexible_limits`` (``--tuning``: the process-noise rule of
:func:`process_noise_scan`) runs every flexible-joint law
(``docs/control.md``, "Flexible-joint controllers") on the flexible map's move (septic
θ1 0 → 1 rad, θ2 0 → 0.5 rad in 1.5 s, 3 s from rest holding itself up, ωn = 10 rad/s,
ζ = 1, 60 / 15 N·m, 1 kHz) over

- three joint sets: ``stiff`` (k = 1e4 on both, J = 0.4 / 0.08), ``realistic``
  (:meth:`~twolink.arm.params.Flexibility.realistic`, k = 1e4 / 3e3) and ``soft``
  (k = 20, J = 0.05), joint damping ratio 0.02;
- three plants: ``exact`` (the controllers' model), ``error`` (masses ×1.2, g ×1.1, the
  joints 1/1.2 as stiff as modelled) and ``error + 0.2 kg`` (that and a 0.2 kg tip
  payload no law models);
- four sensors: the true state, and a 17-bit encoder on every link and motor with the
  differenced rate, or that rate through the 50 Hz or 150 Hz Butterworth filter
  (:mod:`twolink.simulation.sensor`);

and prints, per cell, the outcome, the largest error over the settling window (the last
0.5 s) and the mean torque step per control period as a share of each joint's limit
(Σ|Δτ| / periods / limit; the lab's bound is 1 %). ``docs/control.md``, "Each law's
limits, as measured", is its table; ``tests/test_flexible_lab.py`` reruns its key cells.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twolink.simulation.config import Scenario, scenario_from_dict
from twolink.simulation.experiment import build_controller, measure, run_scenario
from twolink.simulation.outcome import classify_run
from twolink.simulation.sensor import encoder_resolution

__all__ = [
    "JOINT_SETS",
    "LAWS",
    "PLANTS",
    "SENSORS",
    "Cell",
    "limits_table",
    "process_noise_scan",
    "run_cell",
    "scenario",
]

JOINT_SETS = {
    "stiff": ((1.0e4, 1.0e4), (0.4, 0.08)),
    "realistic": ((1.0e4, 3.0e3), (0.4, 0.08)),
    "soft": ((20.0, 20.0), (0.05, 0.05)),
}
JOINT_DAMPING_RATIO = 0.02
MODEL_ERROR = {"m1": 1.2, "m2": 1.2, "g": 1.1, "k": 1 / 1.2}
PLANTS = {"exact": ({}, 0.0), "error": (MODEL_ERROR, 0.0), "error + 0.2 kg": (MODEL_ERROR, 0.2)}
SENSORS = {
    "true state": None,
    "17-bit, differenced": ("difference", 50.0),
    "17-bit, 50 Hz": ("filtered", 50.0),
    "17-bit, 150 Hz": ("filtered", 150.0),
}
LAWS = ("motor_pd", "composite", "flexible_fl", "flexible_fl_integral", "flexible_fl_kalman")
LIMIT = (60.0, 15.0)
TORQUE_STEP_BOUND = 0.01  # the lab's bound: mean |Δτ| per period within 1 % of the limit


def scenario(law: str, joints: str, plant: str, sensor: str, wn: float = 10.0) -> Scenario:
    """One cell's scenario (the module's docstring)."""
    k, j = JOINT_SETS[joints]
    d = [2 * JOINT_DAMPING_RATIO * math.sqrt(ki * ji) for ki, ji in zip(k, j, strict=True)]
    scale, payload = PLANTS[plant]
    data = {
        "name": f"{law}, {joints} joints, {plant}, {sensor}",
        "duration": 3.0,
        "control_dt": 1e-3,
        "timestep": 1e-3,
        "arm": {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 9.81},
        "plant": {
            "flexibility": {"k": list(k), "j": list(j), "d": d},
            "payload": payload,
            "scale": dict(scale),
        },
        "controller": {"kind": law, "kp": wn * wn, "kd": 2 * wn, "torque_limit": list(LIMIT)},
        "reference": {
            "joint1": {"kind": "septic", "initial": 0.0, "final": 1.0, "duration": 1.5},
            "joint2": {"kind": "septic", "initial": 0.0, "final": 0.5, "duration": 1.5},
        },
    }
    rate = SENSORS[sensor]
    if rate is not None:
        data["sensor"] = {
            "resolution_rad": encoder_resolution(17),
            "velocity": rate[0],
            "cutoff_hz": rate[1],
        }
    return scenario_from_dict(data)


@dataclass(frozen=True)
class Cell:
    """One law in one cell: its outcome, the largest |e| over the settling window per
    joint [rad], and the mean |Δτ| per period over each joint's limit."""

    outcome: str
    tail_error: tuple[float, float]
    torque_step_share: tuple[float, float]

    @property
    def lab_ready(self) -> bool:
        """Met the spec with the torque steps within the lab's bound."""
        return self.outcome == "met spec" and max(self.torque_step_share) <= TORQUE_STEP_BOUND

    def describe(self) -> str:
        e = max(self.tail_error)
        err = f"{e * 1e3:.2g} mrad" if e < 0.1 else f"{e:.2g} rad"
        step = max(self.torque_step_share)
        return f"{self.outcome}, {err}, Δτ {100 * step:.2g} %"


def run_cell(s: Scenario) -> Cell:
    """Run one cell's scenario and measure it."""
    return _measured(s, build_controller(s))


def limits_table(laws=LAWS, joints=tuple(JOINT_SETS), plants=tuple(PLANTS),
                 sensors=tuple(SENSORS)) -> list[str]:  # fmt: skip
    """The markdown table: one row per (joints, plant, sensor), one column per law."""
    from twolink.simulation.vocabulary import CONTROLLER_LABELS

    head = "| joints | plant | sensor | " + " | ".join(CONTROLLER_LABELS[n] for n in laws) + " |"
    lines = [head, "|" + "---|" * (3 + len(laws))]
    for jt in joints:
        for plant in plants:
            for sensor in sensors:
                cells = [run_cell(scenario(law, jt, plant, sensor)).describe() for law in laws]
                lines.append(f"| {jt} | {plant} | {sensor} | " + " | ".join(cells) + " |")
    return lines


PROCESS_NOISE_SCALES = (1e-7, 3e-7, 1e-6, 3e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3)
TUNING_PLANTS = ("exact", "error", "error + 0.2 kg")


def process_noise_scan(scales=PROCESS_NOISE_SCALES, sensor: str = "17-bit, differenced"):
    """The rule that chose the Kalman filter's process noise (``docs/control.md``, "A law
    a lab can run"): for each scale s (density s on the accelerations, 100 s on the
    disturbances), the lab-ready cells of the 9 (three joint sets x :data:`TUNING_PLANTS`)
    and the largest torque step share; the chosen s has the most lab-ready cells, ties to
    the lower steps. Returns ``{s: (lab-ready cells, largest step share, cells)}``."""
    from twolink.controllers.flexible_observed import (
        ObservedIntegralFlexibleFeedbackLinearisation as Law,
    )

    out = {}
    for scale in scales:
        cells = {}
        for joints in JOINT_SETS:
            for plant in TUNING_PLANTS:
                s = scenario("flexible_fl_kalman", joints, plant, sensor)
                law = build_controller(s)
                tuned = Law(law.model, law.reference, law.kp, law.kd, law.torque_limit,
                            joints=law.joints, control_dt=law.control_dt,
                            resolution_rad=law.resolution_rad,
                            process_noise=(scale, 100 * scale))  # fmt: skip
                cells[joints, plant] = _measured(s, tuned)
        ready = sum(c.lab_ready for c in cells.values())
        out[scale] = (ready, max(max(c.torque_step_share) for c in cells.values()), cells)
    return out


def _measured(s: Scenario, controller) -> Cell:
    traj = run_scenario(s, controller)
    m = measure(s, traj, controller)
    steps = np.abs(np.diff(traj.tau, axis=0)).mean(axis=0) / np.array(LIMIT)
    share = tuple(float(v) for v in steps) if traj.ok else (math.inf, math.inf)
    return Cell(classify_run(s, m), tuple(float(v) for v in m.tail_error), share)  # type: ignore[arg-type]


if __name__ == "__main__":  # pragma: no cover - the study's command line
    import sys

    if sys.argv[1:] == ["--tuning"]:
        for scale, (ready, step, cells) in process_noise_scan().items():
            worst = ", ".join(f"{j} {p}: {c.describe()}" for (j, p), c in cells.items()
                              if not c.lab_ready)  # fmt: skip
            print(f"s = {scale:g}: {ready} of 9 lab-ready, largest Δτ {100 * step:.2g} %; "
                  f"misses: {worst or 'none'}", flush=True)  # fmt: skip
    else:
        for line in limits_table():
            print(line, flush=True)
