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
import os
import tomllib
import types
from bisect import bisect_left, bisect_right
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal, NamedTuple

import numpy as np
import skfuzzy

from twolink.io import atomic_write_text, toml_key, toml_string, toml_table, toml_value

__all__ = [
    "LABELS_7",
    "MIRROR_LABELS",
    "RULEBASE_DIR",
    "FuzzyVariable",
    "MamdaniEngine",
    "MembershipFunction",
    "Rule",
    "RuleBase",
    "default_fuzzy_pd",
    "load_rule_base",
    "paper_fuzzy_pd",
    "pd_rule_table",
    "save_rule_base",
    "triangular_partition",
]

LABELS_7: tuple[str, ...] = ("NB", "NM", "NS", "Z", "PS", "PM", "PB")
"""The seven linguistic labels, from negative big to positive big."""

MIRROR_LABELS: Mapping[str, str] = types.MappingProxyType(
    {"NB": "PB", "NM": "PM", "NS": "PS", "Z": "Z", "PS": "NS", "PM": "NM", "PB": "NB"}
)
"""Label reflection x -> -x, used to read rule bases written for the opposite error sign."""

RULEBASE_DIR: Path = Path(__file__).resolve().parent / "rulebases"
"""Folder of the rule-base data files shipped with the package."""

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


# --------------------------------------------------------------------------------------
# Membership functions and linguistic variables
# --------------------------------------------------------------------------------------


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


# --------------------------------------------------------------------------------------
# Rules and rule-base files
# --------------------------------------------------------------------------------------


class Rule(NamedTuple):
    """One rule: IF e is ``e`` AND de is ``de`` THEN u is ``u`` (labels)."""

    e: str
    de: str
    u: str


@dataclass(frozen=True)
class RuleBase:
    """Rules read from a TOML file, in this project's sign convention.

    Attributes
    ----------
    rules : tuple of Rule
        The rules, input labels already mirrored if the file asked for it.
    metadata : Mapping
        The file's other top-level tables (read-only), e.g. source or evidence.
    mirror_inputs : bool
        True if the file stores input labels in the opposite error convention.
    """

    rules: tuple[Rule, ...]
    metadata: Mapping[str, Any] = field(default_factory=lambda: types.MappingProxyType({}))
    mirror_inputs: bool = False

    def __iter__(self) -> Iterator[Rule]:
        return iter(self.rules)

    def __len__(self) -> int:
        return len(self.rules)


def pd_rule_table(labels: Sequence[str] = LABELS_7) -> tuple[Rule, ...]:
    """The usual diagonal PD table: ``u`` index = clip(i_e + i_de - mid, 0, n - 1).

    With the 7 labels this is ``clip(i_e + i_de - 3, 0, 6)``, i.e. ``u ~ e + de``.
    It is what ``rulebases/default_7x7.toml`` stores; the file, not this
    function, is what ``default_fuzzy_pd`` reads.
    """
    labels = tuple(labels)
    n = len(labels)
    if n % 2 != 1:
        raise ValueError("the diagonal table needs an odd number of labels")
    mid = n // 2
    return tuple(
        Rule(labels[i], labels[j], labels[min(max(i + j - mid, 0), n - 1)])
        for i in range(n)
        for j in range(n)
    )


def _mirror(label: str, where: str) -> str:
    try:
        return MIRROR_LABELS[label]
    except KeyError:
        raise ValueError(
            f"{where}: cannot mirror label {label!r} (known: {sorted(MIRROR_LABELS)})"
        ) from None


def _freeze(value: Any) -> Any:
    if isinstance(value, Mapping):
        return types.MappingProxyType({k: _freeze(v) for k, v in value.items()})
    if isinstance(value, list | tuple):
        return tuple(_freeze(v) for v in value)
    return value


