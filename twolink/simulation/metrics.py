"""Performance measures of a run: step-response metrics, error integrals, torque effort.

The step-response definitions follow the paper's tables (Tp, Td, Ts, Tr, Mp, ess) as pinned
down in ``docs/paper_notes.md`` section 4 and ``docs/metrics.md``; rise time, settling time,
overshoot and peak time agree with python-control's ``step_info`` (and MATLAB's
``stepinfo``) wherever those are defined the same way.

Every result is a frozen dataclass of plain Python floats (or tuples of floats, one per
joint), so ``dataclasses.asdict`` works on it; :func:`metrics_dict` turns any mix of them
into something ``json.dump(..., allow_nan=False)`` accepts, for ``metrics.json``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, is_dataclass
from typing import Any

import numpy as np

from twolink.simulation.swings import last, persisting_swing, settling_window

__all__ = [
    "ErrorMeasures",
    "StepMetrics",
    "TorqueMeasures",
    "column_max",
    "error_measures",
    "metrics_dict",
    "oscillation_amplitude",
    "settling_time",
    "settling_window",
    "tail_mean",
    "step_metrics",
    "step_metrics_per_joint",
    "torque_measures",
    "to_jsonable",
]


@dataclass(frozen=True)
class StepMetrics:
    """Step-response metrics of one signal (see :func:`step_metrics` for the definitions).

    Times are in the units of ``t`` (seconds), on the same clock as ``t`` (not relative to
    ``t[0]``). A metric the data do not determine is NaN.

    Attributes
    ----------
    peak_time : float
        Tp, time of the largest excursion in the step direction; NaN unless the response
        turns there (it ends more than the settling band below that peak).
    delay_time : float
        Td, first time the response reaches 50 % of the step.
    rise_time : float
        Tr, time from first reaching 10 % to first reaching 90 % of the step.
    settling_time : float
        Ts, first time after which the response stays within 2 % of the step of its final
        value.
    overshoot : float
        Mp, the largest excursion past the target in percent of the step (10.0 = 10 %), as
        python-control's ``step_info`` and every output of twolink give it.
    steady_state_error : float
        ess, the mean of ``|target - y|`` over the record's settling window (its last
        ``max(0.5 s, 10 %)``): not one sample, so a response still circling its final
        value reads the size of its error there, not the phase at which the run ends.
    """

    peak_time: float
    delay_time: float
    rise_time: float
    settling_time: float
    overshoot: float
    steady_state_error: float

    def __str__(self) -> str:
        """One line in the paper's symbols, "—" where a metric is undefined."""
        from twolink.simulation.vocabulary import format_value as f

        return (
            f"Tp {f(self.peak_time)} s, Td {f(self.delay_time)} s, Ts {f(self.settling_time)} s, "
            f"Tr {f(self.rise_time)} s, Mp {f(self.overshoot)} %, "
            f"ess {f(self.steady_state_error)} rad"
        )


@dataclass(frozen=True)
class ErrorMeasures:
    """Integral error measures; floats for one signal, tuples of floats (one per column) else.

    Attributes
    ----------
    iae : float or tuple of float
        Integral of ``|e|``.
    ise : float or tuple of float
        Integral of ``e**2``.
    itae : float or tuple of float
        Integral of ``t |e|``.
    max_abs : float or tuple of float
        Largest ``|e|`` over the run (over the samples).
    """

    iae: float | tuple[float, ...]
    ise: float | tuple[float, ...]
    itae: float | tuple[float, ...]
    max_abs: float | tuple[float, ...]


@dataclass(frozen=True)
class TorqueMeasures:
    """Control effort; floats for one signal, tuples of floats (one per joint) else.

    Attributes
    ----------
    rms : float or tuple of float
        Root mean square over the samples, ``sqrt(mean(tau**2))``.
    peak : float or tuple of float
        Largest magnitude, ``max |tau|``.
    variation : float or tuple of float
        Total variation ``sum |tau[k+1] - tau[k]|`` [N·m]: how much the actuator is
        driven back and forth (noise and chatter show here, not in the RMS).
    """

    rms: float | tuple[float, ...]
    peak: float | tuple[float, ...]
    variation: float | tuple[float, ...] = math.nan


