"""What the reproduction computes, counted: no run of its plan is another's scenario
again, and the profile (benchmarks/profile_reproduce.py) counts phases, regimes and arms
computed twice as a hand count does."""

from __future__ import annotations

import pickle
import sys
from pathlib import Path

from twolink.simulation.config import load_scenario
from twolink.studies.reproduction.manifest import DEFAULT_MANIFEST, load_manifest
from twolink.studies.reproduction.reproduce import plan

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from profile_reproduce import profile  # noqa: E402


def repeated_scenarios(specs) -> list[tuple[str, str]]:
    """Pairs of runs (folders) whose scenarios are equal: one computation done twice."""
    seen: dict[bytes, str] = {}
    pairs = []
    for sp in specs:
        key = pickle.dumps(load_scenario(sp.experiment.scenario, sp.overrides))
        if key in seen:
            pairs.append((seen[key], sp.folder))
        seen.setdefault(key, sp.folder)
    return pairs


def test_the_shipped_reproduction_runs_no_scenario_twice():
    assert repeated_scenarios(plan(load_manifest(DEFAULT_MANIFEST), None)) == []


def test_a_manifest_that_lists_an_experiment_twice_is_found_out():
    import dataclasses

    manifest = load_manifest(DEFAULT_MANIFEST)
    again = dataclasses.replace(manifest.experiments[0], table=None, figure=None, name="again")
    twice = dataclasses.replace(manifest, experiments=(manifest.experiments[0], again))
    pairs = repeated_scenarios(plan(twice, None))
    runs = len(manifest.variants) * len(manifest.controllers)
    assert len(pairs) == runs  # every run of the copy
    assert all(b.split("/")[1] == "again" for _, b in pairs)


def record(start, arms, steps, digests, sweep="", callers=()):
    return {
        "engine": "batch", "start": start, "end": start + 1.0, "arms": arms,
        "physics_steps": steps, "arm_steps": arms * steps, "useful_arm_steps": arms * steps,
        "digests": digests, "sweep": sweep, "callers": list(callers),
    }  # fmt: skip


def test_the_profile_counts_per_phase_per_regime_and_the_arms_computed_twice():
    run = {
        "start": 0.0, "end": 30.0, "phases": [(5.0, "design"), (10.0, "runs")],
        "samples": [(t, 1.5 * t, 2) for t in range(31)],
    }  # fmt: skip
    records = [
        record(6.0, 2, 100, ["a", "b"], callers=["twolink.studies.designs.design.run"]),
        record(12.0, 3, 50, ["c", "a", "d"], sweep="robustness:0123456789ab"),
        record(20.0, 2, 10, ["c", "c"], sweep="lab:ffffffffffff"),
    ]
    p = profile(records, run, {"0123456789ab": "claims_study/"}, cores=2)
    assert p["phases"]["design"]["arm_steps"] == 200
    assert p["phases"]["runs"]["arm_steps"] == 150 + 20
    assert p["regimes"]["design"]["arm_steps"] == 200
    assert p["regimes"]["claims_study/"]["arm_steps"] == 150
    assert p["regimes"]["sweep lab"]["arm_steps"] == 20
    # "a" again (50 steps), "c" twice more (10 steps each)
    assert p["arms_repeated"] == 3 and p["arm_steps_repeated"] == 50 + 2 * 10
    assert p["repeated_where"] == {"design -> claims_study/": 1, "claims_study/ -> sweep lab": 2}
    assert p["phases"]["runs"]["cpu_share"] == 1.5 / 2
