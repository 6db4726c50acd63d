"""Helpers of the command line: its one-line errors, its output folders, its tables."""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator
from pathlib import Path

import click


def fail_input(message: str) -> None:
    """Print one error line and exit 2 (bad input)."""
    click.echo(f"error: {message}", err=True)
    sys.exit(2)


@contextlib.contextmanager
def sweep_exits(out: Path) -> Iterator[None]:
    """How a command ends when its sweep does not finish: stopped by SIGINT / SIGTERM, one
    line and exit 130 / 143; a failed executor or task, one line and exit 1. The chunks
    already written stay in ``out`` for a rerun to resume from."""
    from concurrent import futures

    from twolink.foundation.executors import ExecutorError
    from twolink.foundation.interrupts import command_ending
    from twolink.sweep import SweepInterrupted, SweepTaskError

    try:
        yield
    except SweepInterrupted as exc:
        command_ending()  # a signal more, or a Ctrl-C resent, no longer raises
        click.echo(f"\n{exc}", err=True)
        sys.exit(128 + exc.signum)
    except (ExecutorError, SweepTaskError, futures.BrokenExecutor) as exc:
        click.echo(f"error: {exc}; finished chunks are kept in {out}, rerun to resume", err=True)
        sys.exit(1)


def own_output(out: Path, command: str, source: str | None = None, default: bool = False) -> None:
    """Check that ``twolink COMMAND`` may write into ``out`` (exit 2 if not), then hold it
    (lock, journal and owner record) until the command ends (docs/reliability.md)."""
    from twolink.foundation.io import check_output_folder, check_ownership, owned_output

    try:
        check_output_folder(out)
        check_ownership(out, command, source, default)
    except OSError as exc:
        fail_input(str(exc))
    click.get_current_context().with_resource(owned_output(out, command, source, default))


def format_metrics(metrics) -> str:
    """A run's metrics as a table: one line per key (with its unit), one column per joint."""
    from twolink.simulation.vocabulary import METRICS, format_value, joint_values

    joints = [joint_values(metrics, j) for j in (1, 2)]
    lines = [f"{'metric':24s} {'symbol':7s} {'joint 1':>10s} {'joint 2':>10s}"]
    for m in METRICS:
        cells = [format_value(v[m.key], 4) for v in joints]
        lines.append(f"{m.key:24s} {m.symbol:7s} {cells[0]:>10s} {cells[1]:>10s}")
    return "\n".join(lines)


def format_tip_metrics(tip: dict[str, float]) -> str:
    """The tip's measures of links that bend (their keys, as in ``metrics.json``'s ``tip``):
    one line each, with the symbol, in mm and ms where the key is in m and s."""
    from twolink.simulation.vocabulary import TIP_METRICS, format_value

    lines = [f"{'tip metric':26s} {'symbol':10s} {'value':>10s}"]
    for m in TIP_METRICS:
        scale, unit = {"m": (1e3, "mm"), "s": (1e3, "ms")}[m.unit]
        cell = format_value(tip[m.key] * scale, 4)
        cell += f" {unit}" if cell != "—" else ""
        lines.append(f"{m.key:26s} {m.symbol:10s} {cell:>10s}")
    return "\n".join(lines)


# Python's start-up and its imports before twolink's take well under this (about 0.1-2 s)
START_UP_BOUND_S = 5.0


def done_line() -> str:
    """ "done in X s": the whole command's wall time, from the process's start (Python's
    start-up and imports included; Linux's /proc), or from twolink's import where the
    process started long before it (see :func:`command_seconds`)."""
    seconds, whole = command_seconds()
    if whole:
        return f"done in {seconds:.1f} s (wall time of the whole command, start-up included)"
    return f"done in {seconds:.1f} s (wall time from twolink's import)"


def command_seconds() -> tuple[float, bool]:
    """The command's wall time so far, and whether it counts from the process's start.

    From the process's start (Linux's /proc) where it started at most
    :data:`START_UP_BOUND_S` before twolink's import. A process that started earlier ran
    something else first: a shell runs the last command of ``bash -c "a && twolink
    ..."`` in its own process (exec), whose start is then the shell's, and the /proc
    clock would count ``a`` too (seen: "done in 103.6 s" for a 58 s reproduction after
    a 46 s install). There, and where /proc is missing, it counts from twolink's import.
    """
    import os
    import time

    import twolink

    since_import = time.perf_counter() - twolink.IMPORTED_AT
    try:
        with open("/proc/self/stat") as fh:  # field 22, starttime, in clock ticks after boot
            ticks = int(fh.read().rsplit(")", 1)[1].split()[19])
        with open("/proc/uptime") as fh:
            uptime = float(fh.read().split()[0])
    except (OSError, ValueError, IndexError):
        return since_import, False
    since_start = max(0.0, uptime - ticks / os.sysconf("SC_CLK_TCK"))
    if since_start - since_import > START_UP_BOUND_S:
        return since_import, False
    return max(since_start, since_import), True
