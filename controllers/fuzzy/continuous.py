"""A continuous inference of the same rules: our extension, not the paper's.

The paper's Mamdani inference (min, max, centroid) of a *reduced* rule base is
discontinuous: where one rule fires, however weakly, the centroid is that rule's whole
consequent, and where none fires the output is 0 (docs/fuzzy.md, "The relay"). With the
designed rules the output jumps by 2.5-5 rad/s² across de = 0.

:class:`ContinuousEngine` keeps the rules, the membership functions and the scaling, and
changes only the inference, to the standard product-sum, centre-of-sets one (a
Takagi-Sugeno reading of the Mamdani rules, Wang 1997, "A Course in Fuzzy Systems and
Control", ch. 9), completed so that it is defined everywhere:

* a rule's strength is the *product* of its two memberships;
* every label cell (i, j) of the 7 x 7 antecedent grid without a rule acts as a rule
  with output 0 (the paper's own "no correction" where no rule fires);
* the output is the strength-weighted mean of the rules' consequent centroids.

On a triangular partition (each peak is its neighbours' foot: the project's 7-label
variables) the strengths of the 49 cells sum to one everywhere, so the output is the
bilinear interpolation of the table V[i, j] (the consequent centroid of rule (i, j), or
0) between the peaks:

    u(e, de) = sum_ij  mu_i(e) nu_j(de) V[i, j].

Lipschitz bound (:func:`lipschitz_bound`). In a cell between peaks e_i, e_i+1 and d_j,
d_j+1, with s, t the fractions across it,

    du/de = [(1 - t)(V[i+1, j] - V[i, j]) + t (V[i+1, j+1] - V[i, j+1])] / (e_i+1 - e_i),

a convex combination of two edge slopes, so |du/de| <= L_e = max |V[i+1, j] - V[i, j]| /
(e_i+1 - e_i) over all i, j; likewise L_de. Neighbouring cells agree on their shared
edge, so u is continuous and piecewise C1, hence |u(a) - u(b)| <= L_e |e_a - e_b| +
L_de |de_a - de_b| on the box; inputs are clipped to the box, which only shrinks
distances. In physical units the correction ku u(ke e, kde de) has constants ku ke L_e
[rad/s² per rad] and ku kde L_de [rad/s² per rad/s].
"""

from __future__ import annotations

from bisect import bisect_right
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import skfuzzy

from twolink.controllers.fuzzy import kernels
from twolink.controllers.fuzzy.engine import MamdaniEngine, _partition_peaks
from twolink.controllers.fuzzy.table import bilinear

__all__ = ["ContinuousEngine", "lipschitz_bound"]


