"""Lookup-table mode: a fuzzy surface tabulated once on a grid, read back by bilinear
interpolation (docs/fuzzy.md, "Lookup-table mode").

:class:`FuzzyTable` stands in for a :class:`~controllers.fuzzy.engine.MamdaniEngine`
wherever a controller calls one (``evaluate_floats``, ``evaluate_batch``, ``__call__``);
everything else (``firing``, ``rules``, the variables, ``to_skfuzzy``) is the exact
engine's. Scenarios select it with ``[controller.fuzzy] engine = "table"``.

Error bound (the argument in docs/fuzzy.md): bilinear interpolation is a convex
combination of the four corner values with weights (1-s)(1-t), s(1-t), (1-s)t, st; for a
surface with per-axis Lipschitz constants L_e, L_de on a cell of size h_e x h_de,

    |u(x) - I u(x)| <= L_e h_e 2 s(1-s) + L_de h_de 2 t(1-t) <= (L_e h_e + L_de h_de) / 2.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from twolink.controllers.fuzzy import kernels
from twolink.controllers.fuzzy.engine import MamdaniEngine

__all__ = ["FuzzyTable", "TableBound", "table_bound"]

DEFAULT_POINTS = 201


@dataclass(frozen=True, eq=False)
class FuzzyTable:
    """``exact`` tabulated on a ``points`` x ``points`` grid over its input box (universe
    edges included), bilinear in between; inputs are clipped to the box, NaN is an error.

    Parameters
    ----------
    exact : MamdaniEngine
        The engine whose surface is tabulated.
    points : int
        Grid points per axis (>= 2).
    """

    exact: MamdaniEngine
    points: int = DEFAULT_POINTS
    values: np.ndarray = field(init=False, repr=False)
    _flat: list = field(init=False, repr=False)

    def __post_init__(self) -> None:
        n = self.points
        if isinstance(n, bool) or not isinstance(n, int) or n < 2:
            raise ValueError(f"table points must be an integer >= 2, got {n!r}")
        eu, du = self.exact.e.universe, self.exact.de.universe
        self._set("e_lo", float(eu[0]))
        self._set("e_hi", float(eu[-1]))
        self._set("d_lo", float(du[0]))
        self._set("d_hi", float(du[-1]))
        self._set("e_scale", (n - 1) / (self.e_hi - self.e_lo))
        self._set("d_scale", (n - 1) / (self.d_hi - self.d_lo))
        e, de = np.meshgrid(self.e_nodes, self.de_nodes, indexing="ij")
        values = self.exact.evaluate_batch(e, de)
        values.setflags(write=False)
        self._set("values", values)
        self._set("_flat", values.ravel().tolist())

    def _set(self, name: str, value: Any) -> None:
        object.__setattr__(self, name, value)

    def __getattr__(self, name: str) -> Any:  # the exact engine's rules, variables, ...
        if name.startswith("_") or name == "exact":
            raise AttributeError(name)
        return getattr(self.exact, name)

    @property
    def e_nodes(self) -> np.ndarray:
        return np.linspace(self.e_lo, self.e_hi, self.points)

    @property
    def de_nodes(self) -> np.ndarray:
        return np.linspace(self.d_lo, self.d_hi, self.points)

    @property
    def steps(self) -> tuple[float, float]:
        """Grid spacing (h_e, h_de)."""
        return 1.0 / self.e_scale, 1.0 / self.d_scale

    def with_rules(self, rules: Any) -> FuzzyTable:
        return FuzzyTable(self.exact.with_rules(rules), self.points)

    def __call__(self, e: np.ndarray | float, de: np.ndarray | float) -> np.ndarray:
        return self.evaluate_batch(e, de)

    def evaluate_batch(self, e: np.ndarray | float, de: np.ndarray | float) -> np.ndarray:
        """Bilinear lookup for inputs that broadcast together (vectorised)."""
        e = np.asarray(e, dtype=float)
        de = np.asarray(de, dtype=float)
        if e.shape != de.shape:
            e, de = np.broadcast_arrays(e, de)
        if np.isnan(e).any() or np.isnan(de).any():
            raise ValueError("fuzzy engine inputs contain NaN")
        return self.evaluate_xp(e, de, np)

    def evaluate_compiled(self, e: np.ndarray, de: np.ndarray) -> np.ndarray:
        """:meth:`evaluate_floats`' arithmetic compiled (numba, where installed; else
        :meth:`evaluate_batch`): the batch laws' call, equal to both to the bit."""
        return kernels.compiled_or(kernels.table, self, self.evaluate_batch, e, de)

    def evaluate_xp(self, e: Any, de: Any, xp: Any) -> Any:
        """The bilinear lookup on the array namespace ``xp`` (numpy, or jax.numpy on the
        accelerator backend): a few array operations, :meth:`evaluate_floats`' arithmetic
        in the same order. Inputs must be free of NaN (not checked here)."""
        n = self.points
        fe = (xp.clip(e, self.e_lo, self.e_hi) - self.e_lo) * self.e_scale
        fd = (xp.clip(de, self.d_lo, self.d_hi) - self.d_lo) * self.d_scale
        i = xp.minimum(fe.astype(int), n - 2)
        j = xp.minimum(fd.astype(int), n - 2)
        s = fe - i
        t = fd - j
        k = i * n + j
        v = xp.asarray(self.values).reshape(-1)
        v00, v01 = v[k], v[k + 1]
        v10, v11 = v[k + n], v[k + n + 1]
        lo = v00 + t * (v01 - v00)
        hi = v10 + t * (v11 - v10)
        return lo + s * (hi - lo)

    def evaluate_floats(self, es: Sequence[float], ds: Sequence[float]) -> list[float]:
        """The lookup for a few plain floats (the control loop's call), in pure Python."""
        n, flat = self.points, self._flat
        out = []
        for e, d in zip(es, ds, strict=True):
            if e != e or d != d:
                raise ValueError("fuzzy engine inputs contain NaN")
            fe = (min(max(e, self.e_lo), self.e_hi) - self.e_lo) * self.e_scale
            fd = (min(max(d, self.d_lo), self.d_hi) - self.d_lo) * self.d_scale
            i = min(int(fe), n - 2)
            j = min(int(fd), n - 2)
            out.append(bilinear(flat, n, i, j, fe - i, fd - j))
        return out


