"""Every promise kept at its edge: each case here is one a reliability audit found broken
(a plants file the run then refuses, a stop during ``compare``, names near the file
system's limit, library errors that do not say what went wrong, ...), with the answer a
user of the command line or the library expects (docs/reliability.md)."""

from __future__ import annotations

import errno
import os
import signal
from pathlib import Path

import pytest
from cli_inputs import invoke, one_error_line

from twolink import sweep as sw
from twolink.simulation.config import ConfigError

REPO = Path(__file__).resolve().parents[1]
SHORT = ["--set", "duration=0.5", "--workers", "1", "--no-trace"]


# ------------------------------------------------- compare --plants-file: refused up front

REFUSED = {  # plants file -> (row, column, what the line says): values the run refuses
    "a mass beyond the scenario's": ("m1\n1e308\n", 1, "m1", "must be at most 1e+12"),
    "MuJoCo's smallest mass": ("m1\n5e-324\n", 1, "m1", "mjMINVAL"),
    "a friction level beyond": ("friction_level\n1e12\n", 1, "friction_level", "at most 1e+12"),
    "one bad row among good ones": (
        "m1,payload\n1.0,0.0\n1.1,0.1\n1e300,0.0\n0.9,0.2\n",
        3,
        "m1",
        "at most 1e+12",
    ),
}


@pytest.mark.parametrize("case", sorted(REFUSED))
def test_a_plant_the_run_would_refuse_is_one_line_exit_2_before_any_work(tmp_path, case):
    content, row, column, says = REFUSED[case]
    path = tmp_path / "plants.csv"
    path.write_text(content)
    out = tmp_path / "out"
    result = invoke("compare", "theta1_step", "FCM-CTC", "CTC", "--plants-file", path,
                    "--out", out, *SHORT)  # fmt: skip
    assert result.exit_code == 2, result.output
    one_error_line(result)
    where = f"error: {path}: row {row} under the header, column {column!r}: "
    assert where in result.output and says in result.output, result.output
    assert not out.exists()  # no compare.toml, no sweep/
    from twolink.studies.judgments.compare import compare_sweep

    with pytest.raises(ConfigError, match=f"^{path}: row {row} under the header"):
        compare_sweep(REPO / "runs" / "theta1_step.toml", "FCM-CTC", "CTC", path, 0)


# ------------------------------------------------------------ compare: stops, disks, folders


@pytest.mark.parametrize(
    ("signum", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)], ids=["INT", "TERM"]
)
def test_a_stop_during_compares_sweep_is_one_line_and_130_or_143(tmp_path, monkeypatch, signum,
                                                                 code):  # fmt: skip
    # the sweep's own stop (twolink.sweep.run_sweep raises it on SIGINT / SIGTERM, its
    # chunks kept: tests/test_stopping.py), as compare's sweep meets it
    def stopped(plan, out, **kwargs):
        raise sw.SweepInterrupted(signum, 0, 1, Path(out))

    monkeypatch.setattr(sw, "run_sweep", stopped)
    result = invoke("compare", "theta1_step", "FCM-CTC", "CTC", "-n", "2",
                    "--out", tmp_path / "out", *SHORT)  # fmt: skip
    assert result.exit_code == code, result.output
    assert isinstance(result.exception, SystemExit), result.exception  # no traceback
    lines = [x for x in result.output.splitlines() if x.strip()]
    assert lines[-1].startswith(f"interrupted by {signal.Signals(signum).name}: "), result.output


def test_compare_into_a_folder_it_cannot_write_is_exit_2_before_any_work(tmp_path, monkeypatch):
    # A read-only disk: the probe file of the folder check cannot be made (EROFS), as every
    # other command finds it (twolink.foundation.io.check_output_folder)
    import twolink.foundation.io as tio

    def read_only(*args, **kwargs):
        raise OSError(errno.EROFS, "Read-only file system")

    monkeypatch.setattr(tio.tempfile, "NamedTemporaryFile", read_only)
    ran = []
    monkeypatch.setattr(sw, "run_sweep", lambda *a, **k: ran.append(a))
    out = tmp_path / "out"
    result = invoke("compare", "theta1_step", "FCM-CTC", "CTC", "-n", "2", "--out", out, *SHORT)
    assert result.exit_code == 2, result.output
    one_error_line(result)
    assert f"--out {out}: cannot write in {tmp_path} (Read-only file system)" in result.output
    assert not out.exists() and not ran


