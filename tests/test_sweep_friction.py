"""Friction drawn per plant in a sweep (docs/sweeps.md, "Parameters"): the drawn values
reach the plant (MuJoCo's own frictionloss, the run bit for bit), the breakaway rule, and
bad specs as one-line errors naming the file and key."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from twolink import sweep as sw
from twolink.interface.cli import main as cli_main
from twolink.simulation.config import ConfigError, load_scenario
from twolink.simulation.experiment import measure, run_scenario
from twolink.sweep.friction_draws import friction_data

REPO = Path(__file__).resolve().parents[1]
BASE = REPO / "runs" / "paper" / "base.toml"

SWEEP = f"""
name = "friction"
scenario = "{BASE}"
samples = 3
seed = 3

[overrides]
duration = 0.4

[overrides.plant.friction]
viscous = 0.05
coulomb = [1.0, 0.2]
breakaway = [1.5, 0.3]

[reference.joint1]
kind = "step"
final = 0.2

[parameters]
coulomb1 = {{ dist = "uniform", low = 1.0, high = 2.0 }}
stribeck_velocity = {{ dist = "loguniform", low = 0.01, high = 0.1 }}

[controllers.ctc]
kind = "ctc"
"""


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "sweep.toml"
    path.write_text(text)
    return path


def test_drawn_friction_reaches_the_plant_and_the_run(tmp_path):
    plan = sw.load_sweep(write(tmp_path, SWEEP))
    values, noise_seed = plan.draw(2)
    assert 1.0 <= values["coulomb1"] <= 2.0 and 0.01 <= values["stribeck_velocity"] <= 0.1
    data = plan.sample_data(values, noise_seed)
    friction = data["plant"]["friction"]
    # joint 1 drawn, joint 2 the base's; each keeps the base's breakaway / Coulomb (1.5)
    assert friction["coulomb"] == [values["coulomb1"], 0.2]
    assert friction["breakaway"] == pytest.approx([1.5 * values["coulomb1"], 0.3], rel=1e-15)
    assert friction["viscous"] == 0.05
    assert friction["stribeck_velocity"] == values["stribeck_velocity"]
    # the sweep's row equals a direct run of the scenario written out by hand
    row = dict(zip(plan.columns, sw.run_chunk(plan, 0).rows[2], strict=True))
    common = {
        "duration": 0.4,
        "seed": noise_seed,
        "reference": {"joint1": {"kind": "step", "final": 0.2}},
        "controller": {"kind": "ctc"},
    }
    by_hand = {
        "viscous": 0.05,
        "coulomb": [values["coulomb1"], 0.2],
        "breakaway": [1.5 * values["coulomb1"], 0.3],
        "stribeck_velocity": values["stribeck_velocity"],
    }
    s = load_scenario(BASE, {**common, "plant": {"friction": by_hand}})
    assert s.plant.friction.coulomb == (values["coulomb1"], 0.2)
    model = run_scenario(s)
    m = measure(s, model)
    assert row["status"] == m.status
    assert row["joint1_iae_rad_s"] == m.errors.iae[0]  # bit for bit
    # ... and the friction acts: the same plant without it tracks otherwise
    bare = load_scenario(BASE, common)
    assert measure(bare, run_scenario(bare)).errors.iae[0] != m.errors.iae[0]


def test_a_drawn_ratio_sets_both_breakaways_over_the_base():
    base = {"coulomb": [1.0, 0.2], "breakaway": [1.5, 0.3], "viscous": 0.05}
    got = friction_data(base, {"coulomb2": 0.4, "stribeck_ratio": 1.2})
    assert got["coulomb"] == [1.0, 0.4]
    assert got["breakaway"] == pytest.approx([1.2, 0.48], rel=1e-15)
    # without a drawn ratio and with no breakaway in the base: no dip (F_s = F_c)
    assert friction_data({}, {"coulomb1": 2.0})["breakaway"] == [2.0, 0.0]
    assert friction_data(base, {"m1": 1.0}) is None  # no friction swept


BAD = {
    "ratio below 1": ('stribeck_velocity = {{ dist = "loguniform", low = 0.01, high = 0.1 }}',
                      'stribeck_ratio = {{ dist = "loguniform", low = 0.5, high = 1.5 }}',
                      "parameters.stribeck_ratio.low: must be >= 1"),
    "negative coulomb": ('low = 1.0, high = 2.0', 'low = -1.0, high = 2.0',
                         "parameters.coulomb1.low: must be >= 0"),
    "zero v_s": ('low = 0.01, high = 0.1', 'low = 0.0, high = 0.1',
                 "parameters.stribeck_velocity.low: must be > 0"),
    "normal ratio untruncated": (
        'stribeck_velocity = {{ dist = "loguniform", low = 0.01, high = 0.1 }}',
        'stribeck_ratio = {{ dist = "normal", mean = 1.3, std = 0.1 }}',
        "parameters.stribeck_ratio.low: missing"),
}  # fmt: skip


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_friction_parameters_are_one_line_errors(tmp_path, case):
    old, new, message = (x.replace("{{", "{").replace("}}", "}") for x in BAD[case])
    assert old in SWEEP
    path = write(tmp_path, SWEEP.replace(old, new, 1))
    with pytest.raises(ConfigError) as err:
        sw.load_sweep(path)
    assert str(err.value).startswith(f"{path}: ") and message in str(err.value)
    result = CliRunner().invoke(cli_main, ["sweep", str(path), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2
    assert f"error: {path}: " in result.output and message in result.output
    assert "Traceback" not in result.output and len(result.output.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_friction_draws_last_so_the_other_draws_stay(tmp_path):
    """The same plants and noise seeds with friction added: it draws after them."""
    plants = '[parameters]\nm1 = { dist = "uniform", low = 0.7, high = 1.3 }\n'
    plants += 'payload = { dist = "uniform", low = 0.0, high = 0.2 }\n'
    friction = 'coulomb1 = { dist = "uniform", low = 1.0, high = 2.0 }\n'
    friction += 'stribeck_ratio = { dist = "uniform", low = 1.2, high = 1.5 }\n'
    head = SWEEP[: SWEEP.index("[parameters]")] + '[controllers.ctc]\nkind = "ctc"\n\n'
    plain = sw.load_sweep(write(tmp_path, head + plants))
    lab = sw.load_sweep(write(tmp_path, head + plants + friction))
    for i in range(3):
        (a, seed_a), (b, seed_b) = plain.draw(i), lab.draw(i)
        assert seed_a == seed_b and {n: b[n] for n in a} == a
        assert 1.0 <= b["coulomb1"] <= 2.0 and 1.2 <= b["stribeck_ratio"] <= 1.5


def test_friction_level_is_a_share_of_each_joints_holding_torque(tmp_path):
    """friction_level = 0.1 on the nominal arm: F_c = 0.1 G(q = 0) per joint, G from the
    closed form of two uniform rods held horizontal, (m1 l1/2 + m2 (l1 + l2/2)) g and
    m2 l2/2 g = (19.62, 4.905) N·m."""
    text = SWEEP.replace("coulomb1 = {", "friction_level = {").replace(
        "low = 1.0, high = 2.0", "low = 0.1, high = 0.1"
    )
    plan = sw.load_sweep(write(tmp_path, text))
    values, seed = plan.draw(0)
    friction = plan.sample_data(values, seed)["plant"]["friction"]
    assert friction["coulomb"] == pytest.approx([1.962, 0.4905], rel=1e-12)
    assert friction["breakaway"] == pytest.approx([1.5 * 1.962, 1.5 * 0.4905], rel=1e-12)


def test_friction_level_and_a_joints_coulomb_conflict(tmp_path):
    text = SWEEP + 'friction_level = { dist = "grid", values = [0.1] }\n'
    text = (
        text.replace('[controllers.ctc]\nkind = "ctc"\n', "") + '[controllers.ctc]\nkind = "ctc"\n'
    )
    path = write(tmp_path, text)
    with pytest.raises(ConfigError, match="parameters.coulomb1: conflicts with 'friction_level'"):
        sw.load_sweep(path)
