"""The options that several ``twolink`` commands share, defined once.

Each function returns a click decorator. What is the same everywhere (the option's name,
its type, its flag-ness) is fixed here; what a command says about it (its help, its
default) stays the command's own, as a parameter. A default that is not None is shown in
``--help`` (``show_default``); a None default is explained in the help text instead.
tests/test_cli_options.py checks that every command's option of one name has one definition.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import click

ALL_CORES = "Processes [default: all cores]."


def out_folder_option(help: str, default: Path | None = None) -> Callable:
    """--out FOLDER: where the command writes its results."""
    return _out_option(help, default, file_okay=False)


def out_file_option(help: str, default: Path | None = None) -> Callable:
    """--out FILE: the one file the command writes."""
    return _out_option(help, default, dir_okay=False)


def _out_option(help: str, default: Path | None, **kind: bool) -> Callable:
    shown = {} if default is None else {"show_default": True}
    return click.option(
        "--out", type=click.Path(path_type=Path, **kind), default=default, help=help, **shown
    )


def workers_option(help: str = ALL_CORES) -> Callable:
    """--workers N: the processes of the command's pool (None: the pool's own choice)."""
    return click.option("--workers", type=click.IntRange(min=1), default=None, help=help)


def samples_option(help: str, most: int | None = None, default: int | None = None) -> Callable:
    """-n/--samples N: how many draws (at least 1, at most ``most``)."""
    shown = {} if default is None else {"show_default": True}
    return click.option(
        "-n", "--samples", type=click.IntRange(1, most), default=default, help=help, **shown
    )


def seed_option(help: str) -> Callable:
    """--seed N: the seed of the command's random draws (0 by default)."""
    return click.option(
        "--seed", type=click.IntRange(min=0), default=0, show_default=True, help=help
    )


def install_option(help: str) -> Callable:
    """--install: write the repository's shipped copy of the command's result."""
    return click.option("--install", is_flag=True, help=help)


def no_trace_option(help: str) -> Callable:
    """--no-trace: skip the rerun recordings."""
    return click.option("--no-trace", is_flag=True, help=help)


def no_plots_option() -> Callable:
    """--no-plots: skip the PNG plots."""
    return click.option("--no-plots", is_flag=True, help="Skip the PNG plots.")


def backend_option(help: str, show_default: bool | None = None) -> Callable:
    """--backend cpu|mjx: MuJoCo on the CPU (the default) or MJX."""
    shown = {} if show_default is None else {"show_default": show_default}
    return click.option(
        "--backend", type=click.Choice(["cpu", "mjx"]), default="cpu", help=help, **shown
    )


def set_option(what: str, example: str) -> Callable:
    """--set KEY=VALUE (docs/scenarios.md), with an example valid for its command."""
    return click.option(
        "--set",
        "settings",
        multiple=True,
        metavar="KEY=VALUE",
        help=f"Override a key of {what} (dotted, TOML value; repeatable): --set {example}.",
    )
