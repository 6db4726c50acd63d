"""``twolink regimes``: the regime map of the paper's fuzzy term
(twolink/studies/judgments/regimes.py)."""

from __future__ import annotations

from pathlib import Path

import click

from twolink.foundation.shipped import install_target, locate
from twolink.interface.cli_options import (
    backend_option,
    install_option,
    out_folder_option,
    samples_option,
    set_option,
    workers_option,
)
from twolink.interface.cli_output import done_line, fail_input, own_output, sweep_exits


@click.command("regimes", short_help="Where the FCM term acts, helps and hurts.")
@click.argument("study_file", required=False, type=click.Path(path_type=Path))
@out_folder_option("Output folder.", Path("results/regimes"))
@samples_option("Plants in all, over every cell [default: the file's, 100 per cell].", most=10**6)
@workers_option("Processes.")
@backend_option(
    'MuJoCo on the CPU, or MJX (MuJoCo in JAX; pip install "twolink[mjx]"), in-process.',
    show_default=True,
)
def regimes_command(
    study_file: Path | None, out: Path, samples: int | None, workers: int | None, backend: str
) -> None:
    """Run the regime map (runs/sweeps/regimes.toml: ωn x mass mismatch x payload, 100
    plants per cell) with 2 s quintic moves and with the paper's raw steps, and judge
    FCM-CTC and FCM-CTC-continuous against CTC and CTC-I per cell; writes regimes.csv,
    regimes_summary.csv, regimes.md and regimes.png.

    \b
    Examples:
      twolink regimes                  # ~1.5 min on 2 cores
      twolink regimes -n 300 --out /tmp/regimes   # 10 plants per cell, quicker
    """
    from twolink.foundation.executors import SWEEP_PRELOAD, open_executor, prestart_fork_server

    if backend == "cpu":  # the workers' server imports on another core while we do
        prestart_fork_server(SWEEP_PRELOAD)
    from twolink.sweep.execution import backend_problem

    if problem := backend_problem(backend):  # MJX without JAX: before any work
        fail_input(problem)
    from twolink.foundation.io import atomic_write_text
    from twolink.simulation.config import ConfigError
    from twolink.studies.judgments import regimes
    from twolink.sweep import load_sweep

    study = locate(study_file or regimes.DEFAULT_STUDY)
    try:
        load_sweep(study, {"samples": samples} if samples else None)
    except ConfigError as exc:
        fail_input(str(exc))
    own_output(out, "regimes", str(Path(study).resolve()))
    # What the tables and the figure need, imported while the server still imports
    from twolink.figures.plots import save_figure
    from twolink.studies.judgments import claims  # noqa: F401

    if backend != "cpu":  # one batch per regime in this process: no pool
        with sweep_exits(out):
            results = regimes.run_regimes(study, out, samples, backend=backend)
    else:
        with sweep_exits(out), open_executor("process", workers, preload=SWEEP_PRELOAD) as pool:
            results = regimes.run_regimes(study, out, samples, pool)
    table = regimes.regime_table(results)
    summ = regimes.summary(table)
    atomic_write_text(out / "regimes.csv", table.to_csv(index=False))
    atomic_write_text(out / "regimes_summary.csv", summ.to_csv(index=False))
    atomic_write_text(out / "regimes.md", "\n".join(regimes.markdown(summ)) + "\n")
    save_figure(regimes.figure(summ), out / "regimes.png")
    click.echo("\n".join(regimes.markdown(summ)[:14]))
    click.echo(f"-> {out}: regimes.md, regimes.csv, regimes_summary.csv, regimes.png")
    click.echo(done_line())


