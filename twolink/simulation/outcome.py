"""Did a run do its job? Every run is classified against a success spec.

"Did not diverge" is not success: an arm that settles 0.9 rad short of its target has
not done its job, and neither has one that sits inside the band at the last sample while
its error grows. A run's outcome is one of

- ``"met spec"``: it completed, its reference had finished moving before the settling
  window began, every joint stayed within the band of its **target** over the whole
  window, no joint's error grows over the window, and no moving joint overshoots past
  the bound;
- ``"off target"``: it completed but misses the spec (sag, offset, overshoot, a growing
  or unstable loop, or a run that ends before its reference does: :func:`reasons` says
  which);
- ``"diverged"``: the simulation left its bounds;
- ``"error"``: building or running it raised (sweeps record these instead of stopping).

The settling window is the run's last ``max(0.5 s, 10 % of its duration)``
(:func:`settling_window`). The default spec (``SuccessSpec()``): every joint within 2 % of
the run's largest step of its target over the window (the band of the settling time; the
held joint too, so a joint that swings away while the other moves is off target), tail
growth at most ×1.25 (the largest error in the window's last third against the largest
before it: a mode growing at σ ≥ 0.67 s⁻¹ over a 1 s window is caught; a decaying one, of
any period, or one settled at an offset is not growth), and overshoot at most 20 %.

An unstable mode can still be too small to see at the end of a short run (CTC at ωn 4 on
a realistic 2000 N·m/rad joint: +1.4 s⁻¹, yet 7e-4 rad and decaying at 3 s). So every
run also carries the growth rate σ of its closed loop linearised at its rest state (every
law, its fuzzy term and its own state included: :mod:`twolink.simulation.stability`);
σ > 0 is off target ("unstable at the target"). A sweep file
overrides the spec in a ``[success]`` table (``docs/sweeps.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "OUTCOMES",
    "SuccessSpec",
    "classify",
    "classify_run",
    "largest_step",
    "reasons",
    "reference_end",
    "settling_window",
]

OUTCOMES = ("met spec", "off target", "diverged", "error")


@dataclass(frozen=True)
class SuccessSpec:
    """What a run must do to count as a success.

    Attributes
    ----------
    final_error : float
        Largest final error of every joint, as a fraction of the run's largest step
        (0.02: the 2 % band of the settling time).
    max_overshoot_pct : float
        Largest overshoot of a moving joint, in percent of its step (``inf``: no bound).
    max_tail_growth : float
        Largest growth of a joint's error over the settling window (the peak-to-peak
        error of its last third over that of its first third).
    """

    final_error: float = 0.02
    max_overshoot_pct: float = 20.0
    max_tail_growth: float = 1.25

    def __post_init__(self) -> None:
        if not (math.isfinite(self.final_error) and self.final_error > 0):
            raise ValueError(f"final_error must be a finite number > 0, got {self.final_error}")
        if not self.max_overshoot_pct >= 0:
            raise ValueError(f"max_overshoot_pct must be >= 0, got {self.max_overshoot_pct}")
        if not self.max_tail_growth >= 1:
            raise ValueError(f"max_tail_growth must be >= 1, got {self.max_tail_growth}")


SETTLING_WINDOW_MIN_S = 0.5
SETTLING_WINDOW_SHARE = 0.1
# Below this peak-to-peak error [rad] a tail does not count as growing (numerical jitter;
# a 17-bit encoder's count is 4.8e-5 rad).
GROWTH_FLOOR_RAD = 1e-5


def settling_window(duration: float) -> float:
    """The settling window of a run of ``duration`` seconds: its last
    ``max(0.5 s, 10 % of the run)``, capped at the run."""
    return min(duration, max(SETTLING_WINDOW_MIN_S, SETTLING_WINDOW_SHARE * duration))


def reference_end(reference: Any) -> float:
    """When the references of both joints stop moving [s] (``inf`` for a sine)."""
    end = 0.0
    for ref in (reference.joint1, reference.joint2):
        if not math.isfinite(ref.final):
            return math.inf
        end = max(end, getattr(ref, "t0", 0.0) + getattr(ref, "duration", 0.0))
    return end


def finished(reference: Any, duration: float) -> bool:
    """Whether a run of ``duration`` has its whole settling window after its reference
    stopped moving."""
    return duration - settling_window(duration) >= reference_end(reference) - 1e-12


def largest_step(reference: Any, q0: tuple[float, float]) -> float:
    """The run's largest move |final − start| over the joints [rad]; 1 rad if none moves
    (the band is then 2 % of a radian)."""
    moves = [abs(f - s) for f, s in zip(reference.final, q0, strict=True) if math.isfinite(f)]
    step = max(moves, default=0.0)
    return step if step > 0 else 1.0


def classify(
    status: Any,
    tail_errors: Any,
    overshoots: Any,
    step: float,
    spec: SuccessSpec = SuccessSpec(),
    growth: Any = None,
    done: Any = True,
    linear_growth: Any = None,
) -> np.ndarray:
    """The outcome of each run, from its columns.

    Parameters
    ----------
    status : array of str, shape (N,)
        "ok", "diverged" or "error".
    tail_errors : array, shape (N, 2)
        The largest ``|θ_target − θ|`` of each joint over the settling window [rad]; NaN
        counts as outside the band.
    overshoots : array, shape (N, 2)
        Overshoot of each joint [%]; NaN (a held joint, or one that never got there)
        does not violate the bound.
    step : float
        The runs' largest step [rad] (:func:`largest_step`).
    spec : SuccessSpec
    growth : array, shape (N, 2), optional
        Tail growth of each joint (:func:`tail_growth`); NaN counts as growing.
    done : bool or array of bool, shape (N,)
        Whether the run's reference finished before its settling window (:func:`finished`).
    linear_growth : array, shape (N,), optional
        Growth rate σ [1/s] of the loop linearised at the target (NaN: none); σ > 0 is
        unstable, off target.

    Returns
    -------
    ndarray of str, shape (N,)
        One of :data:`OUTCOMES` per run.
    """
    status = np.asarray(status, dtype=object).reshape(-1)
    tail_errors = np.asarray(tail_errors, dtype=float).reshape(-1, 2)
    overshoots = np.asarray(overshoots, dtype=float).reshape(-1, 2)
    growth = np.ones_like(tail_errors) if growth is None else np.asarray(growth, float)
    growth = growth.reshape(-1, 2)
    done = np.broadcast_to(np.asarray(done, dtype=bool), status.shape)
    with np.errstate(invalid="ignore"):
        on_target = np.all(tail_errors <= spec.final_error * step, axis=1)
        no_overshoot = np.all(~(overshoots > spec.max_overshoot_pct), axis=1)
        steady = np.all(growth <= spec.max_tail_growth, axis=1)
        if linear_growth is not None:
            steady &= ~(np.asarray(linear_growth, dtype=float).reshape(-1) > 0)
    met = np.where(done & on_target & no_overshoot & steady, "met spec", "off target")
    failed = np.where(status == "error", "error", "diverged")
    return np.where(status == "ok", met, failed).astype(object)


def _run_columns(scenario: Any, metrics: Any) -> tuple[list[float], float, bool]:
    overshoot = [math.nan if m is None else m.overshoot for m in metrics.step]
    step = largest_step(scenario.reference, scenario.q0)
    return overshoot, step, finished(scenario.reference, scenario.duration)


def classify_run(scenario: Any, metrics: Any, spec: SuccessSpec = SuccessSpec()) -> str:
    """The outcome of one run (a :class:`~twolink.simulation.experiment.RunMetrics` of
    ``scenario``)."""
    overshoot, step, done = _run_columns(scenario, metrics)
    outcome = classify(
        [metrics.status],
        [metrics.tail_error],
        [overshoot],
        step,
        spec,
        [metrics.tail_growth],
        done,
        [metrics.linear_growth[0]],
    )
    return str(outcome[0])


def reasons(scenario: Any, metrics: Any, spec: SuccessSpec = SuccessSpec()) -> list[str]:
    """Why a completed run is off target, in words (empty when it met the spec)."""
    if metrics.status != "ok":
        return [metrics.message]
    overshoot, step, done = _run_columns(scenario, metrics)
    window = settling_window(scenario.duration)
    out = []
    if not done:
        out.append(
            f"the run ends at {scenario.duration:g} s, before its reference finishes "
            f"(at {reference_end(scenario.reference):g} s) and settles for {window:g} s"
        )
    band = spec.final_error * step
    if metrics.linear_growth[0] > 0:
        out.append(
            f"the loop linearised at the target grows at {metrics.linear_growth[0]:+.3g} s⁻¹: "
            "unstable there, whatever the run's end shows"
        )
    for j in (0, 1):
        err, grow, mp = metrics.tail_error[j], metrics.tail_growth[j], overshoot[j]
        if not err <= band:
            out.append(
                f"joint {j + 1} is up to {err:.3g} rad from its target over the last "
                f"{window:g} s (band {band:.3g} rad)"
            )
        if not grow <= spec.max_tail_growth:
            out.append(
                f"joint {j + 1}'s error grows ×{grow:.3g} over the last {window:g} s "
                f"(bound ×{spec.max_tail_growth:g}): not settled, maybe unstable"
            )
        if mp > spec.max_overshoot_pct:
            out.append(f"joint {j + 1} overshoots {mp:.3g} % (bound {spec.max_overshoot_pct:g} %)")
    return out


def tail_growth(t: np.ndarray, x: np.ndarray, window: float) -> np.ndarray:
    """Growth of each column of ``x`` (errors from the target, shape (N, k)) over the last
    ``window`` s of ``t``: the largest ``|x|`` in the window's last third over the largest
    in its first two thirds.

    A decaying transient or oscillation gives <= 1 whatever its period (the earlier part
    holds the larger swings), a steady offset or limit cycle about 1, a mode growing as
    e^(σt) about e^(σ·window/3). 1.0 where the last third stays below
    :data:`GROWTH_FLOOR_RAD` (settled at the target); NaN for fewer than 6 samples."""
    x = np.abs(np.asarray(x, dtype=float))
    k = x.shape[1] if x.ndim == 2 else 1
    x = x.reshape(len(t), k)
    tail = t >= t[-1] - window - 1e-12 if len(t) else np.zeros(0, bool)
    xt = x[tail]
    if len(xt) < 6:
        return np.full(k, np.nan)
    split = len(xt) - len(xt) // 3
    before, last = xt[:split].max(axis=0), xt[split:].max(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(last < GROWTH_FLOOR_RAD, 1.0, last / before)
    return np.where(np.isnan(ratio), np.inf, ratio)