def load_rule_base(path: str | os.PathLike[str]) -> RuleBase:
    """Read a rule base from a TOML file.

    Format: an optional top-level boolean ``mirror_inputs``; a non-empty
    ``[[rule]]`` array of tables, each with exactly the string keys ``e``,
    ``de`` and ``u``; any other top-level *tables* are metadata, exposed
    read-only in ``RuleBase.metadata``. With ``mirror_inputs = true`` the input
    labels are reflected (NB<->PB, NM<->PM, NS<->PS) into this project's
    convention ``e = theta_d - theta``; output labels are kept as written.

    Parameters
    ----------
    path : path-like
        The TOML file.

    Returns
    -------
    RuleBase

    Raises
    ------
    ValueError
        On malformed content; the message names the file and the key.
    """
    path = Path(path)
    with path.open("rb") as fh:
        try:
            data = tomllib.load(fh)
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"{path}: not valid TOML: {exc}") from exc
    mirror = data.pop("mirror_inputs", False)
    if not isinstance(mirror, bool):
        raise ValueError(f"{path}: 'mirror_inputs' must be true or false, got {mirror!r}")
    raw_rules = data.pop("rule", None)
    if not isinstance(raw_rules, list) or not raw_rules:
        raise ValueError(f"{path}: needs a non-empty [[rule]] array of tables")
    metadata = {}
    for key, value in data.items():
        if not isinstance(value, dict):
            raise ValueError(
                f"{path}: unknown top-level key {key!r} (only 'mirror_inputs', "
                "[[rule]] and metadata tables are allowed)"
            )
        metadata[key] = value
    rules = []
    for n, item in enumerate(raw_rules):
        where = f"{path}: rule[{n}]"
        if not isinstance(item, dict):
            raise ValueError(f"{where}: must be a table with keys e, de, u")
        if set(item) != {"e", "de", "u"}:
            extra = sorted(set(item) - {"e", "de", "u"})
            missing = sorted({"e", "de", "u"} - set(item))
            raise ValueError(
                f"{where}: keys must be exactly e, de, u (unknown {extra}, missing {missing})"
            )
        for key in ("e", "de", "u"):
            if not isinstance(item[key], str):
                raise ValueError(f"{where}: {key!r} must be a string label, got {item[key]!r}")
        e, de = item["e"], item["de"]
        if mirror:
            e, de = _mirror(e, f"{where}.e"), _mirror(de, f"{where}.de")
        rules.append(Rule(e, de, item["u"]))
    return RuleBase(tuple(rules), _freeze(metadata), mirror)


def save_rule_base(
    path: str | os.PathLike[str],
    rules: RuleBase | Iterable[Rule | Sequence[str]],
    *,
    metadata: Mapping[str, Mapping[str, Any]] | None = None,
    mirror_inputs: bool | None = None,
) -> Path:
    """Write a rule base as TOML (atomically: temporary file, then rename).

    Parameters
    ----------
    path : path-like
        Destination file.
    rules : RuleBase or iterable of Rule / (e, de, u)
        Rules in this project's convention.
    metadata : mapping of str to mapping, optional
        Top-level metadata tables (e.g. ``{"design": {...}, "evidence": {...}}``)
        with TOML-representable values (str, int, float, bool, lists, nested
        mappings; numpy scalars and arrays are converted). Defaults to the
        RuleBase's own metadata, else none.
    mirror_inputs : bool, optional
        If true, input labels are written mirrored and the file says
        ``mirror_inputs = true``, so loading gives back the same rules. Defaults
        to the RuleBase's flag, else false.

    Returns
    -------
    Path
        The written file.
    """
    path = Path(path)
    if isinstance(rules, RuleBase):
        if metadata is None:
            metadata = rules.metadata
        if mirror_inputs is None:
            mirror_inputs = rules.mirror_inputs
        rule_list = list(rules.rules)
    else:
        rule_list = [Rule(*r) for r in rules]
    mirror_inputs = bool(mirror_inputs)
    metadata = {} if metadata is None else metadata
    if not rule_list:
        raise ValueError("a rule base needs at least one rule")
    lines = [
        "# Fuzzy rule base for controllers.fuzzy (read with controllers.fuzzy.load_rule_base).",
        f"mirror_inputs = {toml_value(mirror_inputs)}",
        "",
    ]
    for name, table in metadata.items():
        if name in ("rule", "mirror_inputs"):
            raise ValueError(f"metadata table name {name!r} is reserved")
        if not isinstance(table, Mapping):
            raise TypeError(f"metadata[{name!r}] must be a mapping (a TOML table)")
        toml_table(lines, toml_key(name), table)
    for r in rule_list:
        e, de = (_mirror(r.e, "rule e"), _mirror(r.de, "rule de")) if mirror_inputs else (r.e, r.de)
        lines += [
            "[[rule]]",
            f"e = {toml_string(e)}",
            f"de = {toml_string(de)}",
            f"u = {toml_string(r.u)}",
            "",
        ]
    atomic_write_text(path, "\n".join(lines))
    return path


