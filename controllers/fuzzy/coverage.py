"""Rule coverage: where in the (e, de) input box a rule base fires no rule.

scikit-fuzzy raises there, MATLAB warns and pyfuzzylite returns NaN, each at evaluation
time; :func:`coverage` tells a designer beforehand (docs/fuzzy.md, "Rule coverage").

For triangular partitions (every peak its neighbours' foot) and a threshold of 0 the
uncovered set is exact and simple: between neighbouring peaks of e and of de (a *label
cell*) each input has exactly two active terms, so the rules that can fire inside the open
cell are the ones on its four corners (i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1), and
each of those fires everywhere inside it (both of its memberships are > 0 there). A cell
is therefore either wholly covered or wholly uncovered (up to its boundary, which has no
area): the uncovered fraction is a sum of cell areas. With a threshold > 0, or other
term shapes, the fraction is measured on a grid and a cell is listed where any of its
grid points is uncovered.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from twolink.controllers.fuzzy.engine import MamdaniEngine, _partition_peaks

__all__ = [
    "Coverage",
    "Jump",
    "UncoveredRegion",
    "coverage",
    "grid_uncovered_fraction",
    "surface_jumps",
    "uncovered_fraction",
]


@dataclass(frozen=True)
class UncoveredRegion:
    """A rectangle of the input box where no rule fires: ``e`` from ``e_labels[0]``'s
    peak to ``e_labels[1]``'s, ``de`` likewise (a run of neighbouring label cells)."""

    e_range: tuple[float, float]
    de_range: tuple[float, float]
    e_labels: tuple[str, str]
    de_labels: tuple[str, str]

    @property
    def area(self) -> float:
        return (self.e_range[1] - self.e_range[0]) * (self.de_range[1] - self.de_range[0])

    def __str__(self) -> str:
        return (
            f"e in [{self.e_labels[0]}, {self.e_labels[1]}] "
            f"({self.e_range[0]:+.3g}..{self.e_range[1]:+.3g}), "
            f"de in [{self.de_labels[0]}, {self.de_labels[1]}] "
            f"({self.de_range[0]:+.3g}..{self.de_range[1]:+.3g})"
        )


@dataclass(frozen=True)
class Coverage:
    """Result of :func:`coverage`.

    Attributes
    ----------
    uncovered_fraction : share of the input box's area where the total firing is
        <= ``threshold`` (exact for triangular partitions at threshold 0, else on the grid)
    grid_fraction : the same share counted on the ``grid`` x ``grid`` evaluation grid
    regions : the uncovered label cells, merged along e into rectangles
    exact : whether ``uncovered_fraction`` is the exact area share
    """

    uncovered_fraction: float
    grid_fraction: float
    regions: tuple[UncoveredRegion, ...]
    threshold: float
    grid: int
    exact: bool
    n_rules: int

    @property
    def complete(self) -> bool:
        """True where every point of the box fires some rule (above the threshold)."""
        return not self.regions and self.grid_fraction == 0.0


def grid_uncovered_fraction(engine: MamdaniEngine, n: int = 41, threshold: float = 0.0) -> float:
    """Share of the points of an n x n grid over the input box (universe edges included)
    where the total firing is <= ``threshold``: where skfuzzy would raise at threshold 0."""
    e, de = _grid(engine, n)
    return float(np.mean(_uncovered(engine, e, de, threshold)))


# grid points whose firing is computed at once: the firing's working memory is about
# 330 bytes a point with the paper's rules (tracemalloc: 27 MiB for 85,085 points), so a
# block is ~20 MiB whatever the grid
FIRING_BLOCK_POINTS = 1 << 16


