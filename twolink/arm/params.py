"""The arm's physical parameters: the single source of truth for masses, lengths and gravity.

The paper gives no numbers. The defaults are a laboratory-sized arm: two uniform
1 m rods of 1 kg each under standard gravity (see ``docs/model.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import numpy as np


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


# Realistic joints (docs/model.md, "Realistic joints"): a size-20 and a size-14 harmonic
# drive at 100:1, their motor rotors and wave generators reflected through the gear, and a
# light damping ratio.
REALISTIC_STIFFNESS = (1.0e4, 3.0e3)  # N m/rad
REALISTIC_ROTOR_INERTIA = (0.4, 0.08)  # kg m^2: 100^2 x (4e-5, 8e-6) kg m^2 at the motor
REALISTIC_DAMPING_RATIO = 0.02

# Spring twist |phi - theta| beyond which a joint is no longer a linear spring [rad]: about
# 11 degrees, some 100x a harmonic drive's twist at its rated torque and past the
# deflection range of series-elastic joints. Runs that exceed it are flagged
# (``twolink.simulation.experiment.RunMetrics.warnings``): their springs describe no real joint.
TWIST_LIMIT = 0.2


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

    The defaults are the reproduction's flexible variant (a soft, heavily damped joint:
    damping ratio 0.1 at K = 500); :meth:`realistic` gives a harmonic-drive joint of an
    arm of this size with light damping (``docs/model.md``, "Realistic joints").
    """

    k: tuple[float, float] = (500.0, 500.0)
    d: tuple[float, float] = (1.0, 1.0)
    j: tuple[float, float] = (0.05, 0.05)

    @classmethod
    def from_damping_ratio(
        cls, k: tuple[float, float], j: tuple[float, float], zeta: float | tuple[float, float]
    ) -> Flexibility:
        """Joints of stiffness ``k`` and rotor inertia ``j`` whose damping ``d`` gives each
        the damping ratio ``zeta = d / (2 sqrt(k j))`` (the rotor's mode against a held
        link; see :attr:`damping_ratio`)."""
        zetas = (zeta, zeta) if isinstance(zeta, int | float) else tuple(zeta)
        for z in zetas:
            _check_finite("Flexibility", "damping ratio", z, positive=False)
            if z < 0:
                raise ValueError(f"Flexibility damping ratio must be >= 0, got {zeta!r}")
        k2, j2 = tuple(k), tuple(j)
        d = tuple(2.0 * z * math.sqrt(ki * ji) for z, ki, ji in zip(zetas, k2, j2, strict=True))
        return cls(k=k2, d=d, j=j2)

    @classmethod
    def realistic(cls, zeta: float = REALISTIC_DAMPING_RATIO) -> Flexibility:
        """Harmonic-drive joints for this arm (1 m, 1 kg links; 60 and 15 N m drives):
        K = :data:`REALISTIC_STIFFNESS`, J = :data:`REALISTIC_ROTOR_INERTIA` (rotor and wave
        generator reflected through a 100:1 gear), damping ratio ``zeta`` (default 0.02).
        Where the numbers come from: ``docs/model.md``, "Realistic joints"."""
        return cls.from_damping_ratio(REALISTIC_STIFFNESS, REALISTIC_ROTOR_INERTIA, zeta)

    @property
    def damping_ratio(self) -> tuple[float, float]:
        """``d / (2 sqrt(k j))`` per joint: the damping ratio of the rotor's mode on its
        spring with the link held (the joint's own damping, whatever the arm)."""
        return tuple(  # type: ignore[return-value]
            d / (2.0 * math.sqrt(k * j)) for k, d, j in zip(self.k, self.d, self.j, strict=True)
        )

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


