"""A scenario's ``[plant]`` table: how the simulated arm differs from the nominal one
(uncertainty factors, payload, flexible joints, friction), and its ``[disturbance]``, read
(:mod:`twolink.simulation.config` reads the rest of the scenario)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

from twolink.arm.disturbance import (
    Disturbance,
    PayloadPickup,
    SineLoad,
    TorqueImpulse,
    TorqueStep,
)
from twolink.arm.params import Flexibility, Friction

# The table reader is twolink.simulation.config.TomlTable, which imports this module: named
# here by its role only, so the two do not import each other.
TomlTable = Any

SPRING_STARTS = ("holding", "relaxed")
ARM_SCALE_KEYS = ("g", "l1", "l2", "m1", "m2")  # [plant.scale] factors on [arm]
JOINT_SCALE_KEYS = ("j", "k")  # [plant.scale] factors on [plant.flexibility]: model error
LINK_SCALE_KEYS = ("ei",)  # [plant.scale] factor on [arm.links] ei: the links' stiffness


@dataclass(frozen=True)
class PlantConfig:
    """How the simulated arm differs from the nominal one."""

    scale: dict[str, float] = field(default_factory=dict)
    payload: float = 0.0
    flexibility: Flexibility | None = None  # the joints as the controllers model them
    # A flexible arm's springs at t = 0: "holding" (twisted to hold the arm at rest at its
    # start pose) or "relaxed" (rotors at the links: the arm starts to fall).
    springs: str = "holding"
    friction: Friction | None = None  # joint friction, at the motors' joints


def read_plant(t: TomlTable) -> PlantConfig:
    """``[plant]`` of a scenario (docs/scenarios.md)."""
    scale_t = t.table("scale")
    scale = {}
    known = sorted(ARM_SCALE_KEYS + JOINT_SCALE_KEYS + LINK_SCALE_KEYS)
    for key in list(scale_t.data):
        if key not in known:
            scale_t.fail(key, f"unknown key (known here: {known})")
        scale[key] = scale_t.number(key, 1.0, positive=key != "g")
    if "noise_std" in t.data:
        t.fail("noise_std", "moved: measurement noise is [sensor] noise_std_rad (docs/sensors.md)")
    flexibility, springs = None, PlantConfig.springs
    if "flexibility" in t.data:
        f = t.table("flexibility")
        d = Flexibility()
        flexibility = Flexibility(
            k=f.pair("k", d.k, positive=True),
            d=f.pair("d", d.d, minimum=0.0),
            j=f.pair("j", d.j, positive=True),
        )
        springs = f.string("start", "holding", choices=SPRING_STARTS)
        f.done()
    plant = PlantConfig(
        scale=scale,
        payload=t.number("payload", 0.0, minimum=0.0),
        flexibility=flexibility,
        springs=springs,
        friction=read_friction(t.table("friction")) if "friction" in t.data else None,
    )
    t.done()
    if flexibility is None and (scaled := [k for k in JOINT_SCALE_KEYS if k in scale]):
        scale_t.fail(scaled[0], "scales the flexible joints, and this plant has none")
    return plant


def read_friction(t: TomlTable) -> Friction:
    """``[plant.friction]`` (docs/scenarios.md): pairs >= 0, breakaway >= coulomb."""
    fc = t.pair("coulomb", (0.0, 0.0), minimum=0.0)
    fs = t.pair("breakaway", fc, minimum=0.0)
    if fs[0] < fc[0] or fs[1] < fc[1]:
        t.fail("breakaway", f"must be >= coulomb {list(fc)}, got {list(fs)}")
    b = t.pair("viscous", (0.0, 0.0), minimum=0.0)
    vs = t.number("stribeck_velocity", Friction.stribeck_velocity, positive=True)
    t.done()
    return Friction(coulomb=fc, viscous=b, breakaway=fs, stribeck_velocity=vs)


# [disturbance]: each kind a table or an array of tables, with these keys (all required)
DISTURBANCE_KINDS = {
    "step": (TorqueStep, ("joint", "time", "size"), "steps"),
    "impulse": (TorqueImpulse, ("joint", "time", "size"), "impulses"),
    "sine": (SineLoad, ("joint", "amplitude", "frequency"), "sines"),
}


def read_disturbance(t: TomlTable) -> Disturbance:
    """A scenario's ``[disturbance]`` (docs/scenarios.md): ``[[disturbance.step]]``,
    ``[[disturbance.impulse]]``, ``[[disturbance.sine]]``."""
    found: dict[str, list] = {}
    for kind, (cls, keys, field_name) in DISTURBANCE_KINDS.items():
        items = t.raw(kind, [])
        items = [items] if isinstance(items, dict) else items
        if not isinstance(items, list):
            t.fail(kind, f"must be a table or an array of tables, got {items!r}")
        found[field_name] = []
        for n, item in enumerate(items):
            it = type(t)(item, f"{t.where}.{kind}[{n}]", t.file)
            for key in keys:
                if key not in it.data:
                    it.fail(key, "missing")
            joint = it.raw("joint")
            if isinstance(joint, bool) or joint not in (1, 2):
                it.fail("joint", f"must be 1 or 2, got {joint!r}")
            values = {k: it.number(k, 0.0, minimum=_MINIMA.get(k)) for k in keys[1:]}
            it.done()
            found[field_name].append(cls(joint, *values.values()))
    pickup = None
    if "payload" in t.data:
        pt = t.table("payload")
        mass, time = pt.number("mass", 0.0, minimum=0.0), pt.number("time", 0.0, minimum=0.0)
        pickup = PayloadPickup(mass, time)
        pt.done()
    t.done()
    return Disturbance(**{k: tuple(v) for k, v in found.items()}, pickup=pickup)


_MINIMA = {"time": 0.0, "frequency": 0.0}


def nyquist(top: TomlTable, scenario: Any) -> None:
    """Fail naming the key where a sine of ``scenario``'s disturbance is at or above the
    Nyquist frequency of its physics step, where the sine is applied: it would alias (a
    whole multiple of the step rate is zero at every step)."""
    nyquist = 0.5 / scenario.timestep
    for n, sine in enumerate(scenario.disturbance.sines if scenario.disturbance else ()):
        if sine.frequency >= nyquist:
            top.fail(
                f"disturbance.sine[{n}].frequency",
                f"{sine.frequency:g} Hz is at or above {nyquist:g} Hz, the Nyquist frequency "
                f"of the physics step (timestep {scenario.timestep:g} s), where the sine is "
                "applied: it would alias (a whole multiple of the step rate is zero at every "
                "step); give a lower frequency or a finer timestep",
            )


def disturbance_dict(d: Disturbance) -> dict[str, list[dict[str, float]]]:
    """``d`` as a ``[disturbance]`` table (what a run's resolved config holds)."""
    out: dict = {
        kind: [asdict(x) for x in getattr(d, name)]
        for kind, (_, _, name) in DISTURBANCE_KINDS.items()
        if getattr(d, name)
    }
    return out | ({"payload": asdict(d.pickup)} if d.pickup else {})
