"""The text of a MATLAB ``.fis`` file as sections: one reader for both of twolink's
``.fis`` readers (:mod:`controllers.fuzzy.fis.engine_files`, the project's own engine, and
:mod:`controllers.fuzzy.fis.matlab`, any Toolbox system), which differ in what they make of
the sections, not in how they read them.

A file is ``[Section]`` headers, each followed by ``KEY=VALUE`` lines (quotes around the
value dropped), membership lines ``MF3='label':'type',[params]`` (kept whole, under
``MF3``) or, under ``[Rules]``, rule lines (kept whole with their line numbers). Blank
lines and lines starting with ``%`` or ``#`` are skipped. Errors are one line naming the
source and the line.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from contextlib import contextmanager

Sections = dict[str, dict[str, str] | list[tuple[int, str]]]

_SECTION = re.compile(r"^\[(\w+)\]$")


def numbers(text: str, where: str) -> tuple[float, ...]:
    """The numbers of a ``[...]`` list's inside (spaces or commas between them)."""
    try:
        return tuple(float(v) for v in text.replace(",", " ").split())
    except ValueError:
        raise ValueError(f"{where}: not a list of numbers: [{text}]") from None


def whole_number(text: str, where: str) -> int:
    """An index or a count written as a number (``3`` or ``3.0``, as the Toolbox writes
    them); a fraction, ``inf``, ``nan`` or no number is refused, never rounded."""
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{where}: {text!r} is not a number") from None
    if not (math.isfinite(value) and value == int(value)):
        raise ValueError(f"{where}: {text!r} is not a whole number")
    return int(value)


def rule_indices(
    pattern: re.Pattern, line: str, where: str, n_inputs: int, n_outputs: int
) -> tuple[re.Match, tuple[int, ...], tuple[int, ...]]:
    """One ``[Rules]`` line, ``i j, k (w) : c``, read with the reader's ``pattern`` (its
    groups: antecedents, consequents, weight, connection): the match and the antecedents'
    and consequents' membership indices, whole numbers, one per input and output."""
    m = pattern.match(line)
    if not m:
        raise ValueError(f"{where}: not a rule 'i j, k (w) : c': {line!r}")
    index = f"{where}: membership index"
    ante = tuple(whole_number(v, index) for v in m.group(1).split())
    cons = tuple(whole_number(v, index) for v in m.group(2).split())
    if len(ante) != n_inputs or len(cons) != n_outputs:
        raise ValueError(
            f"{where}: {len(ante)} antecedents and {len(cons)} consequents for "
            f"{n_inputs} inputs and {n_outputs} outputs"
        )
    return m, ante, cons


@contextmanager
def naming(source: str) -> Iterator[None]:
    """Every error of reading ``source`` one line naming it: a check deeper down (a
    membership function's own) may not know the file."""
    try:
        yield
    except (ValueError, OverflowError) as exc:
        text = " ".join(str(exc).split())
        if source in text:
            raise ValueError(text) from None
        raise ValueError(f"{source}: {text}") from None


def read_sections(
    text: str, source: str, mf: re.Pattern[str], *, trailing_comments: bool
) -> Sections:
    """The sections of ``.fis`` text: ``{"System": {key: value}, "Input1": {...}, ...,
    "Rules": [(line number, rule line), ...]}``. ``mf`` matches a membership line (its
    first group the MF's number). With ``trailing_comments``, a ``%`` and what follows it
    is cut from every line but a membership line (whose label may hold a ``%``). Refuses
    a line before any section, a line that is none of the above, and a file without a
    ``[System]`` section."""
    sections: Sections = {}
    current = None
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if trailing_comments and not line.startswith("MF"):
            line = line.split("%", 1)[0].strip()
        if not line or line.startswith(("%", "#")):
            continue
        if m := _SECTION.match(line):
            current = m.group(1)
            sections[current] = [] if current == "Rules" else {}
            continue
        if current is None:
            raise ValueError(f"{source}: line {number}: {line!r} before any [section]")
        body = sections[current]
        if isinstance(body, list):
            body.append((number, line))
        elif m := mf.match(line):
            body[f"MF{m.group(1)}"] = line
        else:
            key, sep, value = line.partition("=")
            if not sep:
                raise ValueError(f"{source}: line {number}: expected KEY=VALUE, got {line!r}")
            body[key.strip()] = value.strip().strip("'")
    if not isinstance(sections.get("System"), dict):
        raise ValueError(f"{source}: no [System] section")
    return sections


def variable_section(sections: Sections, section: str, source: str) -> tuple[dict, str]:
    """An ``[InputN]`` / ``[OutputN]`` section's keys and the ``where`` its errors name."""
    body = sections.get(section)
    if not isinstance(body, dict):
        raise ValueError(f"{source}: no [{section}] section")
    return body, f"{source}: [{section}]"


def variable_range(body: dict, where: str, *, closed: bool = False) -> tuple[float, float]:
    """A variable's ``Range=[low high]``: finite, low < high (low <= high where
    ``closed``)."""
    rng = numbers(body.get("Range", "").strip("[]"), f"{where} Range")
    if len(rng) != 2 or not (rng[0] <= rng[1] if closed else rng[0] < rng[1]):
        raise ValueError(f"{where} Range: need [low high] with low < high")
    if not all(math.isfinite(v) for v in rng):
        raise ValueError(f"{where} Range: {list(rng)}: the ends must be finite numbers")
    return rng[0], rng[1]
