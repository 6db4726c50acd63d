"""A sweep's drawn joint friction (docs/sweeps.md, "Parameters"): ``coulomb1``,
``coulomb2`` (or ``friction_level``, both joints' Coulomb friction as a fraction of their
holding gravity torque), ``stribeck_ratio`` and ``stribeck_velocity`` over the base
scenario's ``[plant.friction]`` (docs/scenarios.md)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

__all__ = ["FRICTION_NAMES", "friction_data"]

# name -> domain (twolink.sweep.parameters): F_c per joint [N m], F_s / F_c, v_s [rad/s]
FRICTION_NAMES: Mapping[str, str] = {
    "coulomb1": "nonnegative",
    "coulomb2": "nonnegative",
    "friction_level": "nonnegative",  # F_c / the joint's holding torque, both joints
    "stribeck_ratio": "at_least_one",
    "stribeck_velocity": "positive",
}


def _pair(value: Any) -> list[float]:
    return [float(v) for v in value] if isinstance(value, list | tuple) else [float(value)] * 2


def friction_data(
    base: Mapping[str, Any], values: Mapping[str, float], holding: Sequence[float] = (0.0, 0.0)
) -> dict[str, Any] | None:
    """The ``[plant.friction]`` table of a sample: the base's (``base``, that table or
    empty) with the drawn values over it; None when no friction parameter is swept.
    ``friction_level`` sets each joint's F_c to that fraction of ``holding``, the joints'
    holding gravity torque on the nominal arm (the sweep's: at the horizontal pose).

    The rule: each joint's breakaway is ``stribeck_ratio`` times its Coulomb level (drawn
    or the base's); without a drawn ratio each joint keeps the base's own F_s / F_c (1:
    no dip, where the base has no breakaway or no Coulomb friction), so a drawn Coulomb
    level never falls above its breakaway."""
    if not any(n in FRICTION_NAMES for n in values):
        return None
    coulomb = _pair(base.get("coulomb", 0.0))
    breakaway = _pair(base.get("breakaway", coulomb))
    ratio = [fs / fc if fc > 0 else 1.0 for fs, fc in zip(breakaway, coulomb, strict=True)]
    if "stribeck_ratio" in values:
        ratio = [values["stribeck_ratio"]] * 2
    if "friction_level" in values:
        coulomb = [values["friction_level"] * abs(g) for g in holding]
    for j in (1, 2):
        coulomb[j - 1] = values.get(f"coulomb{j}", coulomb[j - 1])
    breakaway = [r * c for r, c in zip(ratio, coulomb, strict=True)]
    table = {**base, "coulomb": coulomb, "breakaway": breakaway}
    if "stribeck_velocity" in values:
        table["stribeck_velocity"] = values["stribeck_velocity"]
    return table
