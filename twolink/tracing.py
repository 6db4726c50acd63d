"""Rerun recordings of finished runs: time series, phase plane and the arm moving in 3D.

This is the only module that imports ``rerun``; everything else imports it lazily, so
runs work without rerun installed. Nothing is logged while a run is computed: a
finished :class:`~twolink.sim.Trajectory` is sent in columns (``send_columns``) along
one duration timeline, ``"time"`` (seconds).

Entity paths of one run, under its prefix ``P`` (``j`` is 1 or 2)::

    P/joint{j}/angle         Scalars    link angle q_j [rad]
    P/joint{j}/reference     Scalars    reference q_ref_j [rad]
    P/joint{j}/motor_angle   Scalars    rotor angle (flexible arm only) [rad]
    P/joint{j}/error         Scalars    e_j = q_ref_j - q_j [rad]
    P/joint{j}/error_rate    Scalars    de_j = qd_ref_j - qd_j [rad/s]
    P/joint{j}/torque        Scalars    tau_j [N m]
    P/status                 TextLog    static: "ok" or "diverged: <why>"
    P/phase/joint{j}/path    LineStrips2D  static: the whole (e, de) trajectory
    P/phase/joint{j}/state   Points2D   (e_j, de_j) per sample, labelled with the fired rule
    P/phase/joint{j}/fired_rule  TextLog  the fired rule per sample (if given)
    P/phase/centres          Points2D   static: FCM cluster centres (if given; per-joint
                                        centres go to P/phase/joint{j}/centres)
    P/arm/base               Points3D   static: the shoulder
    P/arm/links              LineStrips3D  base -> elbow -> tip per sample
    P/arm/joints             Points3D   base, elbow, tip per sample

A recording of several runs also holds, for the "all runs" overview::

    all_runs/joint{j}/P              Scalars  q_j of run P, named after the run and
                                              coloured by its group (controller)
    all_runs/joint{j}/P/reference    Scalars  its reference, grey (each distinct one once)

The arm moves in the paper's (x, y) plane, which is (x, z) in 3D (z up, as MuJoCo).
See ``docs/tracing.md``.
"""

from __future__ import annotations

import hashlib
import os
import uuid
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import rerun as rr
import rerun.blueprint as rrb
from rerun.error_utils import catch_and_log_exceptions

from twolink.io import atomic_path
from twolink.params import ArmParams
from twolink.sim import Trajectory

if TYPE_CHECKING:
    import pandas as pd

TIMELINE = "time"
JOINT_COLORS = ((31, 119, 180), (255, 127, 14))  # joint 1 blue, joint 2 orange
REFERENCE_COLOR = (140, 140, 140)
MOTOR_COLOR = (44, 160, 44)
CENTRE_COLOR = (214, 39, 40)
ARM_COLOR = (60, 60, 60)
# The "all runs" overview colours each run by its group (controller): matplotlib's tab10
# red, green, blue, purple, brown, pink, as in the report's figures (CTC red, FCM-CTC green).
GROUP_COLORS = (
    (214, 39, 40),
    (44, 160, 44),
    (31, 119, 180),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
)
OVERVIEW = "all_runs"  # entity root of the overview's copies of every run's angles

# Fixed namespace so a recording id is a pure function of the recording's content.
_ID_NAMESPACE = uuid.UUID("5f0e2c8a-6d1b-4c39-9a57-2b7d3e1f4a60")


def entity_prefix(*names: str) -> str:
    """An entity-path prefix from free-text names, one path part each, escaped.

    Scenario names such as ``"θ1 step, CTC"`` hold spaces and commas, which entity
    paths do not take raw.

    Parameters
    ----------
    *names : str
        Path parts, outermost first.

    Returns
    -------
    str
        ``"part1/part2/..."`` with each part escaped for rerun.
    """
    if not names or any(not n for n in names):
        raise ValueError(f"entity_prefix needs non-empty names, got {names!r}")
    return "/".join(rr.escape_entity_path_part(n) for n in names)


def _path(prefix: str, *parts: str) -> str:
    prefix = prefix.strip("/")
    return "/".join((prefix, *parts)) if prefix else "/".join(parts)


def sample_indices(n: int, every: int = 1) -> np.ndarray:
    """Indices of the samples kept when keeping every ``every``-th one (and the last).

    The last sample is always kept so a decimated recording still ends where the run
    ended (the settled or diverged state).

    Parameters
    ----------
    n : int
        Number of samples.
    every : int
        Keep samples 0, every, 2 every, ...; 1 keeps all.

    Returns
    -------
    ndarray of int
    """
    if isinstance(every, bool) or not isinstance(every, int | np.integer) or every < 1:
        raise ValueError(f"every must be an integer >= 1, got {every!r}")
    idx = np.arange(0, n, every)
    if n and idx[-1] != n - 1:
        idx = np.append(idx, n - 1)
    return idx