def bilinear(flat: list[float], n_de: int, i: int, j: int, s: float, t: float) -> float:
    """A table's value at fractions ``s``, ``t`` across its cell ``(i, j)`` (``flat`` its
    values row by row, ``n_de`` per row): the plain-float form of the loop's lookups."""
    k = i * n_de + j
    v00, v01, v10, v11 = flat[k], flat[k + 1], flat[k + n_de], flat[k + n_de + 1]
    lo = v00 + t * (v01 - v00)
    hi = v10 + t * (v11 - v10)
    return lo + s * (hi - lo)


# Margin for floating-point rounding: the proof is in exact arithmetic, the engine and the
# table round (relative 1e-16 on values of order 1).
ROUNDING_MARGIN = 1e-12
# Most fixed-point iterations of the bootstrap (_bound).
_ITERATIONS = 40


@dataclass(frozen=True, eq=False)
class TableBound:
    """The table's proven error bound, per cell and overall (docs/fuzzy.md, "Lookup-table
    mode"): |u(x) - I u(x)| <= ``cell_bound[i, j]`` for every x in cell (i, j), the cell
    [e_i, e_i+1] x [de_j, de_j+1] of ``table.values[i, j]``.

    ``jump`` marks the cells where the lower bounds of the firing strengths vanish: a
    no-fire point (where the surface jumps to the engine's ``no_fire_output``) may lie in
    the closed cell. They get the bound from the jump (the spread of the values the
    surface can take there); every other cell gets min((L_e h_e + L_de h_de) / 2, spread)
    with proven per-cell Lipschitz constants ``cell_lipschitz`` (inf on jump cells).
    ``bound`` is the largest cell bound off the jump cells, ``jump_bound`` the largest on
    them (0.0 without), ``overall`` the larger of the two.
    """

    bound: float
    jump_bound: float
    lipschitz: tuple[float, float]
    steps: tuple[float, float]
    jump_cells: int
    cells: int
    cell_bound: np.ndarray = field(repr=False)
    cell_lipschitz: np.ndarray = field(repr=False)
    jump: np.ndarray = field(repr=False)

    @property
    def overall(self) -> float:
        """The bound over the whole input box, jump cells included."""
        return max(self.bound, self.jump_bound)