def test_compare_whose_plants_all_diverged_judges_nothing_and_exits_1(tmp_path):
    # Arms a million times lighter than the controllers' model: every run leaves the
    # bounds in its first step (sim.Bounds), under both laws
    plants = tmp_path / "light.csv"
    plants.write_text("m1,m2\n1e-6,1e-6\n2e-6,1e-6\n")
    out = tmp_path / "out"
    result = invoke("compare", "theta1_step", "FCM-CTC", "CTC", "--plants-file", plants,
                    "--out", out, *SHORT)  # fmt: skip
    assert result.exit_code == 1, result.output
    one_error_line(result)
    assert (
        "no plant ran to its end under both FCM-CTC and CTC (4 of 4 runs on 2 plants "
        "diverged or failed"
        in result.output
        and "nothing to judge" in result.output
    )
    assert "verdict" not in result.output and not (out / "claims.csv").exists()
    import twolink
    from twolink.studies.judgments.compare import NothingToJudge

    with pytest.raises(NothingToJudge, match="no plant ran to its end"):
        twolink.compare("theta1_step", "FCM-CTC", "CTC", plants=plants,
                        overrides={"duration": 0.5}, trace=False)  # fmt: skip


def test_a_second_comparison_of_the_same_pair_keeps_the_first(tmp_path, monkeypatch):
    # The command's folder is one per pair and plants: 2 drawn plants, then a plants file,
    # each in its own; a comparison of other settings into a folder the command picked is
    # refused before any work, naming what the folder holds
    monkeypatch.chdir(tmp_path)
    plants = tmp_path / "mine.csv"
    plants.write_text("m1\n1.0\n1.1\n")
    drawn = invoke("compare", "theta1_step", "FCM-CTC", "CTC", "-n", "2", *SHORT)
    assert drawn.exit_code == 0, drawn.output
    first = tmp_path / "results" / "compare" / "theta1_step_FCM-CTC_vs_CTC_2_plants"
    before = (first / "claims.csv").read_bytes()
    own = invoke("compare", "theta1_step", "FCM-CTC", "CTC", "--plants-file", plants, *SHORT)
    assert own.exit_code == 0, own.output
    second = tmp_path / "results" / "compare" / "theta1_step_FCM-CTC_vs_CTC_mine"
    assert (second / "claims.csv").is_file() and (first / "claims.csv").read_bytes() == before
    other = invoke("compare", "theta1_step", "FCM-CTC", "CTC", "-n", "2", *SHORT[:1],
                   "duration=0.4", *SHORT[2:])  # fmt: skip
    assert other.exit_code == 2, other.output
    one_error_line(other)
    assert "same default folder" in other.output and "2 drawn plants" in other.output
    assert (first / "claims.csv").read_bytes() == before
    again = invoke("compare", "theta1_step", "FCM-CTC", "CTC", "-n", "2", *SHORT)
    assert again.exit_code == 0, again.output  # the same comparison: its own folder again


# ------------------------------------------------------------- a lock left by a full disk


def test_a_sub_folders_lock_left_by_a_full_disk_does_not_block_the_rerun(tmp_path, monkeypatch):
    # `regimes` holds its folder, its sweep a sub-folder (raw_steps/); the disk fills as
    # the sweep's lock gets its pid: an empty raw_steps/.twolink.lock is left
    from twolink.foundation import ownership
    from twolink.foundation.io import atomic_write_text, check_ownership, owned_output

    out = tmp_path / "out"
    with owned_output(out, "regimes"):
        atomic_write_text(out / "table.csv", "a,b\n")
        with monkeypatch.context() as m:

            def full(*args):
                raise OSError(errno.ENOSPC, "No space left on device")

            m.setattr(ownership.os, "pwrite", full)
            with pytest.raises(ownership.WriteFailed), owned_output(out / "raw_steps", "sweep"):
                pass
    lock = out / "raw_steps" / ".twolink.lock"
    assert lock.read_bytes() == b""
    check_ownership(out, "regimes")  # space freed: the rerun takes the folder
    check_ownership(out / "raw_steps", "sweep")
    lock.write_bytes(b"4242\n")  # the pid of a command that is gone: a lock too
    check_ownership(out, "regimes")
    # a user's file of that name is no lock: still refused
    for planted in (b"my notes\n", b"12345\nmore\n"):
        lock.write_bytes(planted)
        with pytest.raises(ownership.ForeignOutput, match=r"raw_steps/\.twolink\.lock"):
            check_ownership(out, "regimes")
    lock.write_bytes(b"")
    os.link(lock, tmp_path / "elsewhere")  # another name shares its bytes: not twolink's
    with pytest.raises(ownership.ForeignOutput, match=r"raw_steps/\.twolink\.lock"):
        check_ownership(out, "regimes")
    os.unlink(tmp_path / "elsewhere")
    with owned_output(out, "regimes"), owned_output(out / "raw_steps", "sweep"):
        atomic_write_text(out / "raw_steps" / "results.csv", "x\n")
    check_ownership(out, "regimes")


