"""Reading the end of a run: the settling window, the error's swings (turning points,
half-swings, their exponential envelope) and the growth rate of what persists there.
:func:`twolink.simulation.metrics.oscillation_amplitude` and the run's outcome
(:mod:`twolink.simulation.outcome`) read them; docs/metrics.md, "Reading the end of a
run", has the rules and the evidence. Plain numpy and scipy, no other part of twolink.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

__all__ = [
    "ENDING_SWINGS",
    "FITTED_SWINGS",
    "GROWTH_FLOOR_RAD",
    "SETTLING_WINDOW_MIN_S",
    "SETTLING_WINDOW_SHARE",
    "SWING_FLOOR",
    "WIGGLE_SHARE",
    "end_envelope",
    "ending_swings",
    "envelope",
    "growth_rate",
    "growth_rates",
    "half_swings",
    "last",
    "persisting_swing",
    "settling_window",
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


def last(t: np.ndarray, window: float) -> np.ndarray:
    """The samples of the last ``window`` seconds of ``t`` (a boolean mask)."""
    return t >= t[-1] - window - 1e-12


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


# A turn of measurement noise is no swing: the floor rises to this many times the noise's
# standard deviation (:func:`noise_level`). White noise's own turns on a cycle's flat top
# reach the noise's range over the top's few tens of samples, about 4-5 σ; 8 σ leaves
# them out with margin and keeps every swing of a cycle 12 times the noise's σ or more
# (a 10 mrad cycle carrying 0.1 mrad of noise, 1 % of it: docs/metrics.md).
NOISE_SWINGS = 8.0


def noise_level(x: np.ndarray) -> float:
    """The standard deviation of white measurement noise on a smooth signal, from its
    fourth differences (Δ⁴x of white noise has σ√70, the sum of the squares of 1, 4, 6, 4,
    1; a smooth signal sampled finely adds next to nothing: a 0.1 rad 5 Hz cycle at 1 kHz
    1e-7 rad): their median absolute value / 0.6745 / √70, robust to the few large ones of
    a kick. 0 for a quantised signal that mostly stands still (median 0)."""
    fourth = np.abs(np.diff(np.asarray(x, dtype=float), 4))
    return float(np.median(fourth)) / 0.6745 / math.sqrt(70.0) if fourth.size else 0.0


def _turns(t: np.ndarray, x: np.ndarray, floor: float, since: float) -> np.ndarray:
    """:func:`turning_points` of ``x`` at or after ``since``, the floor raised to
    :data:`NOISE_SWINGS` times the :func:`noise_level` after ``since``."""
    floor = max(floor, NOISE_SWINGS * noise_level(x[t >= since]))
    idx = turning_points(x, floor)
    return idx[t[idx] >= since]


def _swings(
    t: np.ndarray, x: np.ndarray, idx: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(times, halves, turns)`` of the turning points ``idx`` (:func:`half_swings`)."""
    turns = t[idx]
    if idx.size < 2:
        return np.empty(0), np.empty(0), turns
    return 0.5 * (turns[1:] + turns[:-1]), 0.5 * np.abs(np.diff(x[idx])), turns