# --------------------------------------------------------------------------------------
# The engine
# --------------------------------------------------------------------------------------


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
    # Fast path (triangular partitions + centroid); None when not applicable.
    peaks_u: np.ndarray | None
    peaks_e: tuple[float, ...] | None
    peaks_de: tuple[float, ...] | None
    peaks_u_list: tuple[float, ...] | None
    grid_u_list: tuple[float, ...] | None
    pair_table: tuple[tuple[tuple[int, ...], ...], ...] | None


def _plan_for(engine: MamdaniEngine) -> _Plan:
    r_e = np.array([engine.e.index(r.e) for r in engine.rules], dtype=np.intp)
    r_de = np.array([engine.de.index(r.de) for r in engine.rules], dtype=np.intp)
    r_u = np.array([engine.u.index(r.u) for r in engine.rules], dtype=np.intp)
    order = np.argsort(r_u, kind="stable")
    used_u, starts = np.unique(r_u[order], return_index=True)
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
        peaks_u=None if pu is None else np.array(pu),
        peaks_e=pe if small_ok else None,
        peaks_de=pd if small_ok else None,
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
        flat_e, flat_de = e_arr.ravel(), de_arr.ravel()
        out = np.empty(flat_e.size)
        for s in range(0, flat_e.size, _CHUNK):
            sl = slice(s, s + _CHUNK)
            out[sl] = self._batch(flat_e[sl], flat_de[sl])
        return out.reshape(e_arr.shape)

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
        if np.isnan(e).any() or np.isnan(de).any():
            raise ValueError("fuzzy engine inputs contain NaN")
        plan = self._plan
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
            out = self._centroid_rows(rows)
        else:
            out = self._grid_defuzz(rows.T)
        return np.where(fired, out, self.no_fire_output)

    def _centroid_partition(self, cuts: np.ndarray) -> np.ndarray:
        """Closed-form centroid from clip levels (N, n_terms); see ``_centroid_rows``."""
        return self._centroid_rows(np.ascontiguousarray(cuts.T))

    def _centroid_rows(self, cuts: np.ndarray) -> np.ndarray:
        """Closed-form skfuzzy centroid for a triangular output partition (see docs/fuzzy.md).

        ``cuts`` is (n_terms, N). Between neighbouring output peaks p < q, in
        t = (x - p) / (q - p), the aggregate is A(t) = max(min(a, 1 - t), min(b, t)) with
        a, b the clip levels of the falling and the rising term. Its area and first moment
        have closed forms. skfuzzy's grid holds every kink of A but one, the point s where
        the two clipped terms meet, and joins the grid neighbours tl <= s <= tr of s by a
        chord instead: that adds the triangle between chord and A, of area
        k (s - tl)(tr - s) / 2 with k the slope change of A at s, centroid (tl + s + tr) / 3.
        """
        peaks = self._plan.peaks_u
        grid = self.u.grid
        p, q = peaks[:-1, None], peaks[1:, None]
        h = q - p
        a, b = cuts[:-1], cuts[1:]
        aa, bb = a * a, b * b
        c = np.minimum(np.minimum(a, b), 0.5)  # the value of A at s
        cc = c - c * c
        area = a - 0.5 * aa + b - 0.5 * bb - cc
        mom = 0.5 * (a - aa + b - cc) + (aa * a - bb * b) / 6.0
        # Kink: the midpoint if both clips reach 0.5 (slopes -1 | +1, or 0 where a clip is
        # exactly 0.5), else where the lower clip level meets the other term's edge.
        mid = c == 0.5
        a_low = a <= b
        s = np.where(mid, 0.5, np.where(a_low, a, 1.0 - b))
        k = np.where(mid, (a > 0.5).astype(float) + (b > 0.5), np.where(a_low, b > a, 1.0))
        xs = np.minimum(p + s * h, q)
        idx = np.searchsorted(grid, xs, side="left")
        gr = grid[idx]
        gl = np.where(gr == xs, gr, grid[np.maximum(idx - 1, 0)])
        tl, tr = (gl - p) / h, (gr - p) / h
        for tk in (1.0 - a, b):  # the two terms' crossing points are grid points too
            np.maximum(tl, tk, out=tl, where=tk <= s)
            np.minimum(tr, tk, out=tr, where=tk >= s)
        extra = 0.5 * k * (s - tl) * (tr - s)
        area += extra
        mom += extra * (tl + s + tr) / 3.0
        total_area = (h * area).sum(axis=0)
        total_mom = (h * (p * area + h * mom)).sum(axis=0)
        return total_mom / np.maximum(total_area, _EPS)

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