# --------------------------------------------------------------- names near the limit


@pytest.mark.parametrize("size", [241, 248, 254])
def test_a_name_that_fits_but_whose_temporary_does_not_is_refused_before_the_work(tmp_path, size):
    # `fis --out NAME.fis` writes NAME.fis through .NAME.fis.XXXXXXXX.tmp beside it (14-18
    # bytes more): the check counts it, so nothing fails after the work
    limit = os.pathconf(tmp_path, "PC_NAME_MAX")
    out = tmp_path / ("a" * (size - 4) + ".fis")
    result = invoke("fis", "--out", out)
    assert result.exit_code == 2, result.output
    one_error_line(result)
    assert f"is {size} bytes, and {size + 18} with the temporary" in result.output
    assert f"at most {limit} bytes a name; {limit - 18} for this one" in result.output
    assert not list(tmp_path.iterdir())


def test_the_longest_name_the_check_passes_is_written(tmp_path):
    limit = os.pathconf(tmp_path, "PC_NAME_MAX")
    out = tmp_path / ("a" * (limit - 18 - 4) + ".fis")
    result = invoke("fis", "--out", out)
    assert result.exit_code == 0, result.output
    assert out.is_file() and [p.name for p in tmp_path.iterdir()] == [out.name]


def deep(tmp_path: Path, size: int) -> Path:
    """A path of exactly ``size`` bytes under ``tmp_path``, of names of 200 bytes."""
    path = str(tmp_path)
    while len(os.fsencode(path)) < size - 201:
        path += "/" + "d" * 200
    return Path(path + "/" + "e" * (size - len(os.fsencode(path)) - 1))


@pytest.mark.parametrize("size", [4095, 3840])
def test_an_out_folder_too_long_for_the_files_inside_it_is_one_line_exit_2(tmp_path, size):
    path_max = os.pathconf(tmp_path, "PC_PATH_MAX")
    out = deep(tmp_path, size)
    assert len(os.fsencode(str(out))) == size
    result = invoke("run", REPO / "runs" / "paper" / "theta1_step.toml", "--set",
                    "duration=0.05", "--no-trace", "--no-plots", "--out", out)  # fmt: skip
    assert result.exit_code == 2, result.output
    one_error_line(result)
    assert f"the path is {size} bytes" in result.output and f"under {path_max}" in result.output
    assert not list(tmp_path.iterdir())
    fits = deep(tmp_path, path_max - 257)  # the longest the check passes: its files fit
    result = invoke("run", REPO / "runs" / "paper" / "theta1_step.toml", "--set",
                    "duration=0.05", "--no-trace", "--no-plots", "--out", fits)  # fmt: skip
    assert result.exit_code == 0, result.output
    assert (fits / "metrics.json").is_file()


# ------------------------------------------------------- two commands into one folder


def test_the_loser_of_two_commands_says_the_winner_is_writing_not_that_it_was_stopped(tmp_path):
    import subprocess
    import sys

    from twolink.foundation.io import ForeignOutput, OutputBusy, check_ownership

    out = tmp_path / "out"
    hold = (
        "import sys, time\n"
        "from twolink.foundation.io import owned_output, atomic_write_text\n"
        f"with owned_output({str(out)!r}, 'sweep'):\n"
        f"    atomic_write_text({str(out / 'part.csv')!r}, 'x\\n')\n"
        "    print('held', flush=True)\n"
        "    time.sleep(60)\n"
    )
    winner = subprocess.Popen([sys.executable, "-c", hold], stdout=subprocess.PIPE, text=True)
    try:
        assert winner.stdout.readline().strip() == "held"
        with pytest.raises(OutputBusy) as busy:
            check_ownership(out, "regimes")
        said = str(busy.value)
        assert f"`twolink sweep` (pid {winner.pid}) is writing into this folder" in said, said
        assert "stopped" not in said and "rerun" not in said
        result = invoke("run", REPO / "runs" / "paper" / "theta1_step.toml", "--no-trace",
                        "--no-plots", "--set", "duration=0.05", "--out", out)  # fmt: skip
        assert result.exit_code == 2 and "is writing into this folder" in result.output
        one_error_line(result)
    finally:
        winner.kill()
        winner.wait()
    with pytest.raises(ForeignOutput, match="before it was stopped"):  # killed: it was
        check_ownership(out, "regimes")


