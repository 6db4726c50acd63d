"""FCM-CTC with its rule table as data, for a search over tables
(twolink/studies/designs/search.py).

A table is a 7 x 7 integer array on the designs' partition (rows: e's labels NB..PB, columns:
ė's): the consequent label's index 0..6 where a rule is, -1 where none is. The scalar law is
:class:`~controllers.fuzzy_ctc.FuzzyComputedTorque` with the engine built from those rules
(Mamdani, or the continuous inference of the same rules); the batch law evaluates a
different table per arm in one numpy pass, so a whole population of tables runs as one
batch of the batch engine. It is tested equal to the engines (``tests/test_search.py``).

Both inferences, on a triangular partition, only ever involve the 2 x 2 label cells around
(e, ė): per arm and joint the batch law finds them, their firing strengths (min for
Mamdani, product for the continuous inference) and their consequents, and then

* Mamdani: each output term's clip level is the largest firing of its rules, and the
  centroid is the engine's own closed form (``MamdaniEngine._centroid_rows``); 0 where no
  rule fires (the engine's no-fire output);
* continuous: the strength-weighted mean of the consequents' centroids (empty cells: 0),
  the bilinear interpolation of the table (controllers/fuzzy/continuous.py).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import skfuzzy

from twolink.controllers.batch import BatchComputedTorque, _fuzzy_scalings
from twolink.controllers.fuzzy_ctc import FuzzyComputedTorque

__all__ = ["LABELS", "RuleTableCTC", "TableEvaluator", "rules_of", "table_of"]

LABELS = ("NB", "NM", "NS", "Z", "PS", "PM", "PB")
NONE = -1


def rules_of(table: np.ndarray) -> list[tuple[str, str, str]]:
    """The rules (e, ė, u labels) of a 7 x 7 table (-1: no rule)."""
    t = np.asarray(table, dtype=int)
    if t.shape != (7, 7) or t.min() < NONE or t.max() > 6:
        raise ValueError(f"a rule table is 7 x 7 with entries -1..6, got {t.tolist()}")
    return [
        (LABELS[i], LABELS[j], LABELS[t[i, j]]) for i in range(7) for j in range(7) if t[i, j] >= 0
    ]


def table_of(rules: Any) -> np.ndarray:
    """The 7 x 7 table of rules (each with e, de, u labels; one rule per cell)."""
    t = np.full((7, 7), NONE, dtype=int)
    for r in rules:
        i, j = LABELS.index(r[0]), LABELS.index(r[1])
        if t[i, j] != NONE:
            raise ValueError(f"two rules in cell {r[0]}, {r[1]}: a table holds one")
        t[i, j] = LABELS.index(r[2])
    return t


class TableEvaluator:
    """The fuzzy term of many tables at once: ``evaluate(tables, e, de)`` with ``tables``
    (N, 7, 7) and inputs (N, k) gives (N, k), row n by table n.

    Parameters
    ----------
    engine : MamdaniEngine
        The engine whose variables (triangular partitions) and centroid the tables use.
    inference : {"mamdani", "continuous"}
    """

    def __init__(self, engine: Any, inference: str = "mamdani") -> None:
        from twolink.controllers.fuzzy.engine import _partition_peaks

        if inference not in ("mamdani", "continuous"):
            raise ValueError(f'inference must be "mamdani" or "continuous", got {inference!r}')
        pe, pd = _partition_peaks(engine.e), _partition_peaks(engine.de)
        if pe is None or pd is None or len(pe) != 7 or len(pd) != 7 or engine.and_method != "min":
            raise ValueError("a rule table needs 7-label triangular partitions and min AND")
        if tuple(engine.e.labels) != LABELS or tuple(engine.u.labels) != LABELS:
            raise ValueError(f"a rule table needs the labels {LABELS}")
        self.engine, self.inference = engine, inference
        self.pe, self.pd = np.array(pe), np.array(pd)
        # the consequents' centroids (the continuous inference's values); 0 for no rule
        u = engine.u
        centroids = [float(skfuzzy.defuzz(u.grid, row, "centroid")) for row in u.table]
        self.centroids = np.array([*centroids, 0.0])  # index -1: no rule

    @staticmethod
    def _cell(x: np.ndarray, peaks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Lower label index and the fraction across the cell, as ``_partition_rows``."""
        x = np.clip(x, peaks[0], peaks[-1])
        i = np.minimum(np.searchsorted(peaks, x, side="right") - 1, peaks.size - 2)
        return i, (x - peaks[i]) / (peaks[i + 1] - peaks[i])

    def evaluate(self, tables: np.ndarray, e: np.ndarray, de: np.ndarray) -> np.ndarray:
        e, de = np.broadcast_arrays(np.asarray(e, dtype=float), np.asarray(de, dtype=float))
        if np.isnan(e).any() or np.isnan(de).any():
            raise ValueError("fuzzy engine inputs contain NaN")
        n = e.shape[0]
        flat = np.asarray(tables).reshape(n, 49)
        i, s = self._cell(e, self.pe)
        j, t = self._cell(de, self.pd)
        rows = np.arange(n).reshape((n,) + (1,) * (e.ndim - 1))
        corners = ((0, 0, 1 - s, 1 - t), (1, 0, s, 1 - t), (0, 1, 1 - s, t), (1, 1, s, t))
        if self.inference == "continuous":
            out = np.zeros(e.shape)
            for di, dj, a, b in corners:
                out += a * b * self.centroids[flat[rows, (i + di) * 7 + j + dj]]
            return out
        # clip levels: per corner one label per sample, so one scatter each (row 7: no rule)
        m = e.size
        cuts = np.zeros((8, m))
        cols = np.arange(m)
        for di, dj, a, b in corners:
            label = flat[rows, (i + di) * 7 + j + dj].ravel()
            where = (np.where(label < 0, 7, label), cols)
            cuts[where] = np.maximum(cuts[where], np.minimum(a, b).ravel())
        cuts = cuts[:7]
        fired = cuts.max(axis=0) > 0.0
        out = np.where(fired, self.engine._centroid_rows(cuts), self.engine.no_fire_output)
        return out.reshape(e.shape)


