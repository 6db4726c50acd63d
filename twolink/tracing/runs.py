"""One run in a rerun recording: time series, phase plane and the arm moving in 3D.

The tracing package is the only one that imports ``rerun``; everything else imports it
lazily, so runs work without rerun installed. Nothing is logged while a run is computed: a
finished :class:`~twolink.simulation.sim.Trajectory` is sent in columns (``send_columns``) along
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
    P/phase/joint{j}/fired_rule  TextLog  the fired rule, at each change (if given)
    P/phase/centres          Points2D   static: FCM cluster centres (if given; per-joint
                                        centres go to P/phase/joint{j}/centres), each named
                                        by its rule where the caller gives the names
    P/phase/axes             LineStrips2D  static: the e and ė axes through the origin,
                                        spanning every path and centre
    P/phase/axes/names       Points2D   static: each axis's name and unit at its positive
                                        end ("e [rad] →", "ė [rad/s] ↓": the viewer's y
                                        axis points down)
    P/phase/axes/scale       Points2D   static: with ``phase_scale``, the note "normalised:
                                        ke = …/rad, kde = … s/rad", centred above the plane
    P/phase/axes/ticks       Points2D   static: round values along both axes, labelled
    P/arm/base               Points3D   static: the shoulder
    P/arm/links              LineStrips3D  base -> elbow -> tip per sample
    P/arm/joints             Points3D   base, elbow, tip per sample
    P/arm/bent               LineStrips3D  links that bend (``bent`` given): hubs ->
                                        hinges -> tip per sample (the rigid strip above
                                        stays: where the hub angles point)
    P/arm/bent/hinges        Points3D   the hinges of the bent links per sample

A recording of several runs also holds, for the "all runs" overview::

    all_runs/joint{j}/P              Scalars  q_j of run P, named after the run, in its
                                              group's (controller's) colour family, a
                                              shade of its own
    all_runs/joint{j}/P/reference    Scalars  its reference, grey and thinner (each
                                              distinct one once, under its first run)

The arm moves in the paper's (x, y) plane, which is (x, z) in 3D (z up, as MuJoCo).
See ``docs/tracing.md``.
"""

from __future__ import annotations

import uuid
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import rerun as rr
from rerun.error_utils import catch_and_log_exceptions

from twolink.arm.params import ArmParams
from twolink.simulation.sim import Trajectory

if TYPE_CHECKING:
    pass

TIMELINE = "time"
JOINT_COLORS = ((31, 119, 180), (255, 127, 14))  # joint 1 blue, joint 2 orange
REFERENCE_COLOR = (140, 140, 140)
MOTOR_COLOR = (44, 160, 44)
CENTRE_COLOR = (214, 39, 40)
ARM_COLOR = (60, 60, 60)
AXIS_COLOR = (110, 110, 110)
AXIS_TICKS = 5  # about this many labelled values per phase-plane axis

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


def nice_ticks(lo: float, hi: float, count: int = AXIS_TICKS) -> np.ndarray:
    """Round values (1, 2 or 5 times a power of ten apart) covering [lo, hi], about
    ``count`` of them; [lo] alone for an empty or non-finite span."""
    span = hi - lo
    if not (np.isfinite(span) and span > 0):
        return np.array([lo if np.isfinite(lo) else 0.0])
    raw = span / (count + 1)
    power = 10.0 ** np.floor(np.log10(raw))
    step = next(m * power for m in (1, 2, 5, 10) if m * power >= raw * (1 - 1e-9))
    first, last = np.ceil(lo / step), np.floor(hi / step)
    return np.arange(first, last + 1) * step + 0.0  # + 0.0: no "-0"


def _axis_names(phase_scale: tuple[float, float]) -> tuple[str, str, str | None]:
    """The phase plane's axis names with their units, and for a normalised plane the
    note that says how (drawn centred above the plane: the viewer centres a label on its
    point, and its y axis points down)."""
    ke, kde = phase_scale
    if (ke, kde) == (1.0, 1.0):
        return "e [rad] →", "ė [rad/s] ↓", None
    note = f"normalised: ke = {ke:.3g}/rad, kde = {kde:.3g} s/rad"
    return "ke·e →", "kde·ė ↓", note


