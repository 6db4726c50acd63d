"""A vectorised Mamdani fuzzy inference engine with two inputs (e, de) and one output (u).

The engine reproduces scikit-fuzzy 0.5's ``ControlSystemSimulation.compute()``
arithmetic (see ``docs/fuzzy.md``):

* every membership function is *sampled* on its variable's universe and read
  back by linear interpolation of those samples (``skfuzzy.interp_membership``);
* AND is ``min`` (``product`` as an option), implication is ``min`` (clipping),
  aggregation is ``max``;
* before defuzzifying, the output universe is "upsampled" with the points where
  each clip level crosses its membership function, and the aggregated output
  is treated as the piecewise-linear function through the values on that
  augmented grid; the centroid divides by ``max(area, machine eps)``.

Where no rule fires, skfuzzy has no answer (it raises); the engine returns
``no_fire_output`` instead (default 0.0: "no fuzzy correction").

Sign convention of this project: ``e = theta_d - theta``, ``de`` its rate, and a
positive ``u`` pushes ``theta`` up, so a PD-like rule base reads ``u ~ e + de``.

Two evaluation paths give the same numbers (tests hold them to 1e-12):

* a fast path for the usual case, where every variable is a triangular
  partition (each peak is its neighbours' foot) and the defuzzifier is the
  centroid: the centroid is computed in closed form per pair of neighbouring
  output peaks, in pure Python for a handful of inputs (one control step for
  both joints) and with numpy for batches;
* a general path for any triangular / trapezoidal / Gaussian terms and for the
  bisector and mean-of-maximum defuzzifiers, which builds the augmented grid.
"""

from __future__ import annotations

import math
from bisect import bisect_left, bisect_right
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np
import skfuzzy

from twolink.controllers.fuzzy import kernels
from twolink.controllers.fuzzy.membership import FuzzyVariable
from twolink.controllers.fuzzy.rulebase import Rule, RuleBase

__all__ = ["MamdaniEngine", "fired_rule_labels", "rule_label"]

AndMethod = Literal["min", "product"]
DefuzzMethod = Literal["centroid", "bisector", "mom"]

_AND_METHODS = ("min", "product")
_DEFUZZ_METHODS = ("centroid", "bisector", "mom")
# skfuzzy's centroid divides by max(area, eps); reproduced so tiny firings agree.
_EPS = float(np.finfo(np.float64).eps)
# Up to this many inputs per call, the pure-Python fast path beats numpy's per-call overhead
# (measured crossover: 64 to 128 inputs).
_SMALL_N = 64
# Rows per chunk on the numpy paths: bounds the temporaries and keeps them in cache.
_CHUNK = 512
# Tolerance for recognising a sampled triangular partition (fast path eligibility).
_PARTITION_TOL = 1e-12


def _partition_peaks(var: FuzzyVariable) -> tuple[float, ...] | None:
    """Peaks if ``var`` is a triangular partition whose peaks are sample points, else None."""
    grid, table = var.grid, var.table
    if table.shape[0] < 2:
        return None
    peak_idx = np.argmax(table, axis=1)
    if peak_idx[0] != 0 or peak_idx[-1] != grid.size - 1 or np.any(np.diff(peak_idx) <= 0):
        return None
    peaks = grid[peak_idx]
    expected = np.array([np.interp(grid, peaks, row) for row in np.eye(table.shape[0])])
    if not np.allclose(table, expected, rtol=0.0, atol=_PARTITION_TOL):
        return None
    return tuple(float(p) for p in peaks)


def _partition_rows(x: np.ndarray, peaks: np.ndarray, xp: Any = np) -> np.ndarray:
    """Memberships (n_terms, N) of a triangular partition with these peaks, as ``_small``
    computes them: on [p_i, p_i+1], 1 - t for term i and t for term i + 1. Equal to the
    sampled triangles read back by interpolation up to rounding (the partition's
    samples are exact, ``_partition_peaks``), and many times cheaper than interpolating
    every term. ``xp``: the array namespace (numpy, or jax.numpy for the accelerator
    backend)."""
    peaks = xp.asarray(peaks)
    x = xp.clip(x, peaks[0], peaks[-1])
    i = xp.minimum(xp.searchsorted(peaks, x, side="right") - 1, peaks.shape[0] - 2)
    lo = peaks[i]
    t = (x - lo) / (peaks[i + 1] - lo)
    term = xp.arange(peaks.shape[0])[:, None]
    return xp.where(term == i, 1.0 - t, xp.where(term == i + 1, t, 0.0))