# ------------------------------------------------------------------ smaller refusals


def test_regimes_on_mjx_without_jax_is_one_line_exit_2_before_any_work(tmp_path):
    from twolink.simulation.mjx_engine import available

    if available():
        pytest.skip("MJX and JAX are installed here")
    out = tmp_path / "out"
    result = invoke("regimes", "--backend", "mjx", "--out", out)
    assert result.exit_code == 2, result.output
    one_error_line(result)
    assert "backend 'mjx' needs MJX and JAX: pip install" in result.output
    assert not out.exists()


@pytest.mark.parametrize("links", [1, 2], ids=["to itself", "two in a ring"])
def test_a_plants_file_that_is_a_loop_of_links_is_one_line_exit_2(tmp_path, links):
    names = [tmp_path / f"loop{k}.csv" for k in range(links)]
    for k, name in enumerate(names):
        name.symlink_to(names[(k + 1) % links].name)
    out = tmp_path / "out"
    result = invoke("compare", "theta1_step", "FCM-CTC", "CTC", "--plants-file", names[0],
                    "--out", out, *SHORT)  # fmt: skip
    assert result.exit_code == 2, result.output
    one_error_line(result)
    assert f"error: {names[0]}: " in result.output and "symbolic links" in result.output
    assert not out.exists()


@pytest.mark.parametrize("command", ["fis", "design"])
def test_a_file_under_a_killed_commands_folder_is_not_noted_in_its_journal(tmp_path, command):
    # A command killed while it held `held/` leaves its lock and journal; `fis --out` or
    # `design --out` into it later must not add to that journal (the rerun would then take
    # the user's file for its own, and might replace it)
    import subprocess
    import sys

    held = tmp_path / "held"
    hold = (
        "import time\n"
        "from twolink.foundation.io import owned_output, atomic_write_text\n"
        f"with owned_output({str(held)!r}, 'sweep'):\n"
        f"    atomic_write_text({str(held / 'part.csv')!r}, 'x\\n')\n"
        "    print('held', flush=True)\n"
        "    time.sleep(60)\n"
    )
    killed = subprocess.Popen([sys.executable, "-c", hold], stdout=subprocess.PIPE, text=True)
    assert killed.stdout.readline().strip() == "held"
    killed.kill()
    killed.wait()
    journal = (held / ".twolink-journal").read_bytes()
    out = held / ("rb.fis" if command == "fis" else "rb.toml")
    args = ["fis", "--out", out] if command == "fis" else ["design", "--out", out]
    result = invoke(*args)
    assert result.exit_code == 0, result.output
    assert out.is_file()
    assert (held / ".twolink-journal").read_bytes() == journal


