"""docs/scenarios.md lists every key the scenario schema reads, so it cannot drift."""

from dataclasses import fields
from pathlib import Path

from twolink.foundation.references import Quintic, Ramp, Septic, Sine, Step
from twolink.simulation.config import FuzzyConfig, load_scenario

REPO = Path(__file__).resolve().parents[1]
DOC = (REPO / "docs" / "scenarios.md").read_text()


def leaves(data: dict) -> set[str]:
    """The keys that hold values (``scale`` is a value: a table of factors)."""
    out = set()
    for key, value in data.items():
        if isinstance(value, dict) and key != "scale":
            out |= leaves(value)
        else:
            out.add(key)
    return out


def test_every_scenario_key_is_documented():
    s = load_scenario(
        REPO / "runs" / "paper" / "theta1_step.toml",
        {"plant": {"scale": {"m1": 1.1}, "flexibility": {"k": 100.0}}, "controller": {}},
    )
    data = s.to_dict()  # every key the schema reads, with its default filled in
    assert {k for k in leaves(data) if f"`{k}`" not in DOC} == set()
    # to_dict leaves out [controller.fuzzy] keys at their defaults (engine, table_points
    # and inference went undocumented that way): its dataclass's fields are its keys
    assert {f.name for f in fields(FuzzyConfig) if f"`{f.name}`" not in DOC} == set()
    for table in ("[arm]", "[plant]", "[plant.flexibility]", "[controller]",
                  "[controller.fuzzy]", "[initial]", "[reference.joint1]"):  # fmt: skip
        assert table in DOC, table


def test_every_reference_kind_and_parameter_is_documented():
    for cls in (Step, Ramp, Sine, Quintic, Septic):
        assert f'`"{cls.kind}"`' in DOC
        for f in fields(cls):
            assert f"`{f.name}`" in DOC, (cls.kind, f.name)
