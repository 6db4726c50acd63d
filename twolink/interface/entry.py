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
"""

from __future__ import annotations

import atexit
import os
import sys
import threading


def run() -> None:
    """``twolink ...``: the command, then the quick exit with its code."""
    from twolink.interface.cli import main

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