def _input_bounds(
    nodes: np.ndarray, peaks: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per term and grid interval [x_c, x_c+1] of a triangular partition: the least and
    the largest membership and the largest |slope|, each shape (n_terms, n_nodes - 1).

    The terms are unimodal, so the least value is at an end of the interval and the
    largest at an end or at the peak, if the peak lies inside."""
    eye = np.eye(peaks.size)
    mu = np.array([np.interp(nodes, peaks, row) for row in eye])
    lo = np.minimum(mu[:, :-1], mu[:, 1:])
    hi = np.maximum(mu[:, :-1], mu[:, 1:])
    x0, x1 = nodes[:-1], nodes[1:]
    hi = np.where((peaks[:, None] > x0) & (peaks[:, None] < x1), 1.0, hi)
    slope = np.zeros_like(lo)
    for i in range(peaks.size):  # term i rises on [p_i-1, p_i] and falls on [p_i, p_i+1]
        for a, b in ((i - 1, i), (i, i + 1)):
            if 0 <= a and b < peaks.size:
                meets = (x0 < peaks[b]) & (x1 > peaks[a])
                slope[i] = np.where(
                    meets, np.maximum(slope[i], 1 / (peaks[b] - peaks[a])), slope[i]
                )
    return lo, hi, slope


def _split(nodes: np.ndarray, peaks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The table's nodes with the peaks inside them added (on each piece every membership
    is linear), and the index of the first piece of each table interval."""
    inner = peaks[(peaks > nodes[0]) & (peaks < nodes[-1])]
    fine = np.union1d(nodes, inner)
    return fine, np.searchsorted(fine, nodes[:-1])


def _above(lo: np.ndarray, hi: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Integral of max(y - u, 0) over y in [lo, hi] (0 where hi <= lo)."""
    hi = np.maximum(hi, lo)
    return np.where(u <= lo, (hi - lo) * (0.5 * (lo + hi) - u), 0.5 * np.maximum(hi - u, 0.0) ** 2)


@dataclass(frozen=True)
class _Cells:
    """Per output term k and table cell: what the bound needs, arrays (n_terms, n-1, n-1)
    (``area``: (n-1, n-1); ``chord_*``: per pair of neighbouring terms)."""

    active: np.ndarray  # alpha_k can be > 0 in the cell
    slope_e: np.ndarray  # Lipschitz constants of alpha_k along e and de
    slope_d: np.ndarray
    p_lo: np.ndarray  # P_k = {mu_k >= alpha_lo_k}: outside it d(aggregate)/d alpha_k = 0
    p_hi: np.ndarray
    q_lo: np.ndarray  # Q_k: there d(aggregate)/d alpha_k = 1 for sure
    q_hi: np.ndarray
    area: np.ndarray  # least area under the aggregate
    chord: np.ndarray  # a pair's chord cell can be here (both terms active)
    chord_lo: np.ndarray  # and lies in [chord_lo, chord_hi] (width <= delta)
    chord_hi: np.ndarray
    delta: float


def _cells(
    exact: MamdaniEngine, e_nodes: np.ndarray, d_nodes: np.ndarray
) -> tuple[_Cells, np.ndarray, np.ndarray, np.ndarray, tuple]:
    """Bounds on the clip levels and the output geometry per piece of a table cell (the
    cells split at the input peaks); also per piece the jump mask and the range
    [u_lo, u_hi] of the active terms' supports (where every centroid lies), and the
    index of each cell's first piece along e and de."""
    from twolink.controllers.fuzzy.engine import _partition_peaks

    pe, pd, pu = (_partition_peaks(v) for v in (exact.e, exact.de, exact.u))
    if exact.defuzz != "centroid" or pe is None or pd is None or pu is None:
        raise ValueError("table_bound needs triangular partitions on e, de and u and the centroid")
    pu = np.array(pu)
    fine_e, starts_e = _split(e_nodes, np.array(pe))
    fine_d, starts_d = _split(d_nodes, np.array(pd))
    inputs = (_input_bounds(fine_e, np.array(pe)), _input_bounds(fine_d, np.array(pd)))
    pieces = (fine_e.size - 1, fine_d.size - 1)
    clips = _clip_levels(exact, inputs, pu.size, pieces)
    alo, ahi = clips.alo, clips.ahi
    jump = alo.max(axis=0) <= 0.0
    over_left, over_right, under_left, under_right = _dominance(clips, inputs, pu.size, pieces)
    active = ahi > 0.0
    # Output term k: peak c, support [c - wl, c + wr] within the universe.
    wl = np.concatenate([[0.0], np.diff(pu)])[:, None, None]
    wr = np.concatenate([np.diff(pu), [0.0]])[:, None, None]
    c = pu[:, None, None]
    u_lo = np.where(active, c - wl, np.inf).min(axis=0)
    u_hi = np.where(active, c + wr, -np.inf).max(axis=0)
    # Least area under the true max-min aggregate (it grows with every alpha): per pair of
    # neighbouring peaks, h (a - a^2/2 + b - b^2/2 - m + m^2), m = min(a, b, 1/2).
    h = np.diff(pu)[:, None, None]
    a, b = alo[:-1], alo[1:]
    m = np.minimum(np.minimum(a, b), 0.5)
    area = (h * (a - 0.5 * a * a + b - 0.5 * b * b - m + m * m)).sum(axis=0)
    # skfuzzy's chord: within one output grid step of the meeting point s of a pair's two
    # clipped terms, s - p in [h min(a_lo, 1/2), h max(1 - b_lo, 1/2)].
    delta = float(np.diff(exact.u.grid).max())
    chord = active[:-1] & active[1:]
    p, q = c[:-1], c[1:]
    chord_lo = np.maximum(p + h * np.minimum(a, 0.5) - delta, p)
    chord_hi = np.minimum(p + h * np.maximum(1.0 - b, 0.5) + delta, q)
    q_lo, q_hi = _clipped_regions(
        clips, (c, wl, wr), (over_left, over_right), (chord, chord_lo, chord_hi), pieces
    )
    # P_k = {mu_k >= alpha_lo_k}, less the part of a pair where a neighbour j with
    # alpha_j >= alpha_k is at least as high as term k (mu_j >= min(mu_k, alpha_hi_k)).
    p_lo = c - (1.0 - alo) * wl
    p_hi = c + (1.0 - alo) * wr
    cells = _Cells(
        active=active,
        slope_e=clips.le,
        slope_d=clips.ld,
        p_lo=np.where(under_left, np.maximum(p_lo, c - np.minimum(0.5, ahi) * wl), p_lo),
        p_hi=np.where(under_right, np.minimum(p_hi, c + np.minimum(0.5, ahi) * wr), p_hi),
        q_lo=q_lo,
        q_hi=np.maximum(q_hi, q_lo),
        area=area,
        chord=chord,
        chord_lo=chord_lo,
        chord_hi=chord_hi,
        delta=delta,
    )
    return cells, jump, u_lo, u_hi, (starts_e, starts_d)


@dataclass(frozen=True)
class _ClipLevels:
    """Per output term and piece: the least and largest clip level and its slopes along e
    and de; per rule, where it can fire, and the terms of its antecedents and consequent."""

    alo: np.ndarray
    ahi: np.ndarray
    le: np.ndarray
    ld: np.ndarray
    live: dict[int, np.ndarray]
    r_e: list[int]
    r_d: list[int]
    r_u: np.ndarray


def _clip_levels(exact: MamdaniEngine, inputs, n_terms: int, pieces) -> _ClipLevels:
    """Each rule's firing strength on each piece (its least and largest value and its
    Lipschitz constant along each axis), and each term's clip level, the max of its rules'."""
    (lo_e, hi_e, sl_e), (lo_d, hi_d, sl_d) = inputs
    r_e = [exact.e.index(r.e) for r in exact.rules]
    r_d = [exact.de.index(r.de) for r in exact.rules]
    r_u = np.array([exact.u.index(r.u) for r in exact.rules])
    use_min = exact.and_method == "min"

    def firing(r: int) -> tuple[np.ndarray, ...]:
        """Least and largest firing of rule r per piece, and its slopes along e, de."""
        a_e, a_d = lo_e[r_e[r]][:, None], lo_d[r_d[r]][None, :]
        b_e, b_d = hi_e[r_e[r]][:, None], hi_d[r_d[r]][None, :]
        s_e, s_d = sl_e[r_e[r]][:, None], sl_d[r_d[r]][None, :]
        if use_min:  # d min(f, g)/de is f' where f < g, else 0: none where f >= g throughout
            f_lo, f_hi = np.minimum(a_e, a_d), np.minimum(b_e, b_d)
            f_se = np.where(a_e >= b_d, 0.0, s_e + 0.0 * b_d)
            f_sd = np.where(a_d >= b_e, 0.0, s_d + 0.0 * b_e)
        else:  # d (f g)/de = f' g
            f_lo, f_hi = a_e * a_d, b_e * b_d
            f_se, f_sd = s_e * b_d, s_d * b_e
        live = f_hi > 0.0
        return f_lo, f_hi, np.where(live, f_se, 0.0), np.where(live, f_sd, 0.0)

    shape = (n_terms, *pieces)
    alo, ahi, le, ld = (np.zeros(shape) for _ in range(4))
    live = {}
    for r in range(len(exact.rules)):  # the clip level of a term is the max of its rules'
        k = r_u[r]
        f_lo, f_hi, f_se, f_sd = firing(r)
        live[r] = f_hi > 0.0
        np.maximum(alo[k], f_lo, out=alo[k])
        np.maximum(ahi[k], f_hi, out=ahi[k])
        np.maximum(le[k], f_se, out=le[k])
        np.maximum(ld[k], f_sd, out=ld[k])
    return _ClipLevels(alo, ahi, le, ld, live, r_e, r_d, r_u)


def _dominance(clips: _ClipLevels, inputs, n_terms: int, pieces) -> tuple[np.ndarray, ...]:
    """Where each output term's clip level is at least its left / right neighbour's, and
    where each neighbour's is at least its own (over_left, over_right, under_left,
    under_right), per term and piece."""
    (lo_e, hi_e, _), (lo_d, hi_d, _) = inputs
    alo, ahi, r_e, r_d, r_u = clips.alo, clips.ahi, clips.r_e, clips.r_d, clips.r_u
    # ge[k, j]: alpha_k >= alpha_j on the whole piece, for neighbouring terms. From the
    # bounds, or rule by rule: every live rule of j has a rule of k firing at least as
    # strongly (both antecedents at least as large: the same term, or a least value
    # above the other's largest), min and product being monotone.
    ge_e = (np.arange(len(lo_e))[:, None, None] == np.arange(len(lo_e))[None, :, None]) | (
        lo_e[:, None, :] >= hi_e[None, :, :]
    )
    ge_d = (np.arange(len(lo_d))[:, None, None] == np.arange(len(lo_d))[None, :, None]) | (
        lo_d[:, None, :] >= hi_d[None, :, :]
    )

    def ge(k: int, j: int) -> np.ndarray:
        out = alo[k] >= ahi[j]
        rules_k = np.flatnonzero(r_u == k)
        by_rules = np.ones(pieces, dtype=bool)
        for rj in np.flatnonzero(r_u == j):
            covered = ~clips.live[rj]
            for rk in rules_k:
                covered = covered | (
                    ge_e[r_e[rk], r_e[rj]][:, None] & ge_d[r_d[rk], r_d[rj]][None, :]
                )
            by_rules &= covered
        return out | by_rules

    none = np.zeros(pieces, dtype=bool)
    return (
        np.stack([none] + [ge(k, k - 1) for k in range(1, n_terms)]),
        np.stack([ge(k, k + 1) for k in range(n_terms - 1)] + [none]),
        np.stack([none] + [ge(k - 1, k) for k in range(1, n_terms)]),
        np.stack([ge(k + 1, k) for k in range(n_terms - 1)] + [none]),
    )


def _clipped_regions(clips: _ClipLevels, terms, over, chords, pieces):
    """Q_k per term and piece, as [q_lo, q_hi]: mu_k > alpha_hi_k (term k clipped), neither
    neighbour can reach alpha_lo_k there, and no chord cell."""
    (c, wl, wr), (over_left, over_right) = terms, over
    chord, chord_lo, chord_hi = chords
    alo, ahi = clips.alo, clips.ahi
    q_lo = c - (1.0 - ahi) * wl
    q_hi = c + (1.0 - ahi) * wr
    zero = np.zeros((1, *pieces))
    left_free = np.concatenate([zero, ahi[:-1] <= 0.0]).astype(bool) | over_left
    right_free = np.concatenate([ahi[1:] <= 0.0, zero]).astype(bool) | over_right
    q_lo = np.where(left_free, q_lo, np.maximum(q_lo, c - alo * wl))
    q_hi = np.where(right_free, q_hi, np.minimum(q_hi, c + alo * wr))
    no = np.inf
    left_chord = np.concatenate([zero - no, np.where(chord, chord_hi, -no)])
    right_chord = np.concatenate([np.where(chord, chord_lo, no), zero + no])
    q_lo = np.maximum(q_lo, left_chord)
    q_hi = np.minimum(q_hi, right_chord)
    return q_lo, np.where(alo > 0.0, q_hi, q_lo)  # alpha_k may be 0: nothing is sure


def _lipschitz(
    g: _Cells, u_lo: np.ndarray, u_hi: np.ndarray, area: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Per-cell Lipschitz constants (L_e, L_de) of the surface, given that it stays in
    [u_lo, u_hi] on the cell: sum_k |du/dalpha_k| L(alpha_k), with
    du/dalpha_k = int (y - u) phi_k dy / area, phi_k = d(aggregate)/d alpha_k."""
    # phi_k = 1 on Q_k, in [0, 1] on the rest of P_k, in [-1, 2] on the chord cells.
    q_len = g.q_hi - g.q_lo
    q_mid = 0.5 * (g.q_hi + g.q_lo)
    above = _above(g.p_lo, g.p_hi, u_lo) - _above(g.q_lo, g.q_hi, u_lo)
    below = _above(-g.p_hi, -g.p_lo, -u_hi) - _above(-g.q_hi, -g.q_lo, -u_hi)
    upper = q_len * (q_mid - u_lo) + np.maximum(above, 0.0)
    lower = q_len * (q_mid - u_hi) - np.maximum(below, 0.0)
    num = np.maximum(np.abs(upper), np.abs(lower))
    dist = np.maximum(np.maximum(g.chord_hi - u_lo, u_hi - g.chord_lo), 0.0)
    chord = np.where(g.chord, 2.0 * g.delta * dist, 0.0)
    num[:-1] += chord
    num[1:] += chord
    sens = np.where(g.active, num, 0.0) / area
    return (sens * g.slope_e).sum(axis=0), (sens * g.slope_d).sum(axis=0)


def _bound(
    exact: MamdaniEngine,
    e_nodes: np.ndarray,
    d_nodes: np.ndarray,
    values: np.ndarray,
    known: tuple[np.ndarray, np.ndarray] | None = None,
) -> dict[str, np.ndarray]:
    """Per-cell bound of the bilinear interpolant of ``values`` (the engine on the grid
    ``e_nodes`` x ``d_nodes``); ``known``: proven per-cell ranges of the surface, if any.
    Returns per cell: ``bound``, ``lip_e``, ``lip_d``, ``jump``, and ``lo``/``hi``, a proven
    range of the surface on the cell."""
    g, piece_jump, piece_lo, piece_hi, (st_e, st_d) = _cells(exact, e_nodes, d_nodes)
    own_e = np.searchsorted(st_e, np.arange(g.area.shape[0]), side="right") - 1
    own_d = np.searchsorted(st_d, np.arange(g.area.shape[1]), side="right") - 1

    def per_cell(x: np.ndarray, reduce: np.ufunc) -> np.ndarray:
        return reduce.reduceat(reduce.reduceat(x, st_e, axis=0), st_d, axis=1)

    def per_piece(x: np.ndarray) -> np.ndarray:
        return x[own_e][:, own_d]

    jump = per_cell(piece_jump, np.logical_or)
    fires = per_cell(g.active.any(axis=0), np.logical_or)
    sup_lo, sup_hi = per_cell(piece_lo, np.minimum), per_cell(piece_hi, np.maximum)
    nf = exact.no_fire_output
    # A priori: u is a centroid within the active terms' supports, or (jump cells) the
    # no-fire output; where nothing can fire, u is the no-fire output.
    r_lo = np.where(fires, sup_lo, nf)
    r_hi = np.where(fires, sup_hi, nf)
    r_lo = np.where(jump & fires, np.minimum(r_lo, nf), r_lo)
    r_hi = np.where(jump & fires, np.maximum(r_hi, nf), r_hi)
    if known is not None:
        r_lo, r_hi = np.maximum(r_lo, known[0]), np.minimum(r_hi, known[1])
    v = values
    corners = np.stack([v[:-1, :-1], v[1:, :-1], v[:-1, 1:], v[1:, 1:]])
    c_min, c_max = corners.min(axis=0), corners.max(axis=0)
    he, hd = np.diff(e_nodes)[:, None], np.diff(d_nodes)[None, :]
    ok = ~jump
    area = np.where(per_piece(ok), g.area, 1.0)
    s_lo, s_hi = np.where(ok, r_lo, 0.0), np.where(ok, r_hi, 0.0)

    def half_step(b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """G(b): (L_e h_e + L_de h_de)/2 with the Lipschitz constants that hold while u
        stays within b of the corner values; a cell's L is the largest of its pieces'."""
        u_lo = per_piece(np.maximum(s_lo, c_min - b))
        u_hi = per_piece(np.minimum(s_hi, c_max + b))
        le, ld = (per_cell(x, np.maximum) for x in _lipschitz(g, u_lo, u_hi, area))
        return 0.5 * (le * he + ld * hd), le, ld

    b_prior, le_prior, ld_prior = half_step(np.full(c_min.shape, np.inf))
    # Bootstrap (docs/fuzzy.md): a b with G(b) < b bounds |u(x) - u(nearest corner)| on the
    # cell. Iterating G from 0 climbs to its least fixed point; the trial just above it
    # is checked.
    b = np.zeros(c_min.shape)
    for _ in range(_ITERATIONS):
        b_next = half_step(b)[0]
        settled = np.abs(b_next - b) <= 1e-6 * b_next
        b = b_next
        if settled[ok & (b < b_prior)].all():  # the rest fall back to the prior
            break
    trial = b * (1.0 + 1e-6) + 1e-15
    b_boot, le_boot, ld_boot = half_step(trial)
    proven = ok & (b_boot < trial)
    best = np.where(proven, b_boot, b_prior)
    reach = np.where(proven, trial, b_prior)
    lo = np.where(ok, np.maximum(s_lo, c_min - reach), r_lo)
    hi = np.where(ok, np.minimum(s_hi, c_max + reach), r_hi)
    # The interpolant lies in [c_min, c_max], u in [lo, hi].
    spread = np.maximum(hi - c_min, c_max - lo)
    return {
        "bound": np.where(ok, np.minimum(best, spread), spread) + ROUNDING_MARGIN,
        "lip_e": np.where(ok, np.where(proven, le_boot, le_prior), np.inf),
        "lip_d": np.where(ok, np.where(proven, ld_boot, ld_prior), np.inf),
        "jump": jump,
        "lo": lo,
        "hi": hi,
    }


def table_bound(table: FuzzyTable, refine: int = 2) -> TableBound:
    """Proven error bound of ``table`` against its exact engine (see :class:`TableBound`;
    the derivation is in docs/fuzzy.md, "Lookup-table mode").

    Needs the engine's closed-form path: triangular partitions on e, de and u and the
    centroid (the project's engines); either AND. ``refine`` > 1 first bounds the
    surface's range on each cell from the exact engine on a grid ``refine`` times finer
    (the same bound, one level down): it tightens the cells where the surface is steep
    or jumps, at the cost of ((points - 1) refine + 1)^2 engine evaluations."""
    exact = table.exact
    if isinstance(refine, bool) or not isinstance(refine, int) or refine < 1:
        raise ValueError(f"refine must be an integer >= 1, got {refine!r}")
    if not isinstance(exact, MamdaniEngine):  # a MATLAB FIS's term: its own argument
        from twolink.controllers.fuzzy.fis.bound import fis_cell_bound

        cell, jump = fis_cell_bound(table)
        cell = cell + ROUNDING_MARGIN
        off, on = cell[~jump], cell[jump]
        return TableBound(
            bound=float(off.max()) if off.size else 0.0,
            jump_bound=float(on.max()) if on.size else 0.0,
            lipschitz=(math.nan, math.nan),  # a range per cell, not a slope
            steps=table.steps,
            jump_cells=int(jump.sum()),
            cells=cell.size,
            cell_bound=cell,
            cell_lipschitz=np.full((2, *cell.shape), math.nan),
            jump=jump,
        )
    e_nodes, d_nodes = table.e_nodes, table.de_nodes
    known = None
    if refine > 1:
        frac = np.arange(refine) / refine

        def finer(nodes: np.ndarray) -> np.ndarray:  # the table's nodes bit for bit among them
            inner = nodes[:-1, None] + frac[None, :] * np.diff(nodes)[:, None]
            return np.append(inner.ravel(), nodes[-1])

        fe, fd = finer(e_nodes), finer(d_nodes)
        fine = _bound(exact, fe, fd, exact.evaluate_batch(*np.meshgrid(fe, fd, indexing="ij")))
        m = table.points - 1
        known = tuple(
            red(fine[key].reshape(m, refine, m, refine), axis=(1, 3))
            for key, red in (("lo", np.min), ("hi", np.max))
        )
    out = _bound(exact, e_nodes, d_nodes, table.values, known)
    cell, jump = out["bound"], out["jump"]
    ok = ~jump
    lip = np.stack([out["lip_e"], out["lip_d"]])
    off = cell[ok]
    return TableBound(
        bound=float(off.max()) if off.size else 0.0,
        jump_bound=float(cell[jump].max()) if jump.any() else 0.0,
        lipschitz=((float(lip[0][ok].max()), float(lip[1][ok].max())) if off.size else (0.0, 0.0)),
        steps=table.steps,
        jump_cells=int(jump.sum()),
        cells=(table.points - 1) ** 2,
        cell_bound=cell,
        cell_lipschitz=lip,
        jump=jump,
    )
