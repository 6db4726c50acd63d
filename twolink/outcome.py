"""Did a run do its job? Every run is classified against a success spec.

"Did not diverge" is not success: an arm that settles 0.9 rad short of its target has
not done its job. A run's outcome is one of

- ``"met spec"``: it completed, every joint ends within the final-error band, and no
  moving joint overshoots past the bound;
- ``"off target"``: it completed but misses the spec (sag, offset, overshoot, a run too
  short to settle);
- ``"diverged"``: the simulation left its bounds;
- ``"error"``: building or running it raised (sweeps record these instead of stopping).

The default spec (``SuccessSpec()``): every joint's final error ``|θd(T) − θ(T)|`` at most
2 % of the run's largest step (the band of the settling time; the held joint too, so a
joint that swings away while the other moves is off target), and overshoot at most 20 %.
A sweep file overrides it in a ``[success]`` table (``docs/sweeps.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["OUTCOMES", "SuccessSpec", "classify", "classify_run", "largest_step"]

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
    """

    final_error: float = 0.02
    max_overshoot_pct: float = 20.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.final_error) and self.final_error > 0):
            raise ValueError(f"final_error must be a finite number > 0, got {self.final_error}")
        if not self.max_overshoot_pct >= 0:
            raise ValueError(f"max_overshoot_pct must be >= 0, got {self.max_overshoot_pct}")


def largest_step(reference: Any, q0: tuple[float, float]) -> float:
    """The run's largest move |final − start| over the joints [rad]; 1 rad if none moves
    (the band is then 2 % of a radian)."""
    moves = [abs(f - s) for f, s in zip(reference.final, q0, strict=True) if math.isfinite(f)]
    step = max(moves, default=0.0)
    return step if step > 0 else 1.0


def classify(
    status: Any,
    final_errors: Any,
    overshoots: Any,
    step: float,
    spec: SuccessSpec = SuccessSpec(),
) -> np.ndarray:
    """The outcome of each run, from its columns.

    Parameters
    ----------
    status : array of str, shape (N,)
        "ok", "diverged" or "error".
    final_errors : array, shape (N, 2)
        ``|θd(T) − θ(T)|`` of each joint [rad]; NaN counts as outside the band.
    overshoots : array, shape (N, 2)
        Overshoot of each joint [%]; NaN (a held joint, or one that never got there)
        does not violate the bound.
    step : float
        The runs' largest step [rad] (:func:`largest_step`).
    spec : SuccessSpec

    Returns
    -------
    ndarray of str, shape (N,)
        One of :data:`OUTCOMES` per run.
    """
    status = np.asarray(status, dtype=object).reshape(-1)
    final_errors = np.asarray(final_errors, dtype=float).reshape(-1, 2)
    overshoots = np.asarray(overshoots, dtype=float).reshape(-1, 2)
    with np.errstate(invalid="ignore"):
        on_target = np.all(final_errors <= spec.final_error * step, axis=1)
        no_overshoot = np.all(~(overshoots > spec.max_overshoot_pct), axis=1)
    met = np.where(on_target & no_overshoot, "met spec", "off target")
    failed = np.where(status == "error", "error", "diverged")
    return np.where(status == "ok", met, failed).astype(object)


def classify_run(scenario: Any, metrics: Any, spec: SuccessSpec = SuccessSpec()) -> str:
    """The outcome of one run (a :class:`~twolink.experiment.RunMetrics` of ``scenario``)."""
    overshoot = [math.nan if m is None else 100 * m.overshoot for m in metrics.step]
    step = largest_step(scenario.reference, scenario.q0)
    return str(classify([metrics.status], [metrics.final_error], [overshoot], step, spec)[0])
