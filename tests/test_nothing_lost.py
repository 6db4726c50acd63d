"""Nothing of the user's lost, nothing of a stranger's run (docs/reliability.md): one test
per fault class of the "nothing lost" issue, each on a case where today's twolink would
have deleted, written through, run or hung."""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pytest
from cli_inputs import QUICK, REPO, STEP, SWEEP, invoke, one_error_line, tree
from packaging.requirements import Requirement
from packaging.version import Version

from twolink.foundation.io import (
    LOCK_NAME,
    OWNER_NAME,
    ForeignOutput,
    OutputBusy,
    output_lock,
    seal_intact,
    write_seal,
)

# 1 ------------------------------------------------------------------ run --out deletes


def test_run_refuses_a_folder_with_the_users_files_and_touches_nothing(tmp_path):
    out = tmp_path / "thesis"
    (out / "sub").mkdir(parents=True)
    (out / "thesis.tex").write_text("chapter 1")
    (out / "sub" / "data.csv").write_text("1,2")
    before = tree(out)
    result = invoke("run", STEP, "--out", out, *QUICK)
    assert result.exit_code == 2
    one_error_line(result)
    assert "thesis.tex" in result.output and "did not write" in result.output
    assert tree(out) == before  # not even a lock file


def test_run_into_the_current_folder_is_refused_without_leftovers(tmp_path, monkeypatch):
    (tmp_path / "notes.txt").write_text("mine")
    monkeypatch.chdir(tmp_path)
    result = invoke("run", STEP, "--out", ".", *QUICK)
    assert result.exit_code == 2
    assert sorted(os.listdir(tmp_path)) == ["notes.txt"]


def test_a_rerun_replaces_its_own_run_and_refuses_a_file_added_since(tmp_path):
    out = tmp_path / "run"
    assert invoke("run", STEP, "--out", out, "--set", "duration=0.05", "--no-trace").exit_code == 0
    assert (out / "angles.png").is_file() and seal_intact(out, ("trajectory.npz",))
    # rerun without plots: its own stale plots go, nothing else is needed
    assert invoke("run", STEP, "--out", out, *QUICK).exit_code == 0
    assert not (out / "angles.png").exists() and seal_intact(out, ("trajectory.npz",))
    (out / "my_notes.md").write_text("keep me")
    result = invoke("run", STEP, "--out", out, *QUICK)
    assert result.exit_code == 2 and "my_notes.md" in result.output
    assert (out / "my_notes.md").read_text() == "keep me"


def test_run_into_a_sweeps_folder_is_refused_and_run_holds_the_lock(tmp_path):
    sweep_file = tmp_path / "tiny.toml"
    sweep_file.write_text(SWEEP)
    sweep_out = tmp_path / "sweep"
    assert invoke("sweep", sweep_file, "--out", sweep_out, "--no-plots").exit_code == 0
    before = tree(sweep_out)
    result = invoke("run", STEP, "--out", sweep_out, *QUICK)
    assert result.exit_code == 2 and "twolink sweep" in result.output
    assert tree(sweep_out) == before
    held = tmp_path / "held"
    with output_lock(held):
        result = invoke("run", STEP, "--out", held, *QUICK)
    assert result.exit_code == 2 and "another twolink" in result.output


def test_run_into_the_repositorys_scenarios_is_refused(tmp_path):
    shutil_copy = tmp_path / "paper"
    shutil_copy.mkdir()
    for p in (REPO / "runs" / "paper").glob("*.toml"):
        (shutil_copy / p.name).write_bytes(p.read_bytes())
    before = tree(shutil_copy)
    assert invoke("run", STEP, "--out", shutil_copy, *QUICK).exit_code == 2
    assert tree(shutil_copy) == before


# 2 ------------------------------------------------------- a file choosing the scheduler


