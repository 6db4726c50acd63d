"""``twolink compare``: two controllers on one scenario in one call."""

from __future__ import annotations

import sys

import click

from twolink.interface.cli_options import (
    no_trace_option,
    out_folder_option,
    seed_option,
    set_option,
    workers_option,
)
from twolink.interface.cli_output import done_line, fail_input, sweep_exits


@click.command("compare", short_help="Compare two controllers on one scenario.")
@click.argument("scenario")
@click.argument("a")
@click.argument("b")
@click.option(
    "-n",
    "--plants",
    type=click.IntRange(min=1),
    default=None,
    help="Plants drawn as the robustness sweep draws them.  [default: 50]",
)
@click.option(
    "--plants-file",
    metavar="FILE.csv",
    default=None,
    help="Your own plants instead: a CSV of one row per plant, one column per sweep "
    "parameter (m1, m2, l1, l2, g, payload, k1, coulomb1, ...: docs/sweeps.md); the "
    "parameters it lacks stay nominal (docs/compare.md).",
)
@out_folder_option(
    "Output folder [default: results/compare/<scenario>_<A>_vs_<B>_<N>_plants, or _<FILE> "
    "for --plants-file].",
)
@seed_option(
    "Seed of the plants' draws (the same seed, the same plants) and of each plant's "
    "measurement noise."
)
@workers_option()
@no_trace_option("Skip the rerun recording (compare.rrd).")
@set_option("the scenario, for both controllers", "controller.kp=9")
def compare_command(
    scenario: str, a: str, b: str, plants, plants_file, out, seed: int, workers, no_trace,
    settings,
) -> None:  # fmt: skip
    """Judge controller A against controller B on SCENARIO (a file or a shipped name) over
    drawn plants, or your own (--plants-file): the paired table with verdicts (better: A
    lower beyond the tolerance; docs/compare.md), an overlay figure with a difference
    panel (compare.png) and one rerun recording of the nominal plant (compare.rrd). A and
    B are controllers of the shipped reproduction (CTC, FCM-CTC, PD-G, CTC-I, CTC-paper,
    fuzzy-PD, FCM-CTC-continuous) or controller kinds (ctc, fcm_ctc, ...).

    \b
    Examples:
      twolink compare theta1_step FCM-CTC CTC              # the raw θ1 step, 50 plants
      twolink compare theta1_step FCM-CTC CTC --set controller.kp=9 --set controller.kd=6
      twolink compare paper/theta2_step CTC-I CTC -n 200 --out /tmp/cmp
      twolink compare theta1_step FCM-CTC CTC --plants-file examples/plants.csv   # your 12 plants
    """
    from twolink.foundation.io import check_output_folder, check_ownership
    from twolink.foundation.shipped import locate
    from twolink.simulation.config import ConfigError, load_scenario, parse_set, read_toml
    from twolink.studies.judgments.compare import (
        NothingToJudge,
        compare,
        compare_sweep,
        comparison_source,
        controller_table,
        default_folder,
    )

    if plants is not None and plants_file is not None:
        fail_input(
            f"give -n/--plants or --plants-file, not both: the rows of {plants_file} are the plants"
        )
    plants = plants_file if plants_file is not None else 50 if plants is None else plants
    try:
        overrides = parse_set(settings)
        path = locate(scenario)
        read_toml(path)
        load_scenario(scenario, overrides)  # a bad --set is named now, not after the runs
        controller_table(a), controller_table(b)
        if a != b:  # the plants (a file's every row and column) are checked now too
            compare_sweep(path, a, b, plants, seed, overrides)
    except (ConfigError, OSError) as exc:
        fail_input(str(exc))
    if a == b:
        fail_input(f"give two different controllers, got {a!r} twice")
    picked = out is None  # the command's folder: one per pair and plants
    out = default_folder(scenario, a, b, plants, seed) if picked else out
    try:  # a folder that cannot be written or is another's: exit 2 before any work
        check_output_folder(out)
        check_ownership(out, "compare", comparison_source(path, a, b, plants, seed, overrides),
                        default=picked)  # fmt: skip
    except OSError as exc:
        fail_input(str(exc))
    # compare() holds the folder; a stop of its sweep is one line and 130 / 143
    try:
        with sweep_exits(out / "sweep"):
            result = compare(
                scenario, a, b, plants, out=out, seed=seed, workers=workers,
                trace=not no_trace, overrides=overrides, progress=True,
            )  # fmt: skip
    except NothingToJudge as exc:  # every plant diverged: a diverged run's exit, 1
        click.echo(f"error: {exc}", err=True)
        sys.exit(1)
    click.echo(str(result))
    click.echo(f"figure:     {out / 'compare.png'} (every plant; below, {a} − {b})")
    click.echo(f"forest:     {out / 'forest.png'} (per metric: the typical shift, the shares)")
    if not no_trace:
        click.echo(f"recording:  {out / 'compare.rrd'} (the nominal plant; rerun FILE)")
    click.echo(f"table:      {out / 'claims.csv'}; the sweep: {out / 'compare.toml'}")
    click.echo(done_line())
