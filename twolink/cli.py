"""The ``twolink`` command line.

Exit codes: 0 ok, 1 a run failed or diverged (or a check failed), 2 bad input.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click

from twolink.params import ArmParams, Flexibility


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
def main() -> None:
    """A two-link arm in MuJoCo with the paper's CTC and FCM fuzzy controllers."""


@main.command()
@click.option("-n", "--samples", default=1000, show_default=True, help="Random arms and states.")
@click.option("--seed", default=0, show_default=True, help="Seed of the random draws.")
def validate(samples: int, seed: int) -> None:
    """Check the analytic M, H, G against MuJoCo's own dynamics; exit 1 on any failure."""
    from twolink.validation import format_table
    from twolink.validation import validate as run_checks

    checks = run_checks(samples, seed)
    click.echo(format_table(checks))
    if not all(c.passed for c in checks):
        sys.exit(1)


@main.command()
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    default=Path("models"),
    show_default=True,
    help="Folder for the MJCF files.",
)
def models(out: Path) -> None:
    """Write the MJCF files of the default arm (rigid, flexible, scene) from ArmParams."""
    from twolink.io import atomic_write_text
    from twolink.plant import model_xml, scene_xml

    out.mkdir(parents=True, exist_ok=True)
    files = {
        "twolink.xml": model_xml(ArmParams()),
        "twolink_flexible.xml": model_xml(ArmParams(), Flexibility()),
        "scene.xml": scene_xml("twolink.xml"),
    }
    for name, text in files.items():
        atomic_write_text(out / name, text)
        click.echo(out / name)