@click.command("frontier", short_help="The linear frontier and the fair opponent, CTC-best.")
@click.argument("spec_file", required=False, type=click.Path(path_type=Path))
@out_folder_option(
    "Folder for frontier.csv, frontier.json and frontier.png.", Path("results/frontier")
)
@install_option(
    "Also write the shipped table (runs/paper/frontier.csv) that the reproduction reads."
)
@workers_option("Processes.")
def frontier_command(spec_file: Path | None, out: Path, install: bool, workers: int | None) -> None:
    """Run the linear frontier (runs/paper/frontier.toml: CTC over ωn x ζ, and CTC clipped
    at FCM-CTC's peak torques, on training plants of each claims regime) and choose the
    fair opponent of the claims studies: the best loop at FCM-CTC's effort.

    \b
    Examples:
      twolink frontier                  # ~1 min on 2 cores
      twolink frontier --install        # update runs/paper/frontier.csv and .json
    """
    from twolink.foundation.executors import open_executor
    from twolink.simulation.config import ConfigError
    from twolink.studies.designs import frontier

    try:
        spec = frontier.load_spec(locate(spec_file) if spec_file else frontier.DEFAULT_SPEC)
        if install:
            install_target(frontier.table_path(spec))
    except (ConfigError, OSError) as exc:
        fail_input(str(exc))
    own_output(out, "frontier", str(Path(spec.source).resolve()))
    with open_executor("process", workers) as pool:
        table = frontier.run_frontier(spec, pool)
    frontier.save_frontier(table, spec, out / "frontier.csv")
    if install:
        frontier.save_frontier(table, spec, frontier.table_path(spec))
    chosen = {r: frontier.choose(table, r) for r, _ in spec.grids}
    frontier.frontier_figure(table, chosen, out / "frontier.png")
    for line in frontier.summary_lines(table, chosen):
        click.echo(line)
    click.echo(f"-> {out}" + (f" and {frontier.table_path(spec)}" if install else ""))
    click.echo(done_line())


@click.command("search", short_help="Search FCM-CTC's rule table at equal effort.")
@click.argument("spec_file", required=False, type=click.Path(path_type=Path))
@out_folder_option(
    "Folder for search.json, heldout.csv and the best tables' rule bases.",
    Path("results/search"),
)
@install_option("Also write the shipped result (runs/paper/search/) that the reproduction reads.")
@workers_option("Processes.")
@set_option("the search file", "maxiter=2")
def search_command(
    spec_file: Path | None, out: Path, install: bool, workers: int | None, settings
) -> None:
    """Search FCM-CTC's odd-symmetric rule table (runs/paper/search.toml: differential
    evolution per regime and inference, at FCM-CTC's effort on the frontier's training
    plants), then judge the best tables against CTC-best on the claims study's held-out
    plants; writes search.json, heldout.csv and the tables' rule bases.

    \b
    Examples:
      twolink search --set plants=2 --set popsize=1 --set maxiter=1   # a smoke test
      twolink search --install          # ~10-20 min on 2 cores: update runs/paper/search/
    """
    from twolink.foundation.executors import open_executor
    from twolink.simulation.config import ConfigError, parse_set
    from twolink.studies.designs import search

    try:
        path = locate(spec_file) if spec_file else search.DEFAULT_SPEC
        spec = search.load_spec(path, parse_set(settings))
        if install:
            install_target(search.folder_of(spec) / "search.json")
    except (ConfigError, OSError) as exc:
        fail_input(str(exc))
    if install and parse_set(settings):
        fail_input("--install writes the shipped result of the search file as it is; drop --set")
    own_output(out, "search", str(Path(spec.source).resolve()))
    with open_executor("process", workers) as pool:
        found = search.run_search(spec, pool, progress=True)
        held = search.heldout(spec, found, out, pool)
    search.save_search(spec, found, held, out)
    if install:
        folder = search.folder_of(spec)
        for f in found:
            search.save_table(f["table"], folder / f"{f['regime']}_{f['inference']}.toml", f)
        search.save_search(spec, found, held, folder)
    meta = {"searches": found}
    for f in found:
        click.echo(
            f"{f['regime']} {f['inference']}: {f['evaluations']} tables, {f['wall_s']:.0f} s; "
            f"index {f['values'][4]:.4g} (FCM-CTC {f['designed'][4]:.4g}, CTC {f['empty'][4]:.4g})"
        )
    for regime in spec.regimes:
        click.echo(search.conclusion_sentence(meta, held, regime))
    click.echo(f"-> {out}" + (f" and {search.folder_of(spec)}" if install else ""))
    click.echo(done_line())
