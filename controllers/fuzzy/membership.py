"""Membership functions and linguistic variables, sampled as scikit-fuzzy samples them.

The seven labels NB..PB, their reflection (for rule bases written with the opposite error
sign), and the evenly spaced triangular partition that the project's engines use.
"""

from __future__ import annotations

import math
import types
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import skfuzzy

__all__ = [
    "LABELS_7",
    "MIRROR_LABELS",
    "FuzzyVariable",
    "MembershipFunction",
    "triangular_partition",
]

LABELS_7: tuple[str, ...] = ("NB", "NM", "NS", "Z", "PS", "PM", "PB")
"""The seven linguistic labels, from negative big to positive big."""

MIRROR_LABELS: Mapping[str, str] = types.MappingProxyType(
    {"NB": "PB", "NM": "PM", "NS": "PS", "Z": "Z", "PS": "NS", "PM": "NM", "PB": "NB"}
)
"""Label reflection x -> -x, used to read rule bases written for the opposite error sign."""


@dataclass(frozen=True)
class MembershipFunction:
    """A membership function of one term, sampled with scikit-fuzzy's generators.

    Parameters
    ----------
    kind : {"tri", "trap", "gauss"}
        ``"tri"``: ``skfuzzy.trimf`` with ``params = (a, b, c)``, ``a <= b <= c``;
        ``"trap"``: ``skfuzzy.trapmf`` with ``params = (a, b, c, d)``;
        ``"gauss"``: ``skfuzzy.gaussmf`` with ``params = (mean, sigma)``, ``sigma > 0``.
    params : tuple of float
        Shape parameters, as above.
    """

    kind: Literal["tri", "trap", "gauss"]
    params: tuple[float, ...]

    def __post_init__(self) -> None:
        counts = {"tri": 3, "trap": 4, "gauss": 2}
        if self.kind not in counts:
            raise ValueError(f"membership kind must be one of {sorted(counts)}, got {self.kind!r}")
        params = tuple(float(p) for p in self.params)
        if len(params) != counts[self.kind]:
            raise ValueError(
                f"{self.kind!r} takes {counts[self.kind]} parameters, got {len(params)}"
            )
        if not all(math.isfinite(p) for p in params):
            raise ValueError(f"membership parameters must be finite, got {params}")
        if self.kind == "gauss":
            if params[1] <= 0:
                raise ValueError(f"gauss sigma must be > 0, got {params[1]}")
        elif any(params[i] > params[i + 1] for i in range(len(params) - 1)):
            raise ValueError(f"{self.kind!r} parameters must be non-decreasing, got {params}")
        object.__setattr__(self, "params", params)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """Sample the membership function at the points ``x`` (1-D)."""
        x = np.asarray(x, dtype=float)
        if self.kind == "tri":
            return skfuzzy.trimf(x, list(self.params))
        if self.kind == "trap":
            return skfuzzy.trapmf(x, list(self.params))
        return skfuzzy.gaussmf(x, *self.params)


