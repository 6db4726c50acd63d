"""Executors for sweeps: one :class:`concurrent.futures.Executor` interface, three back ends.

- ``inprocess``: runs each task in the calling thread when it is submitted (debugging,
  profiling, tests with monkeypatching; Ctrl-C lands in the task itself).
- ``process`` (default): a local :class:`~concurrent.futures.ProcessPoolExecutor`, one worker
  per core. Workers are forked from a "forkserver" (forking the command itself is unsafe:
  tqdm's and rerun's threads), which imports the package once when the pool opens: each
  worker starts with it imported, not paying ~1 s of imports of its own. Workers ignore
  SIGINT: the parent alone decides how a sweep stops, and ends its workers itself
  (:meth:`SweepExecutor.abort`).
- ``dask``: a :mod:`dask.distributed` client, on a scheduler at ``scheduler`` or, without
  one, on a :class:`~distributed.LocalCluster` of ``workers`` single-threaded processes.
  Dask is an optional extra (``pip install twolink[dask]``) and imported only here, lazily.
  Remote workers need ``twolink`` installed; they never touch the client's files (tasks
  return their results, the client writes them).

Every executor is a context manager and counts its ``workers`` (for cost accounting).
"""

from __future__ import annotations

import ctypes
import multiprocessing
import multiprocessing.forkserver
import os
import select
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from concurrent import futures
from contextlib import contextmanager
from multiprocessing import resource_tracker
from typing import Any

from twolink.foundation.interrupts import interrupts_held, sigint_blocked
from twolink.foundation.io import discard_pending

EXECUTORS = ("inprocess", "process", "dask")


class ExecutorError(RuntimeError):
    """An executor could not be started (missing extra, unreachable scheduler, ...)."""


class SweepExecutor(futures.Executor):
    """A :class:`concurrent.futures.Executor` that also knows its size and can be aborted.

    Attributes
    ----------
    workers : int
        How many tasks run at once.
    name : str
        The back end ("inprocess", "process" or "dask").
    """

    name = "abstract"
    workers = 1

    def abort(self) -> None:
        """Stop now: cancel queued tasks and end running ones; their results are lost."""
        self.shutdown(wait=True, cancel_futures=True)

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> bool:
        # Left by an exception (Ctrl-C, SIGTERM, an error): the queued and running tasks
        # are moot, so stop now rather than wait for them (a study's chunk: ~10 s).
        if exc_type is not None:
            with interrupts_held():
                self.abort()
            return False
        return bool(super().__exit__(exc_type, exc, tb))


class InProcessExecutor(SweepExecutor):
    """Runs each task at ``submit``, in the calling process; the future is already done.

    ``workers`` is the number of threads a sweep task may step batches in (a sweep gives
    this executor that many chunks per task, :func:`twolink.sweep.execution.run_chunks`):
    MuJoCo releases the GIL while it steps, so threads use several cores without pickling
    anything (default: all cores)."""

    name = "inprocess"

    def __init__(self, threads: int | None = None) -> None:
        self._shutdown = False
        self.workers = threads or os.cpu_count() or 1

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> futures.Future:
        if self._shutdown:
            raise RuntimeError("cannot submit to an executor that was shut down")
        future: futures.Future = futures.Future()
        future.set_running_or_notify_cancel()
        try:
            result = fn(*args, **kwargs)
        except Exception as exc:  # a task's failure belongs in its future, as in a pool
            future.set_exception(exc)
        else:
            future.set_result(result)
        return future

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self._shutdown = True


