"""Ctrl-C for the command line: every command ends with one line and exit 130, whatever
the Ctrl-C lands in (docs/sweeps.md, "Stopping and resuming").

Held back (:func:`interrupts_held`), where a KeyboardInterrupt would do harm:

- MuJoCo's import. Its extension modules run Python code from C as they initialise
  (``mujoco._callbacks`` looks names up with ``PyRun_String``). A Ctrl-C that lands there
  breaks the import ("ImportError: initialization failed") or is swallowed. The Python
  that glfw starts meanwhile, to probe its library, starts with SIGINT blocked.
- Starting a pool worker. A Ctrl-C while the parent waits for the new worker's pid
  leaves that worker unknown to the pool, so the abort does not end it. It then fails
  loudly (a traceback from the fork server) once the command has exited.

Kept from the pool's fork server: a terminal's Ctrl-C reaches the whole process group,
and the server, starting Python or importing, printed its own traceback; it starts with
SIGINT blocked, then ignores it (``executors._server_deaf_to_ctrl_c``). And recorded from
the entry's first line (``twolink.interface.entry``), while the command line imports.

Raised again where Python or a library dropped it: in a weakref callback or ``__del__``
(:func:`resend_dropped_ctrl_c`), or caught by a C extension (:func:`raise_if_dropped`).
And forgotten once handled (:func:`forget_escaped_interrupt`), or ``python -m twolink``
ends by SIGINT after its exit 130.
"""

from __future__ import annotations

import _thread
import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import ModuleType
from typing import Any

_HELD = (signal.SIGINT, signal.SIGTERM)

CTRL_C_RECEIVED: list[int] = []
"""The Ctrl-Cs the running command has received (kept by :mod:`twolink.interface.cli`'s handler)."""


def raise_if_dropped() -> None:
    """Raise the KeyboardInterrupt of a Ctrl-C that a library caught and dropped.

    For points a KeyboardInterrupt cannot be on its way through (between a command's
    phases): a Ctrl-C received by then was swallowed on the way, as C extensions'
    module inits do (seen in numpy.random's, imported by pandas).
    """
    if CTRL_C_RECEIVED:
        raise KeyboardInterrupt


# Set while a command ends (its one line written, its handlers restored): a signal then, or
# a dropped Ctrl-C resent then, is moot, and a KeyboardInterrupt would cut the line short or
# escape as a traceback.
_ENDING = threading.Event()
_RESEND_PENDING = threading.Event()


def on_ctrl_c(signum: int, frame: Any) -> None:
    """The command line's SIGINT handler: record the Ctrl-C, and raise it (not once the
    command is ending, :func:`command_ending`)."""
    if _ENDING.is_set():
        return
    CTRL_C_RECEIVED.append(signum)
    raise KeyboardInterrupt


def command_starting() -> None:
    """A command starts: signals are raised again (:func:`command_ending` is over)."""
    _ENDING.clear()


def command_ending() -> None:
    """The command has stopped (or finished): later signals, and Ctrl-Cs still to be resent,
    are ignored until its handlers are restored."""
    _ENDING.set()


def resend_dropped_ctrl_c(unraisable: Any) -> None:
    """A KeyboardInterrupt raised where Python cannot raise (a weakref callback, a
    ``__del__``) is printed as "Exception ignored" and dropped, and the command would go
    on: send the Ctrl-C again, to land in the command's own code (once for several drops
    in a row, and not once the command is ending: it has acted on the Ctrl-C by then,
    e.g. at a phase's check, and one resent after its handlers were restored raised a
    KeyboardInterrupt into the code after it)."""
    if isinstance(unraisable.exc_value, KeyboardInterrupt):
        if _ENDING.is_set() or _RESEND_PENDING.is_set():
            return
        _RESEND_PENDING.set()
        # From another thread, a moment later: any signal sent from here would have its
        # handler run here, where raising is moot.
        resend = threading.Timer(0.05, _resend)
        resend.daemon = True
        resend.start()
    else:
        sys.__unraisablehook__(unraisable)


def _resend() -> None:
    _RESEND_PENDING.clear()
    if not _ENDING.is_set():
        _thread.interrupt_main(signal.SIGINT)


@contextmanager
def interrupts_held() -> Iterator[None]:
    """Run the block with the Python handlers of SIGINT and SIGTERM deferred to its end.

    Only handlers written in Python are deferred (Python's own Ctrl-C handler is one);
    a signal whose action is the system's default or "ignore" keeps it. Signals are
    handled by the main thread alone, so elsewhere this does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[tuple[int, Any]] = []
    previous = {s: h for s in _HELD if callable(h := signal.getsignal(s))}
    for s in previous:
        signal.signal(s, lambda signum, frame: received.append((signum, frame)))
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        for signum, frame in received:
            previous[signum](signum, frame)


def import_mujoco() -> ModuleType:
    """:mod:`mujoco`, imported with Ctrl-C held back (see the module's docstring)."""
    return import_held("mujoco")


def import_held(name: str) -> ModuleType:
    """Import module ``name`` with Ctrl-C held back, and blocked in the processes the import
    starts: MuJoCo's import runs glfw, which starts a Python to probe its library's
    version. A terminal's Ctrl-C reaches that process too; starting up, it printed a
    traceback. Blocked from its start (the mask is inherited), SIGINT never reaches it."""
    with interrupts_held(), sigint_blocked():
        __import__(name)  # the import statement's own hook
    return sys.modules[name]


@contextmanager
def sigint_blocked() -> Iterator[None]:
    """Run the block with SIGINT blocked in this thread, so the processes it starts begin
    with it blocked (the mask is inherited across fork and exec). One that came meanwhile
    is delivered at the end, unless it was blocked before. Without signal masks: nothing."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    blocked = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        if signal.SIGINT not in blocked:
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def forget_escaped_interrupt() -> None:
    """Clear CPython's mark that a KeyboardInterrupt escaped code run from a string.

    CPython sets that mark when a KeyboardInterrupt leaves an ``exec`` of a string (or
    ``PyRun_String`` in an extension), even where a caller further out catches it;
    ``python -m`` then ends the process by SIGINT after the command's own exit. Such
    strings run all the time (every dataclass's methods are made so, scipy clones numpy's
    namespace so, MuJoCo's module init looks names up so), so a Ctrl-C can land in one
    anywhere. Each ``exec`` of a string resets the mark first, hence this one, run once
    the command has handled its interruption. A KeyboardInterrupt that does leave the
    command is still marked (``python -m`` marks it again as it leaves the module).
    """
    exec("pass")
