"""Recording files: write runs (with their layout and overview) to one ``.rrd``
atomically, and read a recording's series back."""

from __future__ import annotations

import hashlib
import os
import uuid
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import rerun as rr
from rerun.error_utils import catch_and_log_exceptions

from twolink.arm.params import ArmParams
from twolink.foundation.io import atomic_path
from twolink.simulation.sim import Trajectory
from twolink.simulation.vocabulary import SIGNAL_UNITS, TIME_COLUMN, signal_column

if TYPE_CHECKING:
    import pandas as pd

from twolink.tracing.layout import blueprint
from twolink.tracing.overview import _extent, _overview_series
from twolink.tracing.runs import _ID_NAMESPACE, TIMELINE, _check_trajectory, _time_column, log_run


def recording_id(
    application_id: str, runs: Sequence[tuple[str, Trajectory, ArmParams, dict]]
) -> str:
    """A recording id that is a pure function of what is recorded.

    Two writes of the same runs share an id, so the viewer treats them as one
    recording rather than piling up copies.

    Parameters
    ----------
    application_id : str
    runs : sequence of (prefix, Trajectory, ArmParams, extras)

    Returns
    -------
    str
        A UUID (version 5) as a string.
    """
    h = hashlib.sha256(application_id.encode())
    for prefix, traj, arm, extras in runs:
        h.update(prefix.encode() + b"\0" + repr(arm).encode())
        for name in ("t", "q", "qd", "q_ref", "qd_ref", "qdd_ref", "tau", "motor_q"):
            h.update(np.ascontiguousarray(getattr(traj, name), dtype=float).tobytes())
        h.update(f"{traj.status}\0{traj.message}\0{sorted(extras)!r}".encode())
        for key in sorted(extras):
            value = np.asarray(extras[key])
            if value.dtype.kind in "biufU":  # numbers and strings: their bytes, fast
                h.update(f"{value.dtype.str}{value.shape}".encode() + value.tobytes())
            else:
                h.update(repr(value.tolist()).encode())
    return str(uuid.uuid5(_ID_NAMESPACE, h.hexdigest()))


def write_recording(
    path: str | os.PathLike,
    runs: Sequence[tuple[str, Trajectory, ArmParams, dict[str, Any]]],
    application_id: str = "twolink",
    every: int = 1,
    groups: Sequence[str] | None = None,
) -> Path:
    """Write one ``.rrd`` holding one or several runs and the layout, atomically.

    Parameters
    ----------
    path : path-like
        The ``.rrd`` file; replaced only once it is complete.
    runs : sequence of (prefix, Trajectory, ArmParams, extras)
        Each run under its own prefix (distinct, none inside another); ``extras`` are
        keyword arguments of :func:`log_run` (``centres``, ``fired_rules``,
        ``phase_scale``, ``centre_labels``, ``name``, ``every``).
    application_id : str
        Rerun's application id (the viewer groups recordings and layouts by it).
    every : int
        Default decimation for runs whose extras do not set ``every``.
    groups : sequence of str, optional
        One per run (e.g. its controller): in the "all runs" overview of a recording with
        several runs, the runs of one group share a colour family, each run a shade of
        its own (:func:`overview_colors`), and a run's name gets its group appended
        unless the name ends with it. Default: one group per run.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    RuntimeError
        If rerun logging is disabled (``RERUN=off``): nothing would be written.
    """
    runs = list(runs)
    if not runs:
        raise ValueError("write_recording needs at least one run")
    prefixes = [r[0].strip("/") for r in runs]
    _check_prefixes(prefixes)
    for run in runs:
        _check_trajectory(run[1])  # before the overview reads it
    groups = list(groups) if groups is not None else prefixes
    if len(groups) != len(runs):
        raise ValueError(f"{len(groups)} groups for {len(runs)} runs")
    rec = rr.RecordingStream(application_id, recording_id=recording_id(application_id, runs))
    if not rec.is_enabled():
        raise RuntimeError("rerun logging is disabled (RERUN=off?); no recording written")
    path = Path(path)
    with atomic_path(path, suffix=".rrd") as tmp:
        try:
            titles = [str(r[3].get("name") or p) for r, p in zip(runs, prefixes, strict=True)]
            overview = _overview_series(runs, prefixes, titles, groups, every)
            layout = blueprint(
                prefixes,
                titles,
                overview_extent=[_extent(overview, j) for j in (1, 2)] if overview else None,
                overview_duration=max(float(r[1].t[-1]) for r in runs) if overview else None,
            )
            rec.save(tmp, default_blueprint=layout)
            for (_, traj, arm, extras), prefix in zip(runs, prefixes, strict=True):
                log_run(rec, traj, arm, prefix, **{"every": every, **extras})
            _log_overview(rec, overview)
            rec.flush()
        finally:
            # Close the file sink (writes the footer) before the rename or the cleanup.
            rec.disconnect()
    return path