# The measuring's scipy modules (find_peaks, curve_fit: imported where first used, so a
# command that only plans never pays them) and the compiled fuzzy kernels, loaded by the
# fork server once, not in each worker's first chunk (~0.8 s and ~0.3 s).
_MEASURING = ["scipy.signal", "scipy.optimize", "twolink.controllers.fuzzy.kernels_loaded"]
# What a worker needs, imported once by the fork server (an import that fails is skipped
# there and happens in the worker, as with spawn).
WORKER_PRELOAD = [
    "twolink.studies.reproduction.reproduce",
    "twolink.simulation.experiment",
    "twolink.sweep",
    "twolink.figures.plots",
    "twolink.tracing",
    "twolink.controllers.batch",
    *_MEASURING,
]
# What a sweep's worker needs (run_chunk: the batch engine and the measuring), for the
# commands whose workers only run sweeps (sweep, regimes, gains): the fork server starts
# in a third of the time without the figures, the tracing (rerun) and the reproduction.
SWEEP_PRELOAD = [
    "twolink.simulation.experiment",
    "twolink.sweep",
    "twolink.controllers.batch",
    *_MEASURING,
]
# Imported first by every fork server: it ends with the command, also while it imports.
SERVER_WATCH = "twolink.foundation.server_watch"
_COMMAND_PID = "TWOLINK_FORK_SERVER_COMMAND"  # server_watch.COMMAND_PID (not imported here)


_IN_POOL_WORKER = False


def in_pool_worker() -> bool:
    """Whether this process is a :class:`ProcessExecutor`'s worker (its signal handlers are
    the pool's: a sweep run as its task leaves them alone)."""
    return _IN_POOL_WORKER


def _worker_init(command: int) -> None:
    """Set up a pool worker: it ignores Ctrl-C, leaves no temporary behind when stopped,
    and dies with the command."""
    global _IN_POOL_WORKER
    _IN_POOL_WORKER = True
    # A terminal's Ctrl-C reaches the whole process group; only the parent should act on it.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _stop_worker)
    # A task's (silent) tqdm bar would make its cross-process lock, a named semaphore that
    # the abort's os._exit leaves for the resource tracker to warn about; a worker's bars
    # need no lock shared with other processes.
    from tqdm import tqdm

    tqdm.set_lock(threading.RLock())
    die_with_parent(os.getppid())
    # Forked, the parent is the fork server, and it does not end with the command: every
    # worker is handed the server's "alive" pipe, so the server waits for its workers while
    # they wait for it. The worker watches the command itself.
    die_with_command(command)


def die_with_command(command: int) -> None:
    """End this process as soon as the process ``command`` ends, however it ends.

    A daemon thread waits on a pidfd of ``command`` (Linux 5.3+: it wakes the moment the
    command exits, zombie or not), elsewhere polls its pid twice a second; it removes this
    worker's unfinished temporaries, then exits. A command already gone ends us now.
    """
    try:
        pidfd: int | None = os.pidfd_open(command)
    except (AttributeError, OSError):  # not Linux, an old kernel, or the command is gone
        pidfd = None
    if not _alive(command):
        os._exit(1)
    threading.Thread(
        target=_exit_after, args=(command, pidfd), name="twolink-command-watch", daemon=True
    ).start()


def _exit_after(command: int, pidfd: int | None) -> None:
    if pidfd is not None:
        select.select([pidfd], [], [])
    else:
        while _alive(command):
            time.sleep(0.5)
    discard_pending()
    os._exit(1)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, someone else's
        return True
    return True


def _stop_worker(signum: int, frame: Any) -> None:
    # The pool's abort terminates workers mid-task: remove what they were writing, then go
    # at once (an exception would let the pool hand the worker its next task).
    discard_pending()
    os._exit(128 + signum)


def die_with_parent(parent: int) -> None:
    """End this process when ``parent`` ends, however it ends (SIGTERM, SIGKILL, a crash),
    so that no orphaned worker finishes its queue and writes after the command is gone.

    Linux delivers SIGKILL on the parent's death (``prctl(PR_SET_PDEATHSIG)``); elsewhere a
    daemon thread watches the parent id. Either way, a parent already gone ends us now.
    """
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG = 1
        except (OSError, AttributeError):
            _watch_parent(parent)
    else:
        _watch_parent(parent)
    if os.getppid() != parent:  # it died before the line above took effect
        os._exit(1)


def _watch_parent(parent: int) -> None:
    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, name="twolink-parent-watch", daemon=True).start()


