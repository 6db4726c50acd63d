"""Any MATLAB Fuzzy Logic Toolbox ``.fis`` file, read and evaluated: ``twolink.read_fis``.

:func:`read_fis` reads every Mamdani and Sugeno system the Toolbox writes (``writeFIS``,
the text format ``readfis`` reads): the membership functions trimf, trapmf, gaussmf,
gauss2mf, gbellmf, sigmf, dsigmf, psigmf, pimf, smf, zmf and the Sugeno outputs constant
and linear; AND (min, prod), OR (max, probor), NOT (a negative index) and don't-care (0);
rule weights; implication min / prod, aggregation max / sum / probor; defuzzification
centroid, bisector, mom, som, lom (Mamdani) and wtaver, wtsum (Sugeno); any number of
inputs and outputs. :meth:`Fis.evaluate` takes ``(n, inputs)`` and returns
``(n, outputs)``.

The arithmetic is the Toolbox's own, read from its C inference code (``fis.c``, "Stand-
alone C codes for fuzzy inference systems", J.-S. R. Jang, The MathWorks 1994-2005;
docs/fuzzy.md, "Any MATLAB FIS"): membership formulas, don't-care = 1 under AND and 0
under OR, NOT = 1 - mu, firing times weight, no clipping of inputs to their ranges, and
where the total firing strength is 0 every output is the middle of its range. The one
difference is the Mamdani defuzzification: the Toolbox samples the aggregated output on
``NumPoints`` (101) points and sums; :meth:`Fis.evaluate` integrates it
(:mod:`controllers.fuzzy.fis.exact`) unless ``sampled=True``.

:class:`FisTerm` makes a two-input, one-output system the fuzzy term of a controller
(``engine(e, de)`` on normalised inputs, like :class:`~controllers.fuzzy.engine.MamdaniEngine`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from twolink.controllers.fuzzy.fis.sections import (
    naming,
    numbers,
    read_sections,
    rule_indices,
    variable_range,
    variable_section,
    whole_number,
)

__all__ = ["Fis", "FisMF", "FisRule", "FisTerm", "FisVar", "parse_matlab_fis", "read_fis"]

MAX_FIS_BYTES = 1 << 20
# parameters each membership function takes (the Toolbox's files may pad with zeros)
MF_PARAMS = {
    "trimf": 3, "trapmf": 4, "gaussmf": 2, "gauss2mf": 4, "gbellmf": 3, "sigmf": 2,
    "dsigmf": 4, "psigmf": 4, "pimf": 4, "smf": 2, "zmf": 2,
}  # fmt: skip
AND_METHODS = ("min", "prod")
OR_METHODS = ("max", "probor")
IMP_METHODS = ("min", "prod")
AGG_METHODS = ("max", "sum", "probor")
MAMDANI_DEFUZZ = ("centroid", "bisector", "mom", "som", "lom")
SUGENO_DEFUZZ = ("wtaver", "wtsum")
DEFAULT_POINTS = 101  # evalfis's NumSamplePoints
# Bounds by memory (docs/fuzzy.md, "Any MATLAB FIS"): rules so that the exact mode's one
# input fits in 100 MiB (about 10 KiB a rule: exact.RULE_INPUT_BYTES); the Toolbox's
# sample points so that one sampled input's aggregate (points x rules) fits in 80 MiB;
# inputs per call: 10^8, ~10 min sampled at the measured ~6 us an input (tipper.fis; the
# exact mode 0.7-4 ms an input: far longer), 1.6 GB of two inputs;
# evaluate works through them in blocks of EVALUATE_BLOCK_BYTES of firing and aggregate
MAX_RULES = 10_000
MAX_POINTS = 1_000_000
MAX_INPUTS_PER_CALL = 100_000_000
EVALUATE_BLOCK_BYTES = 64 << 20


def _sig(x: np.ndarray, a: float, c: float) -> np.ndarray:
    with np.errstate(over="ignore"):
        return 1.0 / (1.0 + np.exp(-a * (x - c)))


def _smf(x: np.ndarray, a: float, b: float) -> np.ndarray:
    if a >= b:
        return (x >= (a + b) / 2).astype(float)
    m = (a + b) / 2
    return np.where(
        x <= a, 0.0,
        np.where(x <= m, 2 * ((x - a) / (b - a)) ** 2,
                 np.where(x <= b, 1 - 2 * ((b - x) / (b - a)) ** 2, 1.0)),
    )  # fmt: skip


def _zmf(x: np.ndarray, a: float, b: float) -> np.ndarray:
    if a >= b:
        return (x <= (a + b) / 2).astype(float)
    m = (a + b) / 2
    return np.where(
        x <= a, 1.0,
        np.where(x <= m, 1 - 2 * ((x - a) / (b - a)) ** 2,
                 np.where(x <= b, 2 * ((b - x) / (b - a)) ** 2, 0.0)),
    )  # fmt: skip


@dataclass(frozen=True)
class FisMF:
    """One membership function: its label, Toolbox type and parameters (Toolbox order)."""

    label: str
    kind: str
    params: tuple[float, ...]

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """The Toolbox's formula (``fis.c``), elementwise."""
        x = np.asarray(x, dtype=float)
        p, k = self.params, self.kind
        if k == "trimf":
            a, b, c = p
            if a == b == c:
                return (x == a).astype(float)
            if a == b:
                return np.where((b <= x) & (x <= c), (c - x) / (c - b), 0.0)
            if b == c:
                return np.where((a <= x) & (x <= b), (x - a) / (b - a), 0.0)
            return np.maximum(np.minimum((x - a) / (b - a), (c - x) / (c - b)), 0.0)
        if k == "trapmf":
            a, b, c, d = p
            with np.errstate(divide="ignore", invalid="ignore"):
                y1 = np.where(b <= x, 1.0, np.where(x < a, 0.0, (x - a) / (b - a)))
                y2 = np.where(x <= c, 1.0, np.where(d < x, 0.0, (d - x) / (d - c)))
            return np.minimum(y1, y2)
        if k == "gaussmf":
            s, c = p
            return np.exp(-(((x - c) / s) ** 2) / 2)
        if k == "gauss2mf":
            s1, c1, s2, c2 = p
            t1 = np.where(x >= c1, 1.0, np.exp(-(((x - c1) / s1) ** 2) / 2))
            t2 = np.where(x <= c2, 1.0, np.exp(-(((x - c2) / s2) ** 2) / 2))
            return t1 * t2
        if k == "gbellmf":
            a, b, c = p
            t = ((x - c) / a) ** 2
            with np.errstate(divide="ignore", over="ignore"):
                out = 1.0 / (1.0 + t**b)
            if b == 0:
                return np.where(t == 0, 0.5, out)
            return np.where(t == 0, 0.0, out) if b < 0 else out
        if k == "sigmf":
            return _sig(x, p[0], p[1])
        if k == "dsigmf":
            return np.abs(_sig(x, p[0], p[1]) - _sig(x, p[2], p[3]))
        if k == "psigmf":
            return _sig(x, p[0], p[1]) * _sig(x, p[2], p[3])
        if k == "smf":
            return _smf(x, p[0], p[1])
        if k == "zmf":
            return _zmf(x, p[0], p[1])
        if k == "pimf":
            return _smf(x, p[0], p[1]) * _zmf(x, p[2], p[3])
        raise ValueError(f"{self.label}: {k!r} is a Sugeno output, not a membership function")

    def features(self) -> list[tuple[float, float]]:
        """(point, width) pairs: the points where the function has a kink or its shape
        (a breakpoint: width 0) and, for the curved ones, the scale of the shape around
        them (the exact quadrature meshes there; :mod:`controllers.fuzzy.fis.exact`)."""
        p, k = self.params, self.kind
        if k in ("trimf", "trapmf"):
            return [(v, 0.0) for v in p]
        if k == "gaussmf":
            return [(p[1], abs(p[0]))]
        if k == "gauss2mf":
            return [(p[1], abs(p[0])), (p[3], abs(p[2]))]
        if k == "gbellmf":
            a, b, c = abs(p[0]), abs(p[1]), p[2]
            edge = a / max(b, 1.0)
            return [(c, a), (c - a, edge), (c + a, edge)]
        if k == "sigmf":
            return [(p[1], 1 / abs(p[0]) if p[0] else 0.0)]
        if k in ("dsigmf", "psigmf"):
            out = [(p[1], 1 / abs(p[0]) if p[0] else 0.0), (p[3], 1 / abs(p[2]) if p[2] else 0.0)]
            if k == "dsigmf" and p[0] != p[2]:  # |f1 - f2| has a kink where f1 = f2
                out.append(((p[0] * p[1] - p[2] * p[3]) / (p[0] - p[2]), 0.0))
            return out
        if k in ("smf", "zmf"):
            return [(p[0], 0.0), ((p[0] + p[1]) / 2, 0.0), (p[1], 0.0)]
        if k == "pimf":
            return [
                (v, 0.0) for v in (p[0], (p[0] + p[1]) / 2, p[1], p[2], (p[2] + p[3]) / 2, p[3])
            ]
        return []