def test_a_sweep_file_naming_a_scheduler_is_refused(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text(SWEEP + '[execution]\nexecutor = "dask"\nscheduler = "tcp://127.0.0.1:1"\n')
    result = invoke("sweep", f, "--out", tmp_path / "out")
    assert result.exit_code == 2
    one_error_line(result)
    assert "execution.scheduler" in result.output and "--scheduler" in result.output
    assert str(f) in result.output and not (tmp_path / "out").exists()


# 3 ----------------------------------------------------------------------------- links


@pytest.mark.parametrize("planted", [LOCK_NAME, "computed.log", "chunks", "manifest.json"])
def test_links_planted_in_a_sweeps_folder_are_never_written_through(tmp_path, planted):
    sweep_file = tmp_path / "tiny.toml"
    sweep_file.write_text(SWEEP)
    out = tmp_path / "out"
    out.mkdir()
    victim = tmp_path / "victim"
    if planted == "chunks":
        victim.mkdir()
        (victim / "keep.txt").write_text("precious")
    else:
        victim.write_text("precious")
    (out / planted).symlink_to(victim)
    before = tree(tmp_path / "victim") if victim.is_dir() else victim.read_bytes()
    result = invoke("sweep", sweep_file, "--out", out, "--no-plots")
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    after = tree(victim) if victim.is_dir() else victim.read_bytes()
    assert after == before


def test_a_link_inside_a_reproductions_folder_sends_no_run_elsewhere(tmp_path):
    from twolink.simulation.config import load_scenario
    from twolink.simulation.experiment import measure, run_scenario
    from twolink.studies.reproduction.run_folder import write_run

    root = tmp_path / "reproduce"
    elsewhere = tmp_path / "elsewhere"
    (elsewhere / "table2" / "CTC").mkdir(parents=True)
    (elsewhere / "table2" / "CTC" / "config.toml").write_text("theirs")
    root.mkdir()
    (root / "rigid").symlink_to(elsewhere)
    s = load_scenario(STEP, {"duration": 0.05})
    traj = run_scenario(s)
    with output_lock(root):
        with pytest.raises(ForeignOutput, match="symbolic link"):
            write_run(root / "rigid" / "table2" / "CTC", s, traj, measure(s, traj), False, False)
    assert tree(elsewhere) == {"table2/CTC/config.toml": b"theirs"}


def test_a_users_file_in_a_run_folder_of_a_reproduction_is_kept(tmp_path):
    from twolink.simulation.config import load_scenario
    from twolink.simulation.experiment import measure, run_scenario
    from twolink.studies.reproduction.run_folder import write_run

    folder = tmp_path / "rigid" / "table2" / "CTC"
    s = load_scenario(STEP, {"duration": 0.05})
    traj = run_scenario(s)
    write_run(folder, s, traj, measure(s, traj), False, False)
    (folder / "annotated.png").write_bytes(b"mine")
    with pytest.raises(ForeignOutput, match="annotated.png"):
        write_run(folder, s, traj, measure(s, traj), False, False)
    assert (folder / "annotated.png").read_bytes() == b"mine"


def test_an_out_that_is_a_dangling_link_is_refused_before_the_simulation(tmp_path):
    link = tmp_path / "out"
    link.symlink_to(tmp_path / "nowhere")
    start = time.perf_counter()
    result = invoke("run", STEP, "--out", link, "--set", "duration=5", "--no-trace")
    assert result.exit_code == 2 and "symbolic link" in result.output
    assert time.perf_counter() - start < 3.0  # refused before 5 s of simulation
    assert not (tmp_path / "nowhere").exists()


# 4 ---------------------------------------------------------------------- sealed outputs


def test_a_seal_finds_a_truncated_or_edited_file(tmp_path):
    (tmp_path / "a.npz").write_bytes(b"x" * 100)
    write_seal(tmp_path, ["a.npz"])
    assert seal_intact(tmp_path, ("a.npz",))
    (tmp_path / "a.npz").write_bytes(b"x" * 50)  # cut short
    assert not seal_intact(tmp_path)
    (tmp_path / "a.npz").write_bytes(b"y" * 100)  # edited, same size
    assert not seal_intact(tmp_path)


def test_a_damaged_design_is_designed_again_not_a_traceback(tmp_path, capsys):
    from twolink.studies.designs.design import (
        DEFAULT_DESIGN,
        design,
        load_design,
        load_design_config,
        save_design,
    )

    config = load_design_config(DEFAULT_DESIGN)
    save_design(design(config), tmp_path)
    assert load_design(config, tmp_path) is not None
    data = (tmp_path / "evidence.npz").read_bytes()
    (tmp_path / "evidence.npz").write_bytes(data[: len(data) // 2])  # BadZipFile before
    assert load_design(config, tmp_path) is None
    assert "designed again" in capsys.readouterr().err


def test_an_edited_run_of_a_reproduction_is_computed_again(tmp_path, capsys):
    from twolink.simulation.config import load_scenario
    from twolink.simulation.experiment import measure, run_scenario
    from twolink.studies.reproduction.manifest import load_manifest
    from twolink.studies.reproduction.reproduce import finished_row, plan
    from twolink.studies.reproduction.run_folder import write_run

    manifest = load_manifest()
    spec = plan(manifest, None, (), None)[0]
    s = load_scenario(spec.experiment.scenario, spec.overrides)
    traj = run_scenario(s)
    write_run(tmp_path / spec.folder, s, traj, measure(s, traj), False, False)
    assert finished_row(spec, s, tmp_path, trace=False) is not None
    npz = tmp_path / spec.folder / "trajectory.npz"
    npz.write_bytes(npz.read_bytes()[:1000])  # BadZipFile on every rerun before
    assert finished_row(spec, s, tmp_path, trace=False) is None
    assert "computed again" in capsys.readouterr().err


# 5, 9 ------------------------------------------------------- every bad input: one line


DEEP = "a = " + "[" * 500 + "]" * 500 + "\n"


@pytest.mark.parametrize(
    "args, says",
    [
        (["--set", "controller.kp=1e308"], "controller.kp: must be at most"),
        (["--set", "timestep=5e-324"], "timestep: must be >= 1e-06"),
        (["--set", "arm.l2=1e300"], "arm.l2: must be at most"),
        (["--set", "control_dt=1e308"], "control_dt: must be at most"),
        (["--set", 'name="a\nb"'], "line break"),
        (["--set", "a.b=" + "[" * 500 + "]" * 500], "nested too deep"),
        (["--set", "controller.fuzzy.table_points=1000000"], "table_points: must be 2 to"),
    ],
    ids=["kp", "timestep", "l2", "control_dt", "newline", "deep-set", "table_points"],
)
def test_out_of_range_settings_exit_2_naming_the_key(tmp_path, args, says):
    result = invoke("run", STEP, "--out", tmp_path / "o", "--no-trace", *args)
    assert result.exit_code == 2, result.output
    one_error_line(result)
    assert says in result.output
    assert not (tmp_path / "o").exists()


def test_deep_toml_and_extends_link_loops_exit_2(tmp_path):
    deep = tmp_path / "deep.toml"
    deep.write_text(DEEP)
    result = invoke("run", deep, "--out", tmp_path / "o")
    assert result.exit_code == 2 and "nested too deep" in result.output
    (tmp_path / "a.toml").write_text('extends = "b.toml"\n')
    (tmp_path / "b.toml").symlink_to(tmp_path / "a.toml")
    result = invoke("run", tmp_path / "a.toml", "--out", tmp_path / "o")
    assert result.exit_code == 2 and "extends" in result.output
    one_error_line(result)


def test_design_out_a_named_pipe_is_refused_and_stays_a_pipe(tmp_path):
    pipe = tmp_path / "pipe"
    os.mkfifo(pipe)
    result = invoke("design", "--out", pipe)
    assert result.exit_code == 2 and "not a regular file" in result.output
    assert pipe.is_fifo()


def test_design_never_overwrites_a_file_it_did_not_write(tmp_path):
    mine = tmp_path / "rule_base.toml"
    mine.write_text("# my own rule base\n")
    result = invoke("design", "--out", mine)
    assert result.exit_code == 2 and "did not write" in result.output
    assert mine.read_text() == "# my own rule base\n"


# 6 ------------------------------------------------------------------ write failures


def _limited(command: list[str], limit: int, cwd: Path) -> subprocess.CompletedProcess:
    """Run ``python -m twolink`` with files limited to ``limit`` bytes (EFBIG, as a full
    disk gives ENOSPC: both are write failures)."""

    def preexec() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return subprocess.run(
        [sys.executable, "-m", "twolink", *command],
        cwd=cwd,
        capture_output=True,
        text=True,
        preexec_fn=preexec,
        timeout=300,
    )


def test_a_failed_write_exits_3_naming_the_file_and_keeps_earlier_results(tmp_path):
    out = tmp_path / "run"
    ok = invoke("run", STEP, "--out", out, "--set", "duration=0.05", "--no-trace")
    assert ok.exit_code == 0
    before = tree(out)
    r = _limited(["run", str(STEP), "--out", str(out), "--no-trace"], 20_000, tmp_path)
    assert r.returncode == 3, r.stderr
    assert "Traceback" not in r.stderr and str(out) in r.stderr
    assert "File too large" in r.stderr
    # the earlier run is whole: every file as it was (the lock names the last holder), or
    # the folder reads as unsealed
    after, _ = tree(out), before.pop(LOCK_NAME)
    after.pop(LOCK_NAME)
    assert after == before or not seal_intact(out)
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]


def test_a_sweep_that_cannot_write_exits_3(tmp_path):
    f = tmp_path / "tiny.toml"
    f.write_text(SWEEP)
    r = _limited(["sweep", str(f), "--out", str(tmp_path / "s"), "--no-plots"], 2_000, tmp_path)
    assert r.returncode == 3, r.stderr
    assert "Traceback" not in r.stderr and "cannot write" in r.stderr


# 7 ---------------------------------------------------------------------------- SIGTERM


def _terminated(args: list[str], after: float, tmp_path: Path) -> None:
    """Run ``python -m twolink ARGS``, SIGTERM it ``after`` seconds in: one line, exit 143,
    no temporaries left under ``tmp_path``."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "twolink", *args],
        stderr=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    time.sleep(after)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    if proc.returncode == 0:
        pytest.skip("the command finished before SIGTERM arrived")
    assert proc.returncode == 143, err
    assert "terminated (SIGTERM)" in err and "Traceback" not in err
    leftovers = [p for p in tmp_path.rglob("*") if p.name.endswith((".tmp", ".old"))]
    assert leftovers == []


def test_sigterm_ends_run_with_one_line_exit_143_and_no_temporaries(tmp_path):
    # 2000 s of simulation: SIGTERM lands inside it
    args = ["run", str(STEP), "--out", str(tmp_path / "run"), "--set", "duration=2000"]
    _terminated(args, 3.0, tmp_path)


def test_sigterm_ends_reproduce_with_one_line_and_exit_143(tmp_path):
    # the pool is running by then: design, runs, the claims sweep
    _terminated(["reproduce", "--out", str(tmp_path / "r"), "--no-trace"], 6.0, tmp_path)


@pytest.mark.parametrize("command", ["regimes", "gains"])
def test_sigterm_inside_a_study_sweep_ends_at_once_with_one_line(tmp_path, command):
    # In a study's own sweep (a pool lent to run_sweep): `twolink regimes` ended in a
    # SweepInterrupted traceback, exit 1, and both waited ~10 s for the running chunks.
    import threading

    args = [sys.executable, "-m", "twolink", command, "--out", str(tmp_path / "out")]
    proc = subprocess.Popen(args, stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    err: list[str] = []
    reader = threading.Thread(target=lambda: err.extend(iter(lambda: proc.stderr.read(1), "")))
    reader.start()
    deadline = time.monotonic() + 60
    while "0%|" not in "".join(err) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.1)  # until the progress bar shows: the pool's tasks are running
    time.sleep(2.0)
    proc.send_signal(signal.SIGTERM)
    sent = time.monotonic()
    proc.wait(timeout=120)
    took = time.monotonic() - sent
    reader.join()
    text = "".join(err)
    assert proc.returncode == 143, text
    assert "SIGTERM" in text and "Traceback" not in text
    assert took < 7.0  # the pool is stopped, not waited for (its tasks take ~10 s)


# 8 ---------------------------------------------------------------------------- hangs


def test_coverage_refuses_pipes_and_devices_at_once(tmp_path):
    pipe = tmp_path / "rules.toml"
    os.mkfifo(pipe)
    for target in (pipe, Path("/dev/zero")):
        start = time.perf_counter()
        result = invoke("coverage", target)
        assert result.exit_code == 2 and "not a regular file" in result.output
        assert time.perf_counter() - start < 5


def test_a_20000_rule_base_loads_in_linear_time(tmp_path):
    from twolink.controllers.fuzzy import load_rule_base

    labels = ["NB", "NM", "NS", "Z", "PS", "PM", "PB"]
    rules = [(labels[i % 7], labels[(i // 7) % 7], "Z") for i in range(20_000)]
    text = "".join(f'[[rule]]\ne = "{e}"\nde = "{de}"\nu = "{u}"\n' for e, de, u in rules)
    (tmp_path / "big.toml").write_text(text)
    start = time.perf_counter()
    assert len(load_rule_base(tmp_path / "big.toml").rules) == 20_000
    assert time.perf_counter() - start < 5  # > 60 s with the quadratic check


@pytest.mark.parametrize(
    "args",
    [["validate", "-n", str(10**12)], ["coverage", "--grid", "200000"]],
    ids=["validate-n", "coverage-grid"],
)
def test_sizes_are_bounded(args):
    result = invoke(*args)
    assert result.exit_code == 2 and "range" in result.output


# 10 ------------------------------------------------------------- names and default folders


def test_a_sweep_is_named_by_its_file(tmp_path):
    from twolink.sweep import load_sweep

    f = tmp_path / "tiny.toml"
    f.write_text(SWEEP)
    assert load_sweep(f).name == "tiny_sweep"
    f.write_text(SWEEP.replace('name = "tiny_sweep"\n', ""))
    assert load_sweep(f).name == "tiny"
    for shipped in ("robustness", "flexible_map"):
        assert load_sweep(REPO / "runs" / "sweeps" / f"{shipped}.toml").name == shipped


def test_two_scenarios_with_one_stem_do_not_share_a_default_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    other = tmp_path / "elsewhere" / "theta1_step.toml"
    other.parent.mkdir()
    other.write_text(f'extends = "{STEP.as_posix()}"\nduration = 0.05\n')
    assert invoke("run", STEP, *QUICK).exit_code == 0
    first = tree(tmp_path / "results" / "theta1_step")
    result = invoke("run", other, "--no-trace", "--no-plots")
    assert result.exit_code == 2 and str(STEP) in result.output
    assert tree(tmp_path / "results" / "theta1_step") == first
    owner = (tmp_path / "results" / "theta1_step" / OWNER_NAME).read_text()
    assert str(STEP) in owner


# 11 ------------------------------------------------------------------------- pyarrow


def test_pyarrow_has_no_version_with_the_parquet_cve():
    deps = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["dependencies"]
    (pyarrow,) = [Requirement(d) for d in deps if d.startswith("pyarrow")]
    assert not pyarrow.specifier.contains(Version("14.0.0"))
    assert pyarrow.specifier.contains(Version("14.0.1"))


def test_output_busy_is_an_oserror_the_cli_reports_as_bad_input():
    assert issubclass(OutputBusy, OSError) and issubclass(ForeignOutput, OSError)


def test_a_folder_without_an_owner_record_is_not_adopted_by_its_names(tmp_path):
    # a run folder with its record removed (or one from a twolink before records) holds
    # only a run's names: twolink cannot tell them from a user's and refuses (no adoption)
    out = tmp_path / "old_run"
    assert invoke("run", STEP, "--out", out, *QUICK).exit_code == 0
    for name in (OWNER_NAME, LOCK_NAME, "seal.json"):
        (out / name).unlink()
    before = tree(out)
    result = invoke("run", STEP, "--out", out, *QUICK)
    assert result.exit_code == 2 and "did not write" in result.output
    assert tree(out) == before


@pytest.mark.parametrize("when", ["made", "removed"])
def test_a_ctrl_c_while_a_temporary_is_made_or_removed_leaves_none(tmp_path, monkeypatch, when):
    # CI once found `.seal.json.*.tmp` after a Ctrl-C: the signal landed between mkstemp
    # and the temporary's registration. Here it lands exactly there, every time.
    from twolink.foundation import io

    def ctrl_c(*args, **kwargs):
        signal.raise_signal(signal.SIGINT)

    if when == "made":
        mkstemp = io.tempfile.mkstemp
        monkeypatch.setattr(io.tempfile, "mkstemp", lambda *a, **k: (mkstemp(*a, **k), ctrl_c())[0])
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            with io.atomic_path(tmp_path / "seal.json") as tmp:
                tmp.write_text("{}")
                if when == "removed":
                    # the write fails, and the signal lands as its temporary is removed
                    unlink = Path.unlink
                    monkeypatch.setattr(
                        Path, "unlink", lambda self, **k: (ctrl_c(), unlink(self, **k))
                    )
                    raise OSError(28, "No space left on device")
    finally:
        signal.signal(signal.SIGINT, previous)
    assert list(tmp_path.iterdir()) == []
    assert not io._PENDING
