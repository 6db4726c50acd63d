"""A fair linear opponent: computed torque retuned to spend the torque the proposed
controller spends (docs/reproduction.md, "A fair linear opponent").

FCM-CTC adds a fuzzy acceleration to CTC's PD term, so where its term acts it is a
stiffer loop than the CTC it is compared with, and pays in peak torque. Against the same
CTC it can only look faster. The fair question is whether it beats a *linear* loop given
the same torque: CTC with its natural frequency scaled by s (ζ kept: Kp s², Kd s, Ki s³,
the gain rule's ki ∝ ωn³), s the largest on a grid whose peak torque on the sweep's
nominal plant, on every joint, stays within FCM-CTC's (:func:`match_peak_torque`); s = 1
where FCM-CTC spends no more than CTC (smooth moves: the feedforward sets the peak). The
grid is run as one batch; s between two grid points is interpolated linearly.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["MATCHED", "SCALES", "Matched", "choose_scale", "match_peak_torque"]

MATCHED = "CTC-matched"  # the retuned CTC's name in sweeps, tables and the report
# ωn scales tried: from half the baseline's bandwidth to three times it (one batch run;
# between two, linear: the match's own peak torque is measured and reported)
SCALES = np.round(np.arange(0.5, 3.0 + 1e-9, 0.1), 3)
# Where the proposed controller spends no more than the baseline (within this share) the
# baseline is its own match: on smooth moves the peak torque is the feedforward's and
# does not depend on the bandwidth, so no other scale is singled out.
SAME_TORQUE = 1e-3


@dataclass(frozen=True)
class Matched:
    """The retuned CTC: its ωn scale, gains, and the nominal peak torques [N·m] per joint
    of the proposed controller and of the match (interpolated between the grid's runs as
    the scale is)."""

    scale: float
    kp: tuple[float, float]
    kd: tuple[float, float]
    ki: tuple[float, float]
    proposed_peak: tuple[float, float]
    matched_peak: tuple[float, float]

    def controller(self, baseline: dict[str, Any]) -> dict[str, Any]:
        """The sweep's ``[controllers]`` entry: the baseline's, with the matched gains."""
        return {**baseline, "kp": list(self.kp), "kd": list(self.kd), "ki": list(self.ki)}


def _peaks(scenarios: list[Any]) -> np.ndarray:
    """Peak |τ| per joint of each scenario's run, (N, 2); NaN for a failed run."""
    from twolink.simulation.experiment import run_scenarios

    out = np.full((len(scenarios), 2), np.nan)
    for i, traj in enumerate(run_scenarios(scenarios)):
        if not isinstance(traj, Exception) and traj.status == "ok":
            out[i] = np.abs(traj.tau).max(axis=0)
    return out


def match_peak_torque(plan: Any, proposed: str, baseline: str) -> Matched:
    """CTC (``baseline`` of ``plan``, a sweep) retuned to ``proposed``'s peak torque on the
    sweep's nominal plant: the largest ωn scale s at which its peak torque stays within the
    proposed controller's on both joints (see the module's docstring)."""
    from twolink.foundation.overrides import merge
    from twolink.simulation.config import scenario_from_dict

    prop = scenario_from_dict(plan.controller_data(proposed), plan.file)
    base = scenario_from_dict(plan.controller_data(baseline), plan.file)
    kp, kd, ki = (np.array(getattr(base.controller, k), dtype=float) for k in ("kp", "kd", "ki"))
    tried = [
        scenario_from_dict(
            merge(
                plan.controller_data(baseline),
                {"controller": {"kp": list(kp * s**2), "kd": list(kd * s), "ki": list(ki * s**3)}},
            ),
            plan.file,
        )
        for s in SCALES
    ]
    peaks = _peaks([prop, base, *tried])
    limit = np.asarray(prop.controller.torque_limit, dtype=float)
    scale, matched_peak = choose_scale(peaks[0], peaks[1], peaks[2:], limit)
    return Matched(
        scale=float(scale),
        kp=tuple(float(v) for v in kp * scale**2),
        kd=tuple(float(v) for v in kd * scale),
        ki=tuple(float(v) for v in ki * scale**3),
        proposed_peak=tuple(float(v) for v in peaks[0]),
        matched_peak=tuple(float(v) for v in matched_peak),
    )


def choose_scale(
    target: np.ndarray, base: np.ndarray, grid: np.ndarray, limit: np.ndarray
) -> tuple[float, np.ndarray]:
    """The ωn scale of the match and its peak torques (interpolated as the scale is):
    ``target`` the proposed controller's peak |τ| per joint, ``base`` the baseline's at
    scale 1, ``grid`` the baseline's at each of :data:`SCALES` (rows), ``limit`` the torque
    limits. Joints where the proposed controller is at its limit bound nothing."""
    if not np.isfinite(target).all():
        raise ValueError("the proposed controller's nominal run failed: no torque to match")
    free = target < limit * (1 - 1e-9)
    if not free.any():
        free[:] = True
    if np.max(base[free] / target[free]) >= 1.0 - SAME_TORQUE:
        return 1.0, base
    ratio = np.max(grid[:, free] / target[free], axis=1)  # > 1: spends more on a joint
    within = np.flatnonzero(ratio <= 1.0)
    if not within.size:  # even the smallest scale spends more
        return float(SCALES[0]), grid[0]
    k = int(within[-1])
    if k + 1 == SCALES.size or not ratio[k + 1] > ratio[k]:
        return float(SCALES[k]), grid[k]
    # linear between the last grid point within and the first beyond
    frac = (1.0 - ratio[k]) / (ratio[k + 1] - ratio[k])
    scale = SCALES[k] + frac * (SCALES[k + 1] - SCALES[k])
    return float(scale), (1 - frac) * grid[k] + frac * grid[k + 1]
