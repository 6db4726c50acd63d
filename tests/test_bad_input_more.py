"""More bad input, beyond tests/test_bad_input.py: sweep files, reproduction manifests,
design files, ``--set`` overrides and command-line misuse. Each is refused with exit 2 and
one line naming the file (or option) and the key, before any work, with nothing written.

``DEFECTS`` are inputs these tests found refused late, with a traceback, or with a message
that did not name the file and key where the mistake is (issue 13); all are fixed.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from twolink.interface.cli import main

REPO = Path(__file__).resolve().parents[1]
BASE = REPO / "runs" / "paper" / "base.toml"
STEP = REPO / "runs" / "paper" / "theta1_step.toml"
ROBUSTNESS = REPO / "runs" / "sweeps" / "robustness.toml"

# Short runs everywhere, so that an input wrongly accepted costs little.
TINY = f'extends = "{STEP}"\nduration = 0.05\n'
DESIGN = 'scenarios = ["tiny.toml"]\ncontroller = { kind = "fuzzy_ctc" }\nclusters = 2\n'

# Files the cases point to, written beside the file under test.
SIDE_FILES = {
    "tiny.toml": TINY,
    "short.toml": 'extends = "tiny.toml"\nduration = 0.01\n',
    "design.toml": DESIGN,
    "bad_design.toml": DESIGN.replace("clusters = 2", "clusters = 1"),
    "bad_step.toml": 'extends = "tiny.toml"\nduration = -1.0\n',
    "broken_rules.toml": '[[rule]]\ne = "XX"\nde = "Z"\nu = "Z"\n',
    "bad_base.toml": f'extends = "{BASE}"\n[arm]\nm1 = -1.0\n',
    "orphan_base.toml": 'extends = "gone.toml"\n',
    "garbled_base.toml": "x = [\n",
}

SWEEP = f'''name = "small"
scenario = "{BASE}"
samples = 2
seed = 0
chunk_size = 1

[overrides]
duration = 0.05

[reference.joint1]
kind = "step"
final = 1.0

[reference.joint2]
kind = "step"
final = 0.5

[parameters]
m1 = {{ dist = "uniform", low = 0.8, high = 1.2 }}

[controllers.ctc]
kind = "ctc"
'''

MANIFEST = """design = "design.toml"
proposed = "FCM-CTC"
baseline = "CTC"

[controllers.CTC]
kind = "ctc"

[controllers.FCM-CTC]
kind = "fcm_ctc"
rule_base = "designed"

[variants.rigid]
title = "rigid arm"

