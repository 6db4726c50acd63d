"""The `twolink validate`, `design` and `models` commands."""

import hashlib
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

import twolink.arm.validation
from twolink.arm.params import ArmParams, Flexibility
from twolink.arm.plant import model_xml
from twolink.controllers.fuzzy import load_rule_base
from twolink.interface.cli import main
from twolink.simulation.config import load_scenario

REPO = Path(__file__).resolve().parents[1]


def test_validate_prints_the_table_and_exits_0():
    result = CliRunner().invoke(main, ["validate", "-n", "50", "--seed", "3"])
    assert result.exit_code == 0, result.output
    for name in ("mj_fullM", "qfrc_bias", "mj_inverse", "qacc", "energy drift"):
        assert name in result.output
    assert "FAIL" not in result.output


def test_validate_exits_1_when_a_check_fails(monkeypatch):
    # An impossible tolerance: the command must report the failure, not hide it.
    monkeypatch.setattr(twolink.arm.validation, "TOLERANCE", 0.0)
    result = CliRunner().invoke(main, ["validate", "-n", "20"])
    assert result.exit_code == 1
    assert "FAIL" in result.output


def test_design_writes_a_rule_base_with_evidence(tmp_path):
    out = tmp_path / "rules.toml"
    result = CliRunner().invoke(
        main, ["design", "--out", str(out), "--figure", str(tmp_path / "phase.png")]
    )
    assert result.exit_code == 0, result.output
    rules = load_rule_base(out)
    assert 1 <= len(rules) <= 10  # 5 clusters' rules and, at most, their mirrors
    assert "kept_per_cluster" in rules.metadata["evidence"]
    assert (tmp_path / "phase.png").stat().st_size > 10_000


def test_models_regenerates_the_mjcf_files(tmp_path):
    result = CliRunner().invoke(main, ["models", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "twolink.xml").read_text() == model_xml(ArmParams())
    assert (tmp_path / "twolink_flexible.xml").read_text() == model_xml(ArmParams(), Flexibility())


def _digests(*folders: Path) -> dict[str, str]:
    return {
        str(p): hashlib.sha256(p.read_bytes()).hexdigest()
        for folder in folders
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


def test_design_and_models_without_options_change_nothing_in_the_source_tree(tmp_path, monkeypatch):
    shipped = (REPO / "controllers", REPO / "models", REPO / "runs")
    before = _digests(*shipped)
    monkeypatch.chdir(tmp_path)
    for command in ("design", "models"):
        result = CliRunner().invoke(main, [command])
        assert result.exit_code == 0, result.output
    assert _digests(*shipped) == before
    assert len(load_rule_base(tmp_path / "results/design/rule_base.toml")) >= 1
    assert (tmp_path / "results/models/twolink.xml").read_text() == model_xml(ArmParams())


def test_install_takes_no_out(tmp_path):
    for command in ("design", "models"):
        result = CliRunner().invoke(main, [command, "--install", "--out", str(tmp_path / "x")])
        assert result.exit_code == 2 and "--install" in result.output
    assert not (tmp_path / "x").exists()


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="Linux's /proc clock")
def test_the_done_line_counts_the_command_not_the_shell_that_execd_it():
    """A shell runs the last command of ``bash -c "a; twolink ..."`` in its own process:
    the process's start is then the shell's, and "done in" counted ``a`` too (a 58 s
    reproduction said 103.6 s after a 46 s install). Python run on its own says its
    start-up is included; exec'd 6 s into a shell, it counts from twolink's import."""
    code = "from twolink.interface.cli_output import done_line; print(done_line())"
    alone = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True
    ).stdout.strip()
    assert alone.endswith("s (wall time of the whole command, start-up included)"), alone
    assert 0 <= float(alone.split()[2]) < 5
    late = subprocess.run(
        ["bash", "-c", 'sleep 6; exec "$0" -c "$1"', sys.executable, code],
        capture_output=True, text=True, timeout=60, check=True,
    ).stdout.strip()  # fmt: skip
    assert late.endswith("s (wall time from twolink's import)"), late
    assert 0 <= float(late.split()[2]) < 5  # not the 6 s sleep (an import can print 0.0)


def test_the_commands_page_lists_every_command():
    """docs/commands.md's table has a row for each command the CLI has (it had none for
    `coverage`)."""
    page = (Path(__file__).resolve().parents[1] / "docs" / "commands.md").read_text()
    table = page[page.index("| command | what it does |") :].split("\n\n")[0]
    rows = {line.split("`")[1].split()[1] for line in table.splitlines() if line.startswith("| `")}
    assert rows == set(main.commands)


