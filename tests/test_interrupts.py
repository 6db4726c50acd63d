"""Ctrl-C held back around MuJoCo's import and a worker's start (twolink.interrupts)."""

import os
import signal
import subprocess
import sys

import pytest

from twolink.interrupts import interrupts_held


def test_a_ctrl_c_inside_the_block_arrives_when_it_ends():
    reached_the_end = False
    with pytest.raises(KeyboardInterrupt):
        with interrupts_held():
            os.kill(os.getpid(), signal.SIGINT)
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
from twolink.interrupts import import_mujoco

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
    proc = subprocess.run(
        [sys.executable, "-c", IMPORT_WITH_CTRL_C.format(importer=importer)],
        capture_output=True,
        text=True,
        timeout=60,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    assert proc.stdout.strip() == says, proc.stderr


# A Ctrl-C just after the fork server has started a worker and handed back its pid:
# unheld, the pool never records the worker, so the abort does not end it; it either
# goes on running or, once the pool's queues are gone, fails with a traceback.
WORKER_START_WITH_CTRL_C = """
import os, signal, sys, time
from multiprocessing import forkserver
from twolink.executors import ProcessExecutor

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
            "from twolink.executors import ProcessExecutor",
            "import contextlib, twolink.executors as ex\n"
            "ex.interrupts_held = contextlib.nullcontext\n"
            "from twolink.executors import ProcessExecutor",
        )
    proc = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=60,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    clean = proc.stdout.strip() == "worker ended" and "Traceback" not in proc.stderr
    assert clean == held, proc.stdout + proc.stderr
