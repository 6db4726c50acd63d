"""The options several commands share (twolink/interface/cli_options.py) are one option:
every command's option of a shared name has the same definition (name, flags, type,
flag-ness, multiplicity) and differs at most in its help, its default and its upper bound."""

import click
import pytest

from twolink.interface.cli import main

# the shared options by parameter name; "out" comes in two kinds, a folder and a file
SHARED = ("out", "workers", "samples", "seed", "install", "no_trace", "no_plots", "backend")
SHARED += ("settings",)


def commands():
    return sorted(main.commands.items())


def definition(p: click.Option) -> dict:
    """What a shared option must keep the same in every command: not its help, its default
    or its upper bound (-n/--samples: at most 10^5 arms, 10^6 plants, any sweep)."""
    kind = {k: v for k, v in vars(p.type).items() if k not in ("name", "max")}
    return {
        "opts": (tuple(p.opts), tuple(p.secondary_opts)),
        "type": (type(p.type).__name__, p.type.name, repr(sorted(kind.items(), key=str))),
        "flags": (p.is_flag, p.multiple, p.required, p.count, p.metavar, p.hidden),
        "env": (p.envvar, p.is_eager, p.expose_value, p.callback),
    }


def occurrences(name: str) -> dict[str, click.Option]:
    return {
        command: p
        for command, cmd in commands()
        for p in cmd.params
        if isinstance(p, click.Option) and p.name == name
    }


def test_the_shared_options_stand_in_several_commands():
    for name in SHARED:
        assert len(occurrences(name)) >= 2, name


@pytest.mark.parametrize("name", SHARED)
def test_a_shared_option_has_one_definition(name):
    found = occurrences(name)
    kinds = {}
    for command, p in found.items():
        kinds.setdefault(p.type.name, {})[command] = definition(p)
    # --out: a folder (directory) or a file, never anything else; every other: one kind
    assert len(kinds) <= (2 if name == "out" else 1), kinds.keys()
    if name == "out":
        assert set(kinds) <= {"directory", "file"}
    for by_command in kinds.values():
        first = next(iter(by_command.values()))
        assert all(d == first for d in by_command.values()), by_command


@pytest.mark.parametrize("name", ["out", "samples"])
def test_a_default_is_shown_when_it_is_a_value(name):
    """A value is shown; a None default is not (the help says it: --out's [default: ...])."""
    for command, p in occurrences(name).items():
        if p.default is None:
            assert not p.show_default, command
            assert name != "out" or "[default:" in p.help, command
        else:
            assert p.show_default is True, command