class BatchRuleTableCTC(BatchComputedTorque):
    """:class:`RuleTableCTC` for N arms, each with its own table and inference."""

    def __init__(self, controllers: Sequence[RuleTableCTC], times: np.ndarray) -> None:
        super().__init__(controllers, times)
        if any(c.mode != "add" for c in controllers):
            raise ValueError("a batch of rule tables runs in mode 'add'")
        base = controllers[0].base_engine
        self.groups = []  # (rows, evaluator) per inference present
        for inference in ("mamdani", "continuous"):
            rows = np.array([i for i, c in enumerate(controllers) if c.inference == inference])
            if rows.size:
                self.groups.append((rows, TableEvaluator(base, inference)))
        self.tables = np.stack([c.table for c in controllers])
        self.ke, self.kde, self.ku = _fuzzy_scalings(controllers)

    def finish(self, k: int, a, e, de, m, state: Any) -> tuple[Any, Any]:
        x, dx = self.ke * e, self.kde * de
        if len(self.groups) == 1:
            u = self.groups[0][1].evaluate(self.tables, x, dx)
        else:
            u = np.empty_like(x)
            for rows, ev in self.groups:
                u[rows] = ev.evaluate(self.tables[rows], x[rows], dx[rows])
        # the scalar law's order of sums (controllers/batch.py): bit for bit its torque
        return self.torque(m, a + (self.kp * e + self.kd * de) + self.ku * u), state


class RuleTableCTC(FuzzyComputedTorque):
    """FCM-CTC whose rules are a 7 x 7 ``table`` (see the module docstring); build it with
    :meth:`from_table`. The single-arm law is FuzzyComputedTorque's with those rules."""

    table: np.ndarray = None  # type: ignore[assignment]
    inference: str = "mamdani"
    base_engine: Any = None
    batch_law = BatchRuleTableCTC

    @classmethod
    def from_table(cls, table: np.ndarray, inference: str = "mamdani", **fcm: Any) -> RuleTableCTC:
        """FCM-CTC (``FuzzyComputedTorque.fcm``'s arguments: arm, reference, gains, limits)
        with the rules of ``table`` inferred by ``inference``."""
        from twolink.controllers.fuzzy import default_fuzzy_pd
        from twolink.controllers.fuzzy.continuous import ContinuousEngine

        base = default_fuzzy_pd()
        rules = rules_of(table)
        exact = base.with_rules(rules) if rules else None
        proto = FuzzyComputedTorque.fcm(**fcm, inference="mamdani")
        engine: Any = _NoRules(base) if exact is None else exact
        if inference == "continuous" and exact is not None:
            engine = ContinuousEngine(exact)
        out = cls(
            proto.model, proto.reference, kp=proto.kp, kd=proto.kd, torque_limit=proto.torque_limit,
            engine=engine, ke=proto.ke, kde=proto.kde, ku=proto.ku, mode="add",
        )  # fmt: skip
        out.table = np.array(table, dtype=int)
        out.inference = inference
        out.base_engine = base
        return out


class _NoRules:
    """The fuzzy term of an empty table: 0 everywhere (FCM-CTC is CTC)."""

    def __init__(self, base: Any) -> None:
        self.base = base
        self.rules = ()

    def evaluate_floats(self, es: Sequence[float], ds: Sequence[float]) -> list[float]:
        return [0.0 for _ in es]

    def evaluate_batch(self, e: Any, de: Any) -> np.ndarray:
        return np.zeros(np.broadcast(np.asarray(e), np.asarray(de)).shape)

    __call__ = evaluate_batch
