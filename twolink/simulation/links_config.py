"""A scenario's ``[arm.links]`` table: links that bend (docs/scenarios.md)."""

from __future__ import annotations

from typing import Any

from twolink.arm.links import MAX_SEGMENTS, FlexibleLinks
from twolink.arm.params import ArmParams


def read_links(t, arm: ArmParams) -> FlexibleLinks:
    """``[arm.links]`` (a :class:`twolink.simulation.config.TomlTable`): the bending links
    of ``arm``'s rods (their ρ A = m / l, L = l)."""
    segments = t.integer("segments", 8)
    if not 1 <= segments <= MAX_SEGMENTS:
        t.fail("segments", f"must be in 1..{MAX_SEGMENTS}, got {segments}")
    links = FlexibleLinks.from_arm(
        arm,
        ei=t.pair("ei", (100.0, 100.0), positive=True),
        hub_inertia=t.pair("hub_inertia", (0.0, 0.0), minimum=0.0),
        tip_mass=t.pair("tip_mass", (0.0, 0.0), minimum=0.0),
        damping_ratio=t.pair("damping_ratio", (0.01, 0.01), minimum=0.0),
        segments=segments,
    )
    t.done()
    return links


def links_dict(links: FlexibleLinks) -> dict[str, Any]:
    """``[arm.links]`` as plain data (its keys; ρ A and L are ``[arm]``'s)."""
    names = ("ei", "hub_inertia", "tip_mass", "damping_ratio")
    return {"segments": links.segments} | {
        name: [getattr(b, name) for b in links.links] for name in names
    }


def check_links(top, scenario, flexible_kinds: tuple[str, ...]) -> None:
    """What a run of bending links does not model is an error naming the key: it starts
    straight and at rest and sees the truth, with a law of the hub angles."""
    for key, there in (
        ("plant.flexibility", scenario.plant.flexibility is not None),
        ("plant.friction", scenario.plant.friction is not None),
        ("disturbance", scenario.disturbance is not None),
        ("sensor", not scenario.sensor.ideal),
    ):
        if there:
            top.fail("arm.links", f"links that bend run without [{key}]")
    if scenario.controller.kind in flexible_kinds:
        top.fail("controller.kind", "links that bend: a law of the hub angles")
