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

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from controllers.fuzzy.engine import MamdaniEngine

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
        n = self.points
        fe = (np.clip(e, self.e_lo, self.e_hi) - self.e_lo) * self.e_scale
        fd = (np.clip(de, self.d_lo, self.d_hi) - self.d_lo) * self.d_scale
        if np.isnan(fe).any() or np.isnan(fd).any():
            raise ValueError("fuzzy engine inputs contain NaN")
        i = np.minimum(fe.astype(np.intp), n - 2)
        j = np.minimum(fd.astype(np.intp), n - 2)
        s = fe - i
        t = fd - j
        k = i * n + j
        v = self.values.ravel()
        v00, v01 = v.take(k), v.take(k + 1)
        v10, v11 = v.take(k + n), v.take(k + n + 1)
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
            s, t = fe - i, fd - j
            k = i * n + j
            v00, v01, v10, v11 = flat[k], flat[k + 1], flat[k + n], flat[k + n + 1]
            lo = v00 + t * (v01 - v00)
            hi = v10 + t * (v11 - v10)
            out.append(lo + s * (hi - lo))
        return out


@dataclass(frozen=True)
class TableBound:
    """The table's error bound (L_e h_e + L_de h_de) / 2 over the cells where the surface
    is continuous, and the cells it does not cover (a no-fire boundary crosses them).

    ``lipschitz`` holds (L_e, L_de): the largest difference quotients of the exact
    surface along each axis on a grid ``refine`` times finer than the table (an estimate
    of the Lipschitz constants, see docs/fuzzy.md for what is proven and what is not).
    """

    bound: float
    lipschitz: tuple[float, float]
    steps: tuple[float, float]
    refine: int
    jump_cells: int
    cells: int


def table_bound(table: FuzzyTable, refine: int = 4) -> TableBound:
    """Error bound of ``table`` against its exact engine (see :class:`TableBound`)."""
    exact, n = table.exact, table.points
    m = (n - 1) * refine + 1
    e, de = np.meshgrid(
        np.linspace(table.e_lo, table.e_hi, m),
        np.linspace(table.d_lo, table.d_hi, m),
        indexing="ij",
    )
    u = exact.evaluate_batch(e, de)
    fired = exact.firing(e, de).sum(axis=-1) > 0
    h_e, h_d = (table.e_hi - table.e_lo) / (m - 1), (table.d_hi - table.d_lo) / (m - 1)
    # A fine segment is continuous where both ends fire a rule or neither does.
    de_ok = fired[1:, :] == fired[:-1, :]
    dd_ok = fired[:, 1:] == fired[:, :-1]
    qe = np.where(de_ok, np.abs(np.diff(u, axis=0)) / h_e, 0.0)
    qd = np.where(dd_ok, np.abs(np.diff(u, axis=1)) / h_d, 0.0)
    # Cells of the table that a no-fire boundary crosses.
    f = fired
    cells_any = np.zeros((n - 1, n - 1), dtype=bool)
    cells_all = np.ones((n - 1, n - 1), dtype=bool)
    for a in range(refine + 1):
        for b in range(refine + 1):
            sub = f[a : a + (n - 1) * refine : refine, b : b + (n - 1) * refine : refine]
            cells_any |= sub
            cells_all &= sub
    jump = cells_any & ~cells_all
    le, ld = float(qe.max()), float(qd.max())
    he, hd = table.steps
    return TableBound(
        0.5 * (le * he + ld * hd), (le, ld), (he, hd), refine, int(jump.sum()), (n - 1) ** 2
    )
