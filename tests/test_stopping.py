"""Stopping is clean: after SIGTERM or SIGKILL of `twolink sweep` or `twolink reproduce`
no worker is left, nothing is written into --out afterwards, and a rerun completes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def children(pid: int) -> set[int]:
    """Live (not zombie) processes whose parent is ``pid``, from /proc."""
    out = set()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        state, ppid = fields[0], int(fields[1])
        if ppid == pid and state != "Z":
            out.add(int(stat.parent.name))
    return out


def descendants(pid: int) -> set[int]:
    """Live children of ``pid``, their children, and so on: forked pool workers are the
    fork server's children, not the command's."""
    found, todo = set(), [pid]
    while todo:
        new = children(todo.pop())
        todo += new - found
        found |= new
    return found


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def snapshot(folder: Path) -> dict[str, int]:
    return {str(p): p.stat().st_mtime_ns for p in folder.rglob("*") if p.is_file()}


COMMANDS = {
    "sweep": lambda out: [
        "sweep", str(REPO / "runs/sweeps/robustness.toml"), "-n", "40", "--out", str(out),
        "--workers", "2", "--no-plots", "--no-progress",
    ],
    "reproduce": lambda out: ["reproduce", "--out", str(out), "--workers", "2", "--no-trace"],
}  # fmt: skip


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("signum", [signal.SIGKILL, signal.SIGTERM], ids=["KILL", "TERM"])
@pytest.mark.parametrize("command", sorted(COMMANDS))
@pytest.mark.slow
def test_a_killed_command_leaves_no_worker_and_writes_nothing_after(tmp_path, command, signum):
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "twolink", *COMMANDS[command](out)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 120
    workers: set[int] = set()
    # The pool is up and working: a resource tracker and two workers, or a fork server, its
    # resource tracker and at least one worker.
    while len(workers) < 3:
        assert proc.poll() is None, "finished before the pool was seen"
        assert time.monotonic() < deadline, "no pool workers appeared"
        workers = descendants(proc.pid)
        time.sleep(0.05)
    time.sleep(1.0)
    workers |= descendants(proc.pid)
    os.kill(proc.pid, signum)
    proc.wait(timeout=60)
    before = snapshot(out)
    time.sleep(5.0)
    assert not [w for w in workers if alive(w)], "pool workers outlived the command"
    assert snapshot(out) == before, "files were written into --out after the command ended"
    rerun = subprocess.run(
        [sys.executable, "-m", "twolink", *COMMANDS[command](out)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert rerun.returncode == 0, rerun.stderr


# A sweep run as a pool worker's task (the reproduction's flexible-joint studies) -----------


def _signalled_sweep(sweep_file: str, out: str) -> str:
    """A pool worker's task: a one-chunk sweep whose chunk sends this worker a Ctrl-C (as a
    terminal's reaches the whole process group), then the abort's SIGTERM."""
    import time as _time

    from twolink import sweep
    from twolink.sweep import execution

    real = execution.run_chunks

    def signalled(*args):
        os.kill(os.getpid(), signal.SIGINT)
        _time.sleep(0.2)  # a handler would run here
        os.kill(os.getpid(), signal.SIGTERM)
        _time.sleep(0.2)
        return real(*args)

    execution.run_chunks = signalled
    plan = sweep.load_sweep(sweep_file, {"samples": 1})
    sweep.run_sweep(plan, out, executor="inprocess", workers=1, plots=False)
    return "finished"


def test_a_sweep_in_a_pool_worker_ignores_ctrl_c_and_ends_with_its_worker_on_sigterm(tmp_path):
    # The sweep used to take both signals over in the worker: a Ctrl-C stopped the
    # worker's sweep, and the abort's SIGTERM unwound it (SweepInterrupted), writing its
    # folder's record after the command had stopped and keeping the worker alive until
    # the abort's SIGKILL, 2 s later (one was seen landing in numba's compiler, whose
    # callbacks print such a one as "Exception ignored").
    from concurrent.futures.process import BrokenProcessPool

    from cli_inputs import SWEEP

    from twolink.foundation.executors import ProcessExecutor

    sweep_file = tmp_path / "tiny.toml"
    sweep_file.write_text(SWEEP)
    pool = ProcessExecutor(workers=1, preload=[])
    try:
        future = pool.submit(_signalled_sweep, str(sweep_file), str(tmp_path / "out"))
        error = future.exception(timeout=120)
        (worker,) = pool._worker_processes()
        worker.join(timeout=10)
    finally:
        pool.abort()
    assert isinstance(error, BrokenProcessPool), repr(error)  # not SweepInterrupted
    assert worker.exitcode == 128 + signal.SIGTERM  # by the worker's own handler, at once
    assert not [p for p in tmp_path.rglob("*") if p.name.endswith((".tmp", ".old"))]


_ENDED_IN_THE_RECORD = """
import os, signal, sys
from pathlib import Path
from twolink.foundation.executors import _stop_worker
from twolink.foundation.io import atomic_write_text, owned_output

real_fsync = os.fsync

def fsync(fd):
    real_fsync(fd)
    if ".twolink-owner.json." in os.readlink(f"/proc/self/fd/{fd}"):
        _stop_worker(signal.SIGTERM, None)  # the abort's SIGTERM lands here

