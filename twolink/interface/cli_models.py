"""``twolink models``: the arm's MJCF files (``--install``: the clone's shipped ``models/``)."""

from __future__ import annotations

from pathlib import Path

import click

from twolink.arm.params import ArmParams, Flexibility
from twolink.foundation.shipped import install_target, models_dir
from twolink.interface.cli_options import install_option, out_folder_option
from twolink.interface.cli_output import fail_input as _fail_input
from twolink.interface.cli_output import own_output


@click.command(short_help="Write the arm's MJCF files.")
@out_folder_option("Folder for the MJCF files [default: results/models].")
@install_option("Regenerate the repository's models/ folder instead (a test keeps it in sync).")
def models(out: Path | None, install: bool) -> None:
    """Write the MJCF files of the default arm (rigid, flexible, scene) from ArmParams.

    \b
    Examples:
      twolink models                 # into results/models
      twolink models --install       # regenerate the repository's models/
    """
    from twolink.arm.plant import model_xml, scene_xml
    from twolink.foundation.io import atomic_write_text

    if install and out is not None:
        _fail_input("--install writes the repository's models/; it takes no --out")
    out = install_target(models_dir()) if install else out or Path("results/models")
    if not install:
        own_output(out, "models")
    files = {
        "twolink.xml": model_xml(ArmParams()),
        "twolink_flexible.xml": model_xml(ArmParams(), Flexibility()),
        "scene.xml": scene_xml("twolink.xml"),
    }
    for name, text in files.items():
        atomic_write_text(out / name, text)
        click.echo(out / name)