def squared_rate(v: np.ndarray, stribeck_velocity: float | np.ndarray) -> np.ndarray:
    """(v / v_s)^2 of the Stribeck curve; inf where it is beyond a float (a v_s as small
    as 5e-324: the dip is then a step at v = 0, the exponential's limit, exp(-inf) = 0),
    without a warning."""
    with np.errstate(over="ignore"):
        return (v / stribeck_velocity) ** 2


@dataclass(frozen=True)
class Friction:
    """Joint friction per joint: dry (Coulomb, with stiction up to a breakaway torque),
    viscous, and the Stribeck dip between them.

    The friction torque opposing a sliding joint at rate v is::

        f(v) = (F_c + (F_s - F_c) exp(-(v / v_s)^2)) sign(v) + b v

    and a joint at rest stays at rest while the other torques on it stay within F_s. On a
    flexible joint it acts at the motor side (the rotor's hinge): the gear and bearings
    of a real drive rub there (``docs/model.md``, "Friction").

    Parameters
    ----------
    coulomb : pair of float
        F_c, dry friction while sliding [N m], >= 0.
    viscous : pair of float
        b, viscous friction [N m s / rad], >= 0.
    breakaway : pair of float, optional
        F_s, the torque a joint at rest holds [N m], >= ``coulomb`` (default: equal to it,
        no Stribeck dip).
    stribeck_velocity : float
        v_s, the rate over which friction falls from F_s to F_c [rad/s], > 0.
    """

    coulomb: tuple[float, float] = (0.0, 0.0)
    viscous: tuple[float, float] = (0.0, 0.0)
    breakaway: tuple[float, float] | None = None
    stribeck_velocity: float = 0.1

    def __post_init__(self) -> None:
        if self.breakaway is None:
            object.__setattr__(self, "breakaway", tuple(self.coulomb))
        for name in ("coulomb", "viscous", "breakaway"):
            value = tuple(getattr(self, name))
            if len(value) != 2:
                raise ValueError(f"Friction.{name} must have 2 entries, got {value!r}")
            for v in value:
                _check_finite("Friction", name, v, positive=False)
                if v < 0:
                    raise ValueError(f"Friction.{name} must be >= 0, got {value!r}")
            object.__setattr__(self, name, tuple(float(v) for v in value))
        _check_finite("Friction", "stribeck_velocity", self.stribeck_velocity, positive=True)
        object.__setattr__(self, "stribeck_velocity", float(self.stribeck_velocity))
        for fc, fs in zip(self.coulomb, self.breakaway, strict=True):
            if fs < fc:
                raise ValueError(
                    f"Friction.breakaway must be >= coulomb, got {self.breakaway!r} "
                    f"below {self.coulomb!r}"
                )

    @property
    def stribeck(self) -> bool:
        """Whether any joint's breakaway exceeds its Coulomb friction (the dip is on)."""
        return any(fs > fc for fc, fs in zip(self.coulomb, self.breakaway, strict=True))

    def stribeck_relief(self, v: np.ndarray) -> np.ndarray:
        """The torque that turns MuJoCo's dry friction at the breakaway level F_s into the
        Stribeck curve while sliding: ``(F_s - F_c) (1 - exp(-(v / v_s)^2)) sign(v)``, along
        the motion (it relieves friction). Zero at rest and continuous in v; ``v`` (..., 2)."""
        v = np.asarray(v, dtype=float)
        excess = np.subtract(self.breakaway, self.coulomb)
        return excess * -np.expm1(-squared_rate(v, self.stribeck_velocity)) * np.sign(v)

    def torque(self, v: np.ndarray) -> np.ndarray:
        """The friction law f(v) of a sliding joint (the class docstring), opposing the
        motion is -f(v); at v = 0 it is zero (stiction is not a function of v)."""
        v = np.asarray(v, dtype=float)
        fc, fs = np.asarray(self.coulomb), np.asarray(self.breakaway)
        dry = fc + (fs - fc) * np.exp(-squared_rate(v, self.stribeck_velocity))
        return dry * np.sign(v) + np.asarray(self.viscous) * v