@dataclass(frozen=True)
class FisVar:
    """An input or output: name, range and membership functions (Sugeno outputs: the
    ``constant`` / ``linear`` functions, kind and coefficients)."""

    name: str
    range: tuple[float, float]
    mfs: tuple[FisMF, ...]

    @property
    def mid(self) -> float:
        return 0.5 * (self.range[0] + self.range[1])


@dataclass(frozen=True)
class FisRule:
    """``antecedent`` and ``consequent`` indices (1-based; 0 don't-care, negative NOT),
    ``weight`` and ``connection`` (1 AND, 2 OR), as the file's ``i j, k (w) : c``."""

    antecedent: tuple[int, ...]
    consequent: tuple[int, ...]
    weight: float
    connection: int


@dataclass(frozen=True)
class Fis:
    """A Fuzzy Logic Toolbox system as read from a ``.fis`` file (see the module's
    docstring). ``evaluate(X)`` for outputs, ``firing(X)`` for the rules' strengths."""

    name: str
    type: str  # "mamdani" or "sugeno"
    and_method: str
    or_method: str
    imp_method: str
    agg_method: str
    defuzz_method: str
    inputs: tuple[FisVar, ...]
    outputs: tuple[FisVar, ...]
    rules: tuple[FisRule, ...]
    source: str = "<fis>"
    _cache: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    # ----- inference ------------------------------------------------------------------

    def _inputs(self, x: np.ndarray | Sequence) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        if x.ndim == 1 and len(self.inputs) == 1:
            x = x[:, None]
        if x.ndim == 1 and x.size == len(self.inputs):
            x = x[None, :]
        if x.ndim != 2 or x.shape[1] != len(self.inputs):
            raise ValueError(
                f"{self.source}: evaluate takes (n, {len(self.inputs)}) inputs, got {x.shape}"
            )
        if x.shape[0] > MAX_INPUTS_PER_CALL:
            raise ValueError(
                f"{self.source}: {x.shape[0]:,} inputs > {MAX_INPUTS_PER_CALL:,}, the most "
                "one call evaluates (~10 min sampled at ~6 us an input, far longer exact)"
            )
        if np.isnan(x).any():
            raise ValueError(f"{self.source}: inputs contain NaN")
        return x

    def firing(self, x: np.ndarray | Sequence) -> np.ndarray:
        """Rule firing strengths (n, rules): AND / OR of the antecedents (don't-care 1 under
        AND, 0 under OR; NOT 1 - mu), times the rule's weight. Inputs are not clipped to
        their ranges (the Toolbox evaluates the membership functions where they are)."""
        x = self._inputs(x)
        n = x.shape[0]
        mu = [
            np.stack([mf(x[:, i]) for mf in var.mfs], axis=1) for i, var in enumerate(self.inputs)
        ]
        out = np.empty((n, len(self.rules)))
        for r, rule in enumerate(self.rules):
            is_and = rule.connection == 1
            acc = None
            for i, idx in enumerate(rule.antecedent):
                if idx == 0:
                    v = np.full(n, 1.0 if is_and else 0.0)
                elif idx > 0:
                    v = mu[i][:, idx - 1]
                else:
                    v = 1.0 - mu[i][:, -idx - 1]
                if acc is None:
                    acc = v
                elif is_and:
                    acc = np.minimum(acc, v) if self.and_method == "min" else acc * v
                else:
                    acc = np.maximum(acc, v) if self.or_method == "max" else acc + v - acc * v
            out[:, r] = acc * rule.weight
        return out

    def evaluate(
        self, x: np.ndarray | Sequence, *, sampled: bool = False, points: int = DEFAULT_POINTS
    ) -> np.ndarray:
        """Outputs (n, outputs) for inputs (n, inputs).

        Mamdani outputs are defuzzified exactly (``sampled=False``: the aggregated output
        integrated, docs/fuzzy.md "Any MATLAB FIS") or as the Toolbox does
        (``sampled=True``: on ``points`` evenly spaced points of the output's range, sums
        in place of integrals; evalfis's default is 101). Sugeno outputs are the same
        either way. Where the total firing strength is 0 every output is the middle of
        its range, as in the Toolbox; so is a Mamdani output whose aggregate has no area.
        """
        x = self._inputs(x)
        if sampled and (isinstance(points, bool) or not isinstance(points, int) or points < 2):
            raise ValueError(f"points must be an integer >= 2, got {points!r}")
        if sampled and points > MAX_POINTS:
            raise ValueError(
                f"{self.source}: points: {points:,} > {MAX_POINTS:,}, the most whose "
                f"aggregate of one input fits in 80 MiB with few rules"
            )
        # blocks of inputs: the firing strengths (n, rules) and a sampled aggregate
        # (n, points) of a block stay under EVALUATE_BLOCK_BYTES (8 bytes, ~4 copies)
        width = len(self.rules) + (points if sampled else 0) + 1
        block = max(1, EVALUATE_BLOCK_BYTES // (32 * width))
        out = np.empty((x.shape[0], len(self.outputs)))
        for s in range(0, x.shape[0], block):
            out[s : s + block] = self._evaluate_block(x[s : s + block], sampled, points)
        return out

    def _evaluate_block(self, x: np.ndarray, sampled: bool, points: int) -> np.ndarray:
        from twolink.controllers.fuzzy.fis import exact as matlab_exact

        w = self.firing(x)
        out = np.empty((x.shape[0], len(self.outputs)))
        fired = w.sum(axis=1) > 0  # the Toolbox's test: the sum of the firing strengths
        for m, var in enumerate(self.outputs):
            cons = np.array([r.consequent[m] for r in self.rules], dtype=int)
            if self.type == "sugeno":
                z = np.stack([_sugeno_value(mf, x) for mf in var.mfs], axis=1)
                rz = np.where(cons == 0, 0.0, z[:, np.maximum(np.abs(cons), 1) - 1])
                num = (w * rz).sum(axis=1)
                total = w.sum(axis=1)
                if self.defuzz_method == "wtaver":
                    val = num / np.where(fired, total, 1.0)
                else:
                    val = num
            elif sampled:
                val = matlab_exact.sampled_defuzz(self, m, w, cons, points)
            else:
                val = matlab_exact.exact_defuzz(self, m, w, cons)
            out[:, m] = np.where(fired, val, var.mid)
        return out

    def __call__(self, x: np.ndarray | Sequence, **kwargs) -> np.ndarray:
        return self.evaluate(x, **kwargs)

    def term(self, *, sampled: bool = False, points: int = DEFAULT_POINTS) -> FisTerm:
        """This system as a controller's fuzzy term (:class:`FisTerm`): two inputs (error,
        rate), one output; a ValueError names the file otherwise."""
        return FisTerm(self, sampled=sampled, points=points)


def _sugeno_value(mf: FisMF, x: np.ndarray) -> np.ndarray:
    if mf.kind == "constant":
        return np.full(x.shape[0], mf.params[0])
    return x @ np.asarray(mf.params[:-1]) + mf.params[-1]


# ----------------------------------------------------------------------------- reading

_MF = re.compile(r"^MF(\d+)\s*=\s*'([^']*)'\s*:\s*'([^']+)'\s*,\s*\[([^\]]*)\]$")
_RULE = re.compile(r"^([-+\d\s.eE]+),([-+\d\s.eE]+)\(([-+\d.eE]+)\)\s*:\s*([\d.]+)$")


def _variable(sections: dict, section: str, source: str, sugeno_out: bool, n_inputs: int) -> FisVar:
    """An ``[InputN]`` / ``[OutputN]`` section: its range and membership functions."""
    body, where = variable_section(sections, section, source)
    rng = variable_range(body, where, closed=sugeno_out)
    mfs = []
    for n in range(1, whole_number(body.get("NumMFs", "0"), f"{where} NumMFs") + 1):
        m = _MF.match(body.get(f"MF{n}", ""))
        if not m:
            raise ValueError(f"{where}: MF{n} missing or not 'label':'type',[params]")
        label, mf_kind, params = m.group(2), m.group(3), numbers(m.group(4), f"{where} MF{n}")
        if sugeno_out:
            need = {"constant": 1, "linear": n_inputs + 1}.get(mf_kind)
            if need is None:
                raise ValueError(
                    f"{where} MF{n}: {mf_kind!r}: Sugeno outputs are constant or linear"
                )
        else:
            need = MF_PARAMS.get(mf_kind)
            if need is None:
                raise ValueError(
                    f"{where} MF{n}: {mf_kind!r} is not a Toolbox membership function "
                    f"(read: {sorted(MF_PARAMS)})"
                )
        if len(params) < need:
            raise ValueError(f"{where} MF{n}: {mf_kind} takes {need} parameters, got {len(params)}")
        params = params[:need]  # old files pad every MF's parameters with zeros
        _check_params(mf_kind, params, f"{where} MF{n}")
        mfs.append(FisMF(label, mf_kind, params))
    return FisVar(body.get("Name", section), rng, tuple(mfs))


def _rule(line: str, where: str, inputs, outputs, sugeno: bool) -> FisRule:
    """One ``[Rules]`` line, ``i j, k (w) : c``, checked against the variables."""
    m, ante, cons = rule_indices(_RULE, line, where, len(inputs), len(outputs))
    for idx, var in zip((*ante, *cons), (*inputs, *outputs), strict=True):
        if abs(idx) > len(var.mfs):
            raise ValueError(f"{where}: index {idx}: {var.name} has {len(var.mfs)} MFs")
    if sugeno and min(cons, default=0) < 0:
        raise ValueError(f"{where}: NOT on a Sugeno output (the Toolbox has no such thing)")
    weight = float(m.group(3))
    connection = whole_number(m.group(4), f"{where}: connection")
    if connection not in (1, 2):
        raise ValueError(f"{where}: connection {connection}: 1 (AND) or 2 (OR)")
    if not (math.isfinite(weight) and 0 <= weight <= 1):
        raise ValueError(f"{where}: weight {weight}: a number in [0, 1]")
    return FisRule(ante, cons, weight, connection)


def parse_matlab_fis(text: str, source: str = "<fis>") -> Fis:
    """A :class:`Fis` from ``.fis`` text; every error is one line naming ``source``."""
    with naming(source):
        return _parse(text, source)


def _parse(text: str, source: str) -> Fis:
    sections = read_sections(text, source, _MF, trailing_comments=True)
    system = sections["System"]
    kind = system.get("Type", "mamdani").lower()
    if kind not in ("mamdani", "sugeno"):
        raise ValueError(f"{source}: [System] Type {kind!r}: the Toolbox's are mamdani, sugeno")

    def count(key: str) -> int:
        if key not in system:
            raise ValueError(f"{source}: [System] {key}: missing")
        return whole_number(system[key], f"{source}: [System] {key}")

    n_in, n_out = count("NumInputs"), count("NumOutputs")
    inputs = tuple(
        _variable(sections, f"Input{i}", source, False, n_in) for i in range(1, n_in + 1)
    )
    sugeno = kind == "sugeno"
    outputs = tuple(
        _variable(sections, f"Output{i}", source, sugeno, n_in) for i in range(1, n_out + 1)
    )
    rules = tuple(
        _rule(line, f"{source}: line {number} (rule {n})", inputs, outputs, sugeno)
        for n, (number, line) in enumerate(sections.get("Rules", []), start=1)
    )
    if not inputs or not outputs:
        raise ValueError(f"{source}: needs at least one input and one output")
    if len(rules) > MAX_RULES:
        raise ValueError(
            f"{source}: [Rules]: {len(rules):,} rules > {MAX_RULES:,}, the most whose exact "
            "evaluation of one input fits in 100 MiB (about 10 KiB a rule)"
        )
    connections = {r.connection for r in rules}

    def method(key: str, allowed: tuple[str, ...], default: str, used: bool = True) -> str:
        # as the Toolbox: a method no rule calls (OrMethod of an all-AND file) is never run
        value = system.get(key, default)
        if used and value not in allowed:
            raise ValueError(
                f"{source}: [System] {key}={value!r}: a custom function (read: {list(allowed)})"
            )
        return value

    defuzz = SUGENO_DEFUZZ if sugeno else MAMDANI_DEFUZZ
    return Fis(
        name=system.get("Name", Path(source).stem),
        type=kind,
        and_method=method("AndMethod", AND_METHODS, "prod" if sugeno else "min", 1 in connections),
        or_method=method("OrMethod", OR_METHODS, "probor" if sugeno else "max", 2 in connections),
        # Sugeno files name an implication and aggregation the Toolbox does not use
        imp_method="prod" if sugeno else method("ImpMethod", IMP_METHODS, "min"),
        agg_method="sum" if sugeno else method("AggMethod", AGG_METHODS, "max"),
        defuzz_method=method("DefuzzMethod", defuzz, defuzz[0]),
        inputs=inputs,
        outputs=outputs,
        rules=rules,
        source=source,
    )


def _check_params(kind: str, p: tuple[float, ...], where: str) -> None:
    """What the Toolbox refuses (``fis.c``: illegal parameters) or cannot evaluate."""
    if not all(math.isfinite(v) for v in p):
        raise ValueError(f"{where}: parameters must be finite, got {list(p)}")
    bad = (
        (kind == "trimf" and not p[0] <= p[1] <= p[2])
        or (kind == "trapmf" and not p[0] <= p[1] <= p[2] <= p[3])
        or (kind == "gaussmf" and p[0] == 0)
        or (kind == "gauss2mf" and (p[0] == 0 or p[2] == 0))
        or (kind == "gbellmf" and p[0] == 0)
    )
    if bad:
        raise ValueError(f"{where}: illegal {kind} parameters {list(p)} (the Toolbox refuses them)")


def read_fis(path: str | Path) -> Fis:
    """Read a MATLAB Fuzzy Logic Toolbox ``.fis`` file (a regular file of at most 1 MiB)
    as a :class:`Fis`: ``read_fis(path).evaluate(X)``, X of shape (n, inputs)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: no such file" if not path.exists() else f"{path}: not a file")
    if path.stat().st_size > MAX_FIS_BYTES:
        raise ValueError(f"{path}: larger than {MAX_FIS_BYTES} bytes")
    try:
        text = path.read_text()
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file") from None
    return parse_matlab_fis(text, str(path))


# ----------------------------------------------------------------------------- the fuzzy term


@dataclass(frozen=True, eq=False)
class _Universe:
    """A normalised variable's ends and labels, as much of a
    :class:`~controllers.fuzzy.membership.FuzzyVariable` as the table and coverage read
    (no sampled table: it is not the project's triangular partition)."""

    universe: np.ndarray  # (low, high)
    labels: tuple[str, ...]

    @property
    def grid(self) -> np.ndarray:
        return self.universe

    @property
    def table(self) -> np.ndarray:
        return np.empty((0, 2))


@dataclass(frozen=True, eq=False)
class FisTerm:
    """A two-input (error, rate), one-output :class:`Fis` as a controller's fuzzy term,
    on normalised universes like :class:`~controllers.fuzzy.engine.MamdaniEngine`:

        term(e, de) = F(clip(e R_e), clip(de R_de)) / R_u,

    R the largest magnitude of a variable's range (1 for a Sugeno output's [0 0]) and clip
    to the file's ranges (the
    project's engines clip their inputs; the Toolbox does not). ``scaling`` =
    (1/R_e, 1/R_de, R_u) gives back the file's own physical law as
    ``ku term(ke e, kde de)``; a scenario's ``[controller.fuzzy]`` ke, kde, ku apply as for
    any rule base. ``e``, ``de``, ``u`` carry the normalised ``universe`` ends (what
    :class:`~controllers.fuzzy.table.FuzzyTable` tabulates)."""

    fis: Fis
    sampled: bool = False
    points: int = DEFAULT_POINTS

    def __post_init__(self) -> None:
        f = self.fis
        if (len(f.inputs), len(f.outputs)) != (2, 1):
            raise ValueError(
                f"{f.source}: a fuzzy term takes 2 inputs (error, rate) and 1 output; this "
                f"system has {len(f.inputs)} inputs and {len(f.outputs)} outputs"
            )
        # a Sugeno output's range may be [0 0] (the Toolbox uses it only where nothing
        # fires): its output is then not scaled
        scale = [max(abs(v.range[0]), abs(v.range[1])) or 1.0 for v in (*f.inputs, *f.outputs)]
        object.__setattr__(self, "_scale", tuple(scale))
        for name, var, s in zip(("e", "de", "u"), (*f.inputs, *f.outputs), scale, strict=True):
            lo, hi = var.range
            ends = np.array([lo / s, hi / s])
            ends.setflags(write=False)
            object.__setattr__(self, name, _Universe(ends, tuple(mf.label for mf in var.mfs)))

    @property
    def scaling(self) -> tuple[float, float, float]:
        """(ke, kde, ku) that make ``ku term(ke e, kde de)`` the file's own law."""
        re_, rd, ru = self._scale
        return 1.0 / re_, 1.0 / rd, ru

    @property
    def rules(self) -> tuple[str, ...]:
        """The rules as short text (``"poor|rancid→cheap"``: ``|`` OR, ``,`` AND, ``¬``
        NOT, ``*`` don't-care, a weight other than 1 in brackets), the labels a recording
        shows for the fired rule."""
        f = self.fis
        out = []
        for rule in f.rules:
            parts = []
            pairs = zip((*f.inputs, *f.outputs), (*rule.antecedent, *rule.consequent), strict=True)
            for var, idx in pairs:
                label = var.mfs[abs(idx) - 1].label if idx else "*"
                parts.append(("¬" if idx < 0 else "") + label)
            joint = "," if rule.connection == 1 else "|"
            text = f"{joint.join(parts[: len(f.inputs)])}→{','.join(parts[len(f.inputs) :])}"
            out.append(text + (f" ({rule.weight:g})" if rule.weight != 1 else ""))
        return tuple(out)

    def _physical(self, e: np.ndarray, de: np.ndarray) -> np.ndarray:
        (e_lo, e_hi), (d_lo, d_hi) = self.fis.inputs[0].range, self.fis.inputs[1].range
        re_, rd, _ = self._scale
        return np.stack([np.clip(e * re_, e_lo, e_hi), np.clip(de * rd, d_lo, d_hi)], axis=1)

    def evaluate_batch(self, e: np.ndarray | float, de: np.ndarray | float) -> np.ndarray:
        e, de = np.broadcast_arrays(np.asarray(e, dtype=float), np.asarray(de, dtype=float))
        if np.isnan(e).any() or np.isnan(de).any():
            raise ValueError("fuzzy engine inputs contain NaN")
        x = self._physical(e.ravel(), de.ravel())
        u = self.fis.evaluate(x, sampled=self.sampled, points=self.points)[:, 0]
        return (u / self._scale[2]).reshape(e.shape)

    def __call__(self, e: np.ndarray | float, de: np.ndarray | float) -> np.ndarray:
        return self.evaluate_batch(e, de)

    def evaluate_floats(self, es: Sequence[float], ds: Sequence[float]) -> list[float]:
        return self.evaluate_batch(np.asarray(es, float), np.asarray(ds, float)).tolist()

    def firing(self, e: np.ndarray | float, de: np.ndarray | float) -> np.ndarray:
        e, de = np.broadcast_arrays(np.asarray(e, dtype=float), np.asarray(de, dtype=float))
        w = self.fis.firing(self._physical(e.ravel(), de.ravel()))
        return w.reshape(e.shape + (len(self.fis.rules),))


def rule_base_engine(path: str | Path):
    """The fuzzy term a rule-base file gives a controller (docs/fuzzy.md, "Any MATLAB
    FIS"): a TOML rule base, or a ``.fis`` whose membership functions are the project's
    7-label partition (what ``twolink fis`` writes), is the project's engine with those
    rules, as before; any other ``.fis`` with two inputs (error, rate) and one output is
    a :class:`FisTerm` (exact). Errors are one line naming the file."""
    from twolink.controllers.fuzzy import default_fuzzy_pd
    from twolink.controllers.fuzzy.fis.engine_files import read_rule_base

    path = Path(path)
    if path.suffix.lower() != ".fis":
        return default_fuzzy_pd().with_rules(read_rule_base(path))
    try:
        return default_fuzzy_pd().with_rules(read_rule_base(path))
    except ValueError:
        return read_fis(path).term()