def half_swings(
    t: np.ndarray, x: np.ndarray, floor: float = SWING_FLOOR, since: float = -math.inf
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The half-swings of a 1-d signal: between consecutive turning points
    (:func:`turning_points`, their floor raised to :data:`NOISE_SWINGS` times the
    :func:`noise_level` after ``since``) at or after ``since``, half the change, at the
    midpoint in time. Returns ``(times, halves, turns)``, ``turns`` the turning points'
    times."""
    return _swings(t, x, _turns(t, x, floor, since))


def envelope(times: np.ndarray, halves: np.ndarray, at: float) -> tuple[float, float]:
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
            # relative residuals (sigma = the swing): every swing weighs alike, so the
            # large ones of a decaying transient do not decide the envelope at the end
            (a1, s1), _ = curve_fit(
                lambda u, a, s: a * np.exp(s * u), dt, halves, p0=(a, s), sigma=halves
            )
        if math.isfinite(a1) and math.isfinite(s1) and a1 > 0:
            a, s = float(a1), float(s1)
    except (RuntimeError, ValueError):  # no convergence: the log-linear fit stands
        pass
    return a, s


def ending_swings(
    t: np.ndarray, x: np.ndarray, window: float, since: float = -math.inf
) -> tuple[np.ndarray, np.ndarray] | None:
    """The swings an oscillation at the end of the record is read from: the half-swings of
    the last ``window`` seconds, and at least the record's last :data:`ENDING_SWINGS` + 1,
    each consecutive two averaged (at least :data:`ENDING_SWINGS` of them, at most the last
    :data:`FITTED_SWINGS`), of the turns at or after ``since`` (a run's: after its
    reference stopped, so the move's own tracking error is no swing of it). None where
    there is no swing, or the oscillation has ended (its last turn more than its last
    period before the end)."""
    return _ending(t, window, half_swings(t, x, since=since))


def _ending(
    t: np.ndarray, window: float, swings: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> tuple[np.ndarray, np.ndarray] | None:
    """:func:`ending_swings` of the half-swings ``swings`` (:func:`half_swings`)."""
    times, halves, turns = swings
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


def end_envelope(
    t: np.ndarray, x: np.ndarray, window: float, since: float = -math.inf
) -> tuple[float, float] | None:
    """``(a, s)``: the envelope of :func:`ending_swings` at the record's end and its rate,
    or None (no oscillation at the end). ``a`` is at most half the error's peak-to-peak
    over its last period (after ``since``): what the end shows bounds what persists there
    (a growing envelope's extrapolation too). With one half-swing only (two turns: a slow
    cycle, or the last swing of a heavily damped one, the record cannot tell) ``a`` is
    half the peak-to-peak over the last ``window`` seconds, what the end shows, and ``s``
    is NaN."""
    return _end_reading(t, x, window, since, half_swings(t, x, since=since))


def _end_reading(
    t: np.ndarray,
    x: np.ndarray,
    window: float,
    since: float,
    swings: tuple[np.ndarray, np.ndarray, np.ndarray],
) -> tuple[float, float] | None:
    """:func:`end_envelope` of the half-swings ``swings`` of ``x``."""
    ending = _ending(t, window, swings)
    if ending is None:
        return None
    turns = swings[2]
    if turns.size < 3:
        return 0.5 * float(np.ptp(x[last(t, window)])), math.nan
    a, s = envelope(*ending, at=float(t[-1]))
    seen = x[t >= max(since, t[-1] - (turns[-1] - turns[-3]))]
    return min(a, 0.5 * float(np.ptp(seen))), s


SLOWER_SHARE = 2.0  # a slower swing is read where it is this many times the faster one


def persisting_swing(
    t: np.ndarray, x: np.ndarray, window: float, since: float = -math.inf
) -> float | None:
    """The amplitude of the larger swing that persists at the end of ``x`` (what
    :func:`twolink.simulation.metrics.oscillation_amplitude` reads), or None (none): the
    :func:`end_envelope` of its swings, and of each slower swing that carries a faster one
    (:func:`_slower_swings`), whichever is the larger. Of a slow cycle carrying a fast
    one, the slow swings are read between their extremes, the fast one's ride included."""
    idx = _turns(t, x, SWING_FLOOR, since)
    fine = _end_reading(t, x, window, since, _swings(t, x, idx))
    best = None if fine is None else fine[0]
    for keep in _slower_swings(x[idx], float(x[-1])):
        slow = idx[keep]
        # half the last slow period's peak-to-peak bounds its reading: skip it unread
        # where that cannot beat the reading so far (the fit is the costly part)
        if best is not None and 0.5 * np.ptp(x[slow[-3] :]) < SLOWER_SHARE * best:
            continue
        reading = _end_reading(t, x, window, since, _swings(t, x, slow))
        # read between its extremes, a slower swing carries the faster one's ride (up to
        # its amplitude): at twice the faster one or more it is itself the larger
        if reading is not None and (best is None or reading[0] >= SLOWER_SHARE * best):
            best = reading[0]
    return best


def _zigzag(v: np.ndarray, end: float, step: float) -> np.ndarray:
    """Positions in ``v`` (alternating extremes) of the turns between which it moves by at
    least ``step`` (the zigzag filter: of the extremes in between, the most extreme
    stands), each come to from a step away and left by one; ``end``, the record's last
    value, confirms the last. The first extreme of the first step starts it, no turn."""
    keep: list[int] = []
    hi = lo = c = 0  # running extremes before the first step; c: the turn to confirm
    d = 0  # +1: c is a maximum, -1 a minimum, 0: not known yet
    for i, u in enumerate([*v[1:].tolist(), end], start=1):
        if d == 0:
            hi, lo = (i if u > v[hi] else hi), (i if u < v[lo] else lo)
            if v[hi] - v[lo] >= step and i < v.size:
                c, d = max(hi, lo), (1 if hi > lo else -1)
        elif d * (u - v[c]) >= 0:  # of equal extremes the later: the end of a flat top
            c = i if i < v.size else c
        elif d * (v[c] - u) >= step:
            keep.append(c)
            c, d = i, -d
    return np.array(keep, dtype=int)


def _slower_swings(v: np.ndarray, end: float) -> list[np.ndarray]:
    """Positions in ``v`` (a record's turns, alternating extremes; ``end`` its last value)
    of each slower swing that carries a faster one over its last period: the zigzag of
    ``v`` (:func:`_zigzag`) at half its range, a quarter, ..., where it has three turns or
    more, turns of ``v`` lie between its last three besides its middle one, and neither
    of its last two swings is under :data:`WIGGLE_SHARE` of the other (one turn of a slow
    approach and a ripple at its end make no slower cycle). Down to the step that drops
    no turn between the first and the last, from which on nothing is slower."""
    out: list[np.ndarray] = []
    if v.size < 4:
        return out
    step = 0.5 * float(np.ptp(v))
    for _ in range(24):  # halvings: 2^-24 of the range is below any swing that counts
        keep = _zigzag(v, end, step)
        if keep.size >= v.size - 2 and keep[-1] - keep[0] == keep.size - 1:
            break
        if keep.size >= 3 and keep[-1] - keep[-3] > 2:
            last_two = np.abs(np.diff(v[keep[-3:]]))
            slower = last_two.min() >= WIGGLE_SHARE * last_two.max()
            if slower and not (out and np.array_equal(keep, out[-1])):
                out.append(keep)
        step *= 0.5
    return out


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


def growth_rate(
    t: np.ndarray, x: np.ndarray, window: float, since: float = -math.inf, settling: bool = False
) -> np.ndarray:
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
      NaN, the run too short to tell. With ``settling`` (the loop's linearisation at its
      rest state is stable, :mod:`twolink.simulation.stability`) a trend that accelerates
      away (σ > 0) is a transient not yet turned on its way to that rest: NaN too, the
      run too short; without a linearisation a runaway cannot be told from it: σ.

    Capped at ±:data:`MAX_RATE`; inf where ``x`` is not finite (a run that blew up); NaN
    for fewer than 6 samples in the window.
    """
    free, settling_rates = growth_rates(t, x, window, since)
    return settling_rates if settling else free


def growth_rates(
    t: np.ndarray, x: np.ndarray, window: float, since: float = -math.inf
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`growth_rate` without and with ``settling``, from one pass over the record
    (what a run measured before its linearisation is known keeps)."""
    x = np.asarray(x, dtype=float)
    columns = x.reshape(len(t), -1)
    out = np.full(columns.shape[1], np.nan)
    rising = np.zeros(columns.shape[1], bool)  # a trend accelerating away
    tail = last(t, window) if len(t) else np.zeros(0, bool)
    if tail.sum() < 6:
        return out, out.copy()
    for j in range(columns.shape[1]):
        col = columns[:, j]
        w = col[tail]
        if not np.all(np.isfinite(w)):
            out[j] = math.inf
        elif np.ptp(w) < GROWTH_FLOOR_RAD:
            out[j] = 0.0
        elif (ending := end_envelope(t, col, window, since)) is not None:
            size, rate = ending
            # a ripple is not judged; one swing alone gives no rate (NaN: cannot tell)
            out[j] = rate if size >= GROWTH_FLOOR_RAD else 0.0
        else:
            out[j] = rate = _trend_rate(t[tail], w)
            rising[j] = rate > 0
    free = np.where(np.isinf(out), out, np.clip(out, -MAX_RATE, MAX_RATE))
    return free, np.where(rising, math.nan, free)