def start_fork_server(preload: list[str] | None = None) -> None:
    """Start the fork server of this command's process pools now, importing ``preload``
    (default :data:`WORKER_PRELOAD`): a command calls this first, so that the server's
    imports run beside its own on another core. The first start holds (its list too); no
    fork server on this platform: nothing."""
    if "forkserver" in multiprocessing.get_all_start_methods():
        context = multiprocessing.get_context("forkserver")
        if not _fork_server_started():
            modules = WORKER_PRELOAD if preload is None else preload
            context.set_forkserver_preload([SERVER_WATCH, *modules])
        # The server learns which command to end with from its environment.
        previous = os.environ.get(_COMMAND_PID)
        os.environ[_COMMAND_PID] = str(os.getpid())
        try:
            with _server_deaf_to_ctrl_c():
                multiprocessing.forkserver.ensure_running()
        finally:
            if previous is None:
                os.environ.pop(_COMMAND_PID, None)
            else:
                os.environ[_COMMAND_PID] = previous


@contextmanager
def _server_deaf_to_ctrl_c() -> Iterator[None]:
    """Start the fork server with SIGINT blocked, as the stdlib starts its resource tracker.

    A terminal's Ctrl-C reaches the whole process group; the server, still starting
    Python or importing its preload list, printed its KeyboardInterrupt's traceback to
    the command's stderr (and a worker just forked, before its initializer). Blocked
    from the start (the mask is inherited across exec), SIGINT waits until the server
    ignores it (:mod:`twolink.foundation.server_watch`); its workers are forked with it
    ignored. Only this thread blocks it: the command still gets its Ctrl-C."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    # Started first, or its own start would unblock SIGINT before the server's.
    resource_tracker.ensure_running()
    with sigint_blocked():
        yield


def prestart_fork_server(preload: list[str] | None = None) -> None:
    """:func:`start_fork_server` at a command's very start, where it is only a head start:
    an error there (no usable temporary folder, a full disk) is left for the pool's own
    start, which meets it after the command has checked its output folder (exit 3,
    naming what it cannot write)."""
    try:
        start_fork_server(preload)
    except OSError:
        pass


def _fork_server_started() -> bool:
    return getattr(multiprocessing.forkserver._forkserver, "_forkserver_pid", None) is not None


class ProcessExecutor(SweepExecutor):
    """A local process pool of ``workers`` processes (default: all cores)."""

    name = "process"

    def __init__(self, workers: int | None = None, preload: list[str] | None = None) -> None:
        self.workers = workers or os.cpu_count() or 1
        if "forkserver" in multiprocessing.get_all_start_methods():
            context = multiprocessing.get_context("forkserver")
            # Start the server now (unless the command did): it imports while the command
            # prepares its first tasks.
            start_fork_server(preload)
        else:  # Windows: each worker imports for itself
            context = multiprocessing.get_context("spawn")
        self._pool = futures.ProcessPoolExecutor(
            max_workers=self.workers,
            mp_context=context,
            initializer=_worker_init,
            initargs=(os.getpid(),),
        )

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> futures.Future:
        # A submit can start a worker; Ctrl-C waits until the pool knows it (to end it).
        with interrupts_held():
            return self._pool.submit(fn, *args, **kwargs)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self._pool.shutdown(wait=wait, cancel_futures=cancel_futures)

    def abort(self) -> None:
        # The pool has no public way to stop a running task (before Python 3.14's
        # terminate_workers); without this, shutdown waits for every task already handed
        # to a worker, which can be several chunks.
        terminate = getattr(self._pool, "terminate_workers", None)
        if terminate is not None:
            terminate()
        else:
            for process in self._worker_processes():
                process.terminate()
        # A worker terminated while it sent a result leaves the result queue's lock held,
        # and a worker waiting on that lock never runs its SIGTERM handler; the pool's
        # shutdown then waits for it forever (seen: 2 of 6 SIGTERMs to `reproduce` 4 s
        # in). So the shutdown runs beside a watch that ends every worker still alive
        # after ABORT_GRACE_S with SIGKILL (its temporaries: the next command removes them).
        done = threading.Event()

        def shut() -> None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            done.set()

        threading.Thread(target=shut, name="twolink-pool-shutdown", daemon=True).start()
        grace = time.monotonic() + ABORT_GRACE_S
        signalled = {p.pid for p in self._worker_processes()}
        while not done.wait(0.05):
            late = time.monotonic() >= grace
            for process in self._worker_processes():
                if not process.is_alive():
                    continue
                if late:
                    process.kill()
                elif process.pid not in signalled:  # one the pool started after the first
                    process.terminate()  # pass; once each: a second SIGTERM would re-enter
                    signalled.add(process.pid)  # the handler while it removes temporaries

    def _worker_processes(self) -> list[Any]:
        return list((getattr(self._pool, "_processes", None) or {}).values())


ABORT_GRACE_S = 2.0  # s a worker has to act on SIGTERM before an abort sends SIGKILL


class DaskExecutor(SweepExecutor):
    """Tasks on a Dask distributed cluster: at ``scheduler``, or a new local one."""

    name = "dask"

    def __init__(self, workers: int | None = None, scheduler: str | None = None) -> None:
        try:
            from dask.distributed import Client, LocalCluster
        except ImportError as exc:
            raise ExecutorError(
                f"the dask executor needs dask.distributed: pip install 'twolink[dask]' ({exc})"
            ) from None
        self._cluster = None
        try:
            if scheduler:
                self._client = Client(scheduler, timeout="10s")
            else:
                self._cluster = LocalCluster(
                    n_workers=workers or os.cpu_count() or 1,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=None,
                )
                self._client = Client(self._cluster)
        except OSError as exc:
            self._close()
            raise ExecutorError(f"cannot reach the Dask scheduler {scheduler!r}: {exc}") from None
        info = self._client.scheduler_info()
        threads = sum(w.get("nthreads", 1) for w in info.get("workers", {}).values())
        self.workers = threads or workers or 1
        self._executor = self._client.get_executor(pure=False)

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> futures.Future:
        return self._executor.submit(fn, *args, **kwargs)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        if cancel_futures:
            self._cancel_all()
        self._executor.shutdown(wait=wait and not cancel_futures)
        self._close()

    def abort(self) -> None:
        self.shutdown(wait=False, cancel_futures=True)

    def _cancel_all(self) -> None:
        pending = [f for f in self._executor._futures if not f.done()]
        if pending:
            self._client.cancel(pending)

    def _close(self) -> None:
        client = getattr(self, "_client", None)
        if client is not None:
            client.close()
        if self._cluster is not None:
            self._cluster.close()
            self._cluster = None


def check_options(kind: str, workers: int | None, scheduler: str | None) -> None:
    """Raise ValueError for an unknown ``kind``, ``workers < 1``, a misplaced scheduler, or
    the dask executor without Dask installed."""
    if kind not in EXECUTORS:
        raise ValueError(f"unknown executor {kind!r}: one of {list(EXECUTORS)}")
    if workers is not None and (isinstance(workers, bool) or workers < 1):
        raise ValueError(f"workers must be >= 1, got {workers}")
    if scheduler and kind != "dask":
        raise ValueError(f"a scheduler address needs the dask executor, not {kind!r}")
    if kind == "dask":  # before any work starts, not when the first chunk is submitted
        try:
            import dask.distributed  # noqa: F401
        except ImportError as exc:
            raise ValueError(
                f"the dask executor needs dask.distributed: pip install 'twolink[dask]' ({exc})"
            ) from None


def open_executor(
    kind: str = "process",
    workers: int | None = None,
    scheduler: str | None = None,
    preload: list[str] | None = None,
) -> SweepExecutor:
    """Start an executor; use it as a context manager.

    Parameters
    ----------
    kind : {"inprocess", "process", "dask"}
        The back end.
    workers : int, optional
        Worker processes for "process" and a local Dask cluster, threads for "inprocess"
        (default: all cores). Ignored by a remote Dask scheduler.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``); only with "dask".
    preload : list of str, optional
        Modules a "process" pool's fork server imports once for every worker (default
        :data:`WORKER_PRELOAD`, everything a command's tasks can need; :data:`SWEEP_PRELOAD`
        for sweeps alone). The first pool of a command starts the server: its list holds.

    Returns
    -------
    SweepExecutor

    Raises
    ------
    ValueError
        Unknown ``kind``, ``workers < 1``, or a scheduler for a non-Dask executor.
    ExecutorError
        Dask is not installed or its scheduler cannot be reached.
    """
    check_options(kind, workers, scheduler)
    if kind == "inprocess":
        return InProcessExecutor(workers)
    if kind == "process":
        return ProcessExecutor(workers, preload)
    return DaskExecutor(workers, scheduler)