def arm_points(arm: ArmParams, q: np.ndarray) -> np.ndarray:
    """Base, elbow and tip of the arm in 3D for each sample.

    Parameters
    ----------
    arm : ArmParams
        Link lengths ``l1``, ``l2``.
    q : ndarray (N, 2)
        Link angles: theta1 from the horizontal, theta2 relative to link 1.

    Returns
    -------
    ndarray (N, 3, 3)
        Points [base, elbow, tip] as (x, y, z); the paper's (x, y) plane is (x, z).
    """
    q = np.asarray(q, dtype=float)
    a1, a12 = q[:, 0], q[:, 0] + q[:, 1]
    pts = np.zeros((len(q), 3, 3))
    pts[:, 1, 0] = arm.l1 * np.cos(a1)
    pts[:, 1, 2] = arm.l1 * np.sin(a1)
    pts[:, 2, 0] = pts[:, 1, 0] + arm.l2 * np.cos(a12)
    pts[:, 2, 2] = pts[:, 1, 2] + arm.l2 * np.sin(a12)
    return pts


def _time_column(t: np.ndarray) -> rr.TimeColumn:
    # Whole nanoseconds, rounded: rerun's float path truncates, so 0.003 s would become
    # 2999999 ns and samples would drift off the control grid.
    ns = np.round(np.asarray(t, dtype=float) * 1e9).astype(np.int64)
    return rr.TimeColumn(TIMELINE, duration=ns.astype("timedelta64[ns]"))


def _centre_points(
    prefix: str, centres: np.ndarray | None, labels: Sequence[str] | None
) -> list[tuple[str, np.ndarray, list[str]]]:
    # (entity, centres, labels) to log: one shared set, or one per joint.
    if centres is None:
        return []
    c = np.asarray(centres, dtype=float)
    if c.ndim == 2 and c.shape[1] == 2:
        sets = [(_path(prefix, "phase", "centres"), c)]  # one rule base serves both joints
    elif c.ndim == 3 and c.shape[0] == 2 and c.shape[2] == 2:
        sets = [(_path(prefix, "phase", f"joint{j + 1}", "centres"), c[j]) for j in range(2)]
    else:
        raise ValueError(f"centres must have shape (c, 2) or (2, c, 2), got {c.shape}")
    names = list(labels) if labels is not None else [f"c{k + 1}" for k in range(len(sets[0][1]))]
    if len(names) != len(sets[0][1]):
        raise ValueError(f"{len(names)} centre_labels for {len(sets[0][1])} centres")
    return [(path, pts, names) for path, pts in sets]


def _rules_per_joint(fired_rules: Sequence[Any] | None, n: int) -> list[list[str]] | None:
    if fired_rules is None:
        return None
    rules = np.asarray(fired_rules, dtype=object)
    if rules.shape == (n,):
        col = [str(r) for r in rules]
        return [col, col]
    if rules.shape == (n, 2):
        return [[str(r) for r in rules[:, j]] for j in range(2)]
    raise ValueError(
        f"fired_rules must hold one label per sample, shape ({n},) or ({n}, 2), got {rules.shape}"
    )


def _check_trajectory(traj: Trajectory) -> int:
    n = len(traj.t)
    if n == 0:
        raise ValueError("the trajectory has no samples: nothing to record")
    for name in ("q", "qd", "q_ref", "qd_ref", "qdd_ref", "tau"):
        shape = np.shape(getattr(traj, name))
        if shape != (n, 2):
            raise ValueError(f"Trajectory.{name} has shape {shape}, expected ({n}, 2)")
    if np.shape(traj.motor_q) not in ((n, 2), (0, 2)):
        raise ValueError(f"Trajectory.motor_q has shape {np.shape(traj.motor_q)}")
    return n


