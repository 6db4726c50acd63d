"""``twolink regimes``: the regime map of the paper's fuzzy term (twolink/studies/regimes.py)."""

from __future__ import annotations

from pathlib import Path

import click

from twolink.foundation.shipped import locate
from twolink.interface.cli_output import done_line, fail_input, own_output, sweep_exits


@click.command("regimes", short_help="Where the FCM term acts, helps and hurts.")
@click.argument("study_file", required=False, type=click.Path(path_type=Path))
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    default=Path("results/regimes"),
    show_default=True,
    help="Output folder.",
)
@click.option(
    "-n",
    "--samples",
    type=click.IntRange(1, 10**6),
    default=None,
    help="Plants in all, over every cell [default: the file's, 100 per cell].",
)
@click.option("--workers", type=click.IntRange(min=1), default=None, help="Processes.")
def regimes_command(
    study_file: Path | None, out: Path, samples: int | None, workers: int | None
) -> None:
    """Run the regime map (runs/sweeps/regimes.toml: ωn x mass mismatch x payload, 100
    plants per cell) with 2 s quintic moves and with the paper's raw steps, and judge
    FCM-CTC and FCM-CTC-continuous against CTC and CTC-I per cell; writes regimes.csv,
    regimes_summary.csv, regimes.md and regimes.png.

    \b
    Examples:
      twolink regimes                  # ~2-3 min on 2 cores
      twolink regimes -n 300 --out /tmp/regimes   # 10 plants per cell, quicker
    """
    from twolink.figures.plots import save_figure
    from twolink.foundation.executors import SWEEP_PRELOAD, open_executor
    from twolink.foundation.io import atomic_write_text
    from twolink.simulation.config import ConfigError
    from twolink.studies import regimes
    from twolink.sweep import load_sweep

    study = locate(study_file or regimes.DEFAULT_STUDY)
    try:
        load_sweep(study, {"samples": samples} if samples else None)
    except ConfigError as exc:
        fail_input(str(exc))
    own_output(out, "regimes", str(Path(study).resolve()))
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
