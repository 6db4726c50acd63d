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

from dataclasses import dataclass

import numpy as np

from twolink.controllers.fuzzy.engine import MamdaniEngine, _partition_peaks

__all__ = ["Coverage", "UncoveredRegion", "coverage", "grid_uncovered_fraction"]


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
    return float(np.mean(engine.firing(e, de).sum(axis=-1) <= threshold))


def _grid(engine: MamdaniEngine, n: int) -> tuple[np.ndarray, np.ndarray]:
    eu, du = engine.e.universe, engine.de.universe
    return np.meshgrid(np.linspace(eu[0], eu[-1], n), np.linspace(du[0], du[-1], n), indexing="ij")


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
    pe, pd = _partition_peaks(engine.e), _partition_peaks(engine.de)
    e, de = _grid(engine, grid)
    uncovered_pts = engine.firing(e, de).sum(axis=-1) <= threshold
    grid_fraction = float(uncovered_pts.mean())
    exact = pe is not None and pd is not None and threshold == 0.0
    if pe is None or pd is None:  # cells of the sample grid instead of label cells
        pe, pd = tuple(engine.e.universe[[0, -1]]), tuple(engine.de.universe[[0, -1]])
        labels_e, labels_d = ("min", "max"), ("min", "max")
    else:
        labels_e, labels_d = engine.e.labels, engine.de.labels
    pe, pd = np.asarray(pe), np.asarray(pd)
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
