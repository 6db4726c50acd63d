"""How scenario data combine: ``extends`` chains, variant and sweep overrides and
``--set`` merge table by table (:func:`merge`); a table with ``replace = true`` replaces
the inherited one whole (docs/scenarios.md)."""

from __future__ import annotations

import copy
from typing import Any

__all__ = ["REPLACE", "merge", "set_nested", "strip_replace"]

REPLACE = "replace"  # a table with ``replace = true`` replaces the inherited one whole


def merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    """Deep-merge ``over`` into a copy of ``base``: tables merge, other values replace.

    A table of ``over`` with ``replace = true`` replaces ``base``'s table whole instead of
    merging into it: how a scenario that ``extends`` another changes a reference's kind
    (a step over an inherited quintic would otherwise keep the quintic's ``duration``).
    Where ``base`` has no such table the flag is kept, for a later merge onto one (the
    ``--set`` and variant overrides are merged onto the file last); :func:`strip_replace`
    removes what is left once everything is merged."""
    out = copy.deepcopy(base)
    for key, value in over.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            value = dict(value)
            if value.get(REPLACE) is True:
                del value[REPLACE]
                out[key] = copy.deepcopy(value)
            else:
                out[key] = merge(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def strip_replace(data: Any) -> Any:
    """``data`` without the ``replace = true`` flags left after the last merge."""
    if isinstance(data, dict):
        return {k: strip_replace(v) for k, v in data.items() if not (k == REPLACE and v is True)}
    return data


def set_nested(out: dict[str, Any], parts: list[str], value: Any) -> None:
    """``out[p0][p1]... = value``, making tables on the way (``--set`` accumulation: a
    ``replace`` flag among the items is kept for the merge onto the file)."""
    for part in parts[:-1]:
        if not isinstance(out.get(part), dict):
            out[part] = {}
        out = out[part]
    out[parts[-1]] = value