def _check_times(t: np.ndarray, n: int) -> np.ndarray:
    t = np.asarray(t, dtype=float)
    if t.ndim != 1:
        raise ValueError(f"t must be one-dimensional, got shape {t.shape}")
    if t.shape[0] != n:
        raise ValueError(f"t has {t.shape[0]} samples but the signal has {n}")
    if n == 0:
        raise ValueError("t is empty: need at least one sample")
    if not np.all(np.isfinite(t)):
        raise ValueError("t must be finite")
    if np.any(np.diff(t) <= 0.0):
        raise ValueError("t must be strictly increasing")
    return t


def _check_scalar(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return value


def _first_time(t: np.ndarray, reached: np.ndarray) -> float:
    """Time of the first True in ``reached``, NaN if there is none."""
    idx = np.flatnonzero(reached)
    return float(t[idx[0]]) if idx.size else math.nan


def step_metrics(
    t: np.ndarray,
    y: np.ndarray,
    target: float,
    y0: float = 0.0,
    *,
    final_value: float | None = None,
    settling_threshold: float = 0.02,
    rise_limits: tuple[float, float] = (0.1, 0.9),
    ess_window: float | None = None,
) -> StepMetrics:
    """Step-response metrics of a sampled response ``y(t)`` to a step from ``y0`` to ``target``.

    With the step ``S = target - y0`` (either sign) and the progress ``p = (y - y0) / S``
    (0 at the start, 1 at the target):

    - Td (delay time): the first sample time with ``p >= 0.5``.
    - Tr (rise time): ``T90 - T10``, where ``Tk`` is the first sample time with ``p >= k``
      (``rise_limits``); sample times, no interpolation, as in python-control and MATLAB.
    - Ts (settling time): the first sample time after which ``|y - y_final| < 0.02 |S|``
      (``settling_threshold``) holds to the end, where ``y_final = y[-1]`` (as in
      python-control and MATLAB) unless ``final_value`` is given.
    - Tp (peak time): the time of the largest ``p`` (the first such sample), where there is a
      peak: the response must turn there, ``max(p) - p[-1] > settling_threshold`` (it ends
      more than the 2 % band below its peak). With overshoot this is the time of the largest
      excursion past the target. A response that rises monotonically (or creeps up to its
      final value) has no peak, and its Tp is NaN, not the end of the run. (python-control's
      ``step_info`` reports a PeakTime always.)
    - Mp (overshoot): ``100 max(0, max((y - target) / S))``, in percent of the step (10.0 =
      10 %, as python-control's ``step_info``), measured against the target (not the final
      value).
    - ess (steady-state error): the mean of ``|target - y|`` over the last ``ess_window``
      seconds (default: the record's settling window of ``t[-1] - t[0]``,
      :func:`twolink.simulation.swings.settling_window`); ``ess_window=0`` reads the last
      sample alone.

    A metric the data do not determine is NaN, never an exception:

    - Td, Tr: NaN if the 50 % (for Tr: the 90 %) level is never reached.
    - Tp: NaN if the response never moves towards the target (``max p <= 0``), or if it has
      no peak (``max(p) - p[-1] <= settling_threshold``, e.g. a monotone rise).
    - Ts: NaN unless at least the last two samples lie inside the band. With
      ``y_final = y[-1]`` the last sample always does, so it alone proves nothing. A response
      still moving at the end of a run whose last samples are closer together than the band
      still gets a finite Ts: run long enough, and read ess alongside.
    - Mp and ess are always defined for finite data.

    Non-finite samples (NaN, inf, e.g. from a run that blew up): the first-passage times Td and
    Tr are computed on the finite prefix (up to the first non-finite sample), since a level
    reached before the blow-up was reached; Tp, Ts, Mp and ess depend on the whole record and
    are NaN.

    Parameters
    ----------
    t : ndarray, shape (N,)
        Sample times, finite and strictly increasing.
    y : ndarray, shape (N,)
        Response.
    target : float
        The value the step goes to (e.g. the reference's ``final``).
    y0 : float, default 0.0
        The value the step starts from.
    final_value : float, optional
        Value to settle to for Ts, instead of ``y[-1]``; e.g. ``target`` to ask "when does it
        stay within 2 % of the target". With it Ts can be NaN for a response that never
        settles.
    settling_threshold : float, default 0.02
        Width of the settling band as a fraction of ``|S|``.
    rise_limits : tuple of float, default (0.1, 0.9)
        Lower and upper levels of the rise time, as fractions of the step.
    ess_window : float, optional
        The last seconds ess is the mean over (default: the settling window).

    Returns
    -------
    StepMetrics

    Raises
    ------
    ValueError
        If ``target == y0`` (no step), ``target``/``y0``/``final_value`` is not finite, the
        shapes disagree, or ``t`` is not finite and strictly increasing.
    """
    y = np.asarray(y, dtype=float)
    if y.ndim != 1:
        raise ValueError(f"y must be one-dimensional, got shape {y.shape}")
    t = _check_times(t, y.shape[0])
    target = _check_scalar("target", target)
    y0 = _check_scalar("y0", y0)
    step = target - y0
    if step == 0.0:
        raise ValueError(f"zero step: target == y0 == {target!r}, the metrics are undefined")
    lo, hi = rise_limits
    if not 0.0 < lo < hi <= 1.0:
        raise ValueError(f"rise_limits must satisfy 0 < low < high <= 1, got {rise_limits!r}")
    if not 0.0 < settling_threshold < 1.0:
        raise ValueError(f"settling_threshold must be in (0, 1), got {settling_threshold!r}")

    finite = np.isfinite(y)
    n_ok = y.shape[0] if finite.all() else int(np.argmin(finite))
    progress = (y[:n_ok] - y0) / step
    t_ok = t[:n_ok]
    delay = _first_time(t_ok, progress >= 0.5)
    rise = _first_time(t_ok, progress >= hi) - _first_time(t_ok, progress >= lo)

    if n_ok < y.shape[0]:
        nan = math.nan
        return StepMetrics(nan, delay, rise, nan, nan, nan)

    peak_idx = int(np.argmax(progress))
    # A peak is a turn: the response ends more than the settling band below its largest
    # progress. A monotone response has none (its "peak" would be the end of the run).
    peaked = progress[peak_idx] > 0.0 and progress[peak_idx] - progress[-1] > settling_threshold
    peak_time = float(t[peak_idx]) if peaked else math.nan
    overshoot = 100.0 * max(0.0, float(np.max((y - target) / step)))
    if ess_window is None:
        ess_window = settling_window(float(t[-1] - t[0]))
    ess = float(np.mean(np.abs(target - y[last(t, ess_window)])))

    y_final = float(y[-1]) if final_value is None else _check_scalar("final_value", final_value)
    settling = _settling(t, y, y_final, settling_threshold * abs(step))

    return StepMetrics(
        peak_time=peak_time,
        delay_time=delay,
        rise_time=float(rise),
        settling_time=settling,
        overshoot=overshoot,
        steady_state_error=ess,
    )


def _settling(t: np.ndarray, y: np.ndarray, y_final: float, band: float) -> float:
    """Ts: the first sample time after which ``|y - y_final| < band`` holds to the end
    (strict "<" inside the band, as python-control: the sample after the last one
    outside), NaN unless at least the last two samples are inside."""
    outside = np.flatnonzero(~(np.abs(y - y_final) < band))
    settled = int(outside[-1]) + 1 if outside.size else 0
    return float(t[settled]) if settled <= y.shape[0] - 2 else math.nan


def settling_time(
    t: np.ndarray, y: np.ndarray, target: float, y0: float = 0.0, final_value: float = math.nan
) -> float:
    """``step_metrics(t, y, target, y0, final_value=final_value).settling_time`` alone
    (default ``final_value``: the target), without the other metrics: for inputs
    :func:`step_metrics` has already accepted (a run's second Ts, to its target)."""
    y = np.asarray(y, dtype=float)
    target, y0 = float(target), float(y0)
    final = target if math.isnan(final_value) else _check_scalar("final_value", final_value)
    if not np.isfinite(y).all():
        return math.nan  # as step_metrics: Ts needs the whole record
    return _settling(np.asarray(t, dtype=float), y, final, 0.02 * abs(target - y0))


def step_metrics_per_joint(
    t: np.ndarray,
    y: np.ndarray,
    target: Sequence[float],
    y0: Sequence[float],
    **kwargs: Any,
) -> tuple[StepMetrics, ...]:
    """:func:`step_metrics` of each column of ``y`` (shape (N, k)) with its own target and y0.

    Keyword arguments go to :func:`step_metrics` unchanged.
    """
    y = np.asarray(y, dtype=float)
    if y.ndim != 2 or len(target) != y.shape[1] or len(y0) != y.shape[1]:
        raise ValueError(
            f"y must be (N, k) with k targets and k initial values; got y {y.shape}, "
            f"{len(target)} targets, {len(y0)} initial values"
        )
    return tuple(step_metrics(t, y[:, j], target[j], y0[j], **kwargs) for j in range(y.shape[1]))


def _per_column(values: np.ndarray) -> float | tuple[float, ...]:
    return float(values) if values.ndim == 0 else tuple(float(v) for v in values)


def _check_signal(name: str, x: np.ndarray) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.ndim not in (1, 2):
        raise ValueError(f"{name} must have shape (N,) or (N, k), got {x.shape}")
    if x.shape[0] == 0:
        raise ValueError(f"{name} is empty: need at least one sample")
    return x


def _trapezoid(f: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Trapezoidal integral along axis 0 (np.trapezoid is numpy >= 2 only)."""
    dt = np.diff(t) if f.ndim == 1 else np.diff(t)[:, None]
    return np.sum(0.5 * dt * (f[1:] + f[:-1]), axis=0)


# numpy reduces an (N, k) array along axis 0 row by row, at a cost per row: ~60 µs for
# (4001, 2), where a contiguous row of 4001 takes ~3. Two ways round it, bit for bit
# (tests/test_measure_runs.py holds them to the plain forms on random records):
# - a max is the same in any order: taken along the rows of the transposed copy;
# - sums of several (N, k >= 2) arrays stacked side by side into one reduction: each column
#   is still summed row by row from 0, as alone, and the cost per row is paid once.


def column_max(x: np.ndarray) -> np.ndarray:
    """``np.max(x, axis=0)`` of an (N, k) array without -0.0 (e.g. magnitudes), faster."""
    if x.ndim != 2 or x.shape[0] == 0:
        return np.max(x, axis=0)
    return np.max(np.ascontiguousarray(x.T), axis=1)


def _column_sums(*arrays: np.ndarray) -> list[np.ndarray]:
    """``np.sum(a, axis=0)`` of each (N, k) array (k >= 2), in one reduction."""
    widths = [a.shape[1] for a in arrays]
    if len(arrays) == 1 or min(widths) < 2:  # a single column is summed pairwise: alone
        return [np.sum(a, axis=0) for a in arrays]
    sums = np.sum(np.concatenate(arrays, axis=1), axis=0)
    return np.split(sums, np.cumsum(widths)[:-1])


def error_measures(t: np.ndarray, e: np.ndarray) -> ErrorMeasures:
    """Integral error measures IAE, ISE and ITAE by the trapezoidal rule, and the largest
    error.

    ``IAE = ∫ |e| dt``, ``ISE = ∫ e² dt``, ``ITAE = ∫ t |e| dt`` over ``[t[0], t[-1]]``, with
    ``t`` as given (pass ``t - t_step`` to weight by the time since a step that comes later);
    ``max_abs = max |e|`` over the samples (a held joint's largest deviation, a ramp's
    largest lag). A single sample integrates to 0. Non-finite errors propagate (the result
    is NaN or inf).

    Parameters
    ----------
    t : ndarray, shape (N,)
        Sample times, finite and strictly increasing.
    e : ndarray, shape (N,) or (N, k)
        Error; for (N, k) each column (joint) is integrated separately.

    Returns
    -------
    ErrorMeasures
        Fields are floats for ``e`` of shape (N,) and tuples of k floats for (N, k).
    """
    e = _check_signal("e", e)
    t = _check_times(t, e.shape[0])
    if e.ndim == 1:
        abs_e = np.abs(e)
        iae, ise, itae = (_trapezoid(f, t) for f in (abs_e, e * e, t * abs_e))
        max_abs = np.max(abs_e)
    else:  # _trapezoid of each: the products on the joints' rows, summed in one reduction
        rows = np.ascontiguousarray(e.T)
        a, dt = np.abs(rows), np.diff(t)
        parts = [0.5 * dt * (f[:, 1:] + f[:, :-1]) for f in (a, rows * rows, t * a)]
        iae, ise, itae = _column_sums(*(np.ascontiguousarray(p.T) for p in parts))
        max_abs = np.max(a, axis=1)  # column_max
    return ErrorMeasures(
        iae=_per_column(iae),
        ise=_per_column(ise),
        itae=_per_column(itae),
        # np.max ignores no NaN: a NaN anywhere gives NaN, as the integrals do.
        max_abs=_per_column(max_abs),
    )


OSCILLATION_WINDOW = 0.3  # the swings of the last 30 % of a run (and at least ENDING_SWINGS)


def oscillation_amplitude(
    t: np.ndarray, e: np.ndarray, window: float = OSCILLATION_WINDOW, since: float = -math.inf
) -> float | tuple[float, ...]:
    """Amplitude of the oscillation that persists at the end of the run [rad]: an
    exponential envelope fitted to the error's swings (half the change between consecutive
    turning points, paired; :mod:`twolink.simulation.swings`), read at the last sample.

    The swings are those ending in the last ``window`` share of the run, at least the
    run's last three and at most its last six, so a cycle slower than the window is still
    seen (a 2.4 s cycle in a 4 s run: its window of 1.2 s holds half a period). A limit
    cycle reads its amplitude (half its peak-to-peak); a decaying transient reads what is
    left of it at the end (its envelope there, not where the window starts); a growing one
    its size at the end. A response that has stopped turning reads 0: settled (at its
    target or off it), or still drifting one way (a sag toward its rest state, a slow
    approach, a monotone runaway: no oscillation), or an oscillation that ended (its last
    turn more than its last period before the end). A cycle whose period exceeds about
    two thirds of the run (fewer than three turns) is not told from a drift: run longer
    (the run's outcome is "undecided" where its growth cannot be read). Where it does not
    grow, it is at most half the error's peak-to-peak over its last period: the end bounds
    what persists there. NaN for fewer than 3 samples in the window, or a non-finite
    error.

    Of several tones it reads the larger swing that persists
    (:func:`twolink.simulation.swings.persisting_swing`): a slower swing that carries
    faster ones is read the same way from its own turns, between its extremes, so the
    faster ones' ride on them counts, and stands where it reads at least twice the faster
    swing (where it is itself the larger). A slow tone of amplitude A carrying a fast one
    of B < A reads between A and A + B, half the slow cycle's peak-to-peak (5 mrad
    carrying 1 mrad at 5, 12 or 40 times its frequency: 5.9-6.0 mrad); a fast tone larger
    than the slow one it rides on reads its own swings, paired: about B (1 mrad carrying
    5 mrad: 4.75-4.96 mrad).

    Parameters
    ----------
    t : ndarray, shape (N,)
    e : ndarray, shape (N,) or (N, k)
        Error (or angle); each column separately.
    window : float
        Share of the run (0.3: its last 30 %) whose swings the envelope is fitted to.
    since : float
        Turns before this time are not the oscillation's (a run's: its reference's end,
        so the move's own tracking error is not read as a swing); default: every turn.
    """
    e = _check_signal("e", e)
    t = _check_times(t, e.shape[0])
    span = window * (t[-1] - t[0])
    columns = e.reshape(e.shape[0], -1)
    out = np.full(columns.shape[1], np.nan)
    if last(t, span).sum() >= 3:
        for j in range(columns.shape[1]):
            x = columns[:, j]
            if not np.all(np.isfinite(x)):
                continue  # NaN, as the other measures give
            reading = persisting_swing(t, x, span, since)
            out[j] = 0.0 if reading is None else reading
    return _per_column(out if e.ndim > 1 else out[0])


def tail_mean(t: np.ndarray, e: np.ndarray, window: float) -> float | tuple[float, ...]:
    """The mean of ``|e|`` over the last ``window`` seconds (per column): ess and the
    final error of a run over its settling window, not one sample."""
    e = _check_signal("e", e)
    t = _check_times(t, e.shape[0])
    return _per_column(np.mean(np.abs(e[last(t, window)]), axis=0))


def torque_measures(tau: np.ndarray) -> TorqueMeasures:
    """RMS, peak and total variation of the joint torques.

    The RMS is over samples, ``sqrt(mean(tau²))``, i.e. a time RMS for the uniformly sampled
    torques of a fixed-step simulation. Non-finite torques propagate (NaN or inf).

    Parameters
    ----------
    tau : ndarray, shape (N,) or (N, k)
        Torques; for (N, k) each column (joint) is measured separately.

    Returns
    -------
    TorqueMeasures
        Fields are floats for ``tau`` of shape (N,) and tuples of k floats for (N, k).
    """
    tau = _check_signal("tau", tau)
    peak = column_max(np.abs(tau))
    with np.errstate(over="ignore"):
        squares = tau * tau
        if tau.ndim == 2 and tau.shape[1] >= 2:  # np.mean's sum and the variation's, at once
            # the steps after a row of zeros: the sum from 0 is the same, 0 + 0 = 0
            steps = np.zeros_like(tau)
            steps[1:] = np.abs(np.diff(tau, axis=0))
            total, variation = _column_sums(squares, steps)
            rms = np.sqrt(total / tau.shape[0])
        else:
            rms = np.sqrt(np.mean(squares, axis=0))
            variation = np.sum(np.abs(np.diff(tau, axis=0)), axis=0)
    # tau² overflows for torques past ~1e154 (a diverging controller's demand): scale there.
    huge = np.isinf(rms) & np.isfinite(peak)
    if np.any(huge):
        scaled = np.sqrt(np.mean((tau / np.where(peak > 0, peak, 1.0)) ** 2, axis=0)) * peak
        rms = np.where(huge, scaled, rms)
    return TorqueMeasures(
        rms=_per_column(rms), peak=_per_column(peak), variation=_per_column(variation)
    )


def to_jsonable(value: Any) -> Any:
    """Convert metrics (dataclasses, arrays, tuples, numpy scalars) to plain JSON types.

    Dataclasses and mappings become dicts, sequences and arrays lists, numbers Python floats
    or ints; NaN and ±inf become ``None`` (JSON has no NaN), so the result passes
    ``json.dumps(..., allow_nan=False)``.
    """
    if is_dataclass(value) and not isinstance(value, type):
        return to_jsonable(asdict(value))
    if isinstance(value, Mapping):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, np.ndarray):
        return to_jsonable(value.tolist())
    if isinstance(value, list | tuple):
        return [to_jsonable(v) for v in value]
    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        return float(value) if math.isfinite(value) else None
    if value is None or isinstance(value, str):
        return value
    raise TypeError(f"cannot convert {type(value).__name__} to JSON: {value!r}")


def metrics_dict(**sections: Any) -> dict[str, Any]:
    """Collect named metrics into one JSON-ready dict for ``metrics.json``.

    Example: ``metrics_dict(theta1=step_metrics(...), errors=error_measures(t, e),
    torque=torque_measures(tau))``. Each value goes through :func:`to_jsonable` (NaN becomes
    ``null``).
    """
    return {name: to_jsonable(value) for name, value in sections.items()}
