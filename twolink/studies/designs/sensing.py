"""What the sensor does to the loop: torque activity and tracking of CTC against the rate
estimate (exact, differenced, filtered at several cut-offs), on the robustness sweep's move.

This is the evidence for the velocity filter's cut-off (docs/sensors.md): the rule takes
the lowest cut-off of the grid (the least torque variation: it falls with the cut-off)
whose tracking error on the nominal arm stays within ``ERROR_BUDGET`` at the gains the
gain study chose (those of ``runs/paper/base.toml``). ``python -m twolink.studies.designs.sensing``
prints the table.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from twolink.foundation.overrides import merge
from twolink.foundation.shipped import runs_dir
from twolink.simulation.sensor import ENCODER_BITS, encoder_resolution

__all__ = ["CUTOFFS", "ERROR_BUDGET", "choose_cutoff", "velocity_table"]

SWEEP = runs_dir() / "sweeps" / "robustness.toml"  # package data
CUTOFFS = (10.0, 20.0, 30.0, 50.0, 100.0, 200.0)  # Hz
BANDWIDTHS = (4.0, 10.0, 15.0)  # rad/s: the gain study's range up to its choice
# The filter's lag τ adds a tracking error of about kd τ |q̈| / kp during a move; it may cost
# at most 1 mrad of max|e| (about 20 encoder counts, 1/50 of the gain rule's error bound
# and 1/36 of the error model mismatch leaves on 95 % of the robustness plants).
ERROR_BUDGET = 1e-3  # rad


def _sensors(cutoffs: Sequence[float]) -> dict[str, dict]:
    quantum = encoder_resolution(ENCODER_BITS)
    out = {
        "exact": {},
        "encoder, exact rate": {"resolution_rad": quantum},
        "encoder, differenced": {"resolution_rad": quantum, "velocity": "difference"},
    }
    for fc in cutoffs:
        out[f"encoder, filtered {fc:g} Hz"] = {
            "resolution_rad": quantum,
            "velocity": "filtered",
            "cutoff_hz": fc,
        }
    return out


def velocity_table(
    cutoffs: Sequence[float] = CUTOFFS, bandwidths: Sequence[float] = BANDWIDTHS
) -> pd.DataFrame:
    """CTC on the nominal arm, the robustness sweep's move, per (ωn, sensor): torque
    variation per joint [N·m], max|e| of the larger joint [rad] and final error [rad]."""
    from twolink.simulation.config import scenario_from_dict
    from twolink.simulation.experiment import run_scenarios
    from twolink.simulation.metrics import torque_measures
    from twolink.sweep import load_sweep

    plan = load_sweep(SWEEP)
    labels, scenarios = [], []
    for wn in bandwidths:
        for name, sensor in _sensors(cutoffs).items():
            data = merge(plan.base, {"controller": {"kind": "ctc", "kp": wn**2, "kd": 2 * wn}})
            scenarios.append(scenario_from_dict({**data, "sensor": sensor}, str(SWEEP)))
            labels.append((wn, name, sensor.get("cutoff_hz", np.nan)))
    rows = []
    for (wn, name, fc), traj in zip(labels, run_scenarios(scenarios), strict=True):
        variation = torque_measures(traj.tau).variation
        rows.append(
            {
                "wn": wn,
                "sensor": name,
                "cutoff_hz": fc,
                "torque_variation1_Nm": variation[0],
                "torque_variation2_Nm": variation[1],
                "max_error_rad": float(np.abs(traj.e).max()),
                "final_error_rad": float(np.abs(traj.e[-1]).max()),
                "status": traj.status,
            }
        )
    return pd.DataFrame(rows)


def choose_cutoff(table: pd.DataFrame, wn: float, budget: float = ERROR_BUDGET) -> float:
    """The rule: the lowest cut-off whose max|e| at bandwidth ``wn`` stays within
    ``budget`` [rad]."""
    rows = table[(table.wn == wn) & table.cutoff_hz.notna() & (table.status == "ok")]
    ok = rows[rows.max_error_rad <= budget]
    if ok.empty:
        raise ValueError(f"no cut-off keeps max|e| within {budget:g} rad at ωn = {wn:g}")
    return float(ok.cutoff_hz.min())


def design_wn() -> float:
    """The bandwidth of the shipped gains (runs/paper/base.toml's kp = ωn²)."""
    from twolink.simulation.config import load_scenario

    return float(np.sqrt(load_scenario(runs_dir() / "paper" / "base.toml").controller.kp[0]))


if __name__ == "__main__":
    table = velocity_table()
    with pd.option_context("display.width", 200, "display.max_rows", 200):
        print(table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    wn = design_wn()
    print(f"chosen cut-off at ωn = {wn:g} rad/s: {choose_cutoff(table, wn):g} Hz")
