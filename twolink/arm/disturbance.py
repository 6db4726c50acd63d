"""Torques from outside that the controllers do not know about: a step, an impulse and a
sinusoidal load on a joint (a scenario's ``[disturbance]``, docs/model.md,
"Disturbances"). Pure numpy: the plant applies them as ``qfrc_applied`` on the links'
joints, evaluated at the start of each physics step and held over it."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def _check(kind: str, name: str, value: float, minimum: float | None = None) -> None:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"{kind}.{name} must be a finite number, got {value!r}")
    if minimum is not None and value < minimum:
        raise ValueError(f"{kind}.{name} must be >= {minimum}, got {value!r}")


@dataclass(frozen=True)
class TorqueStep:
    """``size`` [N m] on ``joint`` (1 or 2) from ``time`` [s] on."""

    joint: int
    time: float
    size: float


@dataclass(frozen=True)
class TorqueImpulse:
    """An angular impulse ``size`` [N m s] on ``joint``, delivered over the one physics
    step that contains ``time`` (a torque size / dt held over it)."""

    joint: int
    time: float
    size: float


@dataclass(frozen=True)
class SineLoad:
    """``amplitude sin(2 pi frequency t)`` [N m] on ``joint`` for the whole run."""

    joint: int
    amplitude: float
    frequency: float


@dataclass(frozen=True)
class PayloadPickup:
    """A point mass ``mass`` [kg] at the tip of link 2, picked up at ``time`` [s] with the
    tip's velocity (the arm's rates are kept): from the physics step that starts at or
    after ``time`` the plant's link 2 carries it, as a ``[plant] payload`` would."""

    mass: float
    time: float


@dataclass(frozen=True)
class Disturbance:
    """The disturbances of a run; :meth:`torque` is what they add to each link joint."""

    steps: tuple[TorqueStep, ...] = ()
    impulses: tuple[TorqueImpulse, ...] = ()
    sines: tuple[SineLoad, ...] = ()
    pickup: PayloadPickup | None = None

    def __post_init__(self) -> None:
        if self.pickup is not None:
            _check("payload", "mass", self.pickup.mass, 0.0)
            _check("payload", "time", self.pickup.time, 0.0)
        for kind, items in (("step", self.steps), ("impulse", self.impulses), ("sine", self.sines)):
            for d in items:
                if d.joint not in (1, 2) or isinstance(d.joint, bool):
                    raise ValueError(f"{kind}.joint must be 1 or 2, got {d.joint!r}")
                for name in ("time", "size", "amplitude", "frequency"):
                    if hasattr(d, name):
                        _check(
                            kind,
                            name,
                            getattr(d, name),
                            0.0 if name in ("time", "frequency") else None,
                        )

    def picks_up(self, t: float, dt: float) -> bool:
        """Whether the payload is picked up at the physics step starting at ``t``."""
        p = self.pickup
        return p is not None and p.mass > 0 and round(t / dt) == math.ceil(p.time / dt - 1e-9)

    def torque(self, t: float, dt: float) -> np.ndarray:
        """The torques (2,) [N m] on the link joints over the physics step [t, t + dt)."""
        out = np.zeros(2)
        for s in self.steps:
            if t >= s.time - 1e-9 * dt:  # a step due at a step's start acts from it
                out[s.joint - 1] += s.size
        for i in self.impulses:
            if round(t / dt) == math.floor(i.time / dt + 1e-9):
                out[i.joint - 1] += i.size / dt
        for s in self.sines:
            out[s.joint - 1] += s.amplitude * math.sin(2 * math.pi * s.frequency * t)
        return out
