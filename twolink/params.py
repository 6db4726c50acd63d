"""The arm's physical parameters: the single source of truth for masses, lengths and gravity.

The paper gives no numbers. The defaults are a laboratory-sized arm: two uniform
1 m rods of 1 kg each under standard gravity (see ``docs/model.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace


def _check_finite(owner: str, name: str, value: float, positive: bool) -> None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{owner}.{name} must be a number, got {value!r}")
    if not math.isfinite(value):
        raise ValueError(f"{owner}.{name} must be finite, got {value!r}")
    if positive and value <= 0:
        raise ValueError(f"{owner}.{name} must be > 0, got {value!r}")


@dataclass(frozen=True)
class ArmParams:
    """Parameters of the two-link arm of uniform rods, in SI units.

    Parameters
    ----------
    m1, m2 : float
        Link masses [kg]. Each link is a uniform rod: centre of mass at L/2 and
        inertia m L^2 / 12 about it.
    l1, l2 : float
        Link lengths [m].
    g : float
        Gravitational acceleration [m/s^2], acting along the paper's -y. Zero
        (a horizontal arm) and negative values are allowed; it must be finite.
    """

    m1: float = 1.0
    m2: float = 1.0
    l1: float = 1.0
    l2: float = 1.0
    g: float = 9.81

    def __post_init__(self) -> None:
        for f in fields(self):
            _check_finite("ArmParams", f.name, getattr(self, f.name), positive=f.name != "g")

    def scaled(self, **factors: float) -> ArmParams:
        """Return a copy with some fields multiplied by factors, e.g. ``scaled(m2=1.2)``."""
        return replace(self, **{k: getattr(self, k) * v for k, v in factors.items()})


@dataclass(frozen=True)
class Flexibility:
    """Spong's flexible-joint model: a motor rotor on each joint, coupled by a spring.

    The motor torque acts on the rotor; the rotor drives the link through a torsional
    spring of stiffness ``k`` and a damper ``d``. The rigid arm is the limit k -> inf.

    Parameters
    ----------
    k : tuple of float
        Joint stiffness per joint [N m / rad], > 0.
    d : tuple of float
        Joint damping per joint [N m s / rad], >= 0.
    j : tuple of float
        Rotor inertia per joint (reflected through the gearbox) [kg m^2], > 0.
    """

    k: tuple[float, float] = (500.0, 500.0)
    d: tuple[float, float] = (1.0, 1.0)
    j: tuple[float, float] = (0.05, 0.05)

    def __post_init__(self) -> None:
        for name in ("k", "d", "j"):
            value = tuple(getattr(self, name))
            if len(value) != 2:
                raise ValueError(f"Flexibility.{name} must have 2 entries, got {value!r}")
            for v in value:
                _check_finite("Flexibility", name, v, positive=name != "d")
                if v < 0:
                    raise ValueError(f"Flexibility.{name} must be >= 0, got {value!r}")
            object.__setattr__(self, name, tuple(float(v) for v in value))
