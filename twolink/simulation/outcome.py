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
- ``"undecided"``: it completed and meets every part of the spec that its record can
  decide, but not whether its error grows: the settling window holds a turn of a swing
  slower than the run shows (fewer than three turns), so neither an envelope nor a
  monotone trend can be fitted (:func:`twolink.simulation.swings.growth_rate`). Run
  longer;
- ``"diverged"``: the simulation left its bounds;
- ``"error"``: building or running it raised (sweeps record these instead of stopping).

The settling window is the run's last ``max(0.5 s, 10 % of its duration)``
(:func:`settling_window`). The default spec (``SuccessSpec()``): every joint within 2 % of
the run's largest step of its target over the window (the band of the settling time; the
held joint too, so a joint that swings away while the other moves is off target), tail
growth at most ×1.25, and overshoot at most 20 %. The tail growth is ``e^(σ W)``, σ the
growth rate of what persists over the window W (:func:`tail_growth`): of the envelope of
an oscillation, or of a monotone trend (a sag toward its rest state decays, so it is no
growth). So a run of duration T detects growth faster than
``ln(1.25) / max(0.5 s, 0.1 T)`` (:func:`detectable_growth_rate`): 0.446 s⁻¹ for runs of
5 s and less, 0.223 s⁻¹ at 10 s, 0.112 s⁻¹ at 20 s; slower growth is not seen.

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

from twolink.simulation.swings import GROWTH_FLOOR_RAD, growth_rates, settling_window

__all__ = [
    "GROWTH_FLOOR_RAD",
    "OUTCOMES",
    "SuccessSpec",
    "classify",
    "classify_run",
    "detectable_growth_rate",
    "largest_step",
    "reasons",
    "reference_end",
    "settling_window",
    "tail_growth",
    "tail_growths",
]

OUTCOMES = ("met spec", "off target", "undecided", "diverged", "error")


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
        Largest growth of a joint's error over the settling window, ``e^(σ W)``
        (:func:`tail_growth`); it sets the smallest growth rate a run detects,
        :func:`detectable_growth_rate`.
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


def detectable_growth_rate(duration: float, spec: SuccessSpec = SuccessSpec()) -> float:
    """The smallest growth rate σ [1/s] a run of ``duration`` seconds detects: its tail
    growth ``e^(σ W)`` over its settling window W exceeds the spec's bound where
    ``σ > ln(max_tail_growth) / W``."""
    return math.log(spec.max_tail_growth) / settling_window(duration)


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
        Tail growth of each joint (:func:`tail_growth`); NaN (the record cannot tell) makes
        a run that meets the rest of the spec "undecided".
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
        growing = np.any(growth > spec.max_tail_growth, axis=1)
        unknown = np.any(np.isnan(growth), axis=1) & ~growing
        if linear_growth is not None:
            growing |= np.asarray(linear_growth, dtype=float).reshape(-1) > 0
    rest = done & on_target & no_overshoot & ~growing
    met = np.where(rest, np.where(unknown, "undecided", "met spec"), "off target")
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
        if grow > spec.max_tail_growth:
            out.append(
                f"joint {j + 1}'s error grows ×{grow:.3g} over the last {window:g} s, at "
                f"{math.log(grow) / window:+.3g} s⁻¹ (bound ×{spec.max_tail_growth:g}: "
                f"{detectable_growth_rate(scenario.duration, spec):.3g} s⁻¹): growing"
            )
        elif math.isnan(grow):
            out.append(
                f"joint {j + 1}: whether its error grows cannot be told from the last "
                f"{window:g} s (a swing slower than the run shows): undecided, run longer"
            )
        if mp > spec.max_overshoot_pct:
            out.append(f"joint {j + 1} overshoots {mp:.3g} % (bound {spec.max_overshoot_pct:g} %)")
    return out


def tail_growth(
    t: np.ndarray, x: np.ndarray, window: float, since: float = -math.inf, settling: bool = False
) -> np.ndarray:
    """Growth of each column of ``x`` (errors from the target, shape (N, k)) over the last
    ``window`` s of ``t``: ``e^(σ window)``, σ the growth rate of what persists there
    (:func:`twolink.simulation.swings.growth_rate`: an oscillation's envelope, or a
    monotone trend). < 1 decaying (a sag toward rest too), ~1 settled (at the target, at
    an offset, or in a steady limit cycle), > 1 growing; 1.0 where the error moves less
    than :data:`GROWTH_FLOOR_RAD` over the window; NaN where the record cannot tell (a
    swing slower than it shows, or with ``settling`` a transient accelerating away on its
    way to a stable rest state) or has fewer than 6 samples in the window; inf where the
    error is not finite."""
    free, settled = tail_growths(t, x, window, since)
    return settled if settling else free


def tail_growths(
    t: np.ndarray, x: np.ndarray, window: float, since: float = -math.inf
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`tail_growth` without and with ``settling``, from one pass over the record."""
    x = np.asarray(x, dtype=float)
    k = x.shape[1] if x.ndim == 2 else 1
    with np.errstate(over="ignore"):
        rates = growth_rates(t, x.reshape(len(t), k), window, since)
        return np.exp(rates[0] * window), np.exp(rates[1] * window)
