"""Where the paper's fuzzy term acts: the share of samples it is on, and the paper's own
raw step (a scenario replaces its inherited quintic reference with ``replace = true``)."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from twolink.interface.cli import main
from twolink.simulation.config import ConfigError, load_scenario, parse_set
from twolink.simulation.experiment import measure, run_scenario

STEP = Path(__file__).resolve().parents[1] / "runs" / "paper" / "theta1_step.toml"
RAW = {"joint1": {"replace": True, "kind": "step", "final": 1.0}}


def run(kind: str, wn: float, reference=None):
    over = {"controller": {"kind": kind, "rule_base": "designed", "kp": wn * wn, "kd": 2 * wn}}
    if kind == "ctc":
        del over["controller"]["rule_base"]
    if reference:
        over["reference"] = reference
    s = load_scenario(STEP, over)
    return measure(s, run_scenario(s))


def test_a_scenario_replaces_an_inherited_reference_whole(tmp_path):
    f = tmp_path / "raw.toml"
    f.write_text(f'extends = "{STEP}"\n[reference.joint1]\nkind = "step"\nfinal = 1.0\n')
    with pytest.raises(ConfigError, match=r"unknown parameter\(s\) \['duration'\]"):
        load_scenario(f)  # merged over the quintic, the step inherits its duration
    f.write_text(f'extends = "{STEP}"\n[reference.joint1]\nreplace = true\nkind = "step"\n'
                 "final = 1.0\n")  # fmt: skip
    s = load_scenario(f)
    assert type(s.reference.joint1).__name__ == "Step" and s.reference.joint1.final == 1.0
    assert "replace" not in s.to_dict()["reference"]["joint1"]
    # the same from the command line
    sets = parse_set(["reference.joint1.replace=true", "reference.joint1.kind=step",
                      "reference.joint1.final=0.5"])  # fmt: skip
    assert load_scenario(STEP, sets).reference.joint1.final == 0.5
    out = tmp_path / "o"
    args = ["run", str(STEP), "--out", str(out), "--no-plots", "--no-trace"]
    args += ["--set", "duration=1", "--set", "reference.joint1.replace=true"]
    args += ["--set", "reference.joint1.kind=step", "--set", "reference.joint1.final=1.0"]
    assert CliRunner().invoke(main, args).exit_code == 0


def test_the_designed_fuzzy_term_never_acts_on_the_shipped_quintic_moves():
    # at ωn 15 on a 2 s quintic the errors stay below E/3: no rule gives an output, and
    # FCM-CTC is CTC to rounding
    m, c = run("fcm_ctc", 15.0), run("ctc", 15.0)
    assert m.fuzzy_active == (0.0, 0.0)
    assert abs(m.errors.iae[0] - c.errors.iae[0]) < 1e-15
    assert all(x != x for x in c.fuzzy_active)  # NaN: CTC has no fuzzy term


def test_on_the_papers_raw_step_it_acts_and_helps_at_the_same_gain():
    # the measurement: ωn 4, a raw 1 rad step: Tr 0.84 -> 0.63 s, IAE -18 %
    m, c = run("fcm_ctc", 4.0, RAW), run("ctc", 4.0, RAW)
    assert m.fuzzy_active[0] > 0.01
    assert m.step[0].rise_time == pytest.approx(0.631, abs=0.002)
    assert c.step[0].rise_time == pytest.approx(0.836, abs=0.002)
    assert m.errors.iae[0] < 0.85 * c.errors.iae[0]


def test_the_raw_variant_runs_the_papers_own_references_at_its_stated_gain():
    from twolink.studies.judgments.claims_studies import raw_steps
    from twolink.studies.reproduction.manifest import load_manifest
    from twolink.studies.reproduction.reproduce import plan

    manifest = load_manifest()
    (raw,) = [v for v in manifest.variants if v.raw_steps]
    for spec in plan(manifest, None):
        if spec.variant is not raw:
            continue
        s = load_scenario(spec.experiment.scenario, spec.overrides)
        kinds = {type(r).__name__ for r in (s.reference.joint1, s.reference.joint2)}
        assert kinds <= {"Step", "Ramp"}, (spec.folder, kinds)  # no smooth move left
        if spec.controller == "CTC":
            assert s.controller.kp == (9.0, 9.0) and s.controller.kd == (6.0, 6.0)
    # the stated rule: ωn 3 keeps CTC's raw steps within the torque limits, ωn 4 does not
    for wn, within in ((3.0, True), (4.0, False)):
        peaks = []
        for f in ("theta1_step.toml", "theta2_step.toml"):
            path = STEP.parent / f
            over = {"reference": raw_steps(path), "controller": {"kp": wn * wn, "kd": 2 * wn,
                    "torque_limit": [1e9, 1e9]}}  # fmt: skip
            s = load_scenario(path, over)
            peaks.append(measure(s, run_scenario(s)).torque.peak)
        fits = all(p[0] <= 60.0 and p[1] <= 15.0 for p in peaks)
        assert fits is within, (wn, peaks)
