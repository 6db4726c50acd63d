"""The report's "our choices": what the paper leaves open, as this reproduction set it,
read from the scenarios it ran (so the report cannot drift from what was run)."""

from __future__ import annotations

import math
from typing import Any

from twolink.simulation.config import FUZZY_KINDS, Scenario
from twolink.simulation.outcome import settling_window
from twolink.studies.reproduction.manifest import RunSpec


def describe_choices(
    specs: list[RunSpec], scenarios: dict[str, Scenario], design_config: Any
) -> dict[str, str]:
    """What the paper leaves open, as this reproduction actually set it (from its files).

    Read from the loaded scenarios (``scenarios[spec.folder]``), so the report cannot
    drift from what was run.
    """
    first = next(iter(scenarios.values()))
    a, c = first.arm, first.controller
    wn = [math.sqrt(k) for k in c.kp]
    zeta = [kd / (2 * w) if w else math.nan for kd, w in zip(c.kd, wn, strict=True)]
    references = sorted(
        {
            f"θ{sp.experiment.joint} {type(ref).__name__.lower()} "
            + (
                f"{ref.initial:g}→{ref.final:g} rad"
                + (f" in {ref.duration:g} s" if hasattr(ref, "duration") else "")
            )
            for sp in specs
            for ref in [
                (scenarios[sp.folder].reference.joint1, scenarios[sp.folder].reference.joint2)[
                    sp.experiment.joint - 1
                ]
            ]
        }
    )
    scales = sorted(
        {
            ", ".join(f"{k} ×{v:g}" for k, v in sorted(sc.plant.scale.items()))
            for sc in scenarios.values()
            if sc.plant.scale
        }
    )
    fuzzy = next(
        (sc.controller for sc in scenarios.values() if sc.controller.kind in FUZZY_KINDS), None
    )
    flex = sorted(
        {
            f"k = {sc.plant.flexibility.k} N·m/rad, d = {sc.plant.flexibility.d} N·m·s/rad, "
            f"j = {sc.plant.flexibility.j} kg·m², start {sc.plant.springs!r} (the scenario "
            "keys of [plant.flexibility])"
            for sc in scenarios.values()
            if sc.plant.flexibility is not None
        }
    )
    bending = sorted(
        {
            f"E I = {b.ei:g} N·m², hub inertia J = {b.hub_inertia:g} kg·m², tip mass "
            f"{b.tip_mass:g} kg, material ζ = {b.damping_ratio:g}, N = {sc.links.segments} "
            "pieces a link, from rest in their sag (the scenario keys of [arm.links])"
            for sc in scenarios.values()
            if sc.links is not None
            for b in sc.links.links
        }
    )
    choices = {
        "arm": f"two uniform rods, m1 = {a.m1:g} kg, m2 = {a.m2:g} kg, L1 = {a.l1:g} m, "
        f"L2 = {a.l2:g} m, g = {a.g:g} m/s² (runs/paper/base.toml)",
        "CTC gains": f"Kp = {c.kp} s⁻², Kd = {c.kd} s⁻¹: ωn = {wn[0]:.3g} rad/s, "
        f"ζ = {zeta[0]:.3g}, torque limit {c.torque_limit} N·m, from the gain study's rule "
        "(section below; docs/control.md)",
        "references": "; ".join(references) + "; the other joint holds at its start",
        "uncertainty": "the plant's "
        + "; ".join(scales)
        + " against the controller's nominal model (runs/paper/*_uncertain.toml)",
    }
    if fuzzy is not None:
        f = fuzzy.fuzzy
        choices["fuzzy term"] = (
            "normalised universes [-1, 1], 7 triangular labels, min/max Mamdani, centroid; "
            f"ke = {f.ke:.4g} /rad, kde = {f.kde:.4g} s/rad, ku = {f.ku:.4g} rad/s², mode "
            f"{f.mode!r}: inside the CTC bracket (docs/control.md); by the scaling rule "
            f"(docs/fuzzy.md) span E = {f.span:.3g} rad (the PD term's unsaturated range), "
            f"ke = 1/E, kde = ke/ωn, ku = {f.authority:g} · Kp · E"
        )
        choices["no rule fires"] = "zero fuzzy correction: the CTC term alone acts"
    choices["FCM design"] = (
        f"c = {design_config.clusters}, m = {design_config.fuzzifier:g}, "
        f"ε = {design_config.tolerance:g}, seed {design_config.seed}, on the 7x7 "
        f"fuzzy-CTC's {len(design_config.scenarios)} design runs (steps up and down on both "
        "joints, coupled moves, disturbed starts); settled tail: "
        f"{design_config.settled!r} (|e| + |ė|), odd symmetry: {design_config.symmetry!r}; "
        f"{len(design_config.validation)} held-out moves (runs/paper/design.toml)"
    )
    if flex:
        choices["flexible joints"] = "; ".join(flex)
    if bending:
        choices["flexible links"] = "; ".join(bending)
    choices["simulation"] = (
        f"{first.duration:g} s, RK4 at {first.timestep * 1e3:g} ms, control every "
        f"{first.control_dt * 1e3:g} ms with zero-order hold"
    )
    choices["ess"] = (
        f"the mean |target − θ| over the settling window (the last "
        f"{settling_window(first.duration):g} s of {first.duration:g} s), not one sample"
    )
    choices["sensor"] = sensor_choice({sc.sensor for sc in scenarios.values()})
    return choices


def sensor_choice(sensors: Any) -> str:
    """The "sensor" line of the choices: the experiments' sensors, "as the paper's
    simulation" only where all see the true state (the paper's simulation measures it)."""
    return (
        "; ".join(sorted(s.describe() for s in sensors))
        + " in the paper's experiments"
        + (", as the paper's simulation" if all(s.ideal for s in sensors) else "")
        + "; the gain study and the claims studies state their own (their sections; "
        "docs/sensors.md)"
    )