def log_run(
    rec: rr.RecordingStream,
    traj: Trajectory,
    arm: ArmParams,
    prefix: str = "",
    centres: np.ndarray | None = None,
    fired_rules: Sequence[Any] | None = None,
    *,
    every: int = 1,
    phase_scale: tuple[float, float] = (1.0, 1.0),
    centre_labels: Sequence[str] | None = None,
    name: str | None = None,
) -> None:
    """Send one finished run to ``rec`` in columns along the ``"time"`` timeline.

    Entity paths are listed in the module docstring. Rerun usage errors raise here
    instead of becoming warnings, so a recording is never silently incomplete.

    Parameters
    ----------
    rec : rerun.RecordingStream
        Where to send; its sinks are the caller's business.
    traj : Trajectory
        The finished run.
    arm : ArmParams
        The arm drawn in 3D (link lengths).
    prefix : str
        Entity-path prefix of this run ("" for the root); see :func:`entity_prefix`.
    centres : ndarray (c, 2) or (2, c, 2), optional
        FCM cluster centres in the phase plane, shared by both joints or per joint,
        in the units of the plane (see ``phase_scale``).
    fired_rules : sequence of str, shape (N,) or (N, 2), optional
        The rule that fired at each sample, for both joints or per joint.
    every : int
        Keep every ``every``-th sample (and the last); 1 keeps all.
    phase_scale : (float, float)
        The phase plane shows ``(ke * e, kde * de)``; pass the fuzzy controller's
        (ke, kde) to draw it in the engine's normalised universe, where FCM centres
        live.
    centre_labels : sequence of str, optional
        One label per centre; default "c1", "c2", ...
    name : str, optional
        Human-readable run name, written into the status text.
    """
    # Check everything before sending anything: a live stream gets a whole run or none.
    n = _check_trajectory(traj)
    idx = sample_indices(n, every)
    centres_to_log = _centre_points(prefix, centres, centre_labels)
    rules = _rules_per_joint(fired_rules, n)
    ke, kde = (float(s) for s in phase_scale)
    if not (np.isfinite(ke) and np.isfinite(kde)):
        raise ValueError(f"phase_scale must be finite, got {phase_scale!r}")
    times = [_time_column(traj.t[idx])]
    q, q_ref, tau = traj.q[idx], traj.q_ref[idx], traj.tau[idx]
    e, de = traj.e[idx], traj.de[idx]
    flexible = len(traj.motor_q) == n

    def scalars(path: str, values: np.ndarray, label: str, color: tuple[int, ...]) -> None:
        # Style once (static), values as one column: the viewer joins them per entity.
        rec.log(path, rr.SeriesLines(names=label, colors=[color]), static=True, strict=True)
        rec.send_columns(
            path, indexes=times, columns=rr.Scalars.columns(scalars=values), strict=True
        )

    # Strict for this scope only (thread-local): turn rerun's swallowed errors into raises.
    with catch_and_log_exceptions(context="twolink.tracing.log_run", strict=True):
        text = traj.status if not traj.message else f"{traj.status}: {traj.message}"
        if name:
            text = f"{name}: {text}"
        rec.log(
            _path(prefix, "status"),
            rr.TextLog(text, level="INFO" if traj.ok else "WARN"),
            static=True,
            strict=True,
        )
        for j in range(2):
            joint = f"joint{j + 1}"
            color = JOINT_COLORS[j]
            sub = "₁₂"[j]
            scalars(_path(prefix, joint, "angle"), q[:, j], f"θ{sub}", color)
            scalars(_path(prefix, joint, "reference"), q_ref[:, j], f"θ{sub} ref", REFERENCE_COLOR)
            if flexible:
                motor = traj.motor_q[idx, j]
                scalars(_path(prefix, joint, "motor_angle"), motor, f"motor {sub}", MOTOR_COLOR)
            scalars(_path(prefix, joint, "error"), e[:, j], f"e{sub}", color)
            scalars(_path(prefix, joint, "error_rate"), de[:, j], f"ė{sub}", color)
            scalars(_path(prefix, joint, "torque"), tau[:, j], f"τ{sub}", color)

            plane = np.stack([ke * e[:, j], kde * de[:, j]], axis=1)
            rec.log(
                _path(prefix, "phase", joint, "path"),
                rr.LineStrips2D([plane], colors=[color], radii=rr.Radius.ui_points(1.0)),
                static=True,
                strict=True,
            )
            state = _path(prefix, "phase", joint, "state")
            rec.log(
                state,
                rr.Points2D.from_fields(colors=[color], radii=rr.Radius.ui_points(5.0)),
                static=True,
                strict=True,
            )
            if rules is None:
                cols = rr.Points2D.columns(positions=plane)
            else:
                labels = [rules[j][i] for i in idx]
                cols = rr.Points2D.columns(positions=plane, labels=labels)
                rec.send_columns(
                    _path(prefix, "phase", joint, "fired_rule"),
                    indexes=times,
                    columns=rr.TextLog.columns(text=labels),
                    strict=True,
                )
            rec.send_columns(state, indexes=times, columns=cols, strict=True)

        for path, pts, labels in centres_to_log:
            rec.log(
                path,
                rr.Points2D(
                    pts,
                    labels=labels,
                    colors=[CENTRE_COLOR],
                    radii=rr.Radius.ui_points(6.0),
                    show_labels=True,
                ),
                static=True,
                strict=True,
            )

        pts = arm_points(arm, q)
        rec.log(_path(prefix, "arm"), rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True, strict=True)
        rec.log(
            _path(prefix, "arm", "base"),
            rr.Points3D([[0.0, 0.0, 0.0]], labels=["base"], colors=[ARM_COLOR], radii=[0.05]),
            static=True,
            strict=True,
        )
        links = _path(prefix, "arm", "links")
        rec.log(
            links,
            rr.LineStrips3D.from_fields(colors=[ARM_COLOR], radii=[0.02]),
            static=True,
            strict=True,
        )
        # One strip of three points per sample.
        rec.send_columns(
            links, indexes=times, columns=rr.LineStrips3D.columns(strips=pts), strict=True
        )
        joints = _path(prefix, "arm", "joints")
        rec.log(
            joints,
            rr.Points3D.from_fields(colors=[JOINT_COLORS[0]], radii=[0.035]),
            static=True,
            strict=True,
        )
        rec.send_columns(
            joints,
            indexes=times,
            columns=rr.Points3D.columns(positions=pts.reshape(-1, 3)).partition([3] * len(idx)),
            strict=True,
        )


