"""Imported first by the fork server of a command's process pools (the head of its
preload list, :func:`twolink.foundation.executors.start_fork_server`): the server ends
as soon as the command does, also while it is still importing the rest of its list.

The fork server itself notices its command's end only in its loop, once all its imports
are done; those take seconds, and with a fresh numba cache (the compiled fuzzy kernels)
2-12 s on a loaded 2-core machine. A command stopped meanwhile left its fork server
running that long (``tests/test_stopping.py``). It also makes the server deaf to Ctrl-C,
which the command alone acts on. Imported anywhere else, this does nothing.
"""

from __future__ import annotations

import os
import signal
import sys

# The command's pid, from start_fork_server (the server's parent is init once the command
# is gone: a command stopped as it started its server is gone before this runs).
COMMAND_PID = "TWOLINK_FORK_SERVER_COMMAND"

_command = os.environ.get(COMMAND_PID, "")
_server = any("multiprocessing.forkserver import main" in a for a in getattr(sys, "orig_argv", ()))
if _server and hasattr(signal, "pthread_sigmask"):
    # Started with SIGINT blocked (executors._server_deaf_to_ctrl_c): ignored from here on,
    # by the server and by the workers it forks; one that came meanwhile is dropped.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
if _server and _command.isdigit():
    from twolink.foundation.executors import die_with_command

    die_with_command(int(_command))