os.fsync = fsync
out = Path(sys.argv[1])
with owned_output(out, "run"):
    atomic_write_text(out / "metrics.json", "{}")
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_a_worker_stopped_while_it_writes_an_owner_record_leaves_no_temporary(tmp_path):
    # Seen 3 times in 20 SIGTERMs 4-4.5 s into `reproduce`: a flexible study's worker ended
    # between the record's temporary and its rename, and the rerun refused the folder for
    # its '..twolink-owner.json.PID.tmp' (test_a_killed_command_..._after[reproduce-TERM]).
    from twolink.foundation.io import check_ownership

    out = tmp_path / "out"
    proc = subprocess.run(
        [sys.executable, "-c", _ENDED_IN_THE_RECORD, str(out)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 128 + signal.SIGTERM, proc.stderr
    assert [p.name for p in out.iterdir() if p.name.endswith(".tmp")] == []
    check_ownership(out, "run")  # the next command into the folder is not refused


def test_a_signal_while_the_driver_waits_is_acted_on_at_its_next_turn():
    from twolink.sweep.execution import _StopSignals

    stops = _StopSignals()
    with stops.installed():
        with stops.waiting():
            signal.raise_signal(signal.SIGTERM)  # recorded, not raised inside the wait
            reached = True
        assert reached and stops.received == [signal.SIGTERM]
        with pytest.raises(KeyboardInterrupt):
            stops.check()
        with pytest.raises(KeyboardInterrupt):  # outside a wait: at once, as before
            signal.raise_signal(signal.SIGINT)
            for _ in range(1000):
                pass
    assert stops.received == [signal.SIGTERM, signal.SIGINT]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("delay", [3.0, 4.5, 6.0])
@pytest.mark.slow
def test_sigterm_ends_reproduce_and_its_workers_at_once_with_one_clean_line(tmp_path, delay):
    # Wherever it lands (imports, the design, the runs, the flexible studies' sweeps in the
    # workers, numba compiling there and in the fork server: a fresh cache). Before, the
    # fork server, still compiling its preloaded kernels, outlived the command by 3-12 s
    # (every time), and a flexible study's worker could leave an owner record's temporary.
    from twolink.foundation.io import check_ownership
    from twolink.studies.reproduction.manifest import DEFAULT_MANIFEST

    out = tmp_path / "out"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"))
    with open(tmp_path / "stderr", "w+") as err:
        proc = subprocess.Popen(
            [sys.executable, "-m", "twolink", *COMMANDS["reproduce"](out)],
            stdout=subprocess.DEVNULL,
            stderr=err,
            env=env,
        )
        end = time.monotonic() + delay
        workers: set[int] = set()
        while time.monotonic() < end:
            workers |= descendants(proc.pid)
            time.sleep(0.05)
        workers |= descendants(proc.pid)
        os.kill(proc.pid, signal.SIGTERM)
        sent = time.monotonic()
        proc.wait(timeout=60)
        while [w for w in workers if alive(w)] and time.monotonic() < sent + 30:
            time.sleep(0.05)
        gone = time.monotonic() - sent
        err.seek(0)
        text = err.read()
    assert proc.returncode == 143, text
    assert text.splitlines()[-1].startswith("terminated (SIGTERM): files written so far")
    assert "Traceback" not in text and "Exception ignored" not in text, text
    assert gone < 5.0, f"the command's processes were gone {gone:.1f} s after SIGTERM"
    assert not [p for p in out.rglob("*") if p.name.endswith((".tmp", ".old"))]
    if out.exists():  # the rerun would not be refused
        check_ownership(out, "reproduce", str(DEFAULT_MANIFEST.resolve()))


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.slow
def test_sigterm_to_the_whole_process_group_ends_a_sweep_with_exit_143_and_one_line(tmp_path):
    # As `timeout` or a service manager stop a command: its workers get the SIGTERM too and
    # end at once, breaking the pool while the command acts on its own. The stop must win:
    # exit 143 and its line, not BrokenProcessPool's traceback and exit 1.
    # A long poll: the broken pool, not the poll's end, wakes the driver's wait.
    code = (
        "import sys; import twolink.sweep.execution as ex; ex.STOP_POLL_S = 60.0; "
        "from twolink.interface.cli import main; main(sys.argv[1:], prog_name='twolink')"
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", code, *COMMANDS["sweep"](tmp_path / "out")],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, as a service's
    )
    deadline = time.monotonic() + 120
    while len(descendants(proc.pid)) < 3:  # the pool is up and working (as above)
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "no pool workers appeared"
        time.sleep(0.05)
    time.sleep(1.0)
    os.killpg(proc.pid, signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert "interrupted by SIGTERM" in err and "Traceback" not in err, err


_SLOW_SERVER = """
import os, sys
from multiprocessing import forkserver
from twolink.foundation.executors import start_fork_server

start_fork_server(["slow_import"])  # the server imports for 60 s, as numba compiling
print(forkserver._forkserver._forkserver_pid, flush=True)
os._exit(0)  # the command ends (any way) while its server still imports
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_a_fork_server_still_importing_ends_with_its_command(tmp_path):
    # The server notices its command's end only once its imports are done: with a fresh
    # numba cache it outlived a SIGTERM'd `reproduce` by 2-12 s (the workers' check above).
    (tmp_path / "slow_import.py").write_text("import time\ntime.sleep(60)\n")
    with open(tmp_path / "pid", "w+") as pid:  # not a pipe: the server would hold it
        subprocess.run([sys.executable, "-c", _SLOW_SERVER], cwd=tmp_path, stdout=pid, timeout=60)
        pid.seek(0)
        server = int(pid.read())
    deadline = time.monotonic() + 5.0
    while alive(server) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not alive(server), "the fork server outlived its command"
