"""Input faults of issue 49 (the independent audit), each a case that failed on main:
an ``extends`` through a pure loop of links, a parquet table nested past the recursion
limit, ``engine = "table"`` with ``inference = "continuous"``, a shipped name with ``..``,
a local file shadowed by the shipped one of its name, a loop of links given as the file
itself, a name over the file system's limit. Each: one line naming the file (and key),
exit 2, no traceback."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from cli_inputs import QUICK, STEP, invoke, one_error_line

from twolink.foundation.io import unsafe_name_problem
from twolink.foundation.names import long_name_problem
from twolink.foundation.shipped import locate, runs_dir
from twolink.simulation.config import ConfigError, load_scenario
from twolink.sweep.results import load_results


def test_extends_through_a_pure_loop_of_links_is_one_line_naming_the_loop(tmp_path):
    # l1 -> l2 -> l1: neither resolves (the existing test's link ends at a real file)
    (tmp_path / "l1.toml").symlink_to("l2.toml")
    (tmp_path / "l2.toml").symlink_to("l1.toml")
    (tmp_path / "s.toml").write_text('extends = "l1.toml"\n')
    for scenario in ("s.toml", "l1.toml"):
        result = invoke("run", tmp_path / scenario, "--out", tmp_path / "o", *QUICK)
        assert result.exit_code == 2, result.output
        one_error_line(result)
        assert f"{tmp_path / 'l1.toml'}: a loop of symbolic links" in result.output
        assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    "command",
    [["run", *QUICK], ["compare", "CTC", "FCM-CTC", "-n", "2"], ["sweep", "-n", "2"]],
    ids=["run", "compare", "sweep"],
)
@pytest.mark.parametrize("given", ["l1.toml", "l1"])
def test_a_pure_loop_of_links_given_as_the_file_is_one_line_naming_the_loop(
    tmp_path, monkeypatch, command, given
):
    # Given directly (not through extends) it said "no such file": exists() is False
    monkeypatch.chdir(tmp_path)
    Path("l1.toml").symlink_to("l2.toml")
    Path("l2.toml").symlink_to("l1.toml")
    result = invoke(command[0], given, *command[1:], "--out", tmp_path / "o")
    assert result.exit_code == 2, result.output
    one_error_line(result)
    assert "l1.toml: a loop of symbolic links" in result.output
    assert not (tmp_path / "o").exists()


def test_a_table_nested_past_the_recursion_limit_is_a_value_error_naming_it(tmp_path):
    # pandas reads a parquet file's attrs with json.loads: 100,000 brackets deep
    table = pa.table({"a": [1]}).replace_schema_metadata(
        {b"PANDAS_ATTRS": b"[" * 100_000 + b"]" * 100_000}
    )
    pq.write_table(table, tmp_path / "results.parquet")
    with pytest.raises(ValueError, match=r"results.parquet: not a table twolink wrote \(nested"):
        load_results(tmp_path)


def test_a_table_of_the_continuous_inference_is_refused_naming_both_keys(tmp_path):
    f = tmp_path / "x.toml"
    base = f'extends = "{STEP.as_posix()}"\n[controller]\nkind = "fcm_ctc"\n'
    f.write_text(base + 'fuzzy = { engine = "table", inference = "continuous" }\n')
    with pytest.raises(ConfigError) as err:
        load_scenario(f)
    message = str(err.value)
    assert message.startswith(f"{f}: controller.fuzzy.engine: ")
    assert 'inference = "continuous"' in message and "\n" not in message
    for fuzzy in ('engine = "table"', 'inference = "continuous"'):  # each alone is fine
        f.write_text(base + f"fuzzy = {{ {fuzzy} }}\n")
        load_scenario(f)
    f.write_text(base + 'fuzzy = { engine = "table", inference = "continuous" }\n')
    result = invoke("run", f, "--out", tmp_path / "o", *QUICK)
    assert result.exit_code == 2
    one_error_line(result)


def test_a_shipped_name_never_reaches_outside_the_shipped_files(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    # on main, runs/../pyproject was the clone's pyproject.toml
    assert not locate("../pyproject").is_absolute()
    assert not locate("paper/../../pyproject").is_absolute()
    assert locate("paper/theta1_step") == runs_dir() / "paper" / "theta1_step.toml"
    result = invoke("run", "../pyproject", "--out", tmp_path / "o", *QUICK)
    assert result.exit_code == 2 and "no such file" in result.output, result.output
    one_error_line(result)


def test_a_local_file_wins_over_the_shipped_one_of_its_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    mine = tmp_path / "paper" / "theta1_step.toml"
    mine.parent.mkdir()
    mine.write_text(f'extends = "{STEP.as_posix()}"\nduration = 0.05\n')
    for name in ("paper/theta1_step", "paper/theta1_step.toml"):
        assert locate(name).resolve() == mine
    assert load_scenario("paper/theta1_step").duration == 0.05
    assert load_scenario(STEP).duration != 0.05
    mine.unlink()
    assert locate("paper/theta1_step") == runs_dir() / "paper" / "theta1_step.toml"


@pytest.mark.parametrize(
    "args, key",
    [
        (["compare", "paper/theta1_step", "FCM-CTC", "CTC", "-n", "1000000000"], "-n/--plants"),
        (["gains", "--set", "plants=1000000000"], "plants"),
    ],
    ids=["compare", "gains"],
)
def test_more_plants_than_a_sweep_holds_are_one_line_before_any_work(tmp_path, args, key):
    out = tmp_path / "o"
    result = invoke(*args, "--out", out)
    assert result.exit_code == 2, result.output
    one_error_line(result)
    assert f"{key}: at most 1,000,000, the most a sweep holds" in result.output
    assert "got 1,000,000,000" in result.output
    assert not out.exists()  # on main compare wrote compare.toml there first


@pytest.mark.parametrize(
    "command, setting, words",
    [
        ("search", "popsize=1000000000", "search.toml: popsize: 13,000,000,000,000 runs"),
        ("search", "maxiter=1000000000", "> 10,000,000, about 4 days at the fastest"),
        ("calibrate", "popsize=1000000000", "calibrate.toml: popsize: 12,792,000,092,064,000"),
        ("calibrate", "timestep=1e-6", "arm steps (the arms popsize"),
    ],
)
def test_search_and_calibration_budgets_are_bounded_by_their_time(
    tmp_path, command, setting, words
):
    # on main: 4.55 TiB asked of numpy (search popsize), or days of runs started
    out = tmp_path / "o"
    result = invoke(command, "--set", setting, "--out", out)
    assert result.exit_code == 2, result.output
    one_error_line(result)
    assert words in result.output and not out.exists()


def test_the_shipped_budgets_are_far_inside_the_bounds():
    from twolink.studies.designs import calibrate, search

    study = calibrate.load_calibration(calibrate.DEFAULT_STUDY)
    steps = calibrate.n_runs(study) * round(study.duration / study.timestep)
    assert steps == 156_024_000 < calibrate.MAX_CALIBRATION_STEPS / 100
    spec = search.load_spec(search.DEFAULT_SPEC)
    assert search.search_runs(spec) < search.MAX_SEARCH_RUNS / 100


def test_coverage_of_a_1001_grid_holds_its_firing_a_block_at_a_time():
    import tracemalloc

    from twolink.controllers.fuzzy import paper_fuzzy_pd
    from twolink.controllers.fuzzy.coverage import coverage, uncovered_fraction

    engine = paper_fuzzy_pd()
    tracemalloc.start()
    result = coverage(engine, grid=1001)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    # on main the whole grid's firing at once: 334 MiB here, 954 MB for the command;
    # now ~37 MiB (the grid itself is 16 MB)
    assert peak < 64 * 2**20, peak / 2**20
    # the same share as the firing of the whole grid at once (a 201 grid: cheap)
    e = np.linspace(engine.e.universe[0], engine.e.universe[-1], 201)
    d = np.linspace(engine.de.universe[0], engine.de.universe[-1], 201)
    grid_e, grid_d = np.meshgrid(e, d)
    whole = float(np.mean(engine.firing(grid_e, grid_d).sum(axis=-1) <= 0))
    assert uncovered_fraction(engine, 201) == whole
    assert 0.69 < result.grid_fraction < 0.70


# Names over the file system's limit (255 bytes a name on most), given as any option or
# argument that becomes a file or folder name: each ended in an OSError traceback (compare,
# a scenario or sweep file) or "[Errno 36]" with no limit named. Now: exit 2 before any
# work, one line with the limit.
LONG = "a" * 300
OUTPUTS = {
    "run": ["run", STEP, *QUICK],
    "sweep": ["sweep", "sweeps/robustness", "-n", "2"],
    "compare": ["compare", "paper/theta1_step", "CTC", "FCM-CTC", "-n", "2"],
    "gains": ["gains", "--set", "plants=1"],
    "calibrate": ["calibrate", "--set", "maxiter=1"],
    "search": ["search", "--set", "plants=1"],
    "frontier": ["frontier"],
    "regimes": ["regimes"],
    "models": ["models"],
    "reproduce": ["reproduce"],
    "design": ["design"],
    "fis": ["fis"],
}
INPUTS = ["run", "sweep", "compare", "gains", "calibrate", "search", "frontier", "regimes"]


def refused_as_too_long(result, tmp_path) -> None:
    limit = os.pathconf(tmp_path, "PC_NAME_MAX")
    assert result.exit_code == 2, result.output
    one_error_line(result)
    assert f"at most {limit} bytes a name" in result.output, result.output
    assert not list(tmp_path.iterdir())  # nothing made


@pytest.mark.parametrize("command", sorted(OUTPUTS))
def test_an_out_with_a_name_over_the_limit_is_one_line_naming_the_limit(tmp_path, command):
    refused_as_too_long(invoke(*OUTPUTS[command], "--out", tmp_path / LONG / "x"), tmp_path)


@pytest.mark.parametrize("command", INPUTS)
def test_an_input_file_with_a_name_over_the_limit_is_one_line_naming_the_limit(tmp_path, command):
    args = OUTPUTS[command]
    given = [
        *args[:1],
        tmp_path / f"{LONG}.toml",
        *args[2 if command in ("run", "sweep", "compare") else 1 :],
    ]
    refused_as_too_long(invoke(*given, "--out", tmp_path / "o"), tmp_path)


def test_a_figure_whose_derived_name_is_over_the_limit_is_refused_before_the_design(tmp_path):
    # --figure f.png also writes f_validity.png: 250 + 4 bytes fit, 250 + 13 do not
    figure = tmp_path / ("b" * 250 + ".png")
    result = invoke("design", "--out", tmp_path / "rb.toml", "--figure", figure)
    refused_as_too_long(result, tmp_path)


def test_names_from_files_stay_far_inside_the_limit():
    # sweep, controller and variant names become file names with twolink's suffixes
    # (".parquet", "_vs_", "_mamdani.toml"): at most 100 ASCII bytes, so they fit any
    # file system of 143+ bytes a name (eCryptfs's is the smallest usual one)
    assert unsafe_name_problem("a" * 100) is None and unsafe_name_problem("a" * 101)
    assert unsafe_name_problem("é") is not None  # ASCII only: a byte a letter
    assert long_name_problem("a" * 255) is None and long_name_problem("é" * 128)
