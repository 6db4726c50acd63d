"""Rule bases: rules as data, read from and written to TOML files.

A file lists rules by label and may store its input labels in the opposite error
convention (``mirror_inputs = true``, e.g. the paper's Table 1); reading it mirrors them
into this project's convention, ``e = theta_d - theta``. The shipped files live in
``controllers/rulebases/``; ``pd_rule_table`` is the diagonal table the default file stores.
"""

from __future__ import annotations

import os
import tomllib
import types
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

from twolink.controllers.fuzzy.membership import LABELS_7, MIRROR_LABELS
from twolink.foundation.io import atomic_write_text, toml_key, toml_string, toml_table, toml_value
from twolink.foundation.shipped import rulebases_dir

__all__ = ["RULEBASE_DIR", "Rule", "RuleBase", "load_rule_base", "pd_rule_table", "save_rule_base"]

RULEBASE_DIR: Path = rulebases_dir()  # package data (twolink/foundation/shipped.py)
# The shipped rule bases by name (scenario ``rule_base`` keys, ``twolink.load_rule_base``)
BUILTIN_RULE_BASES = {
    "paper": "paper_table1.toml",
    "designed": "designed.toml",
    "default": "default_7x7.toml",
}


def missing_rule_base(name: str, path: Path) -> str:
    """What to say of a rule base ``name`` whose file ``path`` is not there: no such file,
    and the shipped names it may have meant (``name``, misspelt, is read as a file)."""
    known = ", ".join(repr(n) for n in BUILTIN_RULE_BASES)
    return (
        f"no such file {path}: a rule base is the name of a shipped one ({known}) or a "
        "rule-base TOML or MATLAB .fis file"
    )


def resolve_rule_base(name: str, relative_to: str | os.PathLike[str] = ".") -> Path:
    """Path of a rule base: "paper", "designed", "default" or a TOML or ``.fis`` path
    (relative to the folder of the file ``relative_to``)."""
    if name in BUILTIN_RULE_BASES:
        return RULEBASE_DIR / BUILTIN_RULE_BASES[name]
    path = Path(name)
    return path if path.is_absolute() else Path(relative_to).parent / path


"""Folder of the rule-base data files shipped with the package."""


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

    def __str__(self) -> str:
        """The rules, one per line: "IF e is NM AND de is PS THEN u is NS"."""
        lines = [f"IF e is {r.e} AND de is {r.de} THEN u is {r.u}" for r in self.rules]
        return f"{len(self.rules)} rules:\n  " + "\n  ".join(lines)


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


MAX_RULE_BASE_BYTES = 1 << 20  # 1 MiB: thousands of rules and their metadata


def _read_toml(path: Path) -> dict:
    """The TOML of a rule-base file: a regular file (not a pipe or a device, where a read
    would block or never end) of a sane size; errors name the file."""
    if path.exists() and not path.is_file():
        raise ValueError(f"{path}: is not a regular file")
    if path.stat().st_size > MAX_RULE_BASE_BYTES:
        raise ValueError(
            f"{path}: {path.stat().st_size} bytes; a rule-base file is at most "
            f"{MAX_RULE_BASE_BYTES} bytes"
        )
    with path.open("rb") as fh:
        try:
            data = tomllib.load(fh)
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"{path}: not valid TOML: {exc}") from exc
        except RecursionError:
            raise ValueError(f"{path}: not valid TOML: nested too deep") from None
    return data


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
    data = _read_toml(path)
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
    first: dict[tuple[str, str], int] = {}  # antecedent -> its first rule: a linear check
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
        rule = Rule(e, de, item["u"])
        k = first.setdefault((rule.e, rule.de), n)  # one antecedent, one consequent
        if rules[k:] and rules[k].u != rule.u:
            raise ValueError(
                f"{where}: contradicts rule[{k}]: IF e is {e} AND de is {de} THEN u is "
                f"{rules[k].u} or {rule.u}? (a rule base names one consequent per pair)"
            )
        rules.append(rule)
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
        "# written by twolink",
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
