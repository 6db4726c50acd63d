"""``twolink coverage``: where a rule base fires no rule (registered in
:mod:`twolink.interface.cli`), and the cluster-validity figure that
``twolink design --figure`` writes.

Exit codes of ``coverage``: 0 the rule base covers the input box, 1 it has gaps, 2 bad input.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import click

from twolink.interface.cli_options import out_file_option

# `coverage --grid` at most: 1001 x 1001 points (and the surface check's grid twice as fine)
# peak at ~0.35 GB and ~35 s on a loaded 2-core machine; 4001 took 14 GB (docs/reliability.md)
MAX_GRID = 1001


@click.command("coverage", short_help="Where a rule base fires no rule.")
@click.argument("rule_base", default="paper", required=False)
@click.option(
    "--threshold",
    type=float,
    default=0.0,
    show_default=True,
    help="Count a point as uncovered where the total firing is at most this.",
)
@click.option(
    "--grid",
    type=click.IntRange(2, MAX_GRID),
    default=201,
    show_default=True,
    help=f"Grid points per axis (2-{MAX_GRID}; {MAX_GRID} takes ~0.4 GB and ~40 s).",
)
def coverage_command(rule_base: str, threshold: float, grid: int) -> None:
    """Print the share of the normalised (e, de) input box where RULE_BASE fires no rule,
    the uncovered label cells, and the label cells where its output jumps (the paper's
    Mamdani inference; docs/fuzzy.md, "The relay"). RULE_BASE is "paper" (default),
    "designed", "default" (the 7x7), a rule-base TOML file or a MATLAB .fis file (its
    rules; `twolink fis` writes one); the engine is the project's 7-label one.

    \b
    Examples:
      twolink coverage                      # the paper's Table 1: exit 1, it has gaps
      twolink coverage default              # the 7x7: exit 0
      twolink coverage designed --threshold 0.1
    """
    from twolink.controllers.fuzzy import MamdaniEngine
    from twolink.controllers.fuzzy.coverage import coverage, surface_jumps
    from twolink.controllers.fuzzy.fis.matlab import rule_base_engine

    try:
        path = rule_base_file(rule_base)
        engine = rule_base_engine(path)  # any two-input, one-output .fis too
        result = coverage(engine, threshold=threshold, grid=grid)
    except (OSError, ValueError, KeyError, OverflowError) as exc:  # a 400-digit index
        text = str(exc)  # a .fis reader's messages name the file already
        named = text if text.startswith(rule_base) else f"{rule_base}: {text}"
        click.echo(f"error: {named}", err=True)
        sys.exit(2)
    how = "exact area" if result.exact else f"on a {grid} x {grid} grid"
    click.echo(
        f"{path}: {result.n_rules} rules; no rule fires (total firing <= {threshold:g}) on "
        f"{100 * result.uncovered_fraction:.2f} % of the input box ({how}; "
        f"{100 * result.grid_fraction:.2f} % of the {grid} x {grid} grid points)"
    )
    for region in result.regions:
        click.echo(f"  uncovered: {region}")
    if not isinstance(engine, MamdaniEngine):  # a MATLAB FIS (docs/fuzzy.md, "Any MATLAB FIS")
        click.echo(
            "its jumps are not listed: they are measured per label cell of the project's "
            "7-label partition, which this system is not (the box is its normalised ranges)"
        )
        sys.exit(0 if result.complete else 1)
    jumps = [j for j in surface_jumps(engine, grid=grid) if j.is_jump]
    click.echo(
        f"its output jumps (a change that keeps its size on a grid twice as fine) in "
        f"{len(jumps)} of {(len(engine.e.labels) - 1) * (len(engine.de.labels) - 1)} label "
        "cells" + (", largest first (normalised output):" if jumps else "")
    )
    for jump in jumps:
        click.echo(f"  {jump}")
    sys.exit(0 if result.complete else 1)


def rule_base_file(name: str) -> Path:
    """The file of a rule base by name or path; another kind of this project's TOML files
    is refused naming what reads it."""
    from twolink.simulation.config import expect_kind, read_toml, resolve_rule_base

    path = resolve_rule_base(name)
    if path.suffix.lower() != ".fis" and path.is_file():
        expect_kind(read_toml(path), path, "rule base")
    return path


def validity_figure_path(figure: Path) -> Path:
    """Where ``twolink design --figure PATH`` writes the cluster-validity figure: beside
    PATH, named ``<stem>_validity.png``."""
    return figure.with_name(f"{figure.stem}_validity.png")


def write_validity_figure(result: Any, path: Path) -> tuple:
    """The cluster-validity sweep of a design (PC, PE and XB for c = 2..10 on its data,
    weighted as it weighs; twolink/studies/designs/validity.py) plotted to ``path`` with the
    design's c
    marked, as the report's design section shows it. Returns the sweep's rows."""
    from twolink.figures.plots import save_figure
    from twolink.studies.designs.validity import validity_figure, validity_sweep

    rows = validity_sweep(result.points, result.weights)
    save_figure(validity_figure(rows, int(result.clustering.n_clusters)), path)
    return rows


@click.command("fis", short_help="Export a rule base as a MATLAB .fis file.")
@click.argument("rule_base", default="designed", required=False)
@click.option(
    "--scenario",
    type=click.Path(path_type=Path),
    default=None,
    help="Scenario whose fuzzy scaling (ke, kde, ku) the file carries "
    "[default: runs/paper/base.toml as FCM-CTC].",
)
@out_file_option(".fis file to write.", Path("results/fis/rule_base.fis"))
def fis_command(rule_base: str, scenario: Path | None, out: Path) -> None:
    """Write RULE_BASE ("designed", "paper", "default" or a rule-base file) as a MATLAB
    Fuzzy Logic Toolbox .fis file (readfis reads it): Mamdani, the engine's triangular
    membership functions, min / max, centroid, in physical units (the error in rad, its
    rate in rad/s, the output in rad/s²) by the scenario's scaling.

    \b
    Examples:
      twolink fis                              # the designed rule base, shipped scaling
      twolink fis paper --out table1.fis       # the paper's Table 1
    """
    from twolink.controllers.fuzzy import default_fuzzy_pd
    from twolink.controllers.fuzzy.fis.engine_files import (
        read_rule_base,
        write_fis,
        written_by_twolink,
    )
    from twolink.foundation.io import check_output_file
    from twolink.foundation.shipped import runs_dir
    from twolink.simulation.config import ConfigError, load_scenario
    from twolink.simulation.experiment import build_controller

    base = scenario or runs_dir() / "paper" / "base.toml"
    try:
        # a .fis cannot carry twolink's mark: an existing one is twolink's if it is exactly
        # what twolink writes for its content
        check_output_file(out, "--out", ours_only=not written_by_twolink(out))
        rules = read_rule_base(rule_base_file(rule_base))
        over = {} if scenario else {"controller": {"kind": "fcm_ctc", "rule_base": "designed"}}
        controller = build_controller(load_scenario(base, over))
        scaling = (controller.ke, controller.kde, controller.ku)
    except (ConfigError, OSError, ValueError, AttributeError) as exc:
        click.echo(f"error: {rule_base}: {exc}", err=True)
        sys.exit(2)
    engine = default_fuzzy_pd().with_rules(rules)
    write_fis(out, engine, Path(rule_base).stem, scaling)
    click.echo(f"{out}: {len(engine.rules)} rules, ke {scaling[0]:.4g} /rad, "
               f"kde {scaling[1]:.4g} s/rad, ku {scaling[2]:.4g} rad/s²")  # fmt: skip