# --------------------------------------------------------------------------------------
# The project's engines
# --------------------------------------------------------------------------------------


def _standard_engine(
    rules: RuleBase,
    and_method: AndMethod,
    defuzz: DefuzzMethod,
    no_fire_output: float,
    n_points: int,
) -> MamdaniEngine:
    var = triangular_partition(LABELS_7, -1.0, 1.0, n_points)
    return MamdaniEngine(var, var, var, rules.rules, and_method, defuzz, no_fire_output)


def default_fuzzy_pd(
    *,
    and_method: AndMethod = "min",
    defuzz: DefuzzMethod = "centroid",
    no_fire_output: float = 0.0,
    n_points: int = 61,
) -> MamdaniEngine:
    """The heuristic 7x7 fuzzy PD engine (``u ~ e + de``) on normalised universes.

    e, de and u live on [-1, 1] with the 7 labels NB..PB as evenly spaced
    triangles (``triangular_partition``); the rules are read from
    ``rulebases/default_7x7.toml`` (the diagonal table of ``pd_rule_table``).

    Parameters
    ----------
    and_method, defuzz, no_fire_output
        See ``MamdaniEngine``.
    n_points : int
        Samples per universe (``n_points - 1`` a multiple of 6).

    Returns
    -------
    MamdaniEngine
    """
    rules = load_rule_base(RULEBASE_DIR / "default_7x7.toml")
    return _standard_engine(rules, and_method, defuzz, no_fire_output, n_points)


def paper_fuzzy_pd(
    *,
    and_method: AndMethod = "min",
    defuzz: DefuzzMethod = "centroid",
    no_fire_output: float = 0.0,
    n_points: int = 61,
) -> MamdaniEngine:
    """The same engine as ``default_fuzzy_pd`` with the paper's Table 1 (5 rules).

    The rules come from ``rulebases/paper_table1.toml``, which stores the
    paper's labels verbatim with ``mirror_inputs = true``: in this project's
    convention they read (NB,NS->NB), (PS,NB->NS), (PS,PS->PM), (PB,PB->PB),
    (NS,PB->NM). Most of the (e, de) plane fires no rule; there the engine
    returns ``no_fire_output``.
    """
    rules = load_rule_base(RULEBASE_DIR / "paper_table1.toml")
    return _standard_engine(rules, and_method, defuzz, no_fire_output, n_points)
