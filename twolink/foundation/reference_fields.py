"""What every joint reference checks of its parameters: finite real numbers stored as
floats, a required one given, a derivative order in range. Shared by
:mod:`twolink.foundation.references` and :mod:`twolink.foundation.trajectories`."""

from __future__ import annotations

import math
from dataclasses import fields
from typing import Any

import numpy as np

# Default of a parameter that must be given: ``Step(final=1.0)`` needs no ``initial`` (0 by
# default, as a scenario's start), but a step needs its ``final``.
REQUIRED: Any = None


def _validate_fields(obj: object, positive: tuple[str, ...] = ()) -> None:
    """Check every dataclass field is a finite real number and store it as a Python float.

    Storing floats (not ints or numpy scalars) is what keeps ``__call__`` returning floats.
    """
    owner = type(obj).__name__
    for f in fields(obj):  # type: ignore[arg-type]
        value = getattr(obj, f.name)
        if value is REQUIRED:
            raise ValueError(f"{owner}.{f.name} is required, e.g. {owner}({f.name}=1.0)")
        if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
            raise ValueError(f"{owner}.{f.name} must be a real number, got {value!r}")
        value = float(value)
        if not math.isfinite(value):
            raise ValueError(f"{owner}.{f.name} must be finite, got {value!r}")
        if f.name in positive and value <= 0.0:
            raise ValueError(f"{owner}.{f.name} must be > 0, got {value!r}")
        object.__setattr__(obj, f.name, value)


def _as_times(t: np.ndarray | float) -> np.ndarray:
    return np.asarray(t, dtype=float)


MAX_ORDER = 4  # snap: the highest derivative ``derivatives`` gives


def _check_order(n: int) -> None:
    if isinstance(n, bool) or not isinstance(n, int) or not 0 <= n <= MAX_ORDER:
        raise ValueError(f"derivative order must be an integer 0..{MAX_ORDER}, got {n!r}")