def _uncovered(engine: Any, e: np.ndarray, de: np.ndarray, threshold: float) -> np.ndarray:
    """Total firing <= ``threshold`` at each grid point, a block of rows at a time: the
    whole grid at once made ``coverage --grid 1001`` peak at 954 MB (docs/reliability.md)."""
    rows = max(1, FIRING_BLOCK_POINTS // e.shape[1])
    return np.concatenate(
        [
            engine.firing(e[s : s + rows], de[s : s + rows]).sum(axis=-1) <= threshold
            for s in range(0, e.shape[0], rows)
        ]
    )


def _grid(engine: MamdaniEngine, n: int) -> tuple[np.ndarray, np.ndarray]:
    eu, du = engine.e.universe, engine.de.universe
    return np.meshgrid(np.linspace(eu[0], eu[-1], n), np.linspace(du[0], du[-1], n), indexing="ij")


def _label_cells(engine: Any) -> tuple[np.ndarray, np.ndarray, tuple, tuple, bool]:
    """The cell edges along e and de with their labels: the peaks of triangular partitions
    (and True), else the universes' ends, one cell (and False)."""
    pe, pd = _partition_peaks(engine.e), _partition_peaks(engine.de)
    if pe is None or pd is None:
        ends = (engine.e.universe[[0, -1]], engine.de.universe[[0, -1]])
        return np.asarray(ends[0]), np.asarray(ends[1]), ("min", "max"), ("min", "max"), False
    return np.asarray(pe), np.asarray(pd), engine.e.labels, engine.de.labels, True


def coverage(engine: MamdaniEngine, threshold: float = 0.0, grid: int = 201) -> Coverage:
    """The part of the (e, de) input box where no rule fires (total firing <= threshold).

    Parameters
    ----------
    engine : MamdaniEngine
    threshold : float
        A point counts as uncovered where the sum of the rules' firing strengths is at most
        this (0: no rule fires at all).
    grid : int
        Points per axis of the evaluation grid (>= 2).

    Returns
    -------
    Coverage
    """
    if not (np.isfinite(threshold) and threshold >= 0):
        raise ValueError(f"threshold must be finite and >= 0, got {threshold!r}")
    if isinstance(grid, bool) or not isinstance(grid, int) or grid < 2:
        raise ValueError(f"grid must be an integer >= 2, got {grid!r}")
    e, de = _grid(engine, grid)
    uncovered_pts = _uncovered(engine, e, de, threshold)
    grid_fraction = float(uncovered_pts.mean())
    pe, pd, labels_e, labels_d, partition = _label_cells(engine)
    exact = partition and threshold == 0.0
    cells = np.zeros((pe.size - 1, pd.size - 1), dtype=bool)
    if exact:
        present = np.zeros((pe.size, pd.size), dtype=bool)
        for r in engine.rules:
            present[engine.e.index(r.e), engine.de.index(r.de)] = True
        cells = ~(present[:-1, :-1] | present[1:, :-1] | present[:-1, 1:] | present[1:, 1:])
    else:
        ie = np.clip(np.searchsorted(pe, e[:, 0], side="right") - 1, 0, pe.size - 2)
        idd = np.clip(np.searchsorted(pd, de[0], side="right") - 1, 0, pd.size - 2)
        for a in range(pe.size - 1):
            for b in range(pd.size - 1):
                cells[a, b] = uncovered_pts[np.ix_(ie == a, idd == b)].any()
    area = np.outer(np.diff(pe), np.diff(pd))
    fraction = float(area[cells].sum() / area.sum()) if exact else grid_fraction
    regions = []
    for b in range(cells.shape[1]):  # merge runs of uncovered cells along e
        a = 0
        while a < cells.shape[0]:
            if not cells[a, b]:
                a += 1
                continue
            start = a
            while a < cells.shape[0] and cells[a, b]:
                a += 1
            regions.append(
                UncoveredRegion(
                    (float(pe[start]), float(pe[a])),
                    (float(pd[b]), float(pd[b + 1])),
                    (labels_e[start], labels_e[a]),
                    (labels_d[b], labels_d[b + 1]),
                )
            )
    return Coverage(
        fraction, grid_fraction, tuple(regions), float(threshold), grid, exact, len(engine.rules)
    )


# Changes below this are rounding (the engines agree with skfuzzy to 1e-12), never a jump.
JUMP_FLOOR = 1e-9


@dataclass(frozen=True)
class Jump:
    """The largest change of an engine's output across one grid cell inside a label cell
    (``e`` between two neighbouring peaks, ``de`` likewise): ``size`` on the ``grid`` and
    ``size_finer`` on a grid twice as fine. A continuous surface's change halves as the grid
    does; a jump keeps its size (``is_jump``: it shrinks by less than a quarter)."""

    e_range: tuple[float, float]
    de_range: tuple[float, float]
    e_labels: tuple[str, str]
    de_labels: tuple[str, str]
    size: float
    size_finer: float

    @property
    def is_jump(self) -> bool:
        return self.size_finer > JUMP_FLOOR and self.size_finer > 0.75 * self.size

    def __str__(self) -> str:
        kind = "jump" if self.is_jump else "slope"
        return (
            f"{kind} {self.size_finer:.3g} (grid {self.size:.3g}): "
            f"e in [{self.e_labels[0]}, {self.e_labels[1]}], "
            f"de in [{self.de_labels[0]}, {self.de_labels[1]}]"
        )


def surface_jumps(engine: Any, grid: int = 201) -> tuple[Jump, ...]:
    """Where the output surface of ``engine`` (any engine: ``engine(e, de)``) jumps: per
    label cell of its triangular partitions, the largest change of the output across one
    cell of a grid of about ``grid`` x ``grid`` points over the input box (the spread of its
    four corners' values; nodes on every peak), and the same on a grid twice as fine.
    Largest first.

    A discontinuity keeps its size as the grid refines; a slope L halves (its spread is at
    most L h). The paper's rule bases jump wherever one weakly fired rule gives its whole
    centroid, or the last rule stops firing (docs/fuzzy.md, "The relay")."""
    if isinstance(grid, bool) or not isinstance(grid, int) or grid < 2:
        raise ValueError(f"grid must be an integer >= 2, got {grid!r}")
    pe, pd, labels_e, labels_d, _ = _label_cells(engine)

    def largest_spread(per_cell: int) -> np.ndarray:
        # nodes on every peak, ``per_cell`` grid cells between neighbouring peaks: no grid
        # cell straddles two label cells, at any resolution
        e_nodes, de_nodes = (
            np.concatenate(
                [np.linspace(p[a], p[a + 1], per_cell + 1)[:-1] for a in range(p.size - 1)]
                + [p[-1:]]
            )
            for p in (pe, pd)
        )
        e, de = np.meshgrid(e_nodes, de_nodes, indexing="ij")
        u = np.asarray(engine(e, de))
        corners = np.stack([u[:-1, :-1], u[1:, :-1], u[:-1, 1:], u[1:, 1:]])
        spread = (corners.max(axis=0) - corners.min(axis=0)).reshape(
            pe.size - 1, per_cell, pd.size - 1, per_cell
        )
        return spread.max(axis=(1, 3))

    per_cell = max(1, math.ceil((grid - 1) / max(pe.size - 1, pd.size - 1)))
    coarse, fine = largest_spread(per_cell), largest_spread(2 * per_cell)
    jumps = [
        Jump(
            (float(pe[a]), float(pe[a + 1])),
            (float(pd[b]), float(pd[b + 1])),
            (labels_e[a], labels_e[a + 1]),
            (labels_d[b], labels_d[b + 1]),
            float(coarse[a, b]),
            float(fine[a, b]),
        )
        for a in range(coarse.shape[0])
        for b in range(coarse.shape[1])
    ]
    return tuple(sorted(jumps, key=lambda j: -j.size_finer))


def uncovered_fraction(engine: MamdaniEngine, n: int = 201, threshold: float = 0.0) -> float:
    """The share of the (e, de) input box where no rule fires (total firing <= threshold),
    on an n x n grid: where the engine falls back to ``no_fire_output``."""
    e_lo, e_hi = engine.e.universe[0], engine.e.universe[-1]
    d_lo, d_hi = engine.de.universe[0], engine.de.universe[-1]
    e, de = np.meshgrid(np.linspace(e_lo, e_hi, n), np.linspace(d_lo, d_hi, n))
    return float(np.mean(_uncovered(engine, e, de, threshold)))