[[experiment]]
table = 2
title = "step"
scenario = "tiny.toml"
joint = 1
paper.CTC = { Tp = 5.89, Mp = 0.655 }
"""

M1 = 'm1 = { dist = "uniform", low = 0.8, high = 1.2 }'
CTC = '[controllers.ctc]\nkind = "ctc"\n'
REF1 = '[reference.joint1]\nkind = "step"\nfinal = 1.0\n'
EXPERIMENT = MANIFEST[MANIFEST.index("[[experiment]]") :]
CONTROLLERS = MANIFEST[MANIFEST.index("[controllers.CTC]") : MANIFEST.index("[variants.rigid]")]
RIGID = '[variants.rigid]\ntitle = "rigid arm"\n'


def workspace(tmp_path: Path) -> Path:
    for name, text in SIDE_FILES.items():
        (tmp_path / name).write_text(text)
    return tmp_path


def edited(template: str, old: str, new: str) -> str:
    assert old in template, old
    return template.replace(old, new, 1)


def invoke(*args) -> object:
    return CliRunner().invoke(main, [str(a) for a in args])


def assert_rejected(result, out: Path | None, *says: str, one_line: bool = True) -> None:
    """Exit 2 by a clean exit, no traceback, every ``says`` in the output, no --out."""
    assert result.exit_code == 2, (result.exit_code, result.output, result.exception)
    assert isinstance(result.exception, SystemExit), repr(result.exception)
    assert "Traceback" not in result.output, result.output
    for text in says:
        assert text in result.output, (text, result.output)
    if one_line:
        assert result.output.startswith("error: "), result.output
        assert len(result.output.strip().splitlines()) == 1, result.output
    if out is not None:
        assert not out.exists(), sorted(p.name for p in out.iterdir())


def sweep_args(path: Path, out: Path) -> list:
    return ["sweep", path, "--out", out, "--executor", "inprocess", "--no-plots", "--no-progress"]


def reproduce_args(path: Path, out: Path) -> list:
    return ["reproduce", "--manifest", path, "--out", out, "--no-trace", "--workers", "1"]


# ----------------------------------------------------------------------------- sweep files

# (text replaced in SWEEP, its replacement, what the error says after "FILE: ")
SWEEP_CASES = {
    # top-level numbers
    "samples float": ("samples = 2", "samples = 2.0", "samples: must be an integer >= 1, got 2.0"),
    "samples bool": ("samples = 2", "samples = true", "samples: must be an integer >= 1, got True"),
    "samples negative": ("samples = 2", "samples = -3", "samples: must be an integer >= 1, got -3"),
    "samples string": ("samples = 2", 'samples = "2"', "samples: must be an integer >= 1, got '2'"),
    "samples 10**30 in the file": (
        "samples = 2",
        f"samples = {10**30}",
        "samples: at most 1,000,000",
    ),
    "samples missing": ("samples = 2\n", "", "samples: missing: the number of samples"),
    "seed negative": ("seed = 0", "seed = -1", "seed: must be an integer >= 0, got -1"),
    "seed float": ("seed = 0", "seed = 1.5", "seed: must be an integer >= 0, got 1.5"),
    "seed bool": ("seed = 0", "seed = true", "seed: must be an integer >= 0, got True"),
    "seed string": ("seed = 0", 'seed = "0"', "seed: must be an integer >= 0, got '0'"),
    "chunk_size zero": ("chunk_size = 1", "chunk_size = 0", "chunk_size: must be an integer >= 1"),
    "chunk_size negative": (
        "chunk_size = 1",
        "chunk_size = -1",
        "chunk_size: must be an integer >= 1",
    ),
    "chunk_size float": (
        "chunk_size = 1",
        "chunk_size = 1.5",
        "chunk_size: must be an integer >= 1",
    ),
    "chunk_size bool": (
        "chunk_size = 1",
        "chunk_size = true",
        "chunk_size: must be an integer >= 1",
    ),
    # names that become folders
    "name escapes --out": ('name = "small"', 'name = "../x"', "name: must be 1-100 letters"),
    "name absolute": ('name = "small"', 'name = "/abs"', "name: must be 1-100 letters"),
    "name empty": ('name = "small"', 'name = ""', "name: must be 1-100 letters"),
    "name too long": ('name = "small"', f'name = "{"a" * 101}"', "name: must be 1-100 letters"),
    "name not a string": ('name = "small"', "name = 3", "name: must be a string, got 3"),
    "controller name escapes --out": (
        CTC,
        '[controllers."../x"]\nkind = "ctc"\n',
        "controllers.../x: must be 1-100 letters",
    ),
    "controller name absolute": (
        CTC,
        '[controllers."/abs"]\nkind = "ctc"\n',
        "controllers./abs: must be 1-100 letters",
    ),
    "controller name with slash": (
        CTC,
        '[controllers."a/b"]\nkind = "ctc"\n',
        "controllers.a/b: must be 1-100 letters",
    ),
    "controller name hidden": (
        CTC,
        '[controllers.".hidden"]\nkind = "ctc"\n',
        "controllers..hidden: must be 1-100 letters",
    ),
    "controller name with space": (
        CTC,
        '[controllers."a b"]\nkind = "ctc"\n',
        "controllers.a b: must be 1-100 letters",
    ),
    # the base scenario
    "scenario not a string": (
        f'scenario = "{BASE}"',
        "scenario = 3",
        "scenario: must be a file path",
    ),
    "scenario a list": (
        f'scenario = "{BASE}"',
        'scenario = ["a.toml"]',
        "scenario: must be a file path",
    ),
    "scenario missing key": (f'scenario = "{BASE}"\n', "", "scenario: missing: the base scenario"),
    "scenario a folder": (
        f'scenario = "{BASE}"',
        f'scenario = "{REPO / "runs"}"',
        "scenario: " + str(REPO / "runs") + ": is a folder",
    ),
    "scenario empty string": (
        f'scenario = "{BASE}"',
        'scenario = ""',
        "scenario: {tmp}: is a folder",
    ),
    "scenario a sweep file": (
        f'scenario = "{BASE}"',
        f'scenario = "{ROBUSTNESS}"',
        "scenario: " + str(ROBUSTNESS) + ": chunk_size: unknown key",
    ),
    "scenario with a bad key": (
        f'scenario = "{BASE}"',
        'scenario = "bad_base.toml"',
        "scenario: " + "{tmp}/bad_base.toml: arm.m1: must be > 0",
    ),
    "scenario extends a missing file": (
        f'scenario = "{BASE}"',
        'scenario = "orphan_base.toml"',
        "orphan_base.toml: extends: {tmp}/gone.toml: no such file",
    ),
    "scenario not TOML": (
        f'scenario = "{BASE}"',
        'scenario = "garbled_base.toml"',
        "scenario: {tmp}/garbled_base.toml: not valid TOML",
    ),
    # distributions
    "normal std negative": (
        M1,
        'm1 = { dist = "normal", mean = 1.0, std = -0.1, low = 0.5 }',
        "parameters.m1.std: must be >= 0",
    ),
    "normal std nan": (
        M1,
        'm1 = { dist = "normal", mean = 1.0, std = nan, low = 0.5 }',
        "parameters.m1.std: must be finite, got nan",
    ),
    "normal std inf": (
        M1,
        'm1 = { dist = "normal", mean = 1.0, std = inf, low = 0.5 }',
        "parameters.m1.std: must be finite, got inf",
    ),
    "normal mean outside truncation": (
        M1,
        'm1 = { dist = "normal", mean = 3.0, std = 0.1, low = 0.5, high = 2.0 }',
        "parameters.m1.mean: must lie within the truncation [0.5, 2.0], got 3.0",
    ),
    "normal truncation far from mean": (
        M1,
        'g = { dist = "normal", mean = 0.0, std = 1.0, low = 1000.0 }',
        "parameters.g.mean: must lie within the truncation",
    ),
    "normal missing mean": (
        M1,
        'm1 = { dist = "normal", std = 0.1, low = 0.5 }',
        "parameters.m1.mean: missing: normal needs it",
    ),
    "normal low > high": (
        M1,
        'm1 = { dist = "normal", mean = 1.0, std = 0.1, low = 2.0, high = 0.5 }',
        "parameters.m1.high: must be >= low (2.0)",
    ),
    "normal truncation too narrow to draw from": (
        M1,
        'm1 = { dist = "normal", mean = 1.0, std = 0.1, low = 0.9999, high = 1.0001 }',
        "parameters.m1.high: the truncation [0.9999, 1.0001] keeps 0.000798 of",
    ),
    "uniform missing high": (
        M1,
        'm1 = { dist = "uniform", low = 0.8 }',
        "parameters.m1.high: missing: uniform needs it",
    ),
    "uniform nan bound": (
        M1,
        'm1 = { dist = "uniform", low = nan, high = 1.2 }',
        "parameters.m1.low: must be finite, got nan",
    ),
    "uniform inf bound": (
        M1,
        'm1 = { dist = "uniform", low = 0.8, high = inf }',
        "parameters.m1.high: must be finite, got inf",
    ),
    "uniform string bound": (
        M1,
        'm1 = { dist = "uniform", low = "0.8", high = 1.2 }',
        "parameters.m1.low: must be a number, got '0.8'",
    ),
    "uniform bool bound": (
        M1,
        'm1 = { dist = "uniform", low = true, high = 1.2 }',
        "parameters.m1.low: must be a number, got True",
    ),
    "uniform with a normal key": (
        M1,
        'm1 = { dist = "uniform", low = 0.8, high = 1.2, mean = 1.0 }',
        "parameters.m1.mean: unknown key for uniform",
    ),
    "loguniform from zero": (
        M1,
        'g = { dist = "loguniform", low = 0.0, high = 1.2 }',
        "parameters.g.low: must be > 0 for parameter 'g'",
    ),
    "dist missing": (M1, "m1 = { low = 0.8, high = 1.2 }", "parameters.m1.dist: missing: one of"),
    "dist not a string": (
        M1,
        "m1 = { dist = 3, low = 0.8, high = 1.2 }",
        "parameters.m1.dist: must be one of",
    ),
    "parameter not a table": (M1, "m1 = 1.0", "parameters.m1: must be a table, got 1.0"),
    "choice weights of the wrong length": (
        M1,
        'payload = { dist = "choice", values = [0.0, 0.1], weights = [1.0] }',
        "parameters.payload.weights: must have 2 entries",
    ),
    "choice weights all zero": (
        M1,
        'payload = { dist = "choice", values = [0.0, 0.1], weights = [0.0, 0.0] }',
        "parameters.payload.weights: must not all be zero",
    ),
    "choice weight negative": (
        M1,
        'payload = { dist = "choice", values = [0.0, 0.1], weights = [-1.0, 2.0] }',
        "parameters.payload.weights: must be >= 0",
    ),
    "choice values not a list": (
        M1,
        'payload = { dist = "choice", values = 0.1 }',
        "parameters.payload.values: must be a non-empty list",
    ),
    "choice values strings": (
        M1,
        'payload = { dist = "choice", values = ["a"] }',
        "parameters.payload.values: must be a number, got 'a'",
    ),
    "choice values nested": (
        M1,
        'payload = { dist = "choice", values = [[0.1]] }',
        "parameters.payload.values: must be a number, got [0.1]",
    ),
    "choice values missing": (
        M1,
        'payload = { dist = "choice" }',
        "parameters.payload.values: missing: a list of numbers",
    ),
    "choice negative payload": (
        M1,
        'payload = { dist = "choice", values = [-0.1] }',
        "parameters.payload.values: must be >= 0 for parameter 'payload'",
    ),
    "grid with weights": (
        M1,
        'payload = { dist = "grid", values = [0.1], weights = [1.0] }',
        "parameters.payload.weights: unknown key for grid",
    ),
    "rotor inertia from zero": (
        M1,
        'j = { dist = "uniform", low = 0.0, high = 0.1 }',
        "parameters.j.low: must be > 0 for parameter 'j'",
    ),
    "joint damping negative": (
        M1,
        'd1 = { dist = "grid", values = [-1.0] }',
        "parameters.d1.values: must be >= 0 for parameter 'd1'",
    ),
    "d and d2 together": (
        M1,
        'd = { dist = "grid", values = [1.0] }\nd2 = { dist = "grid", values = [1.0] }',
        "parameters.d2: conflicts with 'd'",
    ),
    "j and j1 together": (
        M1,
        'j = { dist = "grid", values = [0.1] }\nj1 = { dist = "grid", values = [0.1] }',
        "parameters.j1: conflicts with 'j'",
    ),
    "parameter name in capitals": (M1, M1.replace("m1", "M1"), "parameters.M1: unknown parameter"),
    "parameter not sweepable": (
        M1,
        'noise_std = { dist = "uniform", low = 0.0, high = 0.1 }',
        "parameters.noise_std: unknown parameter",
    ),
    "parameters not a table": ("[parameters]\n" + M1, "", "parameters: must be a table, got 3"),
    # controllers
    "controllers not a table": (CTC, "", "controllers: must be a table, got 3"),
    "controllers empty table": (CTC, "[controllers]\n", "controllers: missing: at least one"),
    "controller not a table": (
        CTC,
        '[controllers]\nctc = "ctc"\n',
        "controllers.ctc: must be a table of [controller] overrides",
    ),
    "controller kind unknown": (
        CTC,
        '[controllers.ctc]\nkind = "pid"\n',
        "controllers.ctc.kind: must be one of",
    ),
    "controller kind not a string": (
        CTC,
        "[controllers.ctc]\nkind = 1\n",
        "controllers.ctc.kind: must be a string, got 1",
    ),
    "controller unknown key": (
        CTC,
        CTC + "gain = 1.0\n",
        "controllers.ctc.gain: unknown key",
    ),
    "controller rule base missing": (
        CTC,
        '[controllers.fcm]\nkind = "fcm_ctc"\nrule_base = "nope.toml"\n',
        "controllers.fcm.rule_base: no such file",
    ),
    "controller rule base a folder": (
        CTC,
        '[controllers.fcm]\nkind = "fcm_ctc"\nrule_base = "."\n',
        "controllers.fcm.rule_base: no such file",
    ),
    "controller rule base broken": (
        CTC,
        '[controllers.fcm]\nkind = "fcm_ctc"\nrule_base = "broken_rules.toml"\n',
        "controllers.fcm.rule_base: {tmp}/broken_rules.toml: unknown label 'XX'",
    ),
    "controller rule base not a string": (
        CTC,
        '[controllers.fcm]\nkind = "fcm_ctc"\nrule_base = 3\n',
        "controllers.fcm.rule_base: must be a string, got 3",
    ),
    "controller fuzzy mode unknown": (
        CTC,
        '[controllers.fz]\nkind = "fuzzy_ctc"\nfuzzy = { mode = "mul" }\n',
        "controllers.fz.fuzzy.mode: must be one of",
    ),
    "controller torque limit nan": (
        CTC,
        CTC + "torque_limit = nan\n",
        "controllers.ctc.torque_limit: must be finite",
    ),
    "controller gain of 3 joints": (
        CTC,
        CTC + "kp = [1, 2, 3]\n",
        "controllers.ctc.kp: must be a number or a list of 2",
    ),
    # [success]
    "success unknown key": (
        CTC,
        CTC + "[success]\nfinal_err = 0.1\n",
        "success.final_err: unknown key",
    ),
    "success final_error zero": (
        CTC,
        CTC + "[success]\nfinal_error = 0.0\n",
        "success.final_error: must be > 0, got 0.0",
    ),
    "success final_error nan": (
        CTC,
        CTC + "[success]\nfinal_error = nan\n",
        "success.final_error: must be finite",
    ),
    "success final_error inf": (
        CTC,
        CTC + "[success]\nfinal_error = inf\n",
        "success.final_error: must be finite",
    ),
    "success final_error string": (
        CTC,
        CTC + '[success]\nfinal_error = "2%"\n',
        "success.final_error: must be a number, got '2%'",
    ),
    "success overshoot negative": (
        CTC,
        CTC + "[success]\nmax_overshoot_pct = -1.0\n",
        "success.max_overshoot_pct: must be >= 0.0",
    ),
    "success overshoot nan": (
        CTC,
        CTC + "[success]\nmax_overshoot_pct = nan\n",
        "success.max_overshoot_pct: must be finite",
    ),
    "success not a table": (
        'name = "small"',
        'name = "small"\nsuccess = 0.02',
        "success: must be a table, got 0.02",
    ),
    # [execution]
    "execution not a table": (
        'name = "small"',
        'name = "small"\nexecution = "process"',
        "execution: must be a table, got 'process'",
    ),
    "execution unknown key": (
        CTC,
        CTC + "[execution]\nthreads = 4\n",
        "execution.threads: unknown key",
    ),
    "execution workers zero": (
        CTC,
        CTC + "[execution]\nworkers = 0\n",
        "execution.workers: must be an integer >= 1, got 0",
    ),
    "execution workers float": (
        CTC,
        CTC + "[execution]\nworkers = 2.5\n",
        "execution.workers: must be an integer >= 1, got 2.5",
    ),
    "execution workers bool": (
        CTC,
        CTC + "[execution]\nworkers = true\n",
        "execution.workers: must be an integer >= 1, got True",
    ),
    "execution scheduler a number": (
        CTC,
        CTC + '[execution]\nexecutor = "dask"\nscheduler = 8786\n',
        "execution.scheduler: a sweep file cannot choose a Dask scheduler",
    ),
    "execution scheduler without dask": (
        CTC,
        CTC + '[execution]\nexecutor = "process"\nscheduler = "tcp://1.2.3.4:1"\n',
        "execution.scheduler: a sweep file cannot choose a Dask scheduler",
    ),
    "execution executor a number": (
        CTC,
        CTC + "[execution]\nexecutor = 1\n",
        "execution.executor: must be a string, got 1",
    ),
    # [overrides] and [reference]
    "overrides not a table": (
        "[overrides]\nduration = 0.05\n",
        "",
        "overrides: must be a table, got 3",
    ),
    "overrides unknown key": (
        "duration = 0.05",
        "duration = 0.05\nfoo = 1",
        "overrides.foo: unknown key",
    ),
    "overrides extends": (
        "duration = 0.05",
        'duration = 0.05\nextends = "x.toml"',
        "overrides.extends: unknown key",
    ),
    "overrides zero mass": (
        "duration = 0.05",
        "duration = 0.05\narm = { m1 = 0.0 }",
        "overrides.arm.m1: must be > 0",
    ),
    "overrides nan duration": (
        "duration = 0.05",
        "duration = nan",
        "overrides.duration: must be finite",
    ),
    "overrides huge duration": (
        "duration = 0.05",
        "duration = 1e9",
        "overrides.duration: 1e+09 s at a timestep",
    ),
    "overrides negative seed": (
        "duration = 0.05",
        "duration = 0.05\nseed = -3",
        "overrides.seed: must be an integer >= 0",
    ),
    "overrides zero scale": (
        "duration = 0.05",
        "duration = 0.05\nplant = { scale = { m1 = 0.0 } }",
        "overrides.plant.scale.m1: must be > 0",
    ),
    "overrides negative stiffness": (
        "duration = 0.05",
        "duration = 0.05\nplant = { flexibility = { k = -1.0 } }",
        "overrides.plant.flexibility.k: must be > 0",
    ),
    "overrides missing rule base": (
        "duration = 0.05",
        'duration = 0.05\ncontroller = { kind = "fcm_ctc", rule_base = "nope.toml" }',
        "overrides.controller.rule_base: no such file",
    ),
    "reference not a table": (
        REF1 + '\n[reference.joint2]\nkind = "step"\nfinal = 0.5\n',
        "",
        "reference: must be a table, got 1",
    ),
    "reference joint not a table": (
        REF1,
        "[reference]\njoint1 = 3\n",
        "reference.joint1: must be a table, got 3",
    ),
    "reference kind unknown": (
        'kind = "step"\nfinal = 1.0',
        'kind = "jump"\nfinal = 1.0',
        "reference.joint1: unknown reference kind 'jump'",
    ),
    "reference joint3": (
        REF1,
        '[reference.joint3]\nkind = "step"\n\n' + REF1,
        "reference.joint3: unknown key",
    ),
    "reference final nan": (
        "final = 1.0",
        "final = nan",
        "reference.joint1: Step.final must be finite",
    ),
    "reference final string": (
        "final = 1.0",
        'final = "one"',
        "reference.joint1: Step.final must be a real number",
    ),
    "reference ramp of no duration": (
        'kind = "step"\nfinal = 1.0',
        'kind = "ramp"\nfinal = 1.0\nduration = 0.0',
        "reference.joint1: Ramp.duration must be > 0",
    ),
    # the file as a whole
    "toml syntax": ("[parameters]", "[parameters", "not valid TOML"),
    "unknown table": (CTC, CTC + "[extra]\nx = 1\n", "extra: unknown key"),
    "extends in a sweep file": (
        'name = "small"',
        'name = "small"\nextends = "base.toml"',
        "extends: unknown key",
    ),
}

# Keys set at the top of the file where the case removes the table of the same name.
SWEEP_TOP = {
    "parameters not a table": "parameters = 3",
    "controllers not a table": "controllers = 3",
    "overrides not a table": "overrides = 3",
    "reference not a table": "reference = 1",
}


@pytest.mark.parametrize("case", sorted(SWEEP_CASES))
def test_a_bad_sweep_file_exits_2_naming_file_and_key(tmp_path, case):
    old, new, says = SWEEP_CASES[case]
    text = edited(SWEEP, old, new)
    if case in SWEEP_TOP:
        text = SWEEP_TOP[case] + "\n" + text
    workspace(tmp_path)
    path = tmp_path / "sweep.toml"
    path.write_text(text)
    out = tmp_path / "out"
    result = invoke(*sweep_args(path, out))
    assert_rejected(result, out, f"error: {path}: ", says.replace("{tmp}", str(tmp_path)))


def _folder(path: Path) -> Path:
    path.mkdir()
    return path


def _bytes(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


SWEEP_FILES = {
    "no such file": (lambda tmp: tmp / "nope.toml", "nope.toml: no such file"),
    # it says "no such file" where `run` says "is a folder": still the file, exit 2
    "a folder": (lambda tmp: _folder(tmp / "dir.toml"), "dir.toml: "),
    "not UTF-8": (lambda tmp: _bytes(tmp / "b.toml", b"\xff\xfe\x00"), "b.toml: not valid TOML"),
    "empty": (lambda tmp: _bytes(tmp / "e.toml", b""), "e.toml: scenario: missing"),
    "a manifest": (lambda tmp: REPO / "runs/paper/reproduce.toml", "this is a manifest file"),
}


@pytest.mark.parametrize("case", sorted(SWEEP_FILES))
def test_a_bad_sweep_file_path_exits_2(tmp_path, case):
    make, says = SWEEP_FILES[case]
    out = tmp_path / "out"
    result = invoke(*sweep_args(make(tmp_path), out))
    assert_rejected(result, out, says)


# --set on a valid sweep file -> what the error says after "FILE: "
SWEEP_SETS = {
    "samples=0 by --set": ("samples=0", "samples: must be an integer >= 1, got 0"),
    "chunk_size float by --set": ("chunk_size=1.5", "chunk_size: must be an integer >= 1"),
    "unknown top key by --set": ("foo=1", "foo: unknown key"),
    "unknown parameter by --set": (
        "parameters.mass_ratio.dist=uniform",
        "parameters.mass_ratio: unknown parameter",
    ),
    "controller escapes by --set": ("controllers.x/y.kind=ctc", "controllers.x/y: must be 1-100"),
    "controller not a table by --set": (
        "controllers.ctc=3",
        "controllers.ctc: must be a table",
    ),
    "name escapes by --set": ("name=../x", "name: must be 1-100 letters"),
    "missing scenario by --set": ("scenario=nope.toml", "scenario: {tmp}/nope.toml: no such file"),
    "parameters not a table by --set": ("parameters=3", "parameters: must be a table, got 3"),
    "success by --set": ("success.final_error=0", "success.final_error: must be > 0"),
}


@pytest.mark.parametrize("case", sorted(SWEEP_SETS))
def test_a_bad_set_on_a_sweep_exits_2_naming_file_and_key(tmp_path, case):
    item, says = SWEEP_SETS[case]
    path = tmp_path / "sweep.toml"
    path.write_text(SWEEP)
    out = tmp_path / "out"
    result = invoke(*sweep_args(path, out), "--set", item)
    assert_rejected(result, out, f"error: {path}: ", says.replace("{tmp}", str(tmp_path)))


def test_a_set_without_equals_on_a_sweep_exits_2(tmp_path):
    path = tmp_path / "sweep.toml"
    path.write_text(SWEEP)
    out = tmp_path / "out"
    result = invoke(*sweep_args(path, out), "--set", "samples")
    assert_rejected(result, out, "--set 'samples': expected KEY=VALUE")


# ----------------------------------------------------------------------------- manifests

# (text replaced in MANIFEST, its replacement, what the error says, the file it names)
MANIFEST_CASES = {
    "unknown top key": (
        'design = "design.toml"',
        'design = "design.toml"\ndesing = "x"',
        "desing: unknown key",
        None,
    ),
    "toml syntax": ("[variants.rigid]", "[variants.rigid", "not valid TOML", None),
    "no experiments": (EXPERIMENT, "", "experiment: needs at least one [[experiment]]", None),
    "experiment not a list": (EXPERIMENT, "", "experiment: needs at least one", None),
    "experiment entry not a table": (EXPERIMENT, "", "experiment[0]: must be a table, got 3", None),
    "experiment unknown key": (
        "joint = 1",
        "joint = 1\njoints = 2",
        "experiment[0].joints: unknown key",
        None,
    ),
    "experiment without scenario": (
        'scenario = "tiny.toml"\n',
        "",
        "experiment[0].scenario: no such file",
        None,
    ),
    "experiment scenario missing": (
        'scenario = "tiny.toml"',
        'scenario = "gone.toml"',
        "experiment[0].scenario: no such file {tmp}/gone.toml",
        None,
    ),
    "experiment scenario a folder": (
        'scenario = "tiny.toml"',
        'scenario = "."',
        "experiment[0].scenario: no such file",
        None,
    ),
    "experiment scenario not a string": (
        'scenario = "tiny.toml"',
        "scenario = 3",
        "experiment[0].scenario: must be a string",
        None,
    ),
    "experiment joint 3": ("joint = 1", "joint = 3", "experiment[0].joint: must be 1 or 2", None),
    "experiment joint a string": (
        "joint = 1",
        'joint = "1"',
        "experiment[0].joint: must be an integer",
        None,
    ),
    "experiment without table or figure": (
        "table = 2\n",
        "",
        "experiment[0].table: an experiment needs a table or figure number",
        None,
    ),
    "experiment table a string": (
        "table = 2",
        'table = "2"',
        "experiment[0].table: table and figure must be integers",
        None,
    ),
    "experiment figure a float": (
        "table = 2",
        "figure = 6.5",
        "experiment[0].table: table and figure must be integers",
        None,
    ),
    "experiment title not a string": (
        'title = "step"',
        "title = 3",
        "experiment[0].title: must be a string",
        None,
    ),
    "paper values of an unknown controller": (
        "paper.CTC",
        "paper.PID",
        "experiment[0].paper.PID: not a controller",
        None,
    ),
    "paper value of an unknown metric": (
        "Tp = 5.89",
        "Tq = 5.89",
        "experiment[0].paper.CTC: unknown metric(s) ['Tq']",
        None,
    ),
    "no controllers": (CONTROLLERS, "", "controllers: needs at least one", None),
    "controllers not a table": (CONTROLLERS, "", "controllers: needs at least one", None),
    "controller not a table": (
        '[controllers.CTC]\nkind = "ctc"\n',
        '[controllers]\nCTC = "ctc"\n',
        "controllers.CTC: must be a table of [controller] keys",
        None,
    ),
    "controller name with slash": (
        "[controllers.CTC]",
        '[controllers."a/b"]',
        "controllers.a/b: must be 1-100 letters",
        None,
    ),
    "variant not a table": (
        RIGID,
        '[variants]\nrigid = "rigid"\n',
        "variants.rigid: must be a table, got 'rigid'",
        None,
    ),
    "variant unknown key": (
        'title = "rigid arm"',
        'title = "rigid arm"\nname = "x"',
        "variants.rigid.name: unknown key",
        None,
    ),
    "variant title not a string": (
        'title = "rigid arm"',
        "title = 3",
        "variants.rigid.title: must be a string",
        None,
    ),
    "variant overrides not a table": (
        'title = "rigid arm"',
        'title = "rigid arm"\noverrides = 3',
        "variants.rigid.overrides: must be a table",
        None,
    ),
    "variant name absolute": (
        "[variants.rigid]",
        '[variants."/abs"]',
        "variants./abs: must be 1-100 letters",
        None,
    ),
    "design not a string": (
        'design = "design.toml"',
        "design = 3",
        "design: must be a string, got 3",
        None,
    ),
    "design file with a bad key": (
        'design = "design.toml"',
        'design = "bad_design.toml"',
        "clusters: must be >= 2, got 1",
        "bad_design.toml",
    ),
    "design file a scenario": (
        'design = "design.toml"',
        'design = "tiny.toml"',
        "this is a scenario file, not a design file",
        "tiny.toml",
    ),
    "flexible_study not a string": (
        'design = "design.toml"',
        'design = "design.toml"\nflexible_study = 3',
        "flexible_study: must be a sweep file path",
        None,
    ),
    "flexible_study a folder": (
        'design = "design.toml"',
        'design = "design.toml"\nflexible_study = "."',
        "flexible_study: {tmp}: is a folder, not a sweep file",
        None,
    ),
    "design a folder": (
        'design = "design.toml"',
        'design = "."',
        "design: {tmp}: is a folder, not a design file",
        None,
    ),
    "experiment figure zero": (
        "table = 2",
        "figure = 0",
        "experiment[0].table: table and figure must be integers >= 1, got 0",
        None,
    ),
    "paper value infinite": (
        "Tp = 5.89",
        "Tp = inf",
        "experiment[0].paper.CTC.Tp: must be finite, got inf",
        None,
    ),
    "two experiments of one figure": (
        EXPERIMENT,
        EXPERIMENT.replace("table = 2", "figure = 6")
        + "\n"
        + EXPERIMENT.replace("table = 2", "figure = 6"),
        "experiment[1].figure: figure6 is also experiment[0]'s",
        None,
    ),
    "proposed not a string": (
        'proposed = "FCM-CTC"',
        "proposed = 3",
        "proposed: must name a controller of this manifest",
        None,
    ),
    "baseline unknown": (
        'baseline = "CTC"',
        'baseline = "PID"',
        "baseline: must name a controller of this manifest",
        None,
    ),
}

MANIFEST_TOP = {
    "experiment not a list": "experiment = 3",
    "experiment entry not a table": "experiment = [3]",
    "controllers not a table": "controllers = 3",
}


def manifest(tmp_path: Path, text: str) -> Path:
    workspace(tmp_path)
    path = tmp_path / "manifest.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("case", sorted(MANIFEST_CASES))
def test_a_bad_manifest_exits_2_naming_file_and_key(tmp_path, case):
    old, new, says, names = MANIFEST_CASES[case]
    text = edited(MANIFEST, old, new)
    if case in MANIFEST_TOP:
        text = MANIFEST_TOP[case] + "\n" + text
    path = manifest(tmp_path, text)
    out = tmp_path / "out"
    result = invoke(*reproduce_args(path, out))
    named = f"error: {path}: " if names is None else f"error: {tmp_path / names}: "
    assert_rejected(result, out, named, says.replace("{tmp}", str(tmp_path)))


MANIFEST_FILES = {
    "no such file": (lambda tmp: tmp / "gone.toml", "gone.toml: no such file"),
    "a folder": (lambda tmp: _folder(tmp / "m.toml"), "m.toml: is a folder"),
    "not UTF-8": (lambda tmp: _bytes(tmp / "b.toml", b"\xff\xfe\x00"), "b.toml: cannot be read"),
    "empty": (lambda tmp: _bytes(tmp / "e.toml", b""), "e.toml: controllers: needs at least one"),
    "a sweep file": (lambda tmp: ROBUSTNESS, "this is a sweep file, not a manifest file"),
}


@pytest.mark.parametrize("case", sorted(MANIFEST_FILES))
def test_a_bad_manifest_path_exits_2(tmp_path, case):
    make, says = MANIFEST_FILES[case]
    out = tmp_path / "out"
    result = invoke(*reproduce_args(make(tmp_path), out))
    assert_rejected(result, out, says)


def test_a_set_without_equals_on_reproduce_exits_2(tmp_path):
    path = manifest(tmp_path, MANIFEST)
    out = tmp_path / "out"
    result = invoke(*reproduce_args(path, out), "--set", "controller.kp")
    assert_rejected(result, out, "--set 'controller.kp': expected KEY=VALUE")


# ----------------------------------------------------------------------------- design files

# (text replaced in DESIGN, its replacement, what the error says after "FILE: ")
DESIGN_CASES = {
    "unknown key": ("clusters = 2", "clusters = 2\nclusterz = 3", "clusterz: unknown key"),
    "scenarios missing": ('scenarios = ["tiny.toml"]\n', "", "scenarios: must be a non-empty list"),
    "scenarios a string": (
        'scenarios = ["tiny.toml"]',
        'scenarios = "tiny.toml"',
        "scenarios: must be a non-empty list",
    ),
    "scenarios of numbers": (
        'scenarios = ["tiny.toml"]',
        "scenarios = [3]",
        "scenarios: must be a non-empty list",
    ),
    "controller not a table": (
        'controller = { kind = "fuzzy_ctc" }',
        'controller = "fuzzy_ctc"',
        "controller: must be a table of [controller] keys",
    ),
    "clusters 1": ("clusters = 2", "clusters = 1", "clusters: must be >= 2, got 1"),
    "clusters 0": ("clusters = 2", "clusters = 0", "clusters: must be >= 2, got 0"),
    "clusters negative": ("clusters = 2", "clusters = -3", "clusters: must be an integer >= 0"),
    "clusters float": ("clusters = 2", "clusters = 2.5", "clusters: must be an integer >= 0"),
    "clusters bool": ("clusters = 2", "clusters = true", "clusters: must be an integer >= 0"),
    "clusters above the rules": ("clusters = 2", "clusters = 50", "clusters: at most 49"),
    "clusters above the points": (
        '["tiny.toml"]\ncontroller = { kind = "fuzzy_ctc" }\nclusters = 2',
        # 0.01 s: 6 samples (every 2nd) of each of 2 joints, 12 points
        '["short.toml"]\ncontroller = { kind = "fuzzy_ctc" }\nclusters = 13',
        "clusters: at most the 12 phase-plane points",
    ),
    "scenario a folder": ('["tiny.toml"]', '["."]', "scenarios: "),
    "controller gain negative": (
        'controller = { kind = "fuzzy_ctc" }',
        'controller = { kind = "fuzzy_ctc", kp = -1.0 }',
        "controller.kp: must be >= 0.0",
    ),
    "fuzzifier nan": ("clusters = 2", "clusters = 2\nfuzzifier = nan", "fuzzifier: must be finite"),
    "fuzzifier inf": ("clusters = 2", "clusters = 2\nfuzzifier = inf", "fuzzifier: must be finite"),
    "fuzzifier a string": (
        "clusters = 2",
        'clusters = 2\nfuzzifier = "2"',
        "fuzzifier: must be a number",
    ),
    "fuzzifier huge integer": (
        "clusters = 2",
        "clusters = 2\nfuzzifier = " + "9" * 400,
        "fuzzifier: must be a number a float can hold",
    ),
    "tolerance zero": ("clusters = 2", "clusters = 2\ntolerance = 0.0", "tolerance: must be > 0"),
    "tolerance negative": (
        "clusters = 2",
        "clusters = 2\ntolerance = -1e-5",
        "tolerance: must be > 0",
    ),
    "tolerance nan": ("clusters = 2", "clusters = 2\ntolerance = nan", "tolerance: must be finite"),
    "max_iter negative": (
        "clusters = 2",
        "clusters = 2\nmax_iter = -1",
        "max_iter: must be an integer >= 0",
    ),
    "max_iter float": (
        "clusters = 2",
        "clusters = 2\nmax_iter = 1.5",
        "max_iter: must be an integer >= 0",
    ),
    "seed negative": ("clusters = 2", "clusters = 2\nseed = -1", "seed: must be an integer >= 0"),
    "seed float": ("clusters = 2", "clusters = 2\nseed = 0.5", "seed: must be an integer >= 0"),
    "toml syntax": ("clusters = 2", "clusters = ", "not valid TOML"),
    "a scenario file": (DESIGN, TINY, "this is a scenario file, not a design file"),
}


def design_args(path: Path, out: Path) -> list:
    return ["design", "--config", path, "--out", out / "rule_base.toml"]


@pytest.mark.parametrize("case", sorted(DESIGN_CASES))
def test_a_bad_design_file_exits_2_naming_file_and_key(tmp_path, case):
    old, new, says = DESIGN_CASES[case]
    workspace(tmp_path)
    path = tmp_path / "my_design.toml"
    path.write_text(edited(DESIGN, old, new))
    out = tmp_path / "out"
    result = invoke(*design_args(path, out))
    assert_rejected(result, out, f"error: {path}: ", says)


DESIGN_FILES = {
    "no such file": (lambda tmp: tmp / "nope.toml", "nope.toml: no such file"),
    "a folder": (lambda tmp: _folder(tmp / "d.toml"), "d.toml: is a folder"),
    "not UTF-8": (lambda tmp: _bytes(tmp / "b.toml", b"\xff\xfe\x00"), "b.toml: cannot be read"),
    "a manifest": (lambda tmp: REPO / "runs/paper/reproduce.toml", "this is a manifest file"),
}


@pytest.mark.parametrize("case", sorted(DESIGN_FILES))
def test_a_bad_design_path_exits_2(tmp_path, case):
    make, says = DESIGN_FILES[case]
    out = tmp_path / "out"
    result = invoke(*design_args(make(tmp_path), out))
    assert_rejected(result, out, says)


# ----------------------------------------------------------------------------- --set on run

# KEY=VALUE -> what the error says (after the scenario file's name, or about --set)
RUN_SETS = {
    "unknown top key": ("foo=1", "foo: unknown key"),
    "nested unknown key": ("controller.fuzzy.mod=add", "controller.fuzzy.mod: unknown key"),
    "key under a number": ("arm.m1.x=1", "arm.m1: must be a number, got {'x': 1}"),
    "table replaced by a number": ("controller=3", "controller: must be a table, got 3"),
    "unknown joint": ("reference.joint3.kind=step", "reference.joint3: unknown key"),
    "extends by --set": ("extends=other.toml", "extends: unknown key"),
    "value not TOML": ("duration=abc", "duration: must be a number, got 'abc'"),
    "value empty": ("duration=", "duration: must be a number, got ''"),
    "value half a list": ("duration=[1", "duration: must be a number, got '[1'"),
    "value nan": ("duration=nan", "duration: must be finite, got nan"),
    "kind unknown": ('controller.kind="pid"', "controller.kind: must be one of"),
    "seed float": ("seed=1.5", "seed: must be an integer >= 0, got 1.5"),
    "initial of one joint": ("initial.q=[0]", "initial.q: must be a number or a list of 2"),
    "name a number": ("name=3", "name: must be a string, got 3"),
    "zero timestep": ("timestep=0", "timestep: must be > 0"),
}

SET_SYNTAX = ["=3", "controller..kp=1", ".kp=1", "controller.=1", " = "]


@pytest.mark.parametrize("case", sorted(RUN_SETS))
def test_a_bad_set_on_run_exits_2_naming_file_and_key(tmp_path, case):
    item, says = RUN_SETS[case]
    out = tmp_path / "out"
    result = invoke("run", STEP, "--out", out, "--set", item)
    assert_rejected(result, out, f"error: {STEP}: ", says)


@pytest.mark.parametrize("item", SET_SYNTAX, ids=lambda s: f"--set {s!r}")
def test_a_set_that_is_not_key_equals_value_exits_2(tmp_path, item):
    out = tmp_path / "out"
    result = invoke("run", STEP, "--out", out, "--set", item)
    assert_rejected(result, out, f"error: --set {item!r}: expected KEY=VALUE")


# ----------------------------------------------------------------------------- command line

CLI_CASES = {
    "run --out is a file": (
        lambda tmp, out: ["run", STEP, "--out", tmp / "f"],
        ["Invalid value for '--out'", "f' is a file"],
    ),
    "sweep --out is a file": (
        lambda tmp, out: ["sweep", ROBUSTNESS, "--out", tmp / "f"],
        ["Invalid value for '--out'", "f' is a file"],
    ),
    "reproduce --out is a file": (
        lambda tmp, out: ["reproduce", "--out", tmp / "f"],
        ["Invalid value for '--out'", "f' is a file"],
    ),
    "models --out is a file": (
        lambda tmp, out: ["models", "--out", tmp / "f"],
        ["Invalid value for '--out'", "f' is a file"],
    ),
    "design --out is a folder": (
        lambda tmp, out: ["design", "--config", tmp / "design.toml", "--out", tmp],
        ["Invalid value for '--out'", "is a directory"],
    ),
    "reproduce --workers not a number": (
        lambda tmp, out: ["reproduce", "--out", out, "--workers", "abc"],
        ["Invalid value for '--workers'", "'abc' is not a valid integer"],
    ),
    "sweep -n not a number": (
        lambda tmp, out: ["sweep", ROBUSTNESS, "--out", out, "-n", "abc"],
        ["Invalid value for '-n' / '--samples'", "'abc'"],
    ),
    "sweep --executor unknown": (
        lambda tmp, out: ["sweep", ROBUSTNESS, "--out", out, "--executor", "bogus"],
        ["Invalid value for '--executor'", "'bogus' is not one of"],
    ),
    "run unknown option": (
        lambda tmp, out: ["run", STEP, "--out", out, "--bogus"],
        ["No such option '--bogus'"],
    ),
    "run missing file with --set": (
        lambda tmp, out: ["run", tmp / "nope.toml", "--out", out, "--set", "duration=1"],
        ["error: ", "nope.toml: no such file"],
    ),
    "validate -n not a number": (
        lambda tmp, out: ["validate", "-n", "abc"],
        ["Invalid value for '-n' / '--samples'"],
    ),
    "reproduce --workers -1": (
        lambda tmp, out: ["reproduce", "--out", out, "--no-trace", "--workers", "-1"],
        ["Invalid value for '--workers'", "-1 is not in the range x>=1"],
    ),
    "validate -n -1": (
        lambda tmp, out: ["validate", "-n", "-1"],
        ["Invalid value for '-n' / '--samples'", "-1 is not in the range 1<=x<=100000"],
    ),
    "validate --seed -1": (
        lambda tmp, out: ["validate", "-n", "1", "--seed", "-1"],
        ["Invalid value for '--seed'", "-1 is not in the range x>=0"],
    ),
}


@pytest.mark.parametrize("case", sorted(CLI_CASES))
def test_command_line_misuse_exits_2(tmp_path, case):
    make, says = CLI_CASES[case]
    workspace(tmp_path)
    (tmp_path / "f").write_text("keep")
    before = sorted(p.name for p in tmp_path.iterdir())
    out = tmp_path / "out"
    result = invoke(*make(tmp_path, out))
    assert_rejected(result, out, *says, one_line=says[0].startswith("error: "))
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    assert (tmp_path / "f").read_text() == "keep"


# ----------------------------------------------------------------------------- defects


def _sweep_case(tmp: Path, out: Path, old: str, new: str) -> list:
    path = tmp / "sweep.toml"
    path.write_text(edited(SWEEP, old, new))
    return sweep_args(path, out)


def _manifest_case(tmp: Path, out: Path, old: str, new: str, *extra: str) -> list:
    path = tmp / "manifest.toml"
    path.write_text(edited(MANIFEST, old, new))
    return [*reproduce_args(path, out), *extra]


def _design_case(tmp: Path, out: Path, old: str, new: str, *extra) -> list:
    path = tmp / "my_design.toml"
    path.write_text(edited(DESIGN, old, new))
    return [*design_args(path, out), *extra]


def _under_a_file(tmp: Path) -> Path:
    (tmp / "f").write_text("keep")
    return tmp / "f" / "sub"


# id -> (make the arguments from (tmp, out), what a clean refusal says)
DEFECTS = {
    "sweep: a 400-digit bound": (
        lambda tmp, out: _sweep_case(tmp, out, "high = 1.2", "high = " + "9" * 400),
        ["sweep.toml: parameters.m1.high: must be a number a float can hold"],
    ),
    "sweep: a normal truncation no draw can hit": (
        lambda tmp, out: _sweep_case(
            tmp, out, M1, 'm1 = { dist = "normal", mean = 1.0, std = 1e-3, low = 1.0, high = 1.0 }'
        ),
        ["sweep.toml: parameters.m1"],
    ),
    "manifest: paper not a table": (
        lambda tmp, out: _manifest_case(
            tmp, out, "paper.CTC = { Tp = 5.89, Mp = 0.655 }", "paper = 3"
        ),
        ["manifest.toml: experiment[0].paper"],
    ),
    "manifest: paper values not a table": (
        lambda tmp, out: _manifest_case(
            tmp, out, "paper.CTC = { Tp = 5.89, Mp = 0.655 }", "paper.CTC = 3"
        ),
        ["manifest.toml: experiment[0].paper.CTC"],
    ),
    "manifest: a paper value that is a string": (
        lambda tmp, out: _manifest_case(tmp, out, "Tp = 5.89", 'Tp = "fast"'),
        ["manifest.toml: experiment[0].paper.CTC.Tp"],
    ),
    "manifest: variants not a table": (
        lambda tmp, out: reproduce_args(
            _write(tmp, "manifest.toml", "variants = 3\n" + edited(MANIFEST, RIGID, "")), out
        ),
        ["manifest.toml: variants"],
    ),
    "manifest: no variants": (
        lambda tmp, out: _manifest_case(tmp, out, RIGID, "[variants]\n"),
        ["manifest.toml: variants"],
    ),
    "manifest: a controller kind unknown": (
        lambda tmp, out: _manifest_case(tmp, out, 'kind = "ctc"', 'kind = "pid"'),
        ["manifest.toml: controllers.CTC: ", "controller.kind: must be one of"],
    ),
    "manifest: variant overrides with an unknown key": (
        lambda tmp, out: _manifest_case(
            tmp, out, 'title = "rigid arm"', 'title = "rigid arm"\noverrides = { durration = 1.0 }'
        ),
        ["manifest.toml: variants.rigid.overrides: ", "durration: unknown key"],
    ),
    "manifest: an experiment's scenario with a bad key": (
        lambda tmp, out: _manifest_case(
            tmp, out, 'scenario = "tiny.toml"', 'scenario = "bad_step.toml"'
        ),
        ["bad_step.toml: duration: must be > 0"],
    ),
    "manifest: flexible_study missing": (
        lambda tmp, out: _manifest_case(
            tmp,
            out,
            'design = "design.toml"',
            'design = "design.toml"\nflexible_study = "gone.toml"',
        ),
        ["manifest.toml: flexible_study"],
    ),
    "manifest: design file missing": (
        lambda tmp, out: _manifest_case(tmp, out, 'design = "design.toml"', 'design = "gone.toml"'),
        ["manifest.toml: design:", "gone.toml"],
    ),
    "manifest: two experiments of one table": (
        lambda tmp, out: _manifest_case(tmp, out, EXPERIMENT, EXPERIMENT + "\n" + EXPERIMENT),
        ["manifest.toml: experiment[1].table"],
    ),
    "manifest: a table number that is a boolean": (
        lambda tmp, out: _manifest_case(tmp, out, "table = 2", "table = true"),
        ["manifest.toml: experiment[0].table: table and figure must be integers"],
    ),
    "reproduce: --set with an unknown key": (
        lambda tmp, out: _manifest_case(tmp, out, "joint = 1", "joint = 1", "--set", "foo=1"),
        ["tiny.toml: foo: unknown key"],
    ),
    "design: a controller without a fuzzy engine": (
        lambda tmp, out: _design_case(tmp, out, 'kind = "fuzzy_ctc"', 'kind = "ctc"'),
        ["my_design.toml: controller.kind"],
    ),
    "design: clusters 10**30": (
        lambda tmp, out: _design_case(tmp, out, "clusters = 2", f"clusters = {10**30}"),
        ["my_design.toml: clusters"],
    ),
    "design: max_iter 0": (
        lambda tmp, out: _design_case(tmp, out, "clusters = 2", "clusters = 2\nmax_iter = 0"),
        ["my_design.toml: max_iter"],
    ),
    "design: a scenario file missing": (
        lambda tmp, out: _design_case(tmp, out, '["tiny.toml"]', '["gone.toml"]'),
        ["my_design.toml: scenarios", "gone.toml"],
    ),
    "design: a controller kind unknown": (
        lambda tmp, out: _design_case(tmp, out, 'kind = "fuzzy_ctc"', 'kind = "pid"'),
        ["my_design.toml: controller.kind"],
    ),
    "design: --out under a regular file": (
        lambda tmp, out: [
            "design",
            "--config",
            tmp / "design.toml",
            "--out",
            _under_a_file(tmp) / "rule_base.toml",
        ],
        ["--out", "which is a file"],
    ),
    "design: --figure under a regular file": (
        lambda tmp, out: [
            "design",
            "--config",
            tmp / "design.toml",
            "--out",
            out / "rule_base.toml",
            "--figure",
            _under_a_file(tmp) / "f.png",
        ],
        ["--figure", "which is a file"],
    ),
    "models: --out under a regular file": (
        lambda tmp, out: ["models", "--out", _under_a_file(tmp)],
        ["--out", "which is a file"],
    ),
}


def _write(tmp: Path, name: str, text: str) -> Path:
    (tmp / name).write_text(text)
    return tmp / name


@pytest.mark.parametrize("case", [pytest.param(case, id=case) for case in DEFECTS])
def test_inputs_once_refused_late_or_with_a_traceback(tmp_path, case):
    make, says = DEFECTS[case]
    workspace(tmp_path)
    out = tmp_path / "out"
    result = invoke(*make(tmp_path, out))
    assert_rejected(result, out, *says)


# Every kind of file this project ships (and a .fis file), and every command that reads a
# file: a file given to a command that does not take it exits 2 with one line that names
# its kind and what does take it (issue 31).
FILES = {
    "scenario": "runs/paper/theta1_step.toml",
    "sweep": "runs/sweeps/robustness.toml",
    "manifest": "runs/paper/reproduce.toml",
    "design": "runs/paper/design.toml",
    "gains": "runs/paper/gains.toml",
    "calibration": "runs/paper/calibrate.toml",
    "calibration result": "runs/paper/calibrated.toml",
    "rule base": "controllers/rulebases/designed.toml",
    "fis": None,  # written by `twolink fis` for the test
}
READER = {
    "scenario": "twolink run",
    "sweep": "twolink sweep",
    "manifest": "twolink reproduce --manifest",
    "design": "twolink design --config",
    "gains": "twolink gains",
    "calibration": "twolink calibrate",
    "calibration result": "twolink reproduce",
    "rule base": "twolink coverage",
    "fis": "twolink coverage",
}
COMMANDS = {  # command -> (argv with FILE and OUT, the kinds it takes)
    "run": (["run", "FILE", "--out", "OUT"], {"scenario"}),
    "sweep": (["sweep", "FILE", "--out", "OUT"], {"sweep"}),
    "regimes": (["regimes", "FILE", "--out", "OUT"], {"sweep"}),
    "reproduce": (["reproduce", "--manifest", "FILE", "--out", "OUT"], {"manifest"}),
    "design": (["design", "--config", "FILE", "--out", "OUT/r.toml"], {"design"}),
    "gains": (["gains", "FILE", "--out", "OUT"], {"gains"}),
    "calibrate": (["calibrate", "FILE", "--out", "OUT"], {"calibration"}),
    "coverage": (["coverage", "FILE"], {"rule base", "fis"}),
    "fis": (["fis", "FILE", "--out", "OUT/x.fis"], {"rule base", "fis"}),
}


def test_every_file_kind_given_to_every_command_that_does_not_take_it(tmp_path):
    from click.testing import CliRunner

    from twolink.interface.cli import main

    repo = Path(__file__).resolve().parents[1]
    fis = tmp_path / "designed.fis"
    assert CliRunner().invoke(main, ["fis", "designed", "--out", str(fis)]).exit_code == 0
    files = {k: (str(repo / v) if v else str(fis)) for k, v in FILES.items()}
    tried = 0
    for command, (argv, takes) in COMMANDS.items():
        for kind, path in files.items():
            if kind in takes:
                continue
            out = tmp_path / f"{command}-{kind.replace(' ', '_')}"
            args = [a.replace("FILE", path).replace("OUT", str(out)) for a in argv]
            result = CliRunner().invoke(main, args)
            said = result.output
            assert result.exit_code == 2, (command, kind, said)
            assert len(said.strip().splitlines()) == 1, (command, kind, said)
            named = "MATLAB .fis rule base" if kind == "fis" else f"this is a {kind} file"
            assert named in said and READER[kind] in said, (command, kind, said)
            assert not out.exists(), (command, kind)  # refused before any work
            tried += 1
    assert tried == 9 * 9 - 11


def test_each_commands_set_example_is_valid_for_it_and_reproduce_keeps_controller_keys():
    import re

    from click.testing import CliRunner

    from twolink.interface.cli import main
    from twolink.simulation.config import load_scenario, parse_set
    from twolink.studies.designs.calibrate import load_calibration
    from twolink.studies.designs.gains import load_gain_study
    from twolink.studies.reproduction.manifest import load_manifest
    from twolink.studies.reproduction.reproduce import plan
    from twolink.sweep import load_sweep

    repo = Path(__file__).resolve().parents[1]
    loaders = {
        "run": lambda o: load_scenario(repo / "runs/paper/theta1_step.toml", o),
        "sweep": lambda o: load_sweep(repo / "runs/sweeps/robustness.toml", o),
        "gains": lambda o: load_gain_study(repo / "runs/paper/gains.toml", o),
        "calibrate": lambda o: load_calibration(repo / "runs/paper/calibrate.toml", o),
        "reproduce": lambda o: [
            load_scenario(sp.experiment.scenario, sp.overrides)
            for sp in plan(load_manifest(), None, (), o)
        ],
    }
    for command, load in loaders.items():
        text = " ".join(CliRunner().invoke(main, [command, "--help"]).output.split())
        example = re.search(r"--set (\S+=\S+?)\.(?:\s|$)", text).group(1)
        load(parse_set([example]))  # no ConfigError
    # reproduce: --set reaches every run, but not the keys that make a controller itself
    specs = plan(load_manifest(), None, (), parse_set(["controller.kp=25"]))
    kp = {sp.controller: load_scenario(sp.experiment.scenario, sp.overrides).controller.kp
          for sp in specs if sp.variant.name == "rigid"}  # fmt: skip
    assert kp["CTC"] == (25.0, 25.0) and kp["CTC-paper"] == (4.0, 4.0)