def _run_layout(prefix: str, title: str) -> rrb.Container:
    def series(name: str, *parts: tuple[str, ...]) -> rrb.TimeSeriesView:
        return rrb.TimeSeriesView(name=name, contents=[_path(prefix, *p) for p in parts])

    j1, j2 = "joint1", "joint2"
    plots = rrb.Vertical(
        series("θ₁ vs reference", (j1, "angle"), (j1, "reference"), (j1, "motor_angle")),
        series("θ₂ vs reference", (j2, "angle"), (j2, "reference"), (j2, "motor_angle")),
        series("errors e", (j1, "error"), (j2, "error")),
        series("error rates ė", (j1, "error_rate"), (j2, "error_rate")),
        series("torques τ", (j1, "torque"), (j2, "torque")),
    )
    log = [_path(prefix, "status")] + [_path(prefix, "phase", j, "fired_rule") for j in (j1, j2)]
    spaces = rrb.Vertical(
        rrb.Spatial2DView(name="phase plane (e, ė)", origin=_path(prefix, "phase")),
        rrb.Spatial3DView(name="arm", origin=_path(prefix, "arm")),
        rrb.TextLogView(name="status and fired rules", contents=log),
        row_shares=[4, 4, 1],
    )
    return rrb.Horizontal(plots, spaces, column_shares=[3, 2], name=title)


def time_panel() -> rrb.TimePanel:
    """The time panel on this module's timeline (the viewer would open on ``log_time``,
    where nothing is logged, and show empty plots)."""
    return rrb.TimePanel(timeline=TIMELINE)


def blueprint(prefixes: Sequence[str], titles: Sequence[str] | None = None) -> rrb.Blueprint:
    """The ready layout for runs logged by :func:`log_run` under ``prefixes``.

    One run: time series (angles with references, errors, error rates, torques) beside
    the phase plane, the arm in 3D and the status and fired rules. Several runs: an
    overview tab overlaying every run's joint angles and references, then one tab per
    run.

    Parameters
    ----------
    prefixes : sequence of str
        The runs' entity-path prefixes, as given to :func:`log_run`.
    titles : sequence of str, optional
        Tab titles, one per prefix; default the prefix.

    Returns
    -------
    rerun.blueprint.Blueprint
    """
    prefixes = [p.strip("/") for p in prefixes]
    if not prefixes:
        raise ValueError("blueprint needs at least one prefix")
    titles = list(titles) if titles is not None else [p or "run" for p in prefixes]
    if len(titles) != len(prefixes):
        raise ValueError(f"{len(titles)} titles for {len(prefixes)} prefixes")
    if len(prefixes) == 1:
        return rrb.Blueprint(_run_layout(prefixes[0], titles[0]), time_panel())
    overview = rrb.Vertical(
        *[
            rrb.TimeSeriesView(
                name=f"θ{sub} of every run (colour: controller; grey: references)",
                contents=[f"{_path(OVERVIEW, f'joint{j}')}/**"],
                plot_legend=rrb.PlotLegend(corner="RightTop", visible=True),
            )
            for j, sub in ((1, "₁"), (2, "₂"))
        ],
        name="all runs",
    )
    tabs = [_run_layout(p, title) for p, title in zip(prefixes, titles, strict=True)]
    return rrb.Blueprint(rrb.Tabs(overview, *tabs, active_tab=0), time_panel())


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
            h.update(repr(np.asarray(extras[key]).tolist()).encode())
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
        several runs, runs of one group share a colour. Default: one group per run.

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
            rec.save(tmp, default_blueprint=blueprint(prefixes, titles))
            for (_, traj, arm, extras), prefix in zip(runs, prefixes, strict=True):
                log_run(rec, traj, arm, prefix, **{"every": every, **extras})
            if len(runs) > 1:
                with catch_and_log_exceptions(context="twolink.tracing.overview", strict=True):
                    _log_overview(rec, runs, prefixes, titles, groups, every)
            rec.flush()
        finally:
            # Close the file sink (writes the footer) before the rename or the cleanup.
            rec.disconnect()
    return path


