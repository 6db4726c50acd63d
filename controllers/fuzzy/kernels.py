"""Compiled fuzzy inference for batches: the pure-Python paths' arithmetic, per input, in
machine code (numba, an optional dependency: ``pip install "twolink[fast]"``).

Each kernel is the plain-float path of its engine written once more over arrays, the
same operations in the same order (IEEE double, no fast-math, no fused multiply-add:
numba's defaults), so its outputs equal the pure-Python ones to the bit
(``tests/test_fuzzy_kernels.py``):

* :func:`mamdani` is ``MamdaniEngine._small`` (the closed-form centroid of triangular
  partitions): the batch engine's numpy path agrees with it to 1e-12 only, and costs
  ~0.5 µs per input against ~0.02 µs here;
* :func:`table` is ``FuzzyTable.evaluate_floats`` (the bilinear lookup);
* :func:`continuous` is ``ContinuousEngine.evaluate_floats``.

Without numba (or with ``TWOLINK_NO_NUMBA=1``) :func:`available` is false and the
engines take their numpy paths. Only the batch laws call the kernels (the engines'
``evaluate_compiled``, ``controllers/batch.py``), for more than ``MIN_INPUTS`` inputs (below
it the pure-Python path is as fast): a single-arm run, a table, a design or a coverage map
never imports numba (~0.5 s). Compiled code is cached on disk (``cache=True``): the first
batch run on a machine compiles each kernel once (~1-3 s), later ones load it.
"""

from __future__ import annotations

import os
import sys
import tempfile
from functools import cache
from typing import Any

import numpy as np

__all__ = ["MIN_INPUTS", "available", "compiled_or", "continuous", "mamdani", "table"]

# Below this many inputs per call the pure-Python paths are as fast (measured on the 2-core
# machine, the designed rule base, per call: 2 inputs 3.6 µs pure Python against 4.7 µs
# compiled, 4 inputs 6.1 against 4.8, 8 inputs 11 against 4.8, 60 inputs 75 against 5.7):
# a single arm's law (2 inputs) stays pure Python, and never imports numba.
MIN_INPUTS = 3


@cache
def _numba() -> Any:
    if os.environ.get("TWOLINK_NO_NUMBA"):
        return None
    try:
        import numba
    except ImportError:
        return None
    return numba


def available() -> bool:
    """Whether the compiled kernels can be used (numba is installed and not switched off)."""
    return _numba() is not None


def _mamdani_py(e, d, pe, pd, pu, ug, cells, counts, use_min, no_fire, out):  # noqa: C901
    last_e, last_d, n_int = pe.size - 2, pd.size - 2, pu.size - 1
    elo, ehi, dlo, dhi = pe[0], pe[-1], pd[0], pd[-1]
    cuts = np.zeros(n_int + 1)
    eps = np.finfo(np.float64).eps
    for n in range(e.size):
        x = e[n]
        y = d[n]
        x = elo if x < elo else (ehi if x > ehi else x)
        y = dlo if y < dlo else (dhi if y > dhi else y)
        i = np.searchsorted(pe, x, side="right") - 1
        if i > last_e:
            i = last_e
        j = np.searchsorted(pd, y, side="right") - 1
        if j > last_d:
            j = last_d
        te = (x - pe[i]) / (pe[i + 1] - pe[i])
        td = (y - pd[j]) / (pd[j + 1] - pd[j])
        cuts[:] = 0.0
        kmin, kmax = n_int + 1, -1
        for a_e in range(2):
            ie = i + a_e
            me = te if a_e else 1.0 - te
            if me <= 0.0:
                continue
            for a_d in range(2):
                jd = j + a_d
                md = td if a_d else 1.0 - td
                if md <= 0.0:
                    continue
                if use_min:
                    f = me if me < md else md
                else:
                    f = me * md
                for c in range(counts[ie, jd]):
                    k = cells[ie, jd, c]
                    if f > cuts[k]:
                        cuts[k] = f
                        if k < kmin:
                            kmin = k
                        if k > kmax:
                            kmax = k
        if kmax < 0:
            out[n] = no_fire
            continue
        area = 0.0
        mom = 0.0
        m_lo = kmin - 1 if kmin > 0 else 0
        m_hi = kmax + 1 if kmax < n_int else n_int
        for m in range(m_lo, m_hi):
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
                if c == 0.5:
                    s = 0.5
                    kk = (1.0 if a > 0.5 else 0.0) + (1.0 if b > 0.5 else 0.0)
                elif a <= b:
                    s = a
                    kk = 1.0 if b > a else 0.0
                else:
                    s = 1.0 - b
                    kk = 1.0
                if kk != 0.0:
                    xs = p + s * h
                    if xs > pu[m + 1]:
                        xs = pu[m + 1]
                    g = np.searchsorted(ug, xs)
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
                    extra = 0.5 * kk * (s - tl) * (tr - s)
                    ar += extra
                    mo += extra * (tl + s + tr) / 3.0
            area += h * ar
            mom += h * (p * ar + h * mo)
        out[n] = mom / (area if area > eps else eps)