def _log_overview(rec: rr.RecordingStream, overview) -> None:
    """The "all runs" overview's series, each styled once and sent as one column."""
    with catch_and_log_exceptions(context="twolink.tracing.overview", strict=True):
        for series in overview:
            rec.log(
                series.path,
                rr.SeriesLines(names=series.name, colors=[series.color], widths=[series.width]),
                static=True,
                strict=True,
            )
            rec.send_columns(
                series.path,
                indexes=[_time_column(series.t)],
                columns=rr.Scalars.columns(scalars=series.values),
                strict=True,
            )


def read_recording(path: str | os.PathLike) -> pd.DataFrame:
    """Every scalar time series of a recording, one column per entity, indexed by time.

    A reader for analysis without a viewer. A run's signals are named as everywhere
    (docs/tracing.md, "One naming"): the entity ``P/joint1/angle`` is the column
    ``P/joint1_angle_rad`` (``P`` the run's prefix, e.g. ``rigid/table2/CTC``; a
    recording of one run has none: ``joint1_angle_rad``, as
    :meth:`~twolink.simulation.sim.Trajectory.to_dataframe`); other series keep their
    entity path. The index is ``time_s``; a series missing at some time is NaN there. A
    recording keeps the samples its writer kept (``every``; see the file's writer);
    ``trajectory.npz`` beside a run's recording has every sample
    (:meth:`twolink.simulation.sim.Trajectory.load`). The reproduction's combined
    recording, whose entities hold several curves each, is read as
    :func:`twolink.tracing.comparison.read_comparison` reads it (a column per curve).

    Parameters
    ----------
    path : path-like
        A ``.rrd`` file written by :func:`write_recording` (or by
        :func:`~twolink.tracing.comparison.write_comparison`).

    Returns
    -------
    pandas.DataFrame
    """
    import pandas as pd
    from rerun.chunk import RrdReader

    store = RrdReader(path).store()
    pieces: dict[str, list[pd.Series]] = {}
    for chunk in store.stream():
        if chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        if "Scalars:scalars" not in batch.schema.names or TIMELINE not in batch.schema.names:
            continue
        t = _seconds(batch)
        col = batch.column("Scalars:scalars").flatten()
        if len(col) != len(t):  # several curves per row: the combined recording
            return _read_curves(store)
        pieces.setdefault(chunk.entity_path.lstrip("/"), []).append(
            pd.Series(col.to_numpy(zero_copy_only=False), index=t)
        )
    columns = {
        _column(name): pd.concat(parts).sort_index() for name, parts in sorted(pieces.items())
    }
    frame = pd.DataFrame(columns)
    frame.index.name = TIME_COLUMN
    return frame


def _seconds(batch: Any) -> np.ndarray:
    """A chunk's times on the recording's timeline, in seconds."""
    return batch.column(TIMELINE).to_numpy().astype("timedelta64[ns]").astype(np.int64) / 1e9


def _read_curves(store: Any) -> pd.DataFrame:
    """A loaded recording (``RrdReader(path).store()``) whose entities hold several
    curves each, named by their static ``SeriesLines``: a column ``<entity>/<curve name>``
    per curve, indexed by ``time_s`` (:func:`twolink.tracing.comparison.read_comparison`)."""
    import pandas as pd

    names: dict[str, list[str]] = {}
    pieces: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {}
    for chunk in store.stream():
        batch = chunk.to_record_batch()
        entity = chunk.entity_path.strip("/")
        if chunk.is_static:
            if "SeriesLines:names" in batch.schema.names:
                names[entity] = batch.column("SeriesLines:names")[0].as_py()
            continue
        if "Scalars:scalars" not in batch.schema.names or TIMELINE not in batch.schema.names:
            continue
        t = _seconds(batch)
        flat = batch.column("Scalars:scalars").flatten().to_numpy(zero_copy_only=False)
        pieces.setdefault(entity, []).append((t, flat.reshape(len(t), -1)))
    columns = {}
    for entity, parts in pieces.items():
        t = np.concatenate([p[0] for p in parts])
        values = np.concatenate([p[1] for p in parts])
        for k, name in enumerate(names.get(entity, [str(k) for k in range(values.shape[1])])):
            columns[f"{entity}/{name}"] = pd.Series(values[:, k], index=t).sort_index()
    frame = pd.DataFrame({c: columns[c] for c in sorted(columns)})
    frame.index.name = TIME_COLUMN
    return frame


def _column(entity: str) -> str:
    # ".../joint1/angle" -> ".../joint1_angle_rad"; anything else as it is
    head, _, leaf = entity.rpartition("/")
    prefix, _, joint = head.rpartition("/")
    if leaf in SIGNAL_UNITS and joint in ("joint1", "joint2"):
        column = signal_column(int(joint[-1]), leaf)
        return f"{prefix}/{column}" if prefix else column
    return entity


def _check_prefixes(prefixes: list[str]) -> None:
    for i, a in enumerate(prefixes):
        for b in prefixes[i + 1 :]:
            if a == b or not a or not b or a.startswith(b + "/") or b.startswith(a + "/"):
                raise ValueError(
                    f"run prefixes must be distinct, non-empty and not nested, got {a!r} and {b!r}"
                )