def _log_overview(
    rec: rr.RecordingStream,
    runs: list[tuple[str, Trajectory, ArmParams, dict[str, Any]]],
    prefixes: list[str],
    titles: list[str],
    groups: list[str],
    every: int,
) -> None:
    # Copies of every run's angles, each its own entity with the run's name and its group's
    # colour: a run's own entities keep the per-joint colours of its tab.
    colors = {g: GROUP_COLORS[k % len(GROUP_COLORS)] for k, g in enumerate(dict.fromkeys(groups))}
    references: set[bytes] = set()
    for (_, traj, _, extras), prefix, title, group in zip(
        runs, prefixes, titles, groups, strict=True
    ):
        idx = sample_indices(len(traj.t), extras.get("every", every))
        times = [_time_column(traj.t[idx])]
        for j in (1, 2):
            path = _path(OVERVIEW, f"joint{j}", prefix)
            series = [(path, traj.q[idx, j - 1], f"{title} ({group})", colors[group], 1.5)]
            ref = traj.q_ref[idx, j - 1]
            key = b"%d" % j + traj.t[idx].tobytes() + ref.tobytes()
            if key not in references:  # an experiment's reference once, not per controller
                references.add(key)
                series.append((f"{path}/reference", ref, f"{title} reference", REFERENCE_COLOR, 1))
            for entity_path, values, name, color, width in series:
                rec.log(
                    entity_path,
                    rr.SeriesLines(names=name, colors=[color], widths=[width]),
                    static=True,
                    strict=True,
                )
                rec.send_columns(
                    entity_path,
                    indexes=times,
                    columns=rr.Scalars.columns(scalars=values),
                    strict=True,
                )


def read_recording(path: str | os.PathLike) -> pd.DataFrame:
    """Every scalar time series of a recording, one column per entity, indexed by time.

    A reader for analysis without a viewer: columns are entity paths without the leading
    slash (``"run/joint1/angle"``, ``"rigid/table2/CTC/joint1/torque"``), the index is
    ``time_s``; a series missing at some time is NaN there. A recording keeps the samples
    its writer kept (``every``; see the file's writer); ``trajectory.npz`` beside a run's
    recording has every sample (:meth:`twolink.sim.Trajectory.load`).

    Parameters
    ----------
    path : path-like
        A ``.rrd`` file written by :func:`write_recording`.

    Returns
    -------
    pandas.DataFrame
    """
    import pandas as pd
    from rerun.chunk import RrdReader

    pieces: dict[str, list[pd.Series]] = {}
    for chunk in RrdReader(path).store().stream():
        if chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        if "Scalars:scalars" not in batch.schema.names or TIMELINE not in batch.schema.names:
            continue
        t = batch.column(TIMELINE).to_numpy().astype("timedelta64[ns]").astype(np.int64) / 1e9
        col = batch.column("Scalars:scalars").flatten()
        pieces.setdefault(chunk.entity_path.lstrip("/"), []).append(
            pd.Series(col.to_numpy(zero_copy_only=False), index=t)
        )
    columns = {name: pd.concat(parts).sort_index() for name, parts in sorted(pieces.items())}
    frame = pd.DataFrame(columns)
    frame.index.name = "time_s"
    return frame


def _check_prefixes(prefixes: list[str]) -> None:
    for i, a in enumerate(prefixes):
        for b in prefixes[i + 1 :]:
            if a == b or not a or not b or a.startswith(b + "/") or b.startswith(a + "/"):
                raise ValueError(
                    f"run prefixes must be distinct, non-empty and not nested, got {a!r} and {b!r}"
                )
