"""Imported first by the fork server of a command's process pools (the head of its
preload list, :func:`twolink.foundation.executors.start_fork_server`): the server ends
as soon as the command does, also while it is still importing the rest of its list.

The fork server itself notices its command's end only in its loop, once all its imports
are done; those take seconds, and with a fresh numba cache (the compiled fuzzy kernels)
2-12 s on a loaded 2-core machine. A command stopped meanwhile left its fork server
running that long (``tests/test_stopping.py``). Imported anywhere else, this does nothing.
"""

from __future__ import annotations

import os
import sys

# The command's pid, from start_fork_server (the server's parent is init once the command
# is gone: a command stopped as it started its server is gone before this runs).
COMMAND_PID = "TWOLINK_FORK_SERVER_COMMAND"

_command = os.environ.get(COMMAND_PID, "")
_server = any("multiprocessing.forkserver import main" in a for a in getattr(sys, "orig_argv", ()))
if _server and _command.isdigit():
    from twolink.foundation.executors import die_with_command

    die_with_command(int(_command))