def _phase_axes(
    prefix: str, planes: Sequence[np.ndarray], centres: Sequence[np.ndarray], names
) -> list[tuple[str, Any]]:
    """The static entities that draw the phase plane's axes: (path, archetype) pairs."""
    pts = np.concatenate([np.asarray(p, dtype=float).reshape(-1, 2) for p in (*planes, *centres)])
    pts = pts[np.isfinite(pts).all(axis=1)]
    lo = np.minimum(pts.min(axis=0), 0.0) if len(pts) else np.array([-1.0, -1.0])
    hi = np.maximum(pts.max(axis=0), 0.0) if len(pts) else np.array([1.0, 1.0])
    pad = 0.08 * np.where(hi - lo > 0, hi - lo, 1.0)
    lo, hi = lo - pad, hi + pad
    axes = rr.LineStrips2D(
        [[[lo[0], 0.0], [hi[0], 0.0]], [[0.0, lo[1]], [0.0, hi[1]]]],
        colors=[AXIS_COLOR],
        radii=rr.Radius.ui_points(0.75),
    )
    x_name, y_name, note = names
    ends = rr.Points2D(
        [[hi[0], 0.0], [0.0, hi[1]]],
        labels=[x_name, y_name],
        colors=[AXIS_COLOR],
        radii=rr.Radius.ui_points(2.0),
        show_labels=True,
    )
    tx = [t for t in nice_ticks(lo[0] + pad[0], hi[0] - pad[0]) if t != 0]
    ty = [t for t in nice_ticks(lo[1] + pad[1], hi[1] - pad[1]) if t != 0]
    ticks = rr.Points2D(
        [[t, 0.0] for t in tx] + [[0.0, t] for t in ty],
        labels=[f"{t:g}" for t in (*tx, *ty)],
        colors=[AXIS_COLOR],
        radii=rr.Radius.ui_points(2.5),
        show_labels=True,
    )
    base = _path(prefix, "phase", "axes")
    out = [(base, axes), (f"{base}/names", ends), (f"{base}/ticks", ticks)]
    if note:
        corner = rr.Points2D([[(lo[0] + hi[0]) / 2, lo[1]]], labels=[note], colors=[AXIS_COLOR],
                             radii=rr.Radius.ui_points(1.0), show_labels=True)  # fmt: skip
        out.append((f"{base}/scale", corner))
    return out


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
    bent: np.ndarray | None = None,
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
    bent : ndarray (N, P, 2), optional
        Links that bend: the points of each sample's bent arm in the paper's plane
        (:attr:`twolink.simulation.links_sim.LinkRun.points`).
    """
    if bent is not None and (np.ndim(bent) != 3 or len(bent) != len(traj.t)):
        raise ValueError(f"bent must be (N, P, 2) with N = {len(traj.t)} samples")
    # Check everything before sending anything: a live stream gets a whole run or none.
    n = _check_trajectory(traj)
    idx = sample_indices(n, every)
    centres_to_log = _centre_points(prefix, centres, centre_labels)
    rules = _rules_per_joint(fired_rules, n)
    ke, kde = (float(s) for s in phase_scale)
    if not (np.isfinite(ke) and np.isfinite(kde)):
        raise ValueError(f"phase_scale must be finite, got {phase_scale!r}")
    times = [_time_column(traj.t[idx])]
    planes = [np.stack([ke * traj.e[idx, j], kde * traj.de[idx, j]], axis=1) for j in range(2)]

    # Strict for this scope only (thread-local): turn rerun's swallowed errors into raises.
    with catch_and_log_exceptions(context="twolink.tracing.log_run", strict=True):
        _log_status(rec, traj, prefix, name)
        for j in range(2):
            _log_joint_series(rec, traj, prefix, j, idx, times)
            _log_phase_path(rec, traj, prefix, j, idx, times, planes[j], rules)
        for path, archetype in _phase_axes(
            prefix, planes, [pts for _, pts, _ in centres_to_log], _axis_names((ke, kde))
        ):
            rec.log(path, archetype, static=True, strict=True)
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
        _log_arm(rec, arm_points(arm, traj.q[idx]), prefix, times)
        if bent is not None:
            _log_bent(rec, np.asarray(bent, dtype=float)[idx], prefix, times)


def _log_bent(rec, plane: np.ndarray, prefix: str, times) -> None:
    """The bent links in 3D (the paper's (x, y) is (x, z)): a strip and its hinges."""
    pts = np.zeros((*plane.shape[:2], 3))
    pts[..., 0], pts[..., 2] = plane[..., 0], plane[..., 1]
    path = _path(prefix, "arm", "bent")
    rec.log(
        path,
        rr.LineStrips3D.from_fields(colors=[JOINT_COLORS[0]], radii=[0.012]),
        static=True,
        strict=True,
    )
    rec.send_columns(path, indexes=times, columns=rr.LineStrips3D.columns(strips=pts), strict=True)
    hinges = _path(prefix, "arm", "bent", "hinges")
    rec.log(hinges, rr.Points3D.from_fields(colors=[JOINT_COLORS[1]], radii=[0.018]), static=True)
    rec.send_columns(
        hinges,
        indexes=times,
        columns=rr.Points3D.columns(positions=pts.reshape(-1, 3)).partition(
            [pts.shape[1]] * len(pts)
        ),
        strict=True,
    )


def _log_scalars(rec, path: str, times, values: np.ndarray, label: str, color) -> None:
    # Style once (static), values as one column: the viewer joins them per entity.
    rec.log(path, rr.SeriesLines(names=label, colors=[color]), static=True, strict=True)
    rec.send_columns(path, indexes=times, columns=rr.Scalars.columns(scalars=values), strict=True)


def _log_status(rec, traj: Trajectory, prefix: str, name: str | None) -> None:
    text = traj.status if not traj.message else f"{traj.status}: {traj.message}"
    if name:
        text = f"{name}: {text}"
    rec.log(
        _path(prefix, "status"),
        rr.TextLog(text, level="INFO" if traj.ok else "WARN"),
        static=True,
        strict=True,
    )


def _log_joint_series(rec, traj: Trajectory, prefix: str, j: int, idx, times) -> None:
    """Joint ``j``'s angle, reference, motor angle (flexible joints), error, rate, torque."""
    joint, color, sub = f"joint{j + 1}", JOINT_COLORS[j], "₁₂"[j]
    series = [
        ("angle", traj.q[idx, j], f"θ{sub}", color),
        ("reference", traj.q_ref[idx, j], f"θ{sub} ref", REFERENCE_COLOR),
    ]
    if len(traj.motor_q) == len(traj.t):  # flexible joints
        series.append(("motor_angle", traj.motor_q[idx, j], f"motor {sub}", MOTOR_COLOR))
    series += [
        ("error", traj.e[idx, j], f"e{sub}", color),
        ("error_rate", traj.de[idx, j], f"ė{sub}", color),
        ("torque", traj.tau[idx, j], f"τ{sub}", color),
    ]
    for what, values, label, colour in series:
        _log_scalars(rec, _path(prefix, joint, what), times, values, label, colour)


def _log_phase_path(rec, traj: Trajectory, prefix: str, j: int, idx, times, plane, rules):
    """Joint ``j``'s phase-plane path, its moving state and (where given) the fired rules."""
    joint, color, sub = f"joint{j + 1}", JOINT_COLORS[j], "₁₂"[j]
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
        # the log lists the rule changes (a readable sequence over time), not a row
        # per sample; the phase-plane points carry every sample's label
        changes = [k for k in range(len(idx)) if k == 0 or labels[k] != labels[k - 1]]
        rec.send_columns(
            _path(prefix, "phase", joint, "fired_rule"),
            indexes=[_time_column(traj.t[idx[changes]])],
            columns=rr.TextLog.columns(text=[f"θ{sub}: {labels[k]}" for k in changes]),
            strict=True,
        )
    rec.send_columns(state, indexes=times, columns=cols, strict=True)


def _log_arm(rec, pts: np.ndarray, prefix: str, times) -> None:
    """The arm in 3D: its base, and its links and joints moving (one strip of three points
    per sample)."""
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
    rec.send_columns(links, indexes=times, columns=rr.LineStrips3D.columns(strips=pts), strict=True)
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
        columns=rr.Points3D.columns(positions=pts.reshape(-1, 3)).partition([3] * len(pts)),
        strict=True,
    )
