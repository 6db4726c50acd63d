"""The claims study's plans in a regime: the raw steps that replace smooth moves
(:func:`raw_steps`), the reference's own step metrics (:func:`reference_values`), and the
claims sweep in a regime (:func:`regime_plan`); shared by the claims studies, the linear
frontier and the table search."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from twolink.simulation.config import Scenario, read_toml
from twolink.simulation.vocabulary import metric
from twolink.studies.judgments.move_times import TIMES_OF_THE_MOVE
from twolink.studies.reproduction.manifest import Manifest

__all__ = ["SMOOTH_KINDS", "raw_steps", "reference_values", "regime_plan"]

SMOOTH_KINDS = ("quintic", "septic")


def raw_steps(source: Path | Mapping[str, Any]) -> dict[str, Any]:
    """Reference overrides that make a scenario's (or a sweep's) smooth moves the raw steps
    between the same angles at the same start: the paper's own references (``replace``:
    a step takes no ``duration``). Other references (ramps, holds) are left as they are."""
    tables = read_toml(source).get("reference", {}) if isinstance(source, Path) else source
    out = {}
    for joint, ref in tables.items():
        if isinstance(ref, dict) and ref.get("kind") in SMOOTH_KINDS:
            step = {k: ref[k] for k in ("initial", "final", "t0") if k in ref}
            out[joint] = {"replace": True, "kind": "step", **step}
    return out


def reference_values(scenario: Scenario, joints: Any) -> dict[tuple[int, str], float]:
    """The step metrics of the reference itself, per moving joint: the move's own Td, Tr,
    Tp, Ts and Ts→θd (its own 2 % band settling time: it ends on its target, so both Ts
    are one), which the claims judge a loop's times by their distance to
    (:data:`~twolink.studies.judgments.move_times.TIMES_OF_THE_MOVE`)."""
    from twolink.simulation.metrics import step_metrics

    t = np.arange(0.0, scenario.duration + 1e-12, scenario.control_dt)
    q_ref = scenario.reference.sample(t)[0]  # (N, 2)
    out = {}
    for j in joints:
        target, start = scenario.reference.final[j - 1], scenario.q0[j - 1]
        m = step_metrics(t, q_ref[:, j - 1], target, y0=start)
        for key in TIMES_OF_THE_MOVE:
            field = "settling_time" if key == "settling_time_target_s" else None
            value = getattr(m, field or metric(key).source.split(".")[1])
            if np.isfinite(value):
                out[(j, key)] = float(value)
    return out


def regime_plan(
    manifest: Manifest, variant: Any = None, more: Mapping[str, Any] | None = None
) -> Any:
    """The manifest's claims sweep in ``variant``'s regime (None: as its file says; a
    ``raw_steps`` variant: the paper's raw steps at the variant's gains), with ``more``
    overrides merged over it (samples, seed, controllers, ...)."""
    from twolink import sweep
    from twolink.foundation.overrides import merge

    study = manifest.claims_study
    overrides: dict[str, Any] = {}
    if variant is not None:  # the same study in the variant's regime
        name = sweep.load_sweep(study, {"samples": 1}).name
        overrides = {
            "name": f"{name}_{variant.name}",
            "overrides": variant.overrides,
            "reference": raw_steps(read_toml(study).get("reference", {})),
        }
    return sweep.load_sweep(study, merge(overrides, dict(more or {})))