def test_the_smallest_stribeck_velocity_is_the_curves_limit_without_a_warning():
    # v_s = 5e-324 (the smallest float): (v / v_s)^2 overflows; the curve is then its
    # limit, a step at v = 0 from F_s down to F_c, in the single plant and in the batch
    import warnings

    import numpy as np

    from twolink.arm.params import Friction

    f = Friction(coulomb=(0.5, 0.2), breakaway=(0.6, 0.25), stribeck_velocity=5e-324)
    v = np.array([[-1.0, 2.0], [1e-3, -1e-300], [0.0, 0.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        relief = f.stribeck_relief(v)
        torque = f.torque(v)
    excess = np.subtract(f.breakaway, f.coulomb)
    assert np.array_equal(relief, excess * np.sign(v))  # the whole dip, at any rate
    assert np.array_equal(torque[:2], np.array([0.5, 0.2]) * np.sign(v[:2]))  # F_c sliding
    assert np.array_equal(torque[2], [0.0, 0.0])
    from twolink.simulation.config import load_scenario
    from twolink.simulation.experiment import build_controller, iter_scenarios

    friction = {"coulomb": [0.5, 0.2], "breakaway": [0.6, 0.25], "stribeck_velocity": 5e-324}
    s = load_scenario("paper/theta1_step", {"duration": 0.05, "plant": {"friction": friction}})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        runs = list(iter_scenarios([s, s], [build_controller(s), build_controller(s)]))
    assert len(runs) == 2 and all(not isinstance(t, Exception) and t.ok for _, t in runs)


@pytest.mark.parametrize(("frequency", "refused"), [(1e6, True), (500.0, True), (499.0, False)])
def test_a_sine_disturbance_at_or_above_the_steps_nyquist_is_refused_naming_the_key(
    frequency, refused
):
    # The sine is applied at each physics step (1 kHz): at 1 MHz it is zero at every step,
    # at 500 Hz too (sin(pi k)); below, it is sampled (aliased by nothing the loop adds)
    from twolink.simulation.config import load_scenario

    sine = {"sine": [{"joint": 1, "amplitude": 1.0, "frequency": frequency}]}
    if not refused:
        s = load_scenario("paper/theta1_step", {"disturbance": sine})
        assert s.disturbance.sines[0].frequency == frequency
        return
    with pytest.raises(ConfigError) as caught:
        load_scenario("paper/theta1_step", {"disturbance": sine})
    said = str(caught.value)
    assert "disturbance.sine[0].frequency: " in said and "at or above 500 Hz" in said, said
    assert "timestep 0.001 s" in said and "\n" not in said
    if frequency < 5e5:  # a finer physics step carries it (below its 500 kHz)
        finer = {"disturbance": sine, "timestep": 1e-6, "control_dt": 1e-3, "duration": 0.01}
        assert load_scenario("paper/theta1_step", finer).timestep == 1e-6


# ------------------------------------------------------------- a planted journal, bounded


def planted_journal(folder: Path, size: int) -> None:
    """A journal of ``size`` bytes of well-formed lines naming files that are not there."""
    folder.mkdir()
    (folder / ".twolink.lock").write_bytes(b"")
    line = "0" * 64 + " 10 1 1 some/file_{}.csv\n"
    count = size // len(line.format(0))
    text = "command run\n" + "".join(line.format(k) for k in range(count))
    (folder / ".twolink-journal").write_text(text)


def test_a_planted_journal_over_the_records_bound_is_refused_by_its_size(tmp_path):
    # 60 MB of journal lines: read and parsed six times over, a 0.3 s run took 60 s; a
    # journal lists what an owner record does, so it has the record's bound (16 MiB)
    import time

    from twolink.foundation.io import ForeignOutput, check_ownership
    from twolink.foundation.planted import MAX_RECORD_BYTES

    out = tmp_path / "out"
    planted_journal(out, 60_000_000)
    start = time.perf_counter()
    with pytest.raises(
        ForeignOutput, match=r"\(\.twolink-journal \(larger than 16777216 bytes\)\)"
    ):
        check_ownership(out, "run")
    assert time.perf_counter() - start < 1.0  # by its size: not a byte of it is read
    assert MAX_RECORD_BYTES == 16 << 20


def test_a_journal_is_parsed_once_as_a_command_checks_and_takes_its_folder(tmp_path, monkeypatch):
    from twolink.foundation import journal

    out = tmp_path / "out"
    planted_journal(out, 4_000_000)  # under the bound: a killed command's, listing nothing here
    reads = []
    real = journal.read_bounded

    def counted(where, *args, **kwargs):
        data = real(where, *args, **kwargs)
        reads.append(len(data))
        return data

    monkeypatch.setattr(journal, "read_bounded", counted)
    result = invoke("run", REPO / "runs" / "paper" / "theta1_step.toml", "--no-trace",
                    "--no-plots", "--set", "duration=0.05", "--out", out)  # fmt: skip
    assert result.exit_code == 0, result.output
    assert sum(n > 1_000_000 for n in reads) == 1, reads  # the planted one, once


# --------------------------------------------------------- the suite leaves home alone


def test_the_suites_rerun_cli_writes_nothing_into_the_users_home(tmp_path):
    # the recording tests run `python -m rerun rrd verify`, which writes its analytics
    # opt-in ({"analytics_enabled": true}) into the config folder: the suite's scratch XDG
    # folders (tests/conftest.py), never HOME
    import subprocess
    import sys

    home = tmp_path / "home"
    home.mkdir()
    env = {**os.environ, "HOME": str(home)}
    record = tmp_path / "x.rrd"
    make = (
        "import rerun as rr\n"
        "rr.init('twolink_test', spawn=False)\n"
        f"rr.save({str(record)!r})\n"
        "rr.log('a', rr.Scalars([1.0]))\n"
        "rr.disconnect()\n"
    )
    subprocess.run([sys.executable, "-c", make], env=env, check=True, timeout=120)
    done = subprocess.run([sys.executable, "-m", "rerun", "rrd", "verify", str(record)], env=env,
                          capture_output=True, text=True, timeout=120)  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert list(home.rglob("*")) == []
    scratch = Path(os.environ["XDG_CONFIG_HOME"])
    assert not scratch.is_relative_to(Path.home()) and scratch.name == "config"


# ------------------------------------------------------- the library says what went wrong


@pytest.mark.parametrize("joint", [0, 3, -1, True, 1.0, "1"])
def test_a_response_figure_of_a_joint_other_than_1_or_2_is_refused(joint):
    # joint=0 read column -1: joint 2's response, labelled θ0
    import twolink
    from twolink.simulation.config import load_scenario
    from twolink.simulation.experiment import run_scenario

    s = load_scenario("paper/theta1_step", {"duration": 0.05})
    trajs = {"CTC": run_scenario(s)}
    with pytest.raises(ValueError, match=r"joint must be 1 or 2 .* got " + repr(joint)):
        twolink.response_figure(trajs, joint, "title", ("CTC", "CTC"))
    figure = twolink.response_figure(trajs, 1, "title", ("CTC", "CTC"))  # still draws
    assert "θ1" in " ".join(ax.get_ylabel() for ax in figure.axes)


def test_simulate_with_arm_params_for_a_plant_names_the_type_it_wants():
    import twolink
    from twolink.arm.plant import Plant

    p = twolink.ArmParams()
    with pytest.raises(
        TypeError, match=r"plant must be a twolink\.arm\.plant\.Plant .* got ArmParams"
    ):
        twolink.simulate(p, None, 0.01)
    with pytest.raises(TypeError, match=r"controller must be a controller .* got ArmParams"):
        twolink.simulate(Plant.build(p), p, 0.01)


@pytest.mark.parametrize("name", ["desigend", "Paper"])
def test_a_misspelt_rule_base_name_lists_the_known_names(name):
    import twolink

    with pytest.raises(FileNotFoundError) as caught:
        twolink.load_rule_base(name)
    said = str(caught.value)
    assert said.startswith(f"no such file {name}: ") and "'paper', 'designed', 'default'" in said
    from twolink.simulation.config import load_scenario

    with pytest.raises(ConfigError, match="controller.rule_base: no such file .*'designed'"):
        load_scenario("paper/theta1_step", {"controller": {"kind": "fcm_ctc", "rule_base": name}})


# ------------------------------------------- rules that only one test (or none) pinned


def test_a_journals_temporary_is_removed_only_if_it_is_the_very_file_twolink_made(tmp_path):
    # The journal of a killed command lists its temporary by name and inode. A user's file
    # under that name since (another inode) is theirs: foreign, never removed.
    from twolink.foundation.io import ForeignOutput, check_ownership

    out = tmp_path / "out"
    out.mkdir()
    (out / ".twolink.lock").write_bytes(b"")
    made = out / ".table.csv.abcd1234.tmp"
    made.write_text("half of what twolink wrote")
    noted = made.stat().st_ino
    (out / ".twolink-journal").write_text(f"command run\ntmp file {noted} {made.name}\n")
    assert check_ownership(out, "run") == [made]  # the very file: the next command removes it
    made.unlink()
    other = tmp_path / "keep"
    other.write_text("")  # holds the inode number a moment, so the user's file gets another
    made.write_text("the user's notes")
    assert made.stat().st_ino != noted
    with pytest.raises(ForeignOutput, match=r"\.table\.csv\.abcd1234\.tmp"):
        check_ownership(out, "run")
    assert made.read_text() == "the user's notes"


def test_an_owner_records_temporary_with_a_second_name_is_not_twolinks(tmp_path):
    # A killed command's record temporary ("..twolink-owner.json.PID.tmp", empty or a
    # record's beginning) is removed by the next command; one with a second name (a hard
    # link: a user's file, or a snapshot) is not the file twolink made
    from twolink.foundation.io import ForeignOutput, check_ownership

    out = tmp_path / "out"
    out.mkdir()
    tmp = out / "..twolink-owner.json.4242.tmp"  # "." + the record's name + ".PID.tmp"
    tmp.write_bytes(b'{\n "kind": "twolink owner')
    assert check_ownership(out, "run") == [tmp]
    os.link(tmp, tmp_path / "users_copy")
    with pytest.raises(ForeignOutput, match=r"\.\.twolink-owner\.json\.4242\.tmp"):
        check_ownership(out, "run")


def test_a_slower_swing_under_twice_the_faster_one_is_not_the_reading():
    # 1 mrad at 10 Hz riding 0.7 mrad at 4 Hz: the slow swing read between its extremes
    # (1.55 mrad, the fast one's ride in it) is under twice the fast one's reading (0.81
    # mrad), so the reading is the fast swing's (SLOWER_SHARE, docs/metrics.md)
    import math

    import numpy as np

    from twolink.simulation import swings

    t = np.arange(0.0, 10.0 + 5e-4, 1e-3)
    x = 1e-3 * np.sin(2 * np.pi * 10 * t) + 0.7e-3 * np.sin(2 * np.pi * 4 * t)
    idx = swings._turns(t, x, swings.SWING_FLOOR, -math.inf)
    fast = swings._end_reading(t, x, 1.0, -math.inf, swings._swings(t, x, idx))[0]
    (slow,) = swings._slower_swings(x[idx], float(x[-1]))
    carried = swings._end_reading(t, x, 1.0, -math.inf, swings._swings(t, x, idx[slow]))[0]
    assert fast < carried < 2.0 * fast  # the case the share decides
    assert swings.SLOWER_SHARE == 2.0
    assert swings.persisting_swing(t, x, 1.0) == fast == pytest.approx(0.813e-3, abs=0.01e-3)
    x = 1e-3 * np.sin(2 * np.pi * 10 * t) + 1.2e-3 * np.sin(2 * np.pi * 4 * t)
    assert swings.persisting_swing(t, x, 1.0) > 1.9e-3  # beyond twice: the slow swing is it


def test_several_dropped_ctrl_cs_in_a_row_are_resent_once(monkeypatch):
    # A KeyboardInterrupt dropped in a weakref callback is sent again, once for a row of
    # drops: a resend each (4 of 15 trials) landed one in the handling of the first
    from types import SimpleNamespace

    from twolink.foundation import interrupts

    started = []

    class Timer:
        def __init__(self, delay, fn):
            self.fn, self.daemon = fn, False

        def start(self):
            started.append(self.fn)

    monkeypatch.setattr(interrupts.threading, "Timer", Timer)
    sent = []
    monkeypatch.setattr(interrupts._thread, "interrupt_main", lambda signum: sent.append(signum))
    interrupts.command_starting()
    dropped = SimpleNamespace(exc_value=KeyboardInterrupt())
    try:
        for _ in range(3):
            interrupts.resend_dropped_ctrl_c(dropped)
        assert len(started) == 1
        started[0]()  # the timer fires: one Ctrl-C sent again
        assert sent == [signal.SIGINT]
        interrupts.resend_dropped_ctrl_c(dropped)  # a later drop: sent again, once
        assert len(started) == 2
    finally:
        interrupts._RESEND_PENDING.clear()


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["INT", "TERM"])
def test_ctrl_c_and_sigterm_wait_while_mujoco_imports(monkeypatch, signum):
    # MuJoCo's extension runs Python from C as it initialises: a signal handled there
    # breaks the import; both stops are held to its end, then handled
    import builtins
    import sys

    from twolink.foundation import interrupts

    got = []
    previous = signal.signal(signum, lambda s, frame: got.append(s))
    real_import = builtins.__import__

    def importing(name, *args, **kwargs):
        if name == "mujoco":
            signal.raise_signal(signum)  # lands in the import
            got.append("imported")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", importing)
    try:
        module = interrupts.import_mujoco()
    finally:
        signal.signal(signum, previous)
    assert module is sys.modules["mujoco"]
    assert got == ["imported", signum]  # handled after the import, not inside it
