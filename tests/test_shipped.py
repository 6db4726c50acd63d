"""Shipped files are package data, named by their path under the shipped runs without the
extension; a real path wins; ``--install`` needs a clone (twolink/foundation/shipped.py)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest
from clone_guard import REPO, clone_files, written

from twolink.foundation import shipped
from twolink.simulation.config import ConfigError, load_scenario


def test_the_shipped_folders_are_the_clones_in_an_editable_install():
    assert shipped.runs_dir() == REPO / "runs"
    assert shipped.models_dir() == REPO / "models"
    assert shipped.rulebases_dir() == REPO / "controllers" / "rulebases"
    assert shipped.clone_root() == REPO
    names = shipped.shipped_names()
    assert {"paper/theta1_step", "paper/reproduce", "sweeps/robustness", "theta1_step"} <= set(
        names
    )
    assert len(names) == len(list((REPO / "runs").rglob("*.toml")))


def test_a_shipped_name_finds_its_file_from_any_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    want = REPO / "runs" / "paper" / "theta1_step.toml"
    for name in ("paper/theta1_step", "paper/theta1_step.toml", "runs/paper/theta1_step.toml"):
        assert shipped.locate(name) == want, name
    assert shipped.locate("sweeps/robustness") == REPO / "runs" / "sweeps" / "robustness.toml"
    assert shipped.locate("paper") == Path("paper")  # a folder is no file
    assert shipped.locate("no/such") == Path("no/such")  # the caller's error names it
    assert load_scenario("paper/theta1_step").name == "θ1 step"


def test_a_real_path_wins_over_a_shipped_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "paper").mkdir()
    (tmp_path / "paper" / "theta1_step.toml").write_text(
        f'extends = "{(REPO / "runs/paper/base.toml").as_posix()}"\nname = "mine"\n'
    )
    assert shipped.locate("paper/theta1_step.toml") == Path("paper/theta1_step.toml")
    assert load_scenario("paper/theta1_step.toml").name == "mine"
    # without the extension too (issue 49: the shipped one silently shadowed it)
    assert load_scenario("paper/theta1_step").name == "mine"


def test_a_mistyped_name_says_what_was_meant(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError) as err:
        load_scenario("paper/theta1_stpe")
    assert str(err.value).startswith("paper/theta1_stpe: no such file (nor a shipped file")
    assert "did you mean paper/theta1_step" in str(err.value)
    with pytest.raises(ConfigError, match=r"no such file \(nor a shipped file: the shipped"):
        load_scenario("zzz/qqq")


def test_the_command_line_runs_a_shipped_scenario_by_name_and_writes_only_here(tmp_path):
    before = clone_files()
    done = subprocess.run(
        [sys.executable, "-m", "twolink", "run", "paper/theta1_step", "--set", "duration=0.3",
         "--no-plots", "--no-trace"],
        cwd=tmp_path, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "results in results/theta1_step" in done.stdout
    assert (tmp_path / "results" / "theta1_step" / "metrics.json").is_file()
    assert written(before) == []


def test_install_refuses_in_one_line_where_twolink_is_a_wheels(monkeypatch, tmp_path):
    target = shipped.rulebases_dir() / "designed.toml"
    assert shipped.install_target(target) == target  # a clone: written there
    monkeypatch.setattr(shipped, "clone_root", lambda: None)  # as installed from a wheel
    with pytest.raises(shipped.NotAClone) as err:
        shipped.install_target(target)
    assert "\n" not in str(err.value)
    assert re.match(r"--install rewrites the shipped files of a clone", str(err.value))
    assert "nothing to install into" in str(err.value)
    mine = tmp_path / "gains.csv"  # beside a user's own study file: theirs to write
    assert shipped.install_target(mine) == mine


def test_no_module_finds_its_files_through_the_source_tree():
    """Shipped files come through importlib.resources (shipped.py), never from a path
    relative to a module's own file: a wheel has no source tree around it."""
    offenders = [
        f"{path.relative_to(REPO)}:{n}"
        for folder in ("twolink", "controllers")
        for path in sorted((REPO / folder).rglob("*.py"))
        for n, line in enumerate(path.read_text().splitlines(), 1)
        if "__file__" in line and not line.lstrip().startswith("#")
    ]
    assert offenders == []


def test_a_file_of_ones_own_anywhere_extends_a_shipped_scenario_by_name(tmp_path):
    mine = tmp_path / "mine.toml"
    mine.write_text('extends = "paper/theta1_step"\nname = "mine"\n[controller]\nkp = 100.0\n')
    s = load_scenario(mine)
    assert s.name == "mine" and s.controller.kp == (100.0, 100.0)
    assert s.controller.torque_limit == (60.0, 15.0)  # the shipped base's, inherited
    # a file of that name beside it wins
    (tmp_path / "paper").mkdir()
    (tmp_path / "paper" / "theta1_step").write_text(
        f'extends = "{(REPO / "runs/paper/base.toml").as_posix()}"\n[controller]\nkd = 7.0\n'
    )
    assert load_scenario(mine).controller.kd == (7.0, 7.0)
    from twolink.sweep import load_sweep

    sweep = tmp_path / "s.toml"
    sweep.write_text('scenario = "theta1_step"\nsamples = 2\n[controllers.CTC]\nkind = "ctc"\n')
    assert load_sweep(sweep).samples == 2
