"""twolink's own engine as a MATLAB Fuzzy Logic Toolbox file (``.fis``, the text format
``readfis`` reads and ``writeFIS`` writes): export any engine with its scaling, import one back.

A ``.fis`` file names its system (``[System]``: Mamdani, AND / OR / implication /
aggregation / defuzzification methods), each input and output (``[Input1]``...: name,
range, membership functions ``MF1='NB':'trimf',[a b c]``) and its rules (``[Rules]``:
``i j, k (weight) : connection``, 1-based membership indices, connection 1 = AND).

twolink's engine works on normalised universes, scaled by ke, kde and ku
(:class:`~twolink.controllers.fuzzy_ctc.FuzzyComputedTorque`). The export writes the
physical system a MATLAB user would simulate: the error's range and membership
parameters divided by ke, the error rate's by kde, the output's multiplied by ku
(``scaling=(1, 1, 1)`` keeps them normalised); :func:`read_engine` gives the normalised
engine back with that scaling. What twolink's engine cannot run (OR rules, a don't-care
input, weights other than 1, other implication or aggregation) is refused with the rule or
key named.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from twolink.controllers.fuzzy.engine import MamdaniEngine
from twolink.controllers.fuzzy.fis.sections import (
    naming,
    numbers,
    read_sections,
    rule_indices,
    variable_range,
    variable_section,
    whole_number,
)
from twolink.controllers.fuzzy.membership import FuzzyVariable, MembershipFunction
from twolink.controllers.fuzzy.rulebase import Rule

__all__ = ["FisSystem", "engine_from_fis", "parse_fis", "read_engine", "to_fis", "write_fis"]

_TYPES = {"tri": "trimf", "trap": "trapmf", "gauss": "gaussmf"}
_KINDS = {v: k for k, v in _TYPES.items()}
_DEFUZZ = {"centroid": "centroid", "bisector": "bisector", "mom": "mom"}
_AND = {"min": "min", "prod": "product"}
MAX_FIS_BYTES = 1 << 20


@dataclass(frozen=True)
class FisVariable:
    name: str
    range: tuple[float, float]
    mfs: tuple[tuple[str, str, tuple[float, ...]], ...]  # (label, MATLAB type, params)


@dataclass(frozen=True)
class FisSystem:
    """A ``.fis`` file as read: its ``[System]`` keys, variables and rules."""

    system: dict[str, str]
    inputs: tuple[FisVariable, ...]
    outputs: tuple[FisVariable, ...]
    rules: tuple[tuple[tuple[int, ...], tuple[int, ...], float, int], ...]


# ----------------------------------------------------------------------------- writing


def _scaled(var: FuzzyVariable, name: str, factor: float) -> list[str]:
    lo, hi = var.universe[0] * factor, var.universe[-1] * factor
    lines = [f"Name='{name}'", f"Range=[{lo!r} {hi!r}]", f"NumMFs={len(var.labels)}"]
    for n, (label, mf) in enumerate(zip(var.labels, var.mfs, strict=True), start=1):
        params = [p * factor for p in mf.params]
        if mf.kind == "gauss":  # MATLAB's gaussmf takes [sigma mean]
            params = [params[1], params[0]]
        text = " ".join(repr(float(p)) for p in params)  # shortest exact round trip
        lines.append(f"MF{n}='{label}':'{_TYPES[mf.kind]}',[{text}]")
    return lines


def to_fis(
    engine: MamdaniEngine,
    name: str = "twolink",
    scaling: tuple[float, float, float] = (1.0, 1.0, 1.0),
) -> str:
    """The ``.fis`` text of ``engine`` with ``scaling = (ke, kde, ku)`` applied (see the
    module's docstring); inputs named ``e`` and ``de``, the output ``u``."""
    ke, kde, ku = (float(s) for s in scaling)
    if not all(s > 0 and np.isfinite(s) for s in (ke, kde, ku)):
        raise ValueError(f"scaling must be finite numbers > 0, got {scaling}")
    and_name = {v: k for k, v in _AND.items()}[engine.and_method]
    lines = [
        "[System]",
        f"Name='{name}'",
        "Type='mamdani'",
        "Version=2.0",
        "NumInputs=2",
        "NumOutputs=1",
        f"NumRules={len(engine.rules)}",
        f"AndMethod='{and_name}'",
        "OrMethod='max'",
        "ImpMethod='min'",
        "AggMethod='max'",
        f"DefuzzMethod='{engine.defuzz}'",
        "",
        "[Input1]",
        *_scaled(engine.e, "e", 1.0 / ke),
        "",
        "[Input2]",
        *_scaled(engine.de, "de", 1.0 / kde),
        "",
        "[Output1]",
        *_scaled(engine.u, "u", ku),
        "",
        "[Rules]",
    ]
    index = [{label: i + 1 for i, label in enumerate(v.labels)} for v in (engine.e, engine.de)]
    out_index = {label: i + 1 for i, label in enumerate(engine.u.labels)}
    for r in engine.rules:
        lines.append(f"{index[0][r.e]} {index[1][r.de]}, {out_index[r.u]} (1) : 1")
    return "\n".join(lines) + "\n"


def write_fis(path: str | Path, engine: MamdaniEngine, name: str = "twolink", scaling=(1, 1, 1)):
    """Write :func:`to_fis` to ``path`` atomically."""
    from twolink.foundation.io import atomic_write_text

    atomic_write_text(path, to_fis(engine, name, scaling))
    return Path(path)


# ----------------------------------------------------------------------------- reading

_MF = re.compile(r"^MF(\d+)\s*=\s*'([^']*)'\s*:\s*'(\w+)'\s*,\s*\[([^\]]*)\]$")
_RULE = re.compile(r"^([-\d\s.]+),([-\d\s.]+)\(([-\d.eE+]+)\)\s*:\s*(\d+)$")


def parse_fis(text: str, source: str = "<fis>") -> FisSystem:
    """Read ``.fis`` text (the format, not what twolink can run: see
    :func:`engine_from_fis`). Errors name the source, the section and the line."""
    with naming(source):
        return _parse(text, source)


def _parse(text: str, source: str) -> FisSystem:
    sections = read_sections(text, source, _MF, trailing_comments=False)
    system = sections["System"]

    def count(key: str) -> int:
        if key not in system:
            raise ValueError(f"{source}: [System] {key}: missing")
        return whole_number(system[key], f"{source}: [System] {key}")

    def variable(section: str) -> FisVariable:
        body, where = variable_section(sections, section, source)
        rng = variable_range(body, where)
        mfs = []
        for n in range(1, whole_number(body.get("NumMFs", "0"), f"{where} NumMFs") + 1):
            line = body.get(f"MF{n}")
            m = _MF.match(line or "")
            if not m:
                raise ValueError(f"{where}: MF{n} missing or not 'label':'type',[params]")
            mfs.append((m.group(2), m.group(3), numbers(m.group(4), f"{where} MF{n}")))
        return FisVariable(body.get("Name", section), rng, tuple(mfs))

    inputs = tuple(variable(f"Input{i}") for i in range(1, count("NumInputs") + 1))
    outputs = tuple(variable(f"Output{i}") for i in range(1, count("NumOutputs") + 1))
    rules = []
    for number, line in sections.get("Rules", []):
        where = f"{source}: line {number}"
        m, ante, cons = rule_indices(_RULE, line, where, len(inputs), len(outputs))
        connection = whole_number(m.group(4), f"{source}: line {number}: connection")
        rules.append((ante, cons, float(m.group(3)), connection))
    return FisSystem(dict(system), inputs, outputs, tuple(rules))


def _variable(var: FisVariable, factor: float, where: str) -> FuzzyVariable:
    """A normalised FuzzyVariable (every value times ``factor``) whose universe samples
    every breakpoint, so the triangles and trapezoids are exact."""
    lo, hi = var.range[0] * factor, var.range[1] * factor
    points = set(np.linspace(lo, hi, 61).tolist())
    mfs = []
    for label, kind, params in var.mfs:
        if kind not in _KINDS:
            raise ValueError(
                f"{where}: {label}: membership type {kind!r} (twolink: {list(_KINDS)})"
            )
        p = [x * factor for x in params]
        wanted = {"trimf": 3, "trapmf": 4, "gaussmf": 2}[kind]
        if len(p) != wanted:
            raise ValueError(f"{where}: {label}: {kind} takes {wanted} parameters, got {len(p)}")
        if kind == "gaussmf":
            p = [p[1], p[0]]  # MATLAB [sigma mean] -> (mean, sigma)
        else:
            points.update(x for x in p if lo <= x <= hi)
        mfs.append(MembershipFunction(_KINDS[kind], tuple(p)))
    universe = tuple(sorted(points))
    return FuzzyVariable(universe, tuple(m[0] for m in var.mfs), tuple(mfs))


def engine_from_fis(fis: FisSystem, source: str = "<fis>") -> tuple[MamdaniEngine, tuple]:
    """The normalised engine of a parsed ``.fis`` and its scaling ``(ke, kde, ku)`` (the
    inverse of :func:`to_fis`). Refuses, naming the key or rule, what the engine cannot
    run: other than 2 inputs and 1 output, OR or don't-care antecedents, rule weights
    other than 1, implication other than min or aggregation other than max."""
    s = fis.system
    if s.get("Type", "mamdani").lower() != "mamdani":
        raise ValueError(f"{source}: [System] Type: twolink runs Mamdani systems")
    if (len(fis.inputs), len(fis.outputs)) != (2, 1):
        raise ValueError(f"{source}: twolink's engine takes 2 inputs (e, de) and 1 output")
    for key, want in (("ImpMethod", "min"), ("AggMethod", "max")):
        if s.get(key, want) != want:
            raise ValueError(f"{source}: [System] {key}: twolink's engine uses {want!r}")
    if s.get("AndMethod", "min") not in _AND:
        raise ValueError(f"{source}: [System] AndMethod: one of {list(_AND)}")
    if s.get("DefuzzMethod", "centroid") not in _DEFUZZ:
        raise ValueError(f"{source}: [System] DefuzzMethod: one of {list(_DEFUZZ)}")
    e, de, u = (*fis.inputs, *fis.outputs)
    scale = [1.0 / max(abs(v.range[0]), abs(v.range[1])) for v in (e, de)]
    ku = max(abs(u.range[0]), abs(u.range[1]))
    variables = [
        _variable(e, scale[0], f"{source}: [Input1]"),
        _variable(de, scale[1], f"{source}: [Input2]"),
        _variable(u, 1.0 / ku, f"{source}: [Output1]"),
    ]
    rules = []
    for n, (ante, cons, weight, connection) in enumerate(fis.rules, start=1):
        where = f"{source}: rule {n}"
        if connection != 1:
            raise ValueError(f"{where}: connection {connection} (OR): twolink's rules are AND")
        if weight != 1.0:
            raise ValueError(f"{where}: weight {weight:g}: twolink's rules weigh 1")
        if min(*ante, *cons) < 1:
            raise ValueError(f"{where}: a don't-care or negated term: twolink needs both inputs")
        try:
            labels = [v.labels[i - 1] for v, i in zip(variables, (*ante, *cons), strict=True)]
        except IndexError:
            raise ValueError(f"{where}: a membership index past its variable's NumMFs") from None
        rules.append(Rule(*labels))
    engine = MamdaniEngine(
        *variables,
        rules,
        and_method=_AND[s.get("AndMethod", "min")],
        defuzz=_DEFUZZ[s.get("DefuzzMethod", "centroid")],
    )
    return engine, (scale[0], scale[1], ku)


def read_engine(path: str | Path) -> tuple[MamdaniEngine, tuple[float, float, float]]:
    """:func:`engine_from_fis` of a ``.fis`` file (a regular file of at most 1 MiB)."""
    from twolink.foundation.planted import read_bounded

    path = Path(path)
    try:
        text = read_bounded(path, MAX_FIS_BYTES).decode()
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not UTF-8 text") from None
    except OSError as exc:
        if not path.exists():
            raise
        raise ValueError(str(exc.strerror or exc)) from None
    with naming(str(path)):  # the engine's own checks (a membership function's) too
        return engine_from_fis(parse_fis(text, str(path)), str(path))


def read_rule_base(path: str | Path):
    """The rule base of a rule-base file: TOML (:func:`load_rule_base`) or ``.fis``. A
    ``.fis`` file's membership functions, normalised, must be the engine's 7-label
    partition (a scenario's engine is that partition; its scaling comes from the
    scenario's ``[controller.fuzzy]``, not the file's ranges)."""
    from twolink.controllers.fuzzy.rulebase import RuleBase, load_rule_base
    from twolink.controllers.fuzzy.tables import default_fuzzy_pd

    path = Path(path)
    if path.suffix.lower() != ".fis":
        return load_rule_base(path)
    engine, scaling = read_engine(path)
    standard = default_fuzzy_pd()
    # only the rules are taken: a method the scenario's engine would not use is refused,
    # not ignored
    for key, ours, theirs in (
        ("AndMethod", standard.and_method, engine.and_method),
        ("DefuzzMethod", standard.defuzz, engine.defuzz),
    ):
        if ours != theirs:
            raise ValueError(
                f"{path}: [System] {key}: {theirs!r}; a rule base read from a .fis keeps only "
                f"its rules, and twolink's engine uses {ours!r} (the method would be ignored)"
            )
    for name in ("e", "de", "u"):
        ours, theirs = getattr(standard, name), getattr(engine, name)
        same = ours.labels == theirs.labels and all(
            a.kind == b.kind and np.allclose(a.params, b.params, atol=1e-9)
            for a, b in zip(ours.mfs, theirs.mfs, strict=True)
        )
        if not same:
            raise ValueError(
                f"{path}: {name}: its membership functions, normalised, are not the "
                f"engine's 7-label partition {list(ours.labels)}"
            )
    meta = {"fis": {"file": path.name, "ke": scaling[0], "kde": scaling[1], "ku": scaling[2]}}
    return RuleBase(tuple(engine.rules), meta, False)


def written_by_twolink(path: str | Path) -> bool:
    """Whether the ``.fis`` file ``path`` is byte for byte what :func:`to_fis` writes for
    its own content: then twolink wrote it and may overwrite it. (The format has no place
    for a mark that MATLAB's ``readfis`` is sure to skip.)"""
    from twolink.foundation.planted import read_bounded

    try:
        text = read_bounded(path, MAX_FIS_BYTES).decode()
        fis = parse_fis(text)
        engine, scaling = engine_from_fis(fis)
        return to_fis(engine, fis.system.get("Name", "twolink"), scaling) == text
    except (OSError, ValueError, UnicodeDecodeError):
        return False
