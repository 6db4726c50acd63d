"""Ctrl-C wherever it lands (twolink.foundation.interrupts, and the command line's handling)."""

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from twolink.foundation.interrupts import interrupts_held


def python(*args: str, cwd=None) -> subprocess.CompletedProcess:
    """Run the venv's Python, with Ctrl-C's default action (a shell's background jobs,
    such as this test run under CI, start with it ignored, and Python keeps that)."""
    return subprocess.run(
        [sys.executable, *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=60,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )


def python_module(tmp_path, name: str, code: str) -> subprocess.CompletedProcess:
    """Run ``code`` as ``python -m name``."""
    (tmp_path / f"{name}.py").write_text(code)
    return python("-m", name, cwd=tmp_path)


@pytest.fixture
def python_ctrl_c():
    """Python's own Ctrl-C handler, whatever this run started with (a shell starts its
    background jobs, such as a CI run, with SIGINT ignored, and Python keeps that)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def test_a_ctrl_c_inside_the_block_arrives_when_it_ends(python_ctrl_c):
    reached_the_end = False
    with pytest.raises(KeyboardInterrupt):
        with interrupts_held():
            # to the main thread itself: a process-wide signal may land in another thread
            # (earlier tests leave some), whose handler can run only after the block
            signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)
            for _ in range(1000):  # the handler would run here
                pass
            reached_the_end = True
    assert reached_the_end


def test_handlers_are_restored_and_ignored_signals_stay_ignored():
    before = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    with interrupts_held():
        pass
    assert (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == before
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with interrupts_held():
            assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
            os.kill(os.getpid(), signal.SIGINT)
    finally:
        signal.signal(signal.SIGINT, previous)


# A Ctrl-C arrives just as Python looks up mujoco's first compiled module, the moment
# its init (which runs Python code from C) starts. Held, it is raised once the import is
# complete; unheld, it breaks the import.
IMPORT_WITH_CTRL_C = """
import os, signal, sys
from twolink.foundation.interrupts import import_mujoco

class CtrlCOnFind:
    def find_spec(self, name, path=None, target=None):
        if name == "mujoco._callbacks":
            os.kill(os.getpid(), signal.SIGINT)
            for _ in range(1000):  # unheld, the KeyboardInterrupt is raised here
                pass
        return None

sys.meta_path.insert(0, CtrlCOnFind())
try:
    {importer}
except KeyboardInterrupt:
    whole = hasattr(sys.modules.get("mujoco"), "MjModel")
    print("interrupted", "after the import" if whole else "inside the import")
"""


@pytest.mark.parametrize(
    ("importer", "says"),
    [
        ("import_mujoco()", "interrupted after the import"),
        ("import mujoco", "interrupted inside the import"),
    ],
)
def test_a_ctrl_c_during_mujocos_import_waits_for_it(importer, says):
    proc = python("-c", IMPORT_WITH_CTRL_C.format(importer=importer))
    assert proc.stdout.strip() == says, proc.stderr


@pytest.mark.skipif(not hasattr(signal, "pthread_sigmask"), reason="POSIX signal masks")
def test_a_process_that_mujocos_import_starts_is_deaf_to_ctrl_c(tmp_path, monkeypatch):
    """glfw, imported by mujoco, starts a Python to probe its library; a terminal's Ctrl-C
    reached it while it started up, and it printed a traceback (1 in 18 tries at load 2).
    Here a module imported the way mujoco is starts one: it must start with SIGINT blocked."""
    from twolink.foundation.interrupts import import_held

    probe = "import signal; print(signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, []))"
    (tmp_path / "starts_a_python.py").write_text(
        "import subprocess, sys\n"
        f"SAID = subprocess.run([sys.executable, '-c', {probe!r}], capture_output=True,"
        " text=True).stdout.strip()\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    assert import_held("starts_a_python").SAID == "True"
    assert signal.SIGINT not in signal.pthread_sigmask(signal.SIG_BLOCK, [])  # unblocked after


# A Ctrl-C just after the fork server has started a worker and handed back its pid:
# unheld, the pool never records the worker, so the abort does not end it; it either
# goes on running or, once the pool's queues are gone, fails with a traceback.
WORKER_START_WITH_CTRL_C = """
import os, signal, sys, time
from multiprocessing import forkserver
from twolink.foundation.executors import ProcessExecutor

started = []
real_read_signed = forkserver.read_signed

def read_pid_then_ctrl_c(fd):
    value = real_read_signed(fd)
    if not started:
        started.append(value)
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(1000):  # unheld, the KeyboardInterrupt is raised here
            pass
    return value

forkserver.read_signed = read_pid_then_ctrl_c
pool = ProcessExecutor(2)
try:
    pool.submit(abs, -1)
except KeyboardInterrupt:
    pass
pool.abort()
deadline = time.monotonic() + 10
while time.monotonic() < deadline:
    try:
        os.kill(started[0], 0)
    except ProcessLookupError:
        print("worker ended")
        break
    time.sleep(0.05)
else:
    print("worker left running")
"""


@pytest.mark.parametrize("held", [True, False])
def test_a_worker_started_as_ctrl_c_comes_is_ended_with_the_pool(held):
    code = WORKER_START_WITH_CTRL_C
    if not held:
        code = code.replace(
            "from twolink.foundation.executors import ProcessExecutor",
            "import contextlib, twolink.foundation.executors as ex\n"
            "ex.interrupts_held = contextlib.nullcontext\n"
            "from twolink.foundation.executors import ProcessExecutor",
        )
    proc = python("-c", code)
    clean = proc.stdout.strip() == "worker ended" and "Traceback" not in proc.stderr
    assert clean == held, proc.stdout + proc.stderr


# The command line: one line and exit 130, whatever the Ctrl-C lands in.


def test_ctrl_c_that_a_compiled_extension_turns_into_another_error_still_exits_130():
    # pybind11 reports a KeyboardInterrupt raised while it converts arguments as a
    # TypeError (seen in matplotlib's transforms during the reproduction's figures).
    code = """
import os, signal, sys
from twolink.interface.cli import main

@main.command()
def mangled():
    try:
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(10**7):
            pass
    except KeyboardInterrupt:
        raise TypeError("incompatible function arguments") from None

main(["mangled"])
"""
    proc = python("-c", code)
    assert proc.returncode == 130, proc.stderr
    assert "interrupted" in proc.stderr and "Traceback" not in proc.stderr
    # Without a Ctrl-C the same error is a bug, and shows as one.
    plain = python(
        "-c", code.replace("os.kill(os.getpid(), signal.SIGINT)", "raise KeyboardInterrupt")
    )
    assert plain.returncode == 1 and "TypeError" in plain.stderr


def test_ctrl_c_inside_code_run_from_a_string_still_exits_130_under_python_m(tmp_path):
    # CPython marks a KeyboardInterrupt that leaves an exec() of a string as unhandled for
    # the whole process, and `python -m` then dies by SIGINT (-2) after the command exited
    # 130. Dataclasses, scipy and MuJoCo's module init all run such strings.
    code = """
from twolink.interface.cli import main

@main.command()
def stuck():
    exec("import os, signal\\nos.kill(os.getpid(), signal.SIGINT)\\nfor _ in range(10**7): pass")

main(["stuck"])
"""
    proc = python_module(tmp_path, "stopped_in_exec", code)
    assert proc.returncode == 130, proc.stderr
    assert "interrupted" in proc.stderr and "Traceback" not in proc.stderr


def test_ctrl_c_that_python_drops_is_sent_again(tmp_path):
    # A KeyboardInterrupt raised in a weakref callback (or __del__) is printed as "Exception
    # ignored" and dropped: the command would go on as if no Ctrl-C had come.
    code = """
import os, signal, weakref
from twolink.interface.cli import main

class Thing:
    pass

def callback(ref):
    os.kill(os.getpid(), signal.SIGINT)
    for _ in range(10):  # the handler runs here, inside the callback
        pass

@main.command()
def dropped():
    thing = Thing()
    ref = weakref.ref(thing, callback)
    del thing
    for _ in range(10**7):
        pass
    print("finished")

main(["dropped"])
"""
    proc = python_module(tmp_path, "stopped_in_callback", code)
    assert proc.returncode == 130, proc.stderr
    assert "finished" not in proc.stdout
    assert "interrupted" in proc.stderr and "Traceback" not in proc.stderr, proc.stderr


def test_ctrl_c_that_a_library_swallows_stops_the_reproduction_at_its_next_phase(tmp_path):
    # numpy.random's module init (imported by pandas) was seen catching a KeyboardInterrupt.
    code = """
import os, signal
from twolink.interface.cli import main
from twolink.studies.reproduction.reproduce import _Phases

@main.command()
def swallowed():
    phase = _Phases(False, 2)
    phase("one")
    try:
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(10**7):
            pass
    except KeyboardInterrupt:
        pass  # what the library does
    phase("two")
    print("finished")

main(["swallowed"])
"""
    proc = python_module(tmp_path, "swallowed_by_a_library", code)
    assert proc.returncode == 130 and "finished" not in proc.stdout, proc.stderr
    assert "interrupted" in proc.stderr and "Traceback" not in proc.stderr


def _deaf_task(seconds: float) -> None:
    """A worker that cannot act on SIGTERM, as one waiting on the result queue's lock that
    a terminated worker held."""
    import signal as _signal
    import time as _time

    _signal.signal(_signal.SIGTERM, _signal.SIG_IGN)
    _time.sleep(seconds)


def test_an_abort_ends_a_worker_that_cannot_act_on_sigterm():
    """Without the SIGKILL after the grace, the pool's shutdown waits for the deaf worker
    (here 60 s; a worker blocked on a lock: forever)."""
    import threading
    import time

    from twolink.foundation.executors import ABORT_GRACE_S, ProcessExecutor

    pool = ProcessExecutor(workers=1, preload=[])
    future = pool.submit(_deaf_task, 60.0)
    time.sleep(1.0)  # the task is running
    assert future.running()
    start = time.monotonic()
    aborted = threading.Thread(target=pool.abort, daemon=True)
    aborted.start()
    aborted.join(timeout=ABORT_GRACE_S + 20.0)
    assert not aborted.is_alive(), "abort still waiting on a worker deaf to SIGTERM"
    assert time.monotonic() - start >= ABORT_GRACE_S * 0.9  # SIGTERM first, SIGKILL after


def test_a_dropped_ctrl_c_resent_after_the_command_stopped_is_ignored(tmp_path):
    # A Ctrl-C dropped in a __del__ is resent 50 ms later; the command may have stopped on
    # it by then (a second signal, a phase's or a sweep's check). Resent after the command
    # restored Python's handler, it raised a KeyboardInterrupt into the code after it (at
    # exit: "Exception ignored ... KeyboardInterrupt" or a traceback).
    code = """
import os, signal, time, weakref
from twolink.interface.cli import main

class Thing:
    pass

def callback(ref):
    os.kill(os.getpid(), signal.SIGINT)
    for _ in range(10):  # the handler runs here, inside the callback: dropped
        pass

@main.command()
def twice():
    thing = Thing()
    ref = weakref.ref(thing, callback)
    del thing
    os.kill(os.getpid(), signal.SIGINT)  # the command stops on this one, at once
    for _ in range(10**7):
        pass

try:
    main(["twice"])
except SystemExit as exc:
    print("exit", exc.code)
time.sleep(0.5)  # the resend (50 ms) would land here
print("after")
"""
    proc = python_module(tmp_path, "resent_late", code)
    assert proc.stdout.split() == ["exit", "130", "after"], proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr and "Exception ignored" not in proc.stderr


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="a terminal's Ctrl-C, Linux")
@pytest.mark.parametrize("delay", [0.3, 0.5, 0.7, 0.9, 1.1, 1.3, 1.6, 2.0])
def test_ctrl_c_while_the_command_and_its_pool_start_is_one_line_and_exit_130(tmp_path, delay):
    # A terminal's Ctrl-C reaches the whole process group: the command still importing,
    # the fork server starting Python or importing its preload list, a worker just forked.
    # Each printed a KeyboardInterrupt traceback (14-47 lines) in about half the tries.
    from twolink.foundation.io import check_ownership

    out = tmp_path / "out"
    sweep = Path(__file__).resolve().parents[1] / "runs/sweeps/robustness.toml"
    proc = subprocess.Popen(
        [sys.executable, "-m", "twolink", "sweep", str(sweep), "-n", "8"]
        + ["--workers", "2", "--no-plots", "--no-progress", "--out", str(out)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own group, as a terminal's foreground job
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    time.sleep(delay)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)  # to the end of stderr: the server's too
    assert proc.returncode == 130, err  # the sweep takes seconds more: none is lost
    assert "Traceback" not in err and len(err.strip().splitlines()) <= 2, err
    assert err.strip().splitlines()[-1].startswith("interrupted")  # the sweep says by what
    if out.exists():  # nothing lost: the rerun would take the folder up again
        check_ownership(out, "sweep", str(sweep))