def _table_py(e, d, flat, n, e_lo, e_hi, e_scale, d_lo, d_hi, d_scale, out):
    for m in range(e.size):
        x = e[m]
        y = d[m]
        fe = (min(max(x, e_lo), e_hi) - e_lo) * e_scale
        fd = (min(max(y, d_lo), d_hi) - d_lo) * d_scale
        i = min(int(fe), n - 2)
        j = min(int(fd), n - 2)
        s = fe - i
        t = fd - j
        k = i * n + j
        lo = flat[k] + t * (flat[k + 1] - flat[k])
        hi = flat[k + n] + t * (flat[k + n + 1] - flat[k + n])
        out[m] = lo + s * (hi - lo)


def _continuous_py(e, d, pe, pd, flat, out):
    n_de = pd.size
    for m in range(e.size):
        x = min(max(e[m], pe[0]), pe[-1])
        i = min(np.searchsorted(pe, x, side="right") - 1, pe.size - 2)
        s = (x - pe[i]) / (pe[i + 1] - pe[i])
        y = min(max(d[m], pd[0]), pd[-1])
        j = min(np.searchsorted(pd, y, side="right") - 1, pd.size - 2)
        t = (y - pd[j]) / (pd[j + 1] - pd[j])
        k = i * n_de + j
        lo = flat[k] + t * (flat[k + 1] - flat[k])
        hi = flat[k + n_de] + t * (flat[k + n_de + 1] - flat[k + n_de])
        out[m] = lo + s * (hi - lo)


_KERNELS = {"mamdani": _mamdani_py, "table": _table_py, "continuous": _continuous_py}


def cache_problem() -> str:
    """Why numba's cache folder (``NUMBA_CACHE_DIR``, set by :mod:`twolink` to the user's
    cache folder) cannot be used: not set, not a folder that can be made, or no file can
    be written in it; "" where it can. numba itself would then cache beside the source
    (a wheel's site-packages), or fail."""
    folder = os.environ.get("NUMBA_CACHE_DIR", "")
    if not folder:
        return "NUMBA_CACHE_DIR is not set"
    try:
        os.makedirs(folder, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder, prefix=".twolink-probe-") as fh:
            fh.write(b"\0" * 4096)
            fh.flush()
            os.fsync(fh.fileno())
    except OSError as exc:
        return f"{folder}: {exc.strerror or exc}"
    return ""


_NOTED: list[str] = []  # the note is said once a process


def _note_uncached(why: str) -> None:
    if _NOTED:
        return
    _NOTED.append(why)
    print(
        f"note: numba's cache cannot be used ({why}); the fuzzy kernels are compiled in "
        "each process, not cached (set NUMBA_CACHE_DIR to a writable folder)",
        file=sys.stderr,
    )


@cache
def _uncached() -> dict[str, Any]:
    jit = _numba().njit(cache=False, nogil=True)
    return {name: jit(kernel) for name, kernel in _KERNELS.items()}


@cache
def _compiled() -> dict[str, Any]:
    """The kernels, cached on disk where numba's cache folder can be used; else compiled
    in this process alone, with a note (never cached beside the source). A save that
    fails later (a full disk) turns the cache off the same way."""
    if why := cache_problem():
        _note_uncached(why)
        return _uncached()
    jit = _numba().njit(cache=True, nogil=True)
    return {name: _Guarded(name, jit(kernel)) for name, kernel in _KERNELS.items()}