def _crossings(
    grid: np.ndarray, row: np.ndarray, level: np.ndarray, fill_lo: float, fill_hi: float
) -> tuple[np.ndarray, np.ndarray]:
    """Where a sampled unimodal membership crosses ``level``, as skfuzzy's interp_universe.

    Returns the left (rising) and right (falling) crossing for each level. A
    side without a crossing (the samples there are all >= level) gets
    ``fill_lo`` / ``fill_hi``.
    """
    m = grid.size
    top = row.max()
    first_top = int(np.argmax(row))
    last_top = m - 1 - int(np.argmax(row[::-1]))
    rise = row[: first_top + 1]
    fall_rev = row[last_top:][::-1]
    lvl = np.minimum(level, top)
    # Rising side: first sample >= level; the crossing is on the segment before it.
    j = np.searchsorted(rise, lvl, side="left")
    jj = np.maximum(j, 1)
    x0, x1, y0, y1 = grid[jj - 1], grid[jj], row[jj - 1], row[jj]
    with np.errstate(divide="ignore", invalid="ignore"):
        left = x0 + (lvl - y0) * (x1 - x0) / (y1 - y0)
    left = np.where(j >= 1, left, fill_lo)
    # Falling side: last sample >= level; the crossing is on the segment after it.
    jr = np.searchsorted(fall_rev, lvl, side="left")
    idx = np.minimum(m - 1 - jr, m - 2)
    x0, x1, y0, y1 = grid[idx], grid[idx + 1], row[idx], row[idx + 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        right = x0 + (lvl - y0) * (x1 - x0) / (y1 - y0)
    right = np.where(jr >= 1, right, fill_hi)
    # At the top level the set {mf >= level} is the sampled plateau itself.
    at_top = lvl >= top
    left = np.where(at_top, grid[first_top], left)
    right = np.where(at_top, grid[last_top], right)
    return left, right


@dataclass(frozen=True, eq=False)
class _Plan:
    """Index arrays and fast-path data derived once from an engine's definition."""

    rule_e: np.ndarray
    rule_de: np.ndarray
    rule_u: np.ndarray
    order: np.ndarray  # rules sorted by consequent, for a max-reduceat per output term
    starts: np.ndarray
    used_u: np.ndarray
    # The neighbouring output-peak pairs some rule can clip (the others add exactly 0 to
    # the centroid's sums): the rows the batch centroid computes.
    pair_span: slice
    # Fast path (triangular partitions + centroid); None when not applicable.
    peaks_u: np.ndarray | None
    peaks_e: tuple[float, ...] | None
    peaks_de: tuple[float, ...] | None
    peaks_e_array: np.ndarray | None
    peaks_de_array: np.ndarray | None
    peaks_u_list: tuple[float, ...] | None
    grid_u_list: tuple[float, ...] | None
    pair_table: tuple[tuple[tuple[int, ...], ...], ...] | None


def _plan_for(engine: MamdaniEngine) -> _Plan:
    r_e = np.array([engine.e.index(r.e) for r in engine.rules], dtype=np.intp)
    r_de = np.array([engine.de.index(r.de) for r in engine.rules], dtype=np.intp)
    r_u = np.array([engine.u.index(r.u) for r in engine.rules], dtype=np.intp)
    order = np.argsort(r_u, kind="stable")
    used_u, starts = np.unique(r_u[order], return_index=True)
    n_pairs = len(engine.u.labels) - 1
    pair_span = slice(max(int(used_u[0]) - 1, 0), min(int(used_u[-1]) + 1, n_pairs))
    pu = _partition_peaks(engine.u) if engine.defuzz == "centroid" else None
    pe, pd = _partition_peaks(engine.e), _partition_peaks(engine.de)
    small_ok = pu is not None and pe is not None and pd is not None
    pair_table = None
    if small_ok:
        cells: list[list[list[int]]] = [[[] for _ in pd] for _ in pe]
        for i, j, k in zip(r_e.tolist(), r_de.tolist(), r_u.tolist(), strict=True):
            if k not in cells[i][j]:
                cells[i][j].append(k)
        pair_table = tuple(tuple(tuple(c) for c in row) for row in cells)
    return _Plan(
        rule_e=r_e,
        rule_de=r_de,
        rule_u=r_u,
        order=order,
        starts=starts,
        used_u=used_u,
        pair_span=pair_span,
        peaks_u=None if pu is None else np.array(pu),
        peaks_e=pe if small_ok else None,
        peaks_de=pd if small_ok else None,
        peaks_e_array=np.array(pe) if small_ok else None,
        peaks_de_array=np.array(pd) if small_ok else None,
        peaks_u_list=pu if small_ok else None,
        grid_u_list=tuple(engine.u.universe) if small_ok else None,
        pair_table=pair_table,
    )


@dataclass(frozen=True)
class MamdaniEngine:
    """Immutable two-input, one-output Mamdani engine, vectorised over inputs.

    Parameters
    ----------
    e, de, u : FuzzyVariable
        Error, error rate and output variables.
    rules : sequence of Rule or (e, de, u) label triples
        The rule base (data); at least one rule.
    and_method : {"min", "product"}
        Fuzzy AND of the two antecedents. Implication is min, aggregation max.
    defuzz : {"centroid", "bisector", "mom"}
        Defuzzifier. ``"centroid"`` and ``"bisector"`` act on skfuzzy's
        piecewise-linear aggregated output; ``"mom"`` is the mean of the set
        where the aggregated output is largest (measured by length; the mean of
        the points if that set has no length), see ``docs/fuzzy.md``.
    no_fire_output : float
        Output where no rule fires (all firing strengths are 0).

    Notes
    -----
    Call ``engine(e, de)`` for outputs and ``engine.firing(e, de)`` for rule
    firing strengths. Inputs are clipped to the universes.
    """

    e: FuzzyVariable
    de: FuzzyVariable
    u: FuzzyVariable
    rules: tuple[Rule, ...]
    and_method: AndMethod = "min"
    defuzz: DefuzzMethod = "centroid"
    no_fire_output: float = 0.0
    _plan: _Plan = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        for name in ("e", "de", "u"):
            if not isinstance(getattr(self, name), FuzzyVariable):
                raise TypeError(f"{name} must be a FuzzyVariable")
        if isinstance(self.rules, RuleBase):
            rules = self.rules.rules
        else:
            rules = self.rules
        rules = tuple(Rule(*r) for r in rules)
        if not rules:
            raise ValueError("the rule base is empty")
        if self.and_method not in _AND_METHODS:
            raise ValueError(f"and_method must be one of {_AND_METHODS}, got {self.and_method!r}")
        if self.defuzz not in _DEFUZZ_METHODS:
            raise ValueError(f"defuzz must be one of {_DEFUZZ_METHODS}, got {self.defuzz!r}")
        no_fire = float(self.no_fire_output)
        if not math.isfinite(no_fire):
            raise ValueError(f"no_fire_output must be finite, got {self.no_fire_output!r}")
        object.__setattr__(self, "rules", rules)
        object.__setattr__(self, "no_fire_output", no_fire)
        object.__setattr__(self, "_plan", _plan_for(self))

    # ----- public API -----------------------------------------------------------------

    @property
    def fast_path(self) -> bool:
        """True if this engine uses the closed-form centroid (triangular partitions)."""
        return self._plan.peaks_u is not None

    def with_rules(self, rules: RuleBase | Iterable[Rule | Sequence[str]]) -> MamdaniEngine:
        """A new engine, identical but for the rule base."""
        if isinstance(rules, RuleBase):
            rules = rules.rules
        return replace(self, rules=tuple(Rule(*r) for r in rules))

    def firing(self, e: np.ndarray | float, de: np.ndarray | float) -> np.ndarray:
        """Rule firing strengths, shape ``broadcast(e, de).shape + (n_rules,)``.

        Column ``r`` is the degree to which ``rules[r]`` fires (the AND of its
        two antecedent memberships); 0 means the rule does not fire.
        """
        e_arr, de_arr = self._prepare(e, de)
        return self._firing_flat(e_arr.ravel(), de_arr.ravel()).reshape(
            e_arr.shape + (len(self.rules),)
        )

    def __call__(self, e: np.ndarray | float, de: np.ndarray | float) -> np.ndarray:
        """Crisp output for inputs that broadcast together.

        Parameters
        ----------
        e, de : array_like
            Error and error rate; clipped to their universes. NaN is an error.

        Returns
        -------
        numpy.ndarray
            Float array of the broadcast shape (0-d for scalar inputs);
            ``no_fire_output`` where no rule fires.
        """
        e_arr, de_arr = self._prepare(e, de)
        plan = self._plan
        if e_arr.size <= _SMALL_N and plan.pair_table is not None:
            out = self._small(e_arr.ravel().tolist(), de_arr.ravel().tolist())
            return np.array(out, dtype=float).reshape(e_arr.shape)
        return self.evaluate_batch(e_arr, de_arr)

    def evaluate_batch(self, e: np.ndarray, de: np.ndarray) -> np.ndarray:
        """``engine(e, de)`` for arrays, returning an array: the batch controllers' call
        (``controllers/batch.py``). Up to ``_SMALL_N`` inputs it takes the pure-Python path
        (the single-arm loop's, cheaper than numpy's fixed cost per call there), beyond it
        the numpy path, whose cost per call is nearly fixed up to hundreds of inputs. Equal
        to ``engine(e, de)`` to 1e-12."""
        e_arr, de_arr = self._prepare(e, de)
        flat_e, flat_de = e_arr.ravel(), de_arr.ravel()
        if flat_e.size <= _SMALL_N and self._plan.pair_table is not None:
            out_small = self._small(flat_e.tolist(), flat_de.tolist())
            return np.array(out_small, dtype=float).reshape(e_arr.shape)
        out = np.empty(flat_e.size)
        for s in range(0, flat_e.size, _CHUNK):
            sl = slice(s, s + _CHUNK)
            out[sl] = self._batch(flat_e[sl], flat_de[sl])
        return out.reshape(e_arr.shape)

    def evaluate_compiled(self, e: np.ndarray, de: np.ndarray) -> np.ndarray:
        """The batch laws' call: ``_small`` compiled where numba is installed (equal to it
        to the bit, controllers/fuzzy/kernels.py), else :meth:`evaluate_batch`."""
        e_arr, de_arr = self._prepare(e, de)
        if self._plan.pair_table is None or not kernels.available():
            return self.evaluate_batch(e_arr, de_arr)
        return kernels.mamdani(self, *(np.ravel(x) for x in (e_arr, de_arr))).reshape(e_arr.shape)

    def evaluate_xp(self, e: Any, de: Any, xp: Any) -> Any:
        """The closed form (triangular partitions, centroid) on the array namespace ``xp``
        (jax.numpy on the accelerator backend): the numpy path's ``_partition_rows`` and
        ``_centroid_rows``. Inputs must be free of NaN (a compiled loop cannot raise)."""
        plan = self._plan
        if plan.pair_table is None:
            raise TypeError(
                "this fuzzy engine has no closed form (it needs triangular partitions and "
                "the centroid), so it runs on numpy only"
            )
        shape = e.shape
        e, de = xp.reshape(e, (-1,)), xp.reshape(de, (-1,))
        a = _partition_rows(e, plan.peaks_e_array, xp)[plan.rule_e]
        b = _partition_rows(de, plan.peaks_de_array, xp)[plan.rule_de]
        firing = xp.minimum(a, b) if self.and_method == "min" else a * b
        groups = dict(zip(plan.used_u.tolist(), np.split(plan.order, plan.starts[1:]), strict=True))
        zero = xp.zeros_like(e)
        cut = [xp.max(firing[groups[t]], axis=0) if t in groups else zero for t in
               range(len(self.u.labels))]  # fmt: skip
        cuts = xp.stack(cut)
        out = self._centroid_rows(cuts, plan.pair_span, xp)
        return xp.reshape(xp.where(xp.max(cuts, axis=0) > 0.0, out, self.no_fire_output), shape)

    def evaluate_floats(self, es: Sequence[float], ds: Sequence[float]) -> list[float]:
        """``engine(e, de)`` for a few plain floats, returning floats: the control loop's call.

        Skips numpy altogether where the engine has its closed-form path (triangular
        partitions, centroid): building arrays for 2 inputs costs more than the inference.
        Equal to ``engine(e, de)`` input for input (tested).
        """
        if self._plan.pair_table is not None:
            return self._small(list(es), list(ds))
        return self(np.asarray(es, dtype=float), np.asarray(ds, dtype=float)).tolist()

    def to_skfuzzy(self) -> skfuzzy.control.ControlSystem:
        """The same system as a ``skfuzzy.control.ControlSystem``.

        Antecedents are named ``"e"`` and ``"de"``, the consequent ``"u"``; the
        terms are the same sampled membership functions, the rules the same
        rules (AND = ``np.fmin`` or ``np.multiply``), and the consequent's
        ``defuzzify_method`` is this engine's ``defuzz``. Note that skfuzzy's
        ``"mom"`` averages the grid points at the maximum, a discretised version
        of this engine's mean of maximum.
        """
        from skfuzzy import control as ctrl

        ant_e = ctrl.Antecedent(self.e.grid.copy(), "e")
        ant_de = ctrl.Antecedent(self.de.grid.copy(), "de")
        cons_u = ctrl.Consequent(self.u.grid.copy(), "u", defuzzify_method=self.defuzz)
        for var, spec in ((ant_e, self.e), (ant_de, self.de), (cons_u, self.u)):
            for label, row in zip(spec.labels, spec.table, strict=True):
                var[label] = row.copy()
        and_func = np.fmin if self.and_method == "min" else np.multiply
        rules = [
            ctrl.Rule(ant_e[r.e] & ant_de[r.de], cons_u[r.u], label=f"rule{n}", and_func=and_func)
            for n, r in enumerate(self.rules)
        ]
        return ctrl.ControlSystem(rules)

    # ----- internals ------------------------------------------------------------------

    @staticmethod
    def _prepare(e: Any, de: Any) -> tuple[np.ndarray, np.ndarray]:
        e_arr = np.asarray(e, dtype=float)
        de_arr = np.asarray(de, dtype=float)
        if e_arr.shape != de_arr.shape:
            e_arr, de_arr = np.broadcast_arrays(e_arr, de_arr)
        return e_arr, de_arr

    # The numpy paths keep one row per rule / term and one column per input, so that
    # every slice they take is contiguous (strided (N, 6) slices run several times slower).

    def _firing_rows(self, e: np.ndarray, de: np.ndarray) -> np.ndarray:
        """Firing strengths of 1-D inputs as (n_rules, N)."""
        plan = self._plan
        if plan.peaks_e is not None and plan.peaks_e == plan.peaks_de:
            # One partition for both inputs: half the numpy calls, the same numbers.
            both = np.concatenate([e, de])
            if np.isnan(both).any():
                raise ValueError("fuzzy engine inputs contain NaN")
            rows = _partition_rows(both, plan.peaks_e_array)
            a, b = rows[plan.rule_e, : e.size], rows[plan.rule_de, e.size :]
            return np.minimum(a, b, out=a) if self.and_method == "min" else np.multiply(a, b, out=a)
        if np.isnan(e).any() or np.isnan(de).any():
            raise ValueError("fuzzy engine inputs contain NaN")
        if plan.peaks_e is not None:  # triangular partitions: _small's closed form
            a = _partition_rows(e, plan.peaks_e_array)[plan.rule_e]
            b = _partition_rows(de, plan.peaks_de_array)[plan.rule_de]
        else:
            a = self.e._membership_rows(e)[plan.rule_e]
            b = self.de._membership_rows(de)[plan.rule_de]
        return np.minimum(a, b, out=a) if self.and_method == "min" else np.multiply(a, b, out=a)

    def _cut_rows(self, firing_rows: np.ndarray) -> np.ndarray:
        """Clip level of each output term, (n_terms, N): max firing of its rules."""
        plan = self._plan
        cuts = np.zeros((len(self.u.labels), firing_rows.shape[1]))
        cuts[plan.used_u] = np.maximum.reduceat(firing_rows[plan.order], plan.starts, axis=0)
        return cuts

    def _firing_flat(self, e: np.ndarray, de: np.ndarray) -> np.ndarray:
        """Firing strengths of 1-D inputs as (N, n_rules)."""
        return self._firing_rows(e, de).T

    def _cuts(self, firing: np.ndarray) -> np.ndarray:
        """Clip levels (N, n_terms) from firing strengths (N, n_rules)."""
        return self._cut_rows(np.ascontiguousarray(firing.T)).T

    def _batch(self, e: np.ndarray, de: np.ndarray) -> np.ndarray:
        rows = self._cut_rows(self._firing_rows(e, de))
        fired = rows.max(axis=0) > 0.0
        if self.defuzz == "mom":
            out = self._mom(rows.T)
        elif self._plan.peaks_u is not None:
            out = self._centroid_rows(rows, self._plan.pair_span)
        else:
            out = self._grid_defuzz(rows.T)
        return np.where(fired, out, self.no_fire_output)

    def _centroid_partition(self, cuts: np.ndarray) -> np.ndarray:
        """Closed-form centroid from clip levels (N, n_terms); see ``_centroid_rows``."""
        return self._centroid_rows(np.ascontiguousarray(cuts.T))

    def _centroid_rows(
        self, cuts: np.ndarray, pairs: slice = slice(None), xp: Any = np
    ) -> np.ndarray:
        """Closed-form skfuzzy centroid for a triangular output partition (see docs/fuzzy.md).

        ``cuts`` is (n_terms, N). Between neighbouring output peaks p < q, in
        t = (x - p) / (q - p), the aggregate is A(t) = max(min(a, 1 - t), min(b, t)) with
        a, b the clip levels of the falling and the rising term. Its area and first moment
        have closed forms. skfuzzy's grid holds every kink of A but one, the point s where
        the two clipped terms meet, and joins the grid neighbours tl <= s <= tr of s by a
        chord instead: that adds the triangle between chord and A, of area
        k (s - tl)(tr - s) / 2 with k the slope change of A at s, centroid (tl + s + tr) / 3.
        Only the peak pairs in ``pairs`` are summed: the others must have both cuts 0 (a
        pair with a = b = 0 adds exactly 0 to both sums).
        """
        peaks = xp.asarray(self._plan.peaks_u)
        grid = xp.asarray(self.u.grid)
        p, q = peaks[:-1, None][pairs], peaks[1:, None][pairs]
        h = q - p
        a, b = cuts[:-1][pairs], cuts[1:][pairs]
        aa, bb = a * a, b * b
        c = xp.minimum(xp.minimum(a, b), 0.5)  # the value of A at s
        cc = c - c * c
        area = a - 0.5 * aa + b - 0.5 * bb - cc
        mom = 0.5 * (a - aa + b - cc) + (aa * a - bb * b) / 6.0
        # Kink: the midpoint if both clips reach 0.5 (slopes -1 | +1, or 0 where a clip is
        # exactly 0.5), else where the lower clip level meets the other term's edge.
        mid = c == 0.5
        a_low = a <= b
        s = xp.where(mid, 0.5, xp.where(a_low, a, 1.0 - b))
        one = xp.ones_like(a)
        k = xp.where(
            mid,
            xp.where(a > 0.5, one, 0.0) + xp.where(b > 0.5, one, 0.0),
            xp.where(a_low, xp.where(b > a, one, 0.0), one),
        )
        xs = xp.minimum(p + s * h, q)
        idx = xp.searchsorted(grid, xs, side="left")
        gr = grid[idx]
        gl = xp.where(gr == xs, gr, grid[xp.maximum(idx - 1, 0)])
        tl, tr = (gl - p) / h, (gr - p) / h
        for tk in (1.0 - a, b):  # the two terms' crossing points are grid points too
            tl = xp.where(tk <= s, xp.maximum(tl, tk), tl)
            tr = xp.where(tk >= s, xp.minimum(tr, tk), tr)
        extra = 0.5 * k * (s - tl) * (tr - s)
        area = area + extra
        mom = mom + extra * (tl + s + tr) / 3.0
        total_area = xp.sum(h * area, axis=0)
        total_mom = xp.sum(h * (p * area + h * mom), axis=0)
        return total_mom / xp.maximum(total_area, _EPS)

    def _augmented(self, cuts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """skfuzzy's upsampled universe and aggregated output on it, rows sorted."""
        grid, table = self.u.grid, self.u.table
        n = cuts.shape[0]
        extra = []
        for k, row in enumerate(table):
            level = cuts[:, k]
            left, right = _crossings(grid, row, level, grid[0], grid[0])
            # Level 0 adds only the feet, which are sample points already.
            on = level > 0.0
            extra += [np.where(on, left, grid[0]), np.where(on, right, grid[0])]
        xs = np.sort(
            np.concatenate(
                [np.broadcast_to(grid, (n, grid.size)), np.stack(extra, axis=1)], axis=1
            ),
            axis=1,
        )
        ys = np.zeros_like(xs)
        for k, row in enumerate(table):
            np.maximum(ys, np.minimum(cuts[:, k : k + 1], np.interp(xs, grid, row)), out=ys)
        return xs, ys

    def _grid_defuzz(self, cuts: np.ndarray) -> np.ndarray:
        xs, ys = self._augmented(cuts)
        x1, x2, y1, y2 = xs[:, :-1], xs[:, 1:], ys[:, :-1], ys[:, 1:]
        seg_area = _trap_area(x1, x2, y1, y2)
        if self.defuzz == "centroid":
            total = seg_area.sum(axis=1)
            return _trap_moment(x1, x2, y1, y2).sum(axis=1) / np.maximum(total, _EPS)
        # Bisector: the x where the area to its left is half the total.
        cum = np.cumsum(seg_area, axis=1)
        half = 0.5 * cum[:, -1:]
        seg = np.argmax(cum >= half, axis=1)[:, None]
        before = np.where(seg > 0, np.take_along_axis(cum, np.maximum(seg - 1, 0), 1), 0.0)
        need = (half - before)[:, 0]
        x1, x2, y1, y2 = (np.take_along_axis(v, seg, 1)[:, 0] for v in (x1, x2, y1, y2))
        # Solve y1 t + slope t^2 / 2 = need in the stable form 2 need / (y1 + sqrt(...)):
        # skfuzzy's (root - y1) / slope loses every digit when the segment's ends differ
        # by rounding only (see docs/fuzzy.md). Rows without area are masked by the caller.
        with np.errstate(divide="ignore", invalid="ignore"):
            slope = (y2 - y1) / (x2 - x1)
            root = np.sqrt(np.maximum(y1 * y1 + 2.0 * slope * need, 0.0))
            t = 2.0 * need / (y1 + root)
        return np.where(cum[:, -1] > 0, x1 + np.nan_to_num(t), 0.0)

    def _mom(self, cuts: np.ndarray) -> np.ndarray:
        """Mean of maximum: centre of the union of the plateaus at the top level."""
        grid, table = self.u.grid, self.u.table
        tops = table.max(axis=1)
        levels = np.minimum(cuts, tops)
        best = levels.max(axis=1, keepdims=True)
        lo = np.empty_like(cuts)
        hi = np.empty_like(cuts)
        for k, row in enumerate(table):
            lo[:, k], hi[:, k] = _crossings(grid, row, levels[:, k], grid[0], grid[-1])
        at_max = (levels == best) & (best > 0)
        lo = np.where(at_max, lo, grid[0])
        hi = np.where(at_max, hi, grid[0])
        order = np.argsort(lo, axis=1)
        lo, hi = np.take_along_axis(lo, order, 1), np.take_along_axis(hi, order, 1)
        # Sweep the intervals by left end; each adds the part beyond the ones before it.
        reach = np.maximum.accumulate(hi, axis=1)
        start = np.maximum(
            lo, np.concatenate([np.full((lo.shape[0], 1), -np.inf), reach[:, :-1]], axis=1)
        )
        length = np.maximum(hi - start, 0.0)
        moment = np.where(length > 0, 0.5 * (hi + start) * length, 0.0)
        total = length.sum(axis=1)
        # A top level reached only at isolated points (e.g. a triangle's peak): their mean.
        at_sorted = np.take_along_axis(at_max, order, 1)
        mids = np.where(at_sorted, 0.5 * (lo + hi), 0.0)
        point_mean = mids.sum(axis=1) / np.maximum(at_sorted.sum(axis=1), 1)
        safe_total = np.where(total > 0, total, 1.0)
        return np.where(total > 0, moment.sum(axis=1) / safe_total, point_mean)

    def _small(self, es: list[float], ds: list[float]) -> list[float]:
        """Pure-Python fast path for a few inputs: the batch path's arithmetic, per input.

        With triangular partitions at most 2 terms of each input are active, so
        at most 4 rules fire, and only the output intervals next to a clipped
        term contribute to the centroid.
        """
        plan = self._plan
        pe, pd, pu = plan.peaks_e, plan.peaks_de, plan.peaks_u_list
        ug, table = plan.grid_u_list, plan.pair_table
        use_min = self.and_method == "min"
        last_e, last_d, n_int = len(pe) - 2, len(pd) - 2, len(pu) - 1
        elo, ehi, dlo, dhi = pe[0], pe[-1], pd[0], pd[-1]
        out = []
        for e, d in zip(es, ds, strict=True):
            if e != e or d != d:
                raise ValueError("fuzzy engine inputs contain NaN")
            e = elo if e < elo else (ehi if e > ehi else e)
            d = dlo if d < dlo else (dhi if d > dhi else d)
            i = bisect_right(pe, e) - 1
            if i > last_e:
                i = last_e
            j = bisect_right(pd, d) - 1
            if j > last_d:
                j = last_d
            te = (e - pe[i]) / (pe[i + 1] - pe[i])
            td = (d - pd[j]) / (pd[j + 1] - pd[j])
            cuts = [0.0] * (n_int + 1)
            kmin, kmax = n_int + 1, -1
            for ie, me in ((i, 1.0 - te), (i + 1, te)):
                if me <= 0.0:
                    continue
                row = table[ie]
                for jd, md in ((j, 1.0 - td), (j + 1, td)):
                    if md <= 0.0:
                        continue
                    f = (me if me < md else md) if use_min else me * md
                    for k in row[jd]:
                        if f > cuts[k]:
                            cuts[k] = f
                            if k < kmin:
                                kmin = k
                            if k > kmax:
                                kmax = k
            if kmax < 0:
                out.append(self.no_fire_output)
                continue
            area = mom = 0.0
            for m in range(kmin - 1 if kmin > 0 else 0, kmax + 1 if kmax < n_int else n_int):
                a = cuts[m]
                b = cuts[m + 1]
                p = pu[m]
                h = pu[m + 1] - p
                if b == 0.0:
                    if a == 0.0:
                        continue
                    ar = a - 0.5 * a * a
                    mo = 0.5 * (a - a * a) + a * a * a / 6.0
                elif a == 0.0:
                    ar = b - 0.5 * b * b
                    mo = 0.5 * b - b * b * b / 6.0
                else:
                    c = a if a < b else b
                    if c > 0.5:
                        c = 0.5
                    cc = c - c * c
                    ar = a - 0.5 * a * a + b - 0.5 * b * b - cc
                    mo = 0.5 * (a - a * a + b - cc) + (a * a * a - b * b * b) / 6.0
                    # skfuzzy's chord across the kink s (see _centroid_partition).
                    if c == 0.5:
                        s = 0.5
                        k = (a > 0.5) + (b > 0.5)
                    elif a <= b:
                        s = a
                        k = b > a
                    else:
                        s = 1.0 - b
                        k = 1
                    if k:
                        xs = p + s * h
                        if xs > pu[m + 1]:
                            xs = pu[m + 1]
                        g = bisect_left(ug, xs)
                        gr = ug[g]
                        gl = gr if gr == xs else ug[g - 1]
                        tl = (gl - p) / h
                        tr = (gr - p) / h
                        ta = 1.0 - a
                        if s >= ta > tl:
                            tl = ta
                        if s <= ta < tr:
                            tr = ta
                        if s >= b > tl:
                            tl = b
                        if s <= b < tr:
                            tr = b
                        extra = 0.5 * k * (s - tl) * (tr - s)
                        ar += extra
                        mo += extra * (tl + s + tr) / 3.0
                area += h * ar
                mom += h * (p * ar + h * mo)
            out.append(mom / (area if area > _EPS else _EPS))
        return out


def _trap_area(x1: np.ndarray, x2: np.ndarray, y1: np.ndarray, y2: np.ndarray) -> np.ndarray:
    """Area under the segment from (x1, y1) to (x2, y2)."""
    return 0.5 * (x2 - x1) * (y1 + y2)


def _trap_moment(x1: np.ndarray, x2: np.ndarray, y1: np.ndarray, y2: np.ndarray) -> np.ndarray:
    """First moment (integral of x y dx) under the segment from (x1, y1) to (x2, y2)."""
    return (x2 - x1) * (y1 * (2.0 * x1 + x2) + y2 * (x1 + 2.0 * x2)) / 6.0


def rule_label(rule: Rule) -> str:
    """A rule as short text: ``"PS,NM→NS"``."""
    return f"{rule.e},{rule.de}→{rule.u}"


def fired_rule_labels(engine: MamdaniEngine, e: np.ndarray, de: np.ndarray) -> np.ndarray:
    """The dominant fired rule at each (e, de) (normalised inputs), as labels.

    "none" where no rule fires. Shape of ``e`` and ``de`` broadcast together.
    """
    firing = engine.firing(e, de)
    # a MATLAB FIS's term (controllers/fuzzy/fis/matlab.py) names its rules as text
    labels = np.array([r if isinstance(r, str) else rule_label(r) for r in engine.rules] + ["none"])
    dominant = np.where(firing.max(axis=-1) > 0, firing.argmax(axis=-1), len(engine.rules))
    return labels[dominant]