def test_version_and_short_help():
    result = CliRunner().invoke(main, ["--version"])
    assert result.exit_code == 0 and "twolink, version" in result.output
    result = CliRunner().invoke(main, ["--help"])
    listed = result.output.split("Commands:")[1].strip().splitlines()
    commands = (
        "calibrate",
        "compare",
        "coverage",
        "design",
        "fis",
        "frontier",
        "gains",
        "models",
        "regimes",
        "reproduce",
        "run",
        "search",
        "sweep",
        "validate",
    )
    assert len(listed) == len(commands)
    assert not [line for line in listed if line.endswith("...")]
    for command in commands:
        help_text = CliRunner().invoke(main, [command, "--help"]).output
        assert "Examples:" in help_text, command


def test_a_file_given_to_the_wrong_command_is_named_with_the_right_one(tmp_path):
    cases = [
        ("run", "runs/sweeps/robustness.toml", "this is a sweep file", "twolink sweep"),
        ("sweep", "runs/paper/theta1_step.toml", "this is a scenario file", "twolink run"),
        ("run", "runs/paper/reproduce.toml", "this is a manifest file", "--manifest"),
        ("sweep", "runs/paper/design.toml", "this is a design file", "twolink design --config"),
    ]
    for command, file, says, suggests in cases:
        args = [command, str(REPO / file), "--out", str(tmp_path / "o")]
        result = CliRunner().invoke(main, args)
        assert result.exit_code == 2, result.output
        assert says in result.output and suggests in result.output, result.output
    result = CliRunner().invoke(
        main,
        [
            "reproduce",
            "--manifest",
            str(REPO / "runs/paper/theta1_step.toml"),
            "--out",
            str(tmp_path / "o"),
        ],
    )
    assert result.exit_code == 2 and "this is a scenario file" in result.output
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("command", ["run", "reproduce"])
def test_ctrl_c_exits_130_with_one_line_in_every_command(tmp_path, command):
    long_run = tmp_path / "long.toml"
    long_run.write_text(f'extends = "{REPO / "runs/paper/theta1_step.toml"}"\nduration = 600.0\n')
    args = {
        "run": ["run", str(long_run), "--out", str(tmp_path / "o")],
        "reproduce": ["reproduce", "--out", str(tmp_path / "r"), "--no-trace"],
    }[command]
    proc = subprocess.Popen(
        [sys.executable, "-m", "twolink", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        # Ctrl-C as a terminal sends it, whatever this test runs under: a shell starts
        # background jobs with SIGINT ignored, and Python then leaves it ignored.
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    time.sleep(2.5)  # past start-up, inside the work
    assert proc.poll() is None, proc.communicate()
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert "interrupted" in stderr and "Traceback" not in stderr and "Aborted" not in stderr
    assert "Warning" not in stderr, stderr  # e.g. the resource tracker's leaked semaphores


def test_set_overrides_keys_and_the_saved_config_records_them(tmp_path):
    args = ["run", str(REPO / "runs/paper/theta1_step.toml"), "--out", str(tmp_path / "o")]
    args += ["--set", "controller.kp=25", "--set", "controller.kd=10", "--set", "duration=3"]
    result = CliRunner().invoke(main, [*args, "--no-plots", "--no-trace"])
    assert result.exit_code == 0, result.output
    saved = load_scenario(tmp_path / "o" / "config.toml")
    assert saved.controller.kp == (25.0, 25.0) and saved.duration == 3.0
    assert "outcome: met spec" in result.output  # the 2 s move done, 0.5 s settled at ωn = 5
    for bad, says in (("controller.kpp=1", "controller.kpp: unknown key"), ("kp", "KEY=VALUE")):
        result = CliRunner().invoke(main, [*args[:4], "--set", bad])
        assert result.exit_code == 2 and says in result.output


def test_a_results_folder_can_move_with_its_rule_base(tmp_path):
    import shutil

    from twolink.simulation.config import RULEBASE_DIR
    from twolink.simulation.experiment import build_controller, measure, run_scenario
    from twolink.studies.reproduction.run_folder import write_run

    project = tmp_path / "a"
    project.mkdir()
    shutil.copy(RULEBASE_DIR / "paper_table1.toml", project / "rules.toml")
    (project / "scenario.toml").write_text(
        f'extends = "{REPO / "runs/paper/theta1_step.toml"}"\nduration = 0.2\n'
        '[controller]\nkind = "fcm_ctc"\nrule_base = "rules.toml"\n'
    )
    s = load_scenario(project / "scenario.toml")
    traj = run_scenario(s)
    write_run(project / "out", s, traj, measure(s, traj), plots=False, trace=False)
    assert 'rule_base = "../rules.toml"' in (project / "out" / "config.toml").read_text()
    rules = build_controller(s).engine.rules
    project.rename(tmp_path / "moved")
    again = load_scenario(tmp_path / "moved" / "out" / "config.toml")
    assert build_controller(again).engine.rules == rules