class _Guarded:
    """A cached kernel, or where numba cannot write its cache (OSError: a full disk) its
    uncached twin, from then on; ``signatures`` are those of the one it calls."""

    def __init__(self, name: str, kernel: Any) -> None:
        self.name, self.cached, self.kernel = name, kernel, kernel

    def __call__(self, *args: Any) -> Any:
        try:
            return self.kernel(*args)
        except OSError as exc:
            if self.kernel is not self.cached:
                raise
            where = exc.filename or os.environ.get("NUMBA_CACHE_DIR")
            _note_uncached(f"{where}: {exc.strerror or exc}")
            self.kernel = _uncached()[self.name]
            return self.kernel(*args)

    @property
    def signatures(self) -> list:
        return self.kernel.signatures


def warm() -> None:
    """Load every kernel's machine code now (numba's on-disk cache; compiled once per
    machine): what a fork server does for the workers it forks
    (:mod:`twolink.controllers.fuzzy.kernels_loaded`). Without numba: nothing. The
    arguments are empty arrays of the types the engines pass (a type the engines did not
    pass would compile a second version at their first call, not change a result)."""
    if not available():
        return
    f = np.zeros(0)
    frozen = np.zeros(0)
    frozen.setflags(write=False)  # the table's values and the continuous rule grid
    kernel = _compiled()
    cells, counts = np.zeros((1, 1, 1), np.int64), np.zeros((1, 1), np.int64)
    kernel["mamdani"](f, f, f, f, f, f, cells, counts, True, 0.0, f)
    kernel["table"](f, f, frozen, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, f)
    kernel["continuous"](f, f, f, f, frozen, f)


def compiled_or(kernel: Any, owner: Any, fallback: Any, e: Any, d: Any) -> np.ndarray:
    """``kernel(owner, e, d)`` on the inputs broadcast together and flattened (contiguous),
    in their shape; ``fallback(e, d)`` where the kernels cannot be used: the engines'
    ``evaluate_compiled``."""
    e, d = np.broadcast_arrays(np.asarray(e, dtype=float), np.asarray(d, dtype=float))
    if not available():
        return fallback(e, d)
    flat = (np.ascontiguousarray(x).ravel() for x in (e, d))
    return kernel(owner, *flat).reshape(e.shape)


def _no_nan(e: np.ndarray, d: np.ndarray) -> None:
    if np.isnan(e).any() or np.isnan(d).any():
        raise ValueError("fuzzy engine inputs contain NaN")


def mamdani(engine: Any, e: np.ndarray, d: np.ndarray) -> np.ndarray:
    """``engine._small`` on 1-D float arrays (NaN is an error)."""
    _no_nan(e, d)
    plan = engine._plan
    packed = _packed(engine)
    out = np.empty(e.size)
    _compiled()["mamdani"](
        e,
        d,
        plan.peaks_e_array,
        plan.peaks_de_array,
        plan.peaks_u,
        packed[0],
        packed[1],
        packed[2],
        engine.and_method == "min",
        float(engine.no_fire_output),
        out,
    )
    return out


_PACKED: dict[int, tuple[Any, np.ndarray, np.ndarray, np.ndarray]] = {}


def _packed(engine: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The output grid and the rule table of an engine as arrays (cached per engine)."""
    hit = _PACKED.get(id(engine))
    if hit is not None and hit[0] is engine:
        return hit[1:]
    plan = engine._plan
    table = plan.pair_table
    width = max(1, max(len(c) for row in table for c in row))
    cells = np.zeros((len(table), len(table[0]), width), dtype=np.int64)
    counts = np.zeros((len(table), len(table[0])), dtype=np.int64)
    for i, row in enumerate(table):
        for j, c in enumerate(row):
            counts[i, j] = len(c)
            cells[i, j, : len(c)] = c
    grid = np.array(plan.grid_u_list, dtype=float)
    _PACKED[id(engine)] = (engine, grid, cells, counts)
    return grid, cells, counts


def table(t: Any, e: np.ndarray, d: np.ndarray) -> np.ndarray:
    """``FuzzyTable.evaluate_floats`` on 1-D float arrays (NaN is an error)."""
    _no_nan(e, d)
    out = np.empty(e.size)
    _compiled()["table"](
        e, d, t.values.ravel(), t.points, t.e_lo, t.e_hi, t.e_scale, t.d_lo, t.d_hi, t.d_scale, out
    )
    return out


def continuous(c: Any, e: np.ndarray, d: np.ndarray) -> np.ndarray:
    """``ContinuousEngine.evaluate_floats`` on 1-D float arrays (NaN is an error)."""
    _no_nan(e, d)
    out = np.empty(e.size)
    _compiled()["continuous"](e, d, c._peaks_e, c._peaks_d, c._ravel, out)
    return out
