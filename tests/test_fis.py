"""MATLAB .fis files: the designed rule base round-trips with its scaling, a hand-written
file in the MathWorks format parses, and what twolink's engine cannot run is refused."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from twolink.controllers.fuzzy import default_fuzzy_pd
from twolink.controllers.fuzzy.fis.engine_files import (
    engine_from_fis,
    parse_fis,
    read_rule_base,
    to_fis,
)
from twolink.interface.cli import main
from twolink.simulation.config import load_scenario
from twolink.simulation.experiment import build_controller

REPO = Path(__file__).resolve().parents[1]

# The tipping problem as the MathWorks documentation writes it in the .fis format
# (Fuzzy Logic Toolbox, "tipper.fis"): Gaussian and trapezoidal inputs, OR rules, and a
# don't-care input (0).
TIPPER = """[System]
Name='tipper'
Type='mamdani'
Version=2.0
NumInputs=2
NumOutputs=1
NumRules=3
AndMethod='min'
OrMethod='max'
ImpMethod='min'
AggMethod='max'
DefuzzMethod='centroid'

[Input1]
Name='service'
Range=[0 10]
NumMFs=3
MF1='poor':'gaussmf',[1.5 0]
MF2='good':'gaussmf',[1.5 5]
MF3='excellent':'gaussmf',[1.5 10]

[Input2]
Name='food'
Range=[0 10]
NumMFs=2
MF1='rancid':'trapmf',[0 0 1 3]
MF2='delicious':'trapmf',[7 9 10 10]

[Output1]
Name='tip'
Range=[0 30]
NumMFs=3
MF1='cheap':'trimf',[0 5 10]
MF2='average':'trimf',[10 15 20]
MF3='generous':'trimf',[20 25 30]

[Rules]
1 1, 1 (1) : 2
2 0, 2 (1) : 1
3 2, 3 (1) : 2
"""


def designed():
    s = load_scenario(REPO / "runs/paper/base.toml",
                      {"controller": {"kind": "fcm_ctc", "rule_base": "designed"}})  # fmt: skip
    return build_controller(s)


def test_the_designed_rule_base_round_trips_with_its_scaling(tmp_path):
    c = designed()
    scaling = (c.ke, c.kde, c.ku)
    text = to_fis(c.engine, "designed", scaling)
    engine, back = engine_from_fis(parse_fis(text))
    assert np.allclose(back, scaling, rtol=1e-12)
    assert engine.rules == c.engine.rules
    for name in ("e", "de", "u"):
        ours, theirs = getattr(c.engine, name), getattr(engine, name)
        assert ours.labels == theirs.labels
        for a, b in zip(ours.mfs, theirs.mfs, strict=True):
            assert a.kind == b.kind and np.allclose(a.params, b.params, atol=1e-12)
    # the physical control law is the same: ku f(ke e, kde de) on random inputs
    rng = np.random.default_rng(0)
    e, de = rng.uniform(-0.1, 0.1, 2000), rng.uniform(-1.5, 1.5, 2000)
    ours = c.ku * c.engine(c.ke * e, c.kde * de)
    theirs = back[2] * engine(back[0] * e, back[1] * de)
    assert np.max(np.abs(ours - theirs)) < 1e-12
    # a scenario and coverage take the file as a rule base
    path = tmp_path / "designed.fis"
    path.write_text(text)
    assert tuple(read_rule_base(path).rules) == c.engine.rules
    f = tmp_path / "s.toml"
    f.write_text(f'extends = "{REPO / "runs/paper/theta1_step.toml"}"\n'
                 f'[controller]\nkind = "fcm_ctc"\nrule_base = "{path}"\n')  # fmt: skip
    assert build_controller(load_scenario(f)).engine.rules == c.engine.rules
    result = CliRunner().invoke(main, ["coverage", str(path)])
    assert "61.11 %" in result.output  # the designed base's exact gap, as from TOML


def test_the_fis_command_writes_what_readfis_reads(tmp_path):
    out = tmp_path / "table1.fis"
    result = CliRunner().invoke(main, ["fis", "paper", "--out", str(out)])
    assert result.exit_code == 0, result.output
    fis = parse_fis(out.read_text())
    assert fis.system["Type"] == "mamdani" and len(fis.rules) == 5
    assert [v.name for v in fis.inputs] == ["e", "de"] and fis.outputs[0].name == "u"
    assert all(t == "trimf" for v in (*fis.inputs, *fis.outputs) for _, t, _ in v.mfs)
    assert tuple(read_rule_base(out).rules) == default_fuzzy_pd().with_rules(
        read_rule_base(REPO / "controllers/rulebases/paper_table1.toml")).rules  # fmt: skip
    result = CliRunner().invoke(main, ["fis", "paper", "--out", str(out)])
    assert result.exit_code == 0  # its own file: overwritten
    mine = tmp_path / "mine.fis"
    mine.write_text("% my own\n")
    assert CliRunner().invoke(main, ["fis", "--out", str(mine)]).exit_code == 2
    assert mine.read_text() == "% my own\n"


def test_the_mathworks_format_example_parses_and_what_the_engine_cannot_run_is_named():
    fis = parse_fis(TIPPER, "tipper.fis")
    assert fis.system["Name"] == "tipper" and fis.system["DefuzzMethod"] == "centroid"
    service, food = fis.inputs
    assert service.name == "service" and service.range == (0.0, 10.0)
    assert service.mfs[1] == ("good", "gaussmf", (1.5, 5.0))
    assert food.mfs[1] == ("delicious", "trapmf", (7.0, 9.0, 10.0, 10.0))
    assert fis.outputs[0].mfs[2] == ("generous", "trimf", (20.0, 25.0, 30.0))
    assert fis.rules == (((1, 1), (1,), 1.0, 2), ((2, 0), (2,), 1.0, 1), ((3, 2), (3,), 1.0, 2))
    with pytest.raises(ValueError, match=r"tipper.fis: rule 1: connection 2 \(OR\)"):
        engine_from_fis(fis, "tipper.fis")
    and_only = TIPPER.replace(": 2", ": 1").replace("2 0, 2", "2 1, 2")
    engine, scaling = engine_from_fis(parse_fis(and_only), "tipper.fis")
    assert scaling == (0.1, 0.1, 30.0) and len(engine.rules) == 3
    with pytest.raises(ValueError, match="rule 2: a don't-care"):
        engine_from_fis(parse_fis(TIPPER.replace(": 2", ": 1")), "tipper.fis")
    with pytest.raises(ValueError, match=r"line 38: not a rule"):
        parse_fis(TIPPER.replace("1 1, 1 (1) : 2", "1 1 1 : 2"), "tipper.fis")
