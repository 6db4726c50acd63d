"""A run's result folder: the resolved config, ``trajectory.npz``, ``metrics.json``, PNG
plots and a rerun recording, written atomically and sealed. It sits above the simulation
because it draws figures and writes recordings of a finished run."""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from twolink.controllers.base import Controller
from twolink.foundation.io import (
    SEAL_NAME,
    ForeignOutput,
    WriteFailed,
    atomic_write_json,
    atomic_write_text,
    folder_entries,
    held_by_a_command,
    read_seal,
    refuse_links,
    replace_files,
    scratch_folder,
    sha256_of,
    show_names,
    to_toml,
    write_seal,
)
from twolink.simulation.config import BUILTIN_RULE_BASES, Scenario, resolve_rule_base
from twolink.simulation.experiment import TRACE_EVERY, RunMetrics, trace_extras
from twolink.simulation.metrics import to_jsonable
from twolink.simulation.outcome import classify_run
from twolink.simulation.sim import Trajectory
from twolink.simulation.vocabulary import CONTROLLER_LABELS


def portable_config(s: Scenario, out: Path) -> dict[str, Any]:
    """The resolved config, with a rule-base file path relative to the folder it is saved
    in (it resolves against that folder when read back), so a results folder can move."""
    data = s.to_dict()
    name = data["controller"]["rule_base"]
    if name not in BUILTIN_RULE_BASES:
        path = resolve_rule_base(name, s.source).resolve()
        data["controller"]["rule_base"] = os.path.relpath(path, out.resolve())
    return data


# What a run folder holds (besides its seal): the only names write_run replaces.
RUN_FILES = (
    "config.toml",
    "trajectory.npz",
    "metrics.json",
    "angles.png",
    "errors.png",
    "torques.png",
    "trace.rrd",
)


def check_run_folder(out: Path) -> None:
    """Refuse (:class:`~twolink.foundation.io.ForeignOutput`) a run folder that holds anything but a
    run's files, or is reached through a link inside its output folder. Outside a folder
    a twolink command holds (whose owner record proved every file twolink's as it began),
    a run's file is replaced only while its seal lists it with its current bytes: a file
    of the user's named ``angles.png`` is not taken for one."""
    refuse_links(out)
    if out.is_dir():
        extra = folder_entries(out) - {*RUN_FILES, SEAL_NAME}
        if not extra and not held_by_a_command(out):
            seal = read_seal(out) or {}
            for name in sorted(folder_entries(out) - {SEAL_NAME}):
                try:
                    if sha256_of(out / name) != seal.get(name):
                        extra.add(name)
                except OSError:
                    extra.add(name)
        if extra:
            raise ForeignOutput(
                f"{out}: holds files that are not a twolink run's ({show_names(extra)}); "
                "twolink does not overwrite a folder it did not write: move them away or "
                "use another --out"
            )


@contextlib.contextmanager
def _named_in(out: Path) -> Iterator[None]:
    try:
        yield
    except WriteFailed as exc:
        raise exc.moved_to(out) from None


def write_run(
    out: str | Path,
    s: Scenario,
    traj: Trajectory,
    metrics: RunMetrics,
    plots: bool = True,
    trace: bool = True,
    controller: Controller | None = None,
    centres: Any = (),
    prefix: str = "run",
    name: str | None = None,
    centre_labels: Any = (),
    more_metrics: dict[str, Any] | None = None,
    more_extras: dict[str, Any] | None = None,
) -> Path:
    """Write one run's folder: config.toml, trajectory.npz, metrics.json, PNG plots and a
    rerun recording ``trace.rrd`` (of the run under ``prefix``).

    The files are written into a temporary folder, then each moved into ``out`` by one
    rename and sealed (``seal.json``: their SHA-256, written last), so no file of an
    earlier run stays beside the new ones and a damaged or edited run is found on reuse.
    Only the run's own files are replaced: a folder holding anything else is refused
    (:class:`~twolink.foundation.io.ForeignOutput`). ``name`` is the controller's name in
    the outputs (default: its kind's label); ``centre_labels`` name the FCM ``centres`` in
    the recording (the reproduction: each centre's kept rule). ``more_metrics`` join
    ``metrics.json`` (links that bend: the tip's measures), ``more_extras`` the recording's
    extras (links that bend: ``bent``, their points)."""
    out = Path(out)
    name = name or CONTROLLER_LABELS.get(s.controller.kind, s.controller.kind)
    check_run_folder(out)
    out.mkdir(parents=True, exist_ok=True)
    # the scratch inside the run folder: a SIGKILL leaves it where the journal lists it
    with scratch_folder(out / "run") as tmp, _named_in(out):
        atomic_write_text(tmp / "config.toml", to_toml(portable_config(s, out)))
        traj.save(tmp / "trajectory.npz")
        summary = metrics.to_dict(name, classify_run(s, metrics)) | to_jsonable(more_metrics or {})
        atomic_write_json(tmp / "metrics.json", summary)
        if plots:  # matplotlib and rerun load only when asked for
            from twolink.figures.plots import save_run_plots

            save_run_plots(tmp, traj, title=s.name)
        if trace:
            from twolink.tracing import write_recording

            extras = (
                trace_extras(controller, traj, centres, centre_labels)
                if controller is not None
                else {}
            ) | (more_extras or {})
            write_recording(
                tmp / "trace.rrd", [(prefix, traj, s.plant_params, extras)], every=TRACE_EVERY
            )
        replace_files(out, tmp, RUN_FILES)
    write_seal(out, [n for n in RUN_FILES if (out / n).is_file()])
    return out