@dataclass(frozen=True)
class FuzzyVariable:
    """A linguistic variable: a sampled universe and its terms.

    Parameters
    ----------
    universe : sequence of float
        Strictly increasing sample points (at least 2). Inputs are clipped to
        ``[universe[0], universe[-1]]``; membership values between the samples
        are linear interpolations of the sampled functions (as in skfuzzy), so
        sample every breakpoint of a triangle or trapezoid to represent it exactly.
    labels : sequence of str
        Term names, unique.
    mfs : sequence of MembershipFunction
        One per label. Each sampled function must lie in [0, 1], reach a
        positive maximum and be unimodal (non-decreasing, then non-increasing).
    """

    universe: tuple[float, ...]
    labels: tuple[str, ...]
    mfs: tuple[MembershipFunction, ...]
    _grid: np.ndarray = field(init=False, repr=False, compare=False)
    _table: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        universe = tuple(float(v) for v in self.universe)
        labels = tuple(str(v) for v in self.labels)
        mfs = tuple(self.mfs)
        grid = np.array(universe, dtype=float)
        if grid.ndim != 1 or grid.size < 2:
            raise ValueError("universe must be a 1-D sequence of at least 2 points")
        if not np.all(np.isfinite(grid)) or not np.all(np.diff(grid) > 0):
            raise ValueError("universe must be finite and strictly increasing")
        if len(labels) == 0 or len(labels) != len(mfs):
            raise ValueError(
                f"need one membership function per label: {len(labels)} labels, "
                f"{len(mfs)} functions"
            )
        if len(set(labels)) != len(labels):
            raise ValueError(f"labels must be unique, got {labels}")
        rows = []
        for label, mf in zip(labels, mfs, strict=True):
            if not isinstance(mf, MembershipFunction):
                raise TypeError(f"term {label!r}: expected a MembershipFunction, got {mf!r}")
            row = np.asarray(mf(grid), dtype=float)
            if row.min() < 0.0 or row.max() > 1.0 or row.max() <= 0.0:
                raise ValueError(
                    f"term {label!r}: sampled membership must lie in [0, 1] and "
                    "reach a positive maximum on the universe"
                )
            peak = int(np.argmax(row))
            if np.any(np.diff(row[: peak + 1]) < 0) or np.any(np.diff(row[peak:]) > 0):
                raise ValueError(f"term {label!r}: sampled membership must be unimodal")
            rows.append(row)
        table = np.vstack(rows)
        grid.flags.writeable = False
        table.flags.writeable = False
        object.__setattr__(self, "universe", universe)
        object.__setattr__(self, "labels", labels)
        object.__setattr__(self, "mfs", mfs)
        object.__setattr__(self, "_grid", grid)
        object.__setattr__(self, "_table", table)

    @property
    def grid(self) -> np.ndarray:
        """The universe as a read-only float array, shape (M,)."""
        return self._grid

    @property
    def table(self) -> np.ndarray:
        """Sampled membership functions, read-only, shape (n_terms, M)."""
        return self._table

    def index(self, label: str) -> int:
        """Position of ``label`` among the terms (ValueError if unknown)."""
        try:
            return self.labels.index(label)
        except ValueError:
            raise ValueError(f"unknown label {label!r}; expected one of {self.labels}") from None

    def membership(self, x: np.ndarray | float) -> np.ndarray:
        """Membership of each term at ``x`` (clipped), shape ``x.shape + (n_terms,)``."""
        x = np.asarray(x, dtype=float)
        return np.moveaxis(self._membership_rows(x.ravel()).reshape((-1,) + x.shape), 0, -1)

    def _membership_rows(self, x: np.ndarray) -> np.ndarray:
        """Memberships of 1-D ``x`` as (n_terms, N): rows contiguous for the numpy paths."""
        x = np.clip(x, self._grid[0], self._grid[-1])
        out = np.empty((self._table.shape[0], x.size))
        for k, row in enumerate(self._table):
            out[k] = np.interp(x, self._grid, row)
        return out


def triangular_partition(
    labels: Sequence[str] = LABELS_7,
    lo: float = -1.0,
    hi: float = 1.0,
    n_points: int = 61,
) -> FuzzyVariable:
    """Evenly spaced triangles on ``[lo, hi]``, each peak the neighbours' foot.

    The end terms are triangles whose peak sits on the universe edge (as
    ``skfuzzy``'s ``automf``), so memberships sum to one everywhere. The
    universe is ``linspace(lo, hi, n_points)`` and every peak is one of its
    points, so the sampled triangles are exact.

    Parameters
    ----------
    labels : sequence of str
        Term names from the most negative to the most positive (at least 2).
    lo, hi : float
        Universe bounds, ``lo < hi``.
    n_points : int
        Universe sample count; ``n_points - 1`` must be a multiple of ``len(labels) - 1``.
        More points make skfuzzy's piecewise-linear centroid closer to the exact one.

    Returns
    -------
    FuzzyVariable
    """
    labels = tuple(labels)
    k = len(labels)
    if k < 2:
        raise ValueError("a partition needs at least 2 labels")
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(f"need finite lo < hi, got {lo}, {hi}")
    if n_points < k or (n_points - 1) % (k - 1) != 0:
        raise ValueError(f"n_points - 1 must be a positive multiple of {k - 1}, got {n_points}")
    grid = np.linspace(lo, hi, n_points)
    # Peaks taken from the grid itself, so each one is a sample point bit for bit.
    peaks = grid[:: (n_points - 1) // (k - 1)]
    left = np.concatenate([[peaks[0] - (peaks[1] - peaks[0])], peaks[:-1]])
    right = np.concatenate([peaks[1:], [peaks[-1] + (peaks[-1] - peaks[-2])]])
    mfs = tuple(
        MembershipFunction("tri", (float(a), float(b), float(c)))
        for a, b, c in zip(left, peaks, right, strict=True)
    )
    return FuzzyVariable(tuple(grid.tolist()), labels, mfs)
