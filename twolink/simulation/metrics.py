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
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, is_dataclass
from typing import Any

import numpy as np

__all__ = [
    "ENDING_SWINGS",
    "SWING_FLOOR",
    "ErrorMeasures",
    "StepMetrics",
    "TorqueMeasures",
    "error_measures",
    "growth_rate",
    "half_swings",
    "metrics_dict",
    "oscillation_amplitude",
    "settling_window",
    "tail_mean",
    "step_metrics",
    "step_metrics_per_joint",
    "torque_measures",
    "to_jsonable",
    "turning_points",
]

# The settling window of a run: its last max(0.5 s, 10 %) (docs/metrics.md). The run's
# outcome, ess, the final and the tail error are all read over it.
SETTLING_WINDOW_MIN_S = 0.5
SETTLING_WINDOW_SHARE = 0.1


def settling_window(duration: float) -> float:
    """The settling window of a run of ``duration`` seconds: its last
    ``max(0.5 s, 10 % of the run)``, capped at the run."""
    return min(duration, max(SETTLING_WINDOW_MIN_S, SETTLING_WINDOW_SHARE * duration))


def _last(t: np.ndarray, window: float) -> np.ndarray:
    """The samples of the last ``window`` seconds of ``t`` (a boolean mask)."""
    return t >= t[-1] - window - 1e-12


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
      seconds (default: the record's settling window, :func:`settling_window` of
      ``t[-1] - t[0]``); ``ess_window=0`` reads the last sample alone.

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
    ess = float(np.mean(np.abs(target - y[_last(t, ess_window)])))

    y_final = float(y[-1]) if final_value is None else _check_scalar("final_value", final_value)
    # Strict "<" inside the band, as python-control; Ts = the sample after the last one outside.
    outside = np.flatnonzero(~(np.abs(y - y_final) < settling_threshold * abs(step)))
    settled = int(outside[-1]) + 1 if outside.size else 0
    settling = float(t[settled]) if settled <= y.shape[0] - 2 else math.nan

    return StepMetrics(
        peak_time=peak_time,
        delay_time=delay,
        rise_time=float(rise),
        settling_time=settling,
        overshoot=overshoot,
        steady_state_error=ess,
    )


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
    tt = t if e.ndim == 1 else t[:, None]
    abs_e = np.abs(e)
    return ErrorMeasures(
        iae=_per_column(_trapezoid(abs_e, t)),
        ise=_per_column(_trapezoid(e * e, t)),
        itae=_per_column(_trapezoid(tt * abs_e, t)),
        # np.max ignores no NaN: a NaN anywhere gives NaN, as the integrals do.
        max_abs=_per_column(np.max(abs_e, axis=0)),
    )


OSCILLATION_WINDOW = 0.3  # the swings of the last 30 % of a run (and at least ENDING_SWINGS)
# A turn of the error smaller than this is no swing: 1e-6 rad is 1/48 of a 17-bit
# encoder's count (4.8e-5 rad), below what any sensor here resolves; a quantised loop's
# micro-ripple lies under it, and an oscillation that has decayed below it has ended.
SWING_FLOOR = 1e-6
ENDING_SWINGS = 3  # the envelope is fitted to at least the run's last 3 (paired) swings
FITTED_SWINGS = 6  # and to at most its last 6: three periods before the end
# An oscillation has ended where its last turn lies further back than its last period
# (its last three turns; twice its only half-period with two): a cycle still going would
# have turned again (and a decaying one that stopped turning has died below SWING_FLOOR).
# A full period, not a half: a relay's cycle rises fast and falls slowly.


def turning_points(x: np.ndarray, floor: float = SWING_FLOOR) -> np.ndarray:
    """Indices of the turning points of a 1-d signal, alternating maxima and minima:
    ``scipy.signal.find_peaks`` of ``x`` and of ``-x`` with a prominence of at least
    ``floor`` (a plateau's middle sample for a flat one, as a quantised signal has), and of
    two maxima (minima) in a row the higher (lower)."""
    from scipy.signal import find_peaks

    x = np.asarray(x, dtype=float)
    hi, _ = find_peaks(x, prominence=floor)
    lo, _ = find_peaks(-x, prominence=floor)
    idx = np.concatenate([hi, lo])
    sign = np.concatenate([np.ones(hi.size), -np.ones(lo.size)])
    order = np.argsort(idx, kind="stable")
    kept: list[tuple[int, float]] = []
    for i, k in zip(idx[order].tolist(), sign[order].tolist(), strict=True):
        if kept and kept[-1][1] == k:  # two maxima (minima) in a row: the more extreme
            if k * x[i] > k * x[kept[-1][0]]:
                kept[-1] = (i, k)
        else:
            kept.append((i, k))
    return _without_wiggles(x, np.array([i for i, _ in kept], dtype=int))


