"""The ``twolink`` program (the console script and ``python -m twolink``): the command
line (:func:`twolink.interface.cli.main`), then an exit that skips the interpreter's
teardown of its modules.

That teardown frees every object of numpy, pandas, scipy, matplotlib and MuJoCo one by
one: 0.3-0.4 s of a 2-core VM after each command, more under load, with nothing left to
write (every output is written atomically and closed before the command returns). Here
the command's code is taken from its ``SystemExit``, the atexit handlers run (the
process pool's, multiprocessing's, rerun's), threads that are not daemons are joined as
the interpreter would, the standard streams are flushed, and ``os._exit`` ends the
process with that code. An exception that is not ``SystemExit`` (a bug's traceback)
takes the interpreter's usual way out. The library and the tests call ``cli.main``.

A Ctrl-C while the command line is still imported (0.2-0.6 s on a loaded machine,
before its own handling is in place) ends it the same way: one line, exit 130.
"""

from __future__ import annotations

import atexit
import os
import signal
import sys
import threading
from typing import NoReturn


def run() -> None:
    """``twolink ...``: the command, then the quick exit with its code."""
    from twolink.foundation.interrupts import CTRL_C_RECEIVED, on_ctrl_c

    # The command line's own Ctrl-C handler from the start (the command keeps it): one
    # that lands in an extension's init while the command line is imported is recorded
    # even where the init swallows it.
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, on_ctrl_c)
    try:
        from twolink.interface.cli import main
    except BaseException:
        if not CTRL_C_RECEIVED:
            raise
        _interrupted_while_importing()
    if CTRL_C_RECEIVED:
        _interrupted_while_importing()
    try:
        main(prog_name="twolink")
        code: object = 0
    except SystemExit as exc:
        code = exc.code
    if code is None:
        code = 0
    elif not isinstance(code, int):  # sys.exit("message"): printed, exit 1
        print(code, file=sys.stderr)
        code = 1
    for thread in threading.enumerate():
        if thread is not threading.current_thread() and not thread.daemon:
            thread.join()
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe: nothing more can be said there
            pass
    os._exit(code)


def _interrupted_while_importing() -> NoReturn:
    # Nothing is written yet, and no process started: the command's own line.
    print("interrupted: files written so far are whole; rerun to complete", file=sys.stderr)
    sys.stderr.flush()
    os._exit(130)
