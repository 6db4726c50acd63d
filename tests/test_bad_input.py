"""Bad input never ends in a traceback: exit 2, one line naming the file and the key,
checked before any work, nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from twolink.interface.cli import main

REPO = Path(__file__).resolve().parents[1]
BASE = REPO / "runs" / "paper" / "theta1_step.toml"

# body appended to `extends = BASE` -> what the one-line error must say
SCENARIOS = {
    # syntax and structure
    "toml syntax": ("[controller\nkp = 1", "not valid TOML"),
    "unknown top key": ("durration = 3.0", "durration: unknown key"),
    "unknown table key": ("[controller]\nkpp = 3.0", "controller.kpp: unknown key"),
    "unknown arm key": ("[arm]\nm3 = 1.0", "arm.m3: unknown key"),
    "table as value": ("arm = 3", "arm: must be a table"),
    "value as table": ("[duration]\nx = 1", "duration: must be a number"),
    # types
    "string number": ('duration = "ten"', "duration: must be a number"),
    "bool number": ("duration = true", "duration: must be a number"),
    "list number": ("duration = [1.0]", "duration: must be a number"),
    "string kind": ("[controller]\nkind = 3", "controller.kind: must be a string"),
    "unknown kind": ('[controller]\nkind = "pid"', "controller.kind: must be one of"),
    "bad pair": ("[controller]\nkp = [1, 2, 3]", "controller.kp: must be a number or a list of 2"),
    "bad fuzzy mode": ('[controller.fuzzy]\nmode = "mul"', "controller.fuzzy.mode: must be one of"),
    "reference kind": ('[reference.joint1]\nkind = "jump"', "unknown reference kind 'jump'"),
    "reference param": ("[reference.joint1]\nheight = 1.0", "reference.joint1"),
    # non-finite
    "nan duration": ("duration = nan", "duration: must be finite"),
    "inf mass": ("[arm]\nm1 = inf", "arm.m1: must be finite"),
    "nan gain": ("[controller]\nkp = nan", "controller.kp: must be finite"),
    "nan reference": ("[reference.joint1]\nfinal = nan", "reference.joint1"),
    "inf noise": ("[sensor]\nnoise_std_rad = inf", "sensor.noise_std_rad: must be finite"),
    "noise in its old place": ("[plant]\nnoise_std = 0.1", "plant.noise_std: moved"),
    # zero and negative
    "zero duration": ("duration = 0.0", "duration: must be > 0"),
    "negative duration": ("duration = -1.0", "duration: must be > 0"),
    "zero timestep": ("timestep = 0.0", "timestep: must be > 0"),
    "zero mass": ("[arm]\nm2 = 0.0", "arm.m2: must be > 0"),
    "negative length": ("[arm]\nl1 = -1.0", "arm.l1: must be > 0"),
    "negative gain": ("[controller]\nkd = -2.4", "controller.kd: must be >= 0"),
    "zero torque limit": (
        "[controller]\ntorque_limit = 0.0",
        "controller.torque_limit: must be > 0",
    ),
    "negative payload": ("[plant]\npayload = -0.1", "plant.payload: must be >= 0"),
    "negative noise": ("[sensor]\nnoise_std_rad = -1.0", "sensor.noise_std_rad: must be >= 0"),
    "negative quantum": ("[sensor]\nresolution_rad = -1e-5", "sensor.resolution_rad: must be >= 0"),
    "unknown velocity": ('[sensor]\nvelocity = "tacho"', "sensor.velocity: must be one of"),
    "fractional delay": (
        "[sensor]\ndelay_samples = 1.5",
        "sensor.delay_samples: must be an integer",
    ),
    "cut-off past Nyquist": (
        '[sensor]\nvelocity = "filtered"\ncutoff_hz = 500.0',
        "sensor.cutoff_hz: cutoff_hz 500 must be below the Nyquist frequency",
    ),
    "unknown sensor key": ("[sensor]\nbits = 17", "sensor.bits: unknown key"),
    "joint scale on a rigid arm": (
        "[plant.scale]\nk = 0.8",
        "plant.scale.k: scales the flexible joints",
    ),
    "zero scale": ("[plant.scale]\nm1 = 0.0", "plant.scale.m1: must be > 0"),
    "unknown scale": ("[plant.scale]\nm3 = 1.0", "plant.scale.m3: unknown key"),
    "zero stiffness": ("[plant.flexibility]\nk = 0.0", "plant.flexibility.k: must be > 0"),
    "negative damping": ("[plant.flexibility]\nd = -1.0", "plant.flexibility.d: must be >= 0"),
    "zero rotor": ("[plant.flexibility]\nj = [0.05, 0.0]", "plant.flexibility.j: must be > 0"),
    "zero ke": ("[controller.fuzzy]\nke = 0.0", "controller.fuzzy.ke: must be > 0"),
    "negative ku": ("[controller.fuzzy]\nku = -1.0", "controller.fuzzy.ku: must be >= 0"),
    "negative seed": ("seed = -1", "seed: must be an integer >= 0"),
    "ramp duration": (
        '[reference.joint1]\nkind = "ramp"\nfinal = 1.0\nduration = 0.0',
        "reference.joint1",
    ),
    # tiny and huge
    "tiny mass": ("[arm]\nm1 = 1e-300", "MuJoCo cannot build this arm"),
    "huge integer": ("[arm]\nm1 = " + "9" * 400, "arm.m1: must be a number a float can hold"),
    "huge duration": ("duration = 1e9", "duration: 1e+09 s at a timestep of 0.001 s"),
    "tiny timestep": ("timestep = 1e-12\ncontrol_dt = 1e-12", "control_dt: must be >= 1e-06"),
    "control_dt not multiple": ("control_dt = 0.0015", "control_dt: must be a whole multiple"),
    "duration below control_dt": ("duration = 0.0001", "duration: must be at least control_dt"),
    # files it points to
    "missing rule base": (
        '[controller]\nkind = "fcm_ctc"\nrule_base = "missing.toml"',
        "controller.rule_base: no such file",
    ),
    "broken rule base": (
        '[controller]\nkind = "fcm_ctc"\nrule_base = "broken_rules.toml"',
        "controller.rule_base:",
    ),
}


def scenario(tmp_path: Path, body: str) -> Path:
    (tmp_path / "broken_rules.toml").write_text('[[rule]]\ne = "XX"\nde = "Z"\nu = "Z"\n')
    path = tmp_path / "bad.toml"
    path.write_text(f'extends = "{BASE}"\n{body}\n')
    return path


def assert_clean_failure(result, says: str, out: Path) -> None:
    assert result.exit_code == 2, (result.output, result.exception)
    assert isinstance(result.exception, SystemExit), result.exception  # not a traceback
    assert result.output.startswith("error: ") and says in result.output, result.output
    assert "Traceback" not in result.output
    assert not out.exists()


@pytest.mark.parametrize("case", sorted(SCENARIOS))
def test_a_bad_scenario_exits_2_with_one_line_and_writes_nothing(tmp_path, case):
    body, says = SCENARIOS[case]
    path = scenario(tmp_path, body)
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["run", str(path), "--out", str(out)])
    assert_clean_failure(result, says, out)
    assert str(path) in result.output or "bad.toml" in result.output


def _file(path: Path, data: bytes | None) -> Path:
    """``path`` with ``data`` written, or a folder for None."""
    if data is None:
        path.mkdir()
    else:
        path.write_bytes(data)
    return path


def _chain(tmp_path: Path, depth: int) -> Path:
    previous = BASE
    for i in range(depth):
        path = tmp_path / f"chain{i}.toml"
        path.write_text(f'extends = "{previous}"\n')
        previous = path
    return previous


FILES = {
    "no such file": (lambda tmp: tmp / "nope.toml", "nope.toml: no such file"),
    "a folder": (lambda tmp: _file(tmp / "dir.toml", None), "is a folder"),
    "missing base": (
        lambda tmp: _file(tmp / "x.toml", b'extends = "gone.toml"\n'),
        "x.toml: extends: ",
    ),
    "extends cycle": (
        lambda tmp: _file(tmp / "loop.toml", b'extends = "loop.toml"\n'),
        "extends itself",
    ),
    "deep chain": (lambda tmp: _chain(tmp, 1500), "extends: a chain of more than 64 files"),
    "binary file": (lambda tmp: _file(tmp / "b.toml", b"\xff\xfe\x00"), "b.toml: cannot be read"),
    "sweep file": (lambda tmp: REPO / "runs/sweeps/robustness.toml", "this is a sweep file"),
}


@pytest.mark.parametrize("case", sorted(FILES))
def test_bad_files_exit_2_naming_the_file(tmp_path, case):
    make, says = FILES[case]
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["run", str(make(tmp_path)), "--out", str(out)])
    assert_clean_failure(result, says, out)


@pytest.mark.parametrize(
    "args",
    [
        ["run", str(BASE)],
        ["sweep", str(REPO / "runs/sweeps/robustness.toml"), "-n", "2"],
        ["reproduce"],
    ],
    ids=["run", "sweep", "reproduce"],
)
def test_an_unwritable_out_is_bad_input_found_before_any_work(tmp_path, args):
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    result = CliRunner().invoke(main, [*args, "--out", str(blocker / "sub")])
    assert result.exit_code == 2 and isinstance(result.exception, SystemExit), result.output
    assert "a_file, which is a file, not a folder" in result.output
    assert blocker.read_text() == ""


def test_sweep_sizes_are_bounded(tmp_path):
    result = CliRunner().invoke(
        main, ["sweep", str(REPO / "runs/sweeps/robustness.toml"), "-n", "1000000000"]
    )
    assert result.exit_code == 2 and "samples: at most 1,000,000" in result.output


def test_names_from_a_manifest_never_leave_the_output_folder(tmp_path):
    text = (REPO / "runs/paper/reproduce.toml").read_text()
    for field in ("design", "flexible_study", "scenario"):
        text = text.replace(f'{field} = "', f'{field} = "{REPO / "runs/paper"}/')
    for evil in ("../../escape", "/tmp/abs", ".hidden"):
        bad = text.replace("[controllers.CTC]", f'[controllers."{evil}"]')
        bad = bad.replace('baseline = "CTC"', f'baseline = "{evil}"')
        path = tmp_path / "evil.toml"
        path.write_text(bad)
        out = tmp_path / "out"
        result = CliRunner().invoke(main, ["reproduce", "--manifest", str(path), "--out", str(out)])
        assert result.exit_code == 2, result.output
        assert f"controllers.{evil}: must be 1-100 letters" in result.output
        assert not out.exists() and not (tmp_path / "escape").exists()
    variant = text.replace("[variants.rigid]", '[variants."../up"]')
    path.write_text(variant)
    result = CliRunner().invoke(main, ["reproduce", "--manifest", str(path), "--out", str(out)])
    assert result.exit_code == 2 and "variants.../up: must be 1-100 letters" in result.output


def test_a_run_on_a_rule_base_with_gaps_says_how_much_it_leaves_uncovered(tmp_path):
    path = scenario(tmp_path, 'duration = 0.1\n[controller]\nkind = "fcm_ctc"\nrule_base = "paper"')
    result = CliRunner().invoke(main, ["run", str(path), "--out", str(tmp_path / "o")])
    assert result.exit_code == 0, result.output
    assert "no rule fires on 70 % of the (e, de) input box" in result.stderr
