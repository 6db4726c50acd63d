"""A quiet terminal: what a pool task of the reproduction prints as it works, recorded
instead of printed, for the report to name.

The reproduction's flexible-joint studies drive soft joints past their stability limit on
purpose (the map marks those cells unstable): there numpy warns of overflow and MuJoCo
writes "simulation is unstable" to the process's stderr from C. Both are expected; the
terminal is for progress and what the user must know. :func:`quietly` runs a task with
Python's warnings recorded (``warnings.catch_warnings(record=True)``) and file descriptor 2
sent to a temporary file (MuJoCo's C writes bypass Python), and returns them beside the
task's result.
"""

from __future__ import annotations

import os
import sys
import tempfile
import warnings
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any

__all__ = ["quietly", "warnings_section"]


def quietly(function: Any, *args: Any) -> tuple[Any, list[str]]:
    """``function(*args)`` with what it warns or writes to stderr recorded, one line each:
    (its result, the lines). The stderr descriptor is restored however it ends."""
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as tmp, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        os.dup2(tmp.fileno(), 2)
        try:
            result = function(*args)
        finally:
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)
        tmp.seek(0)
        printed = tmp.read().decode(errors="replace").splitlines()
    lines = [line.strip() for line in printed if line.strip()]
    lines += [
        f"{w.category.__name__}: {w.message} ({Path(w.filename).name}:{w.lineno})" for w in caught
    ]
    return result, lines


def warnings_section(tasks: Sequence[tuple[str, Sequence[str], Sequence[str]]]) -> list[str]:
    """The report's section on what the tasks warned: per task (its name, its warning
    lines, the runs it names: those that diverged or stopped early), each distinct
    warning with its count; [] where no task warned."""
    warned = [(name, lines, runs) for name, lines, runs in tasks if lines]
    if not warned:
        return []
    out = [
        "",
        "## Warnings the runs raised (recorded here, not printed)",
        "",
        "Expected where a run is driven past its stability limit (the flexible-joint maps",
        "mark those cells unstable). Each task's runs that the divergence stop ended are",
        'named; "none": every run of the task ran to its end, however far off target.',
    ]
    for name, lines, runs in warned:
        named = ", ".join(runs) if runs else "none"
        out += ["", f"- **{name}**: {len(lines)} warnings; runs stopped as diverged: {named}."]
        out += [f"  - {n} × {line}" for line, n in Counter(lines).most_common()]
    return out