# A wiggle: a swing that stays inside the swing around it (both its ends between the
# points before and after it: the rainflow count's inner cycle) and is smaller than this
# share of its larger neighbour: a ripple on a flank or a double peak (a relay's kick, a
# sensor's chatter), not a swing of the oscillation. An oscillation's own swings, steady,
# decaying or growing, each reach past the extremes around them, so none is inside.
WIGGLE_SHARE = 0.25


def _without_wiggles(x: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """Alternating turning points ``idx`` of ``x`` with their wiggles removed (both ends
    of each, which leaves the points around it alternating), smallest first, in one pass
    over the swings as they are: a train of small swings on a drift (a cycle on a sag) is
    the oscillation, not a wiggle of the drift, so a removal does not make its neighbour
    one. The record's first and last samples bound the first and last swings."""
    pts = np.array([0, *idx.tolist(), len(x) - 1])
    if pts.size < 4:
        return idx
    v = x[pts]
    h = np.abs(np.diff(v))  # h[k]: from pts[k] to pts[k + 1]
    k = np.arange(1, pts.size - 2)  # swings between two real turning points
    lo = np.minimum(v[k - 1], v[k + 2])
    hi = np.maximum(v[k - 1], v[k + 2])
    inner = (lo <= v[k]) & (v[k] <= hi) & (lo <= v[k + 1]) & (v[k + 1] <= hi)
    small = h[k] < WIGGLE_SHARE * np.maximum(h[k - 1], h[k + 1])
    found = k[inner & small]
    taken: set[int] = set()
    for j in found[np.argsort(h[found], kind="stable")].tolist():
        if taken.isdisjoint((j - 1, j, j + 1, j + 2)):
            taken.update((j, j + 1))
    keep = np.array([i not in taken for i in range(1, pts.size - 1)], dtype=bool)
    return idx[keep]


def half_swings(
    t: np.ndarray, x: np.ndarray, floor: float = SWING_FLOOR
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The half-swings of a 1-d signal: between consecutive turning points
    (:func:`turning_points`), half the change, at the midpoint in time. Returns
    ``(times, halves, turns)``, ``turns`` the turning points' times."""
    idx = turning_points(x, floor)
    turns = t[idx]
    if idx.size < 2:
        return np.empty(0), np.empty(0), turns
    v = x[idx]
    return 0.5 * (turns[1:] + turns[:-1]), 0.5 * np.abs(np.diff(v)), turns


def _envelope(times: np.ndarray, halves: np.ndarray, at: float) -> tuple[float, float]:
    """An exponential envelope ``a e^(s (t - at))`` fitted to half-swings (least squares,
    ``scipy.optimize.curve_fit``, started from the log-linear fit): ``(a, s)``, its value
    at ``at`` and its rate [1/s]. One half-swing gives itself and no rate (NaN)."""
    if halves.size == 1:
        return float(halves[0]), math.nan
    from scipy.optimize import OptimizeWarning, curve_fit

    dt = times - at
    s0, loga = np.polyfit(dt, np.log(halves), 1)
    a, s = math.exp(loga), float(s0)
    try:
        with np.errstate(over="ignore", invalid="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", OptimizeWarning)  # an exact fit: no covariance
            (a1, s1), _ = curve_fit(lambda u, a, s: a * np.exp(s * u), dt, halves, p0=(a, s))
        if math.isfinite(a1) and math.isfinite(s1) and a1 > 0:
            a, s = float(a1), float(s1)
    except (RuntimeError, ValueError):  # no convergence: the log-linear fit stands
        pass
    return a, s


def _ending_swings(
    t: np.ndarray, x: np.ndarray, window: float
) -> tuple[np.ndarray, np.ndarray] | None:
    """The swings an oscillation at the end of the record is read from: the half-swings of
    the last ``window`` seconds, and at least the record's last :data:`ENDING_SWINGS` + 1,
    each consecutive two averaged (at least :data:`ENDING_SWINGS` of them, at most the last
    :data:`FITTED_SWINGS`). None
    where the record has no swing, or its oscillation has ended (its last turn more than
    its last period before the end)."""
    times, halves, turns = half_swings(t, x)
    if not halves.size:
        return None
    period = turns[-1] - turns[-3] if turns.size >= 3 else 2.0 * (turns[-1] - turns[-2])
    if t[-1] - turns[-1] > period:
        return None
    keep = times >= t[-1] - window
    keep[-(ENDING_SWINGS + 1) :] = True
    times, halves = times[keep], halves[keep]
    if halves.size < 2:
        return times, halves
    # consecutive half-swings averaged: on a drift they alternate A ± the drift over a
    # half-period, and the pair's mean is A (exact for a straight drift); the last
    # FITTED_SWINGS of them: the envelope at the end is read where the end is
    times, halves = 0.5 * (times[1:] + times[:-1]), 0.5 * (halves[1:] + halves[:-1])
    return times[-FITTED_SWINGS:], halves[-FITTED_SWINGS:]


def oscillation_amplitude(
    t: np.ndarray, e: np.ndarray, window: float = OSCILLATION_WINDOW
) -> float | tuple[float, ...]:
    """Amplitude of the oscillation that persists at the end of the run [rad]: an
    exponential envelope fitted to the error's half-swings (half the change between
    consecutive turning points, :func:`half_swings`), read at the run's last sample.

    The half-swings are those ending in the last ``window`` share of the run, and at least
    the run's last :data:`ENDING_SWINGS` (3), so a cycle slower than the window is still
    seen (a 2.4 s cycle in a 4 s run: its window of 1.2 s holds half a period). A limit
    cycle reads its amplitude (half its peak-to-peak); a decaying transient reads what is
    left of it at the end (its envelope there, not where the window starts); a growing one
    its size at the end. A response that has stopped turning reads 0: settled (at its
    target or off it), or still drifting one way (a sag toward its rest state, a slow
    approach, a monotone runaway: no oscillation), or an oscillation that ended (its last
    turn more than its last period before the end). A cycle whose period exceeds
    about two thirds of the run (fewer than three turns) is not told from a drift: run
    longer (the run's outcome is then "undecided" where its growth cannot be read,
    :func:`growth_rate`). NaN for fewer than 3 samples in the window, or a non-finite
    error.

    Parameters
    ----------
    t : ndarray, shape (N,)
    e : ndarray, shape (N,) or (N, k)
        Error (or angle); each column separately.
    window : float
        Share of the run (0.3: its last 30 %) whose swings the envelope is fitted to.
    """
    e = _check_signal("e", e)
    t = _check_times(t, e.shape[0])
    span = window * (t[-1] - t[0])
    columns = e.reshape(e.shape[0], -1)
    out = np.full(columns.shape[1], np.nan)
    if _last(t, span).sum() >= 3:
        for j in range(columns.shape[1]):
            x = columns[:, j]
            if not np.all(np.isfinite(x)):
                continue  # NaN, as the other measures give
            ending = _ending_swings(t, x, span)
            out[j] = 0.0 if ending is None else _envelope(*ending, at=float(t[-1]))[0]
    return _per_column(out if e.ndim > 1 else out[0])


def tail_mean(t: np.ndarray, e: np.ndarray, window: float) -> float | tuple[float, ...]:
    """The mean of ``|e|`` over the last ``window`` seconds (per column): ess and the
    final error of a run over its settling window, not one sample."""
    e = _check_signal("e", e)
    t = _check_times(t, e.shape[0])
    return _per_column(np.mean(np.abs(e[_last(t, window)]), axis=0))


# Growth is judged of what persists above this at the end [rad]: 1 mrad, the claims'
# practical tolerance for angles and 5 % of the 2 % band of a 1 rad move. A ripple of a
# few encoder counts (a 17-bit count is 4.8e-5 rad), irregular at that scale, is no
# instability; a loop with a linearisation has its growth decided there instead
# (twolink.simulation.stability), however small its unstable mode still is.
GROWTH_FLOOR_RAD = 1e-3
MAX_RATE = 50.0  # 1/s: a fitted rate is capped at this (a run diverging faster is "diverged")


def _trend_rate(tw: np.ndarray, w: np.ndarray) -> float:
    """σ of a monotone window ``w`` (at times ``tw``, uniform), ``x = c + d e^(σ t)``: from
    the means of its three equal thirds (the oldest samples beyond a multiple of 3 left
    out), ``(m3 − m2)/(m2 − m1) = r = e^(σ h)``, h the thirds' length; 0 where the mode's
    size at the end, ``|d| = |m3 − m2| / (I |1 − 1/r|)`` with I = (1 − 1/r)/ln r the mean
    of ``e^(σ (t − T))`` over the last third, is below :data:`GROWTH_FLOOR_RAD`; NaN where
    the thirds turn (r <= 0)."""
    n = len(w) // 3
    w, tw = w[len(w) - 3 * n :], tw[len(tw) - 3 * n :]
    m1, m2, m3 = (float(np.mean(part)) for part in np.split(w, 3))
    if m2 == m1:
        return 0.0 if m3 == m2 else math.nan
    r = (m3 - m2) / (m2 - m1)
    if not r > 0:
        return math.nan
    u = math.log(r)  # σ h
    if abs(u) < 1e-9:
        return 0.0  # a straight drift
    h = float(np.mean(tw[n : 2 * n]) - np.mean(tw[:n]))
    mean_last = (1.0 - 1.0 / r) / u
    size = abs((m3 - m2) / (mean_last * (1.0 - 1.0 / r)))
    return u / h if size >= GROWTH_FLOOR_RAD else 0.0


def growth_rate(t: np.ndarray, x: np.ndarray, window: float) -> np.ndarray:
    """The growth rate σ [1/s] of what persists over the last ``window`` seconds of each
    column of ``x`` (errors from the target, shape (N,) or (N, k)); ``e^(σ window)`` is
    its growth over the window (:func:`twolink.simulation.outcome.tail_growth`).

    - Settled (the error moves less than :data:`GROWTH_FLOOR_RAD` over the window): 0.
    - Oscillating (:func:`oscillation_amplitude`'s swings reach the end): the rate of the
      exponential envelope fitted to the half-swings of the window (and at least the last
      three): > 0 a growing oscillation, ~0 a limit cycle, < 0 a decaying one; 0 for a
      ripple whose envelope at the end is below :data:`GROWTH_FLOOR_RAD`.
    - Else monotone: the window's three thirds' means m1, m2, m3 of ``x = c + d e^(σt)``
      make a geometric progression, ``(m3 − m2)/(m2 − m1) = e^(σ window / 3)`` (exact for
      an exponential with an offset): σ > 0 a runaway, σ < 0 a sag toward its rest state
      (its error from the target grows, but less and less: it is settling, not growing),
      0 for a straight drift, and for a mode whose size at the end ``|d|`` is below
      :data:`GROWTH_FLOOR_RAD`. Where the thirds turn (the ratio is not positive: a swing
      slower than the window, no exponential), or an oscillation shows one swing only:
      NaN, the run too short to tell.

    Capped at ±:data:`MAX_RATE`; inf where ``x`` is not finite (a run that blew up); NaN
    for fewer than 6 samples in the window.
    """
    x = np.asarray(x, dtype=float)
    columns = x.reshape(len(t), -1)
    out = np.full(columns.shape[1], np.nan)
    tail = _last(t, window) if len(t) else np.zeros(0, bool)
    if tail.sum() < 6:
        return out
    for j in range(columns.shape[1]):
        col = columns[:, j]
        w = col[tail]
        if not np.all(np.isfinite(w)):
            out[j] = math.inf
        elif np.ptp(w) < GROWTH_FLOOR_RAD:
            out[j] = 0.0
        elif (ending := _ending_swings(t, col, window)) is not None:
            size, rate = _envelope(*ending, at=float(t[-1]))
            # a ripple is not judged; one swing alone gives no rate (NaN: cannot tell)
            out[j] = rate if size >= GROWTH_FLOOR_RAD else 0.0
        else:
            out[j] = _trend_rate(t[tail], w)
    return np.where(np.isinf(out), out, np.clip(out, -MAX_RATE, MAX_RATE))


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
    peak = np.max(np.abs(tau), axis=0)
    with np.errstate(over="ignore"):
        rms = np.sqrt(np.mean(tau * tau, axis=0))
    # tau² overflows for torques past ~1e154 (a diverging controller's demand): scale there.
    huge = np.isinf(rms) & np.isfinite(peak)
    if np.any(huge):
        scaled = np.sqrt(np.mean((tau / np.where(peak > 0, peak, 1.0)) ** 2, axis=0)) * peak
        rms = np.where(huge, scaled, rms)
    variation = np.sum(np.abs(np.diff(tau, axis=0)), axis=0)
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