@dataclass(frozen=True, eq=False)
class ContinuousEngine:
    """The rules of ``exact`` inferred continuously (product, zero-output empty cells,
    centre of sets): a drop-in for the engine wherever a controller calls one
    (``__call__``, ``evaluate_batch``, ``evaluate_floats``); the rules, variables and
    ``firing`` are ``exact``'s.

    Parameters
    ----------
    exact : MamdaniEngine
        The engine whose rules are inferred; its ``e`` and ``de`` must be triangular
        partitions (a ValueError says so otherwise).
    """

    exact: MamdaniEngine
    values: np.ndarray = field(init=False, repr=False)
    e_peaks: tuple[float, ...] = field(init=False, repr=False)
    de_peaks: tuple[float, ...] = field(init=False, repr=False)
    _flat: list = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.exact, MamdaniEngine):  # a MATLAB FIS's term (matlab.py)
            source = getattr(getattr(self.exact, "fis", None), "source", "this engine")
            raise ValueError(
                f"{source}: continuous inference re-infers the rules of the project's "
                'triangular partitions; this system is not one (use inference = "mamdani")'
            )
        e_peaks, de_peaks = _partition_peaks(self.exact.e), _partition_peaks(self.exact.de)
        if e_peaks is None or de_peaks is None:
            raise ValueError(
                "continuous inference needs triangular partitions on e and de "
                "(every peak its neighbours' foot)"
            )
        u = self.exact.u
        centroid = {
            label: float(skfuzzy.defuzz(u.grid, row, "centroid"))
            for label, row in zip(u.labels, u.table, strict=True)
        }
        e_index = {label: i for i, label in enumerate(self.exact.e.labels)}
        de_index = {label: j for j, label in enumerate(self.exact.de.labels)}
        # rules sharing a cell fire equally everywhere: the centre of sets is their mean
        total = np.zeros((len(e_peaks), len(de_peaks)))
        count = np.zeros_like(total)
        for rule in self.exact.rules:
            i, j = e_index[rule.e], de_index[rule.de]
            total[i, j] += centroid[rule.u]
            count[i, j] += 1
        values = np.divide(total, count, out=np.zeros_like(total), where=count > 0)
        values.setflags(write=False)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "e_peaks", tuple(e_peaks))
        object.__setattr__(self, "de_peaks", tuple(de_peaks))
        object.__setattr__(self, "_flat", values.ravel().tolist())
        object.__setattr__(self, "_ravel", values.ravel())
        object.__setattr__(self, "_peaks_e", np.array(e_peaks, dtype=float))
        object.__setattr__(self, "_peaks_d", np.array(de_peaks, dtype=float))

    def __getattr__(self, name: str) -> Any:  # the exact engine's rules, variables, ...
        if name.startswith("_") or name == "exact":
            raise AttributeError(name)
        return getattr(self.exact, name)

    def with_rules(self, rules: Any) -> ContinuousEngine:
        return ContinuousEngine(self.exact.with_rules(rules))

    def __call__(self, e: np.ndarray | float, de: np.ndarray | float) -> np.ndarray:
        return self.evaluate_batch(e, de)

    def evaluate_batch(self, e: np.ndarray | float, de: np.ndarray | float) -> np.ndarray:
        """The output for inputs that broadcast together (vectorised)."""
        e, de = np.broadcast_arrays(np.asarray(e, dtype=float), np.asarray(de, dtype=float))
        if np.isnan(e).any() or np.isnan(de).any():
            raise ValueError("fuzzy engine inputs contain NaN")
        return self.evaluate_xp(e, de, np)

    def evaluate_compiled(self, e: np.ndarray, de: np.ndarray) -> np.ndarray:
        """:meth:`evaluate_floats`' arithmetic compiled (numba, where installed; else
        :meth:`evaluate_batch`): the batch laws' call, equal to both to the bit."""
        return kernels.compiled_or(kernels.continuous, self, self.evaluate_batch, e, de)

    def evaluate_xp(self, e: Any, de: Any, xp: Any) -> Any:
        """The output on the array namespace ``xp`` (numpy, or jax.numpy on the
        accelerator backend): ``_cell``'s arithmetic on arrays (clip, the cell, the
        fraction across it) and ``bilinear``'s, in the same order, so equal to
        :meth:`evaluate_floats` to the bit on numpy. Inputs must be free of NaN."""
        i, s = _cells(xp.asarray(self._peaks_e), e, xp)
        j, t = _cells(xp.asarray(self._peaks_d), de, xp)
        n_de = self._peaks_d.size
        k = i * n_de + j
        v = xp.asarray(self._ravel)
        v00, v01 = v[k], v[k + 1]
        v10, v11 = v[k + n_de], v[k + n_de + 1]
        lo = v00 + t * (v01 - v00)
        hi = v10 + t * (v11 - v10)
        return lo + s * (hi - lo)

    def evaluate_floats(self, es: Sequence[float], ds: Sequence[float]) -> list[float]:
        """The output for a few plain floats (the control loop's call), in pure Python."""
        pe, pd, flat = self.e_peaks, self.de_peaks, self._flat
        n_de = len(pd)
        out = []
        for e, d in zip(es, ds, strict=True):
            if e != e or d != d:
                raise ValueError("fuzzy engine inputs contain NaN")
            i, s = _cell(pe, e)
            j, t = _cell(pd, d)
            out.append(bilinear(flat, n_de, i, j, s, t))
        return out


def _cells(peaks: Any, x: Any, xp: Any = np) -> tuple[Any, Any]:
    """:func:`_cell` for arrays, the same arithmetic."""
    x = xp.clip(x, peaks[0], peaks[-1])
    i = xp.minimum(xp.searchsorted(peaks, x, side="right") - 1, peaks.shape[0] - 2)
    lo = peaks[i]
    return i, (x - lo) / (peaks[i + 1] - lo)


def _cell(peaks: tuple[float, ...], x: float) -> tuple[int, float]:
    """The cell of ``x`` (clipped to the peaks' range) and its fraction across it."""
    x = min(max(x, peaks[0]), peaks[-1])
    i = min(bisect_right(peaks, x) - 1, len(peaks) - 2)
    return i, (x - peaks[i]) / (peaks[i + 1] - peaks[i])


def lipschitz_bound(engine: ContinuousEngine) -> tuple[float, float]:
    """``(L_e, L_de)``: |u(a) - u(b)| <= L_e |e_a - e_b| + L_de |de_a - de_b| on the
    normalised inputs (the proof is in the module's docstring): the largest slope of the
    table between neighbouring peaks, along each axis."""
    v = engine.values
    slope_e = np.abs(np.diff(v, axis=0)) / np.diff(engine.e_peaks)[:, None]
    slope_de = np.abs(np.diff(v, axis=1)) / np.diff(engine.de_peaks)[None, :]
    return float(slope_e.max()), float(slope_de.max())
