"""Matplotlib figures of finished results; computation never plots.

Uses the non-interactive Agg backend: runs are headless.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.layout_engine import PlaceHolderLayoutEngine  # noqa: E402

from twolink.foundation.io import atomic_path  # noqa: E402
from twolink.simulation.vocabulary import controller_styles, split_by_scale  # noqa: E402

if TYPE_CHECKING:
    from twolink.simulation.sim import Trajectory

JOINT_COLOURS = ("tab:blue", "tab:orange")


def save_figure(fig: Figure, path: str | Path, dpi: int = 110) -> None:
    """Save a figure as PNG atomically and close it. A figure with a layout engine
    (constrained layout, or a placeholder on one laid out by hand) is saved as laid out: a
    tight bounding box would draw it twice. One laid out by hand is drawn once (matplotlib
    draws a figure with a layout engine once before it prints it; the same pixels)."""
    engine = fig.get_layout_engine()
    tight = "tight" if engine is None else None
    if isinstance(engine, PlaceHolderLayoutEngine):  # laid out by hand (fixed_layout):
        fig.set_layout_engine(None)  # with an engine, savefig draws it once more first
    with atomic_path(path, suffix=".png") as tmp:
        # the mark that lets a later run overwrite this file (twolink.foundation.io.WRITTEN_BY)
        mark = {"Software": "written by twolink"}
        fig.savefig(tmp, dpi=dpi, format="png", bbox_inches=tight, metadata=mark)
    plt.close(fig)


def fixed_layout(fig: Figure, **margins: float) -> Figure:
    """Lay ``fig`` out by hand (``subplots_adjust`` margins) and mark it laid out, so that
    :func:`save_figure` draws it once as is. For the figures every reproduction draws:
    constrained layout costs about a third of their drawing time."""
    fig.subplots_adjust(**margins)
    fig.set_layout_engine(PlaceHolderLayoutEngine(adjust_compatible=True, colorbar_gridspec=True))
    return fig


def _per_joint(traj: Trajectory, title: str, ylabel: str, series) -> Figure:
    fig, axes = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True, constrained_layout=True)
    for j, ax in enumerate(axes):
        for label, values, style in series(j):
            ax.plot(traj.t, values, style, label=label, lw=1.4)
        ax.set_ylabel(f"joint {j + 1}: {ylabel}")
        ax.grid(alpha=0.3)
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(title)
    return fig


def angles_figure(traj: Trajectory, title: str = "") -> Figure:
    """Joint angles against their references, one panel per joint."""
    note = "" if traj.ok else f" ({traj.status})"
    return _per_joint(
        traj,
        f"{title}: joint angles{note}",
        "angle [rad]",
        lambda j: [
            ("reference", traj.q_ref[:, j], "k--"),
            (f"θ{j + 1}", traj.q[:, j], JOINT_COLOURS[j]),
        ],
    )


def run_figures(traj: Trajectory, title: str = "") -> dict[str, Figure]:
    """Angles vs reference, errors, and torques of one run."""
    return {
        "angles": angles_figure(traj, title),
        "errors": _per_joint(
            traj,
            f"{title}: tracking error e = θd − θ",
            "error [rad]",
            lambda j: [(f"e{j + 1}", traj.e[:, j], JOINT_COLOURS[j])],
        ),
        "torques": _per_joint(
            traj,
            f"{title}: joint torques",
            "torque [N·m]",
            lambda j: [(f"τ{j + 1}", traj.tau[:, j], JOINT_COLOURS[j])],
        ),
    }


def save_run_plots(out: str | Path, traj: Trajectory, title: str = "") -> list[Path]:
    """Write ``angles.png``, ``errors.png`` and ``torques.png`` into ``out``."""
    paths = []
    for name, fig in run_figures(traj, title).items():
        path = Path(out) / f"{name}.png"
        save_figure(fig, path)
        paths.append(path)
    return paths


def joint_index(joint: Any) -> int:
    """The column of ``joint`` (1 or 2, as the paper numbers them) in a (N, 2) array;
    ValueError for any other joint (0 would be read as the last column, joint 2)."""
    if isinstance(joint, bool) or not isinstance(joint, int | np.integer) or joint not in (1, 2):
        raise ValueError(
            f"joint must be 1 or 2 (θ1 or θ2, as the paper numbers them), got {joint!r}"
        )
    return int(joint) - 1


def response_figure(
    trajs: dict[str, Trajectory],
    joint: int,
    title: str,
    pair: tuple[str, str] = ("FCM-CTC", "CTC"),
) -> Figure:
    """One joint's response under several controllers, with the reference (Figs 3-10),
    drawn so that the comparison the project exists for shows.

    Left, on a scale fitted to the reference and ``pair`` (the proposed controller and its
    baseline; any other FCM variant joins them): θ, the error e, and the difference of the
    pair's responses (which shows whether they differ at all, however small). Baselines
    that stay on that scale are drawn there too; those that leave it (a failing baseline's
    swings would flatten every other curve) get the right-hand panel, on their own scale,
    with a note."""
    j = joint_index(joint)
    first = next(iter(trajs.values()))
    t_ref, ref = first.t, first.q_ref[:, j]
    angles = {n: tr.q[:, j] for n, tr in trajs.items()}
    close, _, far, (lo, hi) = split_by_scale(angles, ref, pair)
    fig = plt.figure(figsize=(10.5 if far else 8.0, 6.5))
    top = 0.89 - 0.035 * max(0, title.count("\n") - 2)  # room for a title of more lines
    grid = fig.add_gridspec(3, 2 if far else 1, height_ratios=(2, 1, 1),
                            width_ratios=(2, 1) if far else None)  # fmt: skip
    ax = fig.add_subplot(grid[0, 0])
    ax_e = fig.add_subplot(grid[1, 0], sharex=ax)
    ax_d = fig.add_subplot(grid[2, 0], sharex=ax)
    fixed_layout(fig, left=0.09, right=0.97 if far else 0.8, top=top, bottom=0.08,
                 hspace=0.22, wspace=0.28)  # fmt: skip
    for upper in (ax, ax_e):
        upper.tick_params(labelbottom=False)
    ax.plot(t_ref, ref, "k--", lw=1.2, label="reference")
    # one colour and dash per controller, everywhere (twolink.simulation.vocabulary):
    # FCM-CTC dashed over CTC solid, so both show where they coincide
    styles = controller_styles(trajs)
    for name, traj in trajs.items():
        if name in far:
            continue
        colour, style = styles[name]
        label = name if traj.ok else f"{name} ({traj.status})"
        ax.plot(traj.t, traj.q[:, j], linestyle=style, color=colour, lw=1.5, label=label)
        ax_e.plot(traj.t, traj.e[:, j], linestyle=style, color=colour, lw=1.2)
    ax.set_ylim(lo, hi)
    errors = [trajs[n].e[:, j] for n in close]
    if errors:
        top = max(float(np.nanmax(np.abs(e))) for e in errors)
        ax_e.set_ylim(-1.2 * top - 1e-12, 1.2 * top + 1e-12)
    if all(n in trajs for n in pair):
        a, b = trajs[pair[0]], trajs[pair[1]]
        n = min(len(a.t), len(b.t))
        diff = a.q[:n, j] - b.q[:n, j]
        ax_d.plot(a.t[:n], diff, color=styles[pair[0]][0], lw=1.2)
        ax_d.set_ylabel(f"Δθ{joint} [rad]")
        ax_d.text(
            0.01,
            0.92,
            f"{pair[0]} − {pair[1]}: largest |Δθ{joint}| {np.nanmax(np.abs(diff)):.2g} rad",
            transform=ax_d.transAxes,
            fontsize=8,
            va="top",
            bbox={"facecolor": "white", "alpha": 0.8, "edgecolor": "none"},
        )
    ax.set_ylabel(f"θ{joint} [rad]")
    ax_e.set_ylabel(f"e{joint} = θd − θ [rad]")
    ax_d.set_xlabel("time [s]")
    for a_ in (ax, ax_e, ax_d):
        a_.grid(alpha=0.3)
    if far:
        ax_far = fig.add_subplot(grid[0:2, 1], sharex=ax)
        ax_far.plot(t_ref, ref, "k--", lw=1.0)
        for name in far:
            colour, style = styles[name]
            tr = trajs[name]
            label = name if tr.ok else f"{name} ({tr.status})"
            ax_far.plot(tr.t, tr.q[:, j], linestyle=style, color=colour, lw=1.2, label=label)
        ax_far.set_title("off the pair's scale (own scale)", fontsize=9)
        ax_far.grid(alpha=0.3)
        ax_far.legend(loc="best", fontsize=8)
        note = fig.add_subplot(grid[2, 1])
        note.axis("off")
        handles, labels = ax.get_legend_handles_labels()
        note.legend(handles, labels, loc="center", fontsize=8, frameon=False)
    else:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    ax.set_title(title)
    return fig


def phase_plane_figure(result) -> Figure:
    """The paper's Figure 2: phase-plane data, FCM centres, and the fired-rule sequence.

    ``result`` is a :class:`twolink.studies.designs.design.DesignResult`.
    """
    fig, ax = plt.subplots(figsize=(7.5, 6.5))
    fixed_layout(fig, left=0.14, right=0.97, top=0.94, bottom=0.12)
    pts = result.points
    for run in np.split(pts, result.splits):  # one line per design run
        ax.plot(run[:, 0], run[:, 1], "-", color="0.6", lw=0.8, zorder=1)
    hard = result.clustering.memberships.argmax(axis=1)
    ax.scatter(
        pts[:, 0],
        pts[:, 1],
        c=hard,
        cmap="tab10",
        s=6,
        zorder=2,
        vmin=0,
        vmax=9,
        label="phase-plane samples (by cluster)",
    )
    centres = result.clustering.centers
    ax.scatter(
        centres[:, 0],
        centres[:, 1],
        marker="X",
        s=180,
        c="k",
        zorder=4,
        label="FCM cluster centres",
    )
    for j, (x, y) in enumerate(centres):
        rule = result.engine.rules[result.kept[j]]
        ax.annotate(
            f"{rule.e},{rule.de}→{rule.u}",
            (x, y),
            xytext=(8, 8),
            textcoords="offset points",
            fontsize=9,
            weight="bold",
        )
    # label each long run of the linguistic trajectory with its rule, lightly
    for start, end, rule in result.segments():
        if end - start >= 5:
            mid = (start + end) // 2
            ax.annotate(
                f"{rule.e},{rule.de}", pts[mid], fontsize=6, color="0.35", ha="center", zorder=3
            )
    ticks = [-1, -2 / 3, -1 / 3, 0, 1 / 3, 2 / 3, 1]
    labels = ["NB", "NM", "NS", "Z", "PS", "PM", "PB"]
    ax.set_xticks(ticks, [f"{lab}\n{t:.2g}" for lab, t in zip(labels, ticks, strict=True)])
    ax.set_yticks(ticks, [f"{lab} {t:.2g}" for lab, t in zip(labels, ticks, strict=True)])
    ax.set_xlim(-1.05, 1.05)
    ax.set_ylim(-1.05, 1.05)
    ax.grid(alpha=0.3)
    ax.set_xlabel("normalised error ke·e")
    ax.set_ylabel("normalised error rate kde·ė")
    ax.set_title("Phase plane of the 7x7 fuzzy-CTC runs with FCM centres and kept rules")
    ax.legend(loc="lower left", fontsize=8)
    return fig


def membership_figure(engine) -> Figure:
    """Membership functions of e, de and u of a Mamdani engine."""
    fig, axes = plt.subplots(3, 1, figsize=(7, 6.5))
    fixed_layout(fig, left=0.1, right=0.97, top=0.93, bottom=0.08, hspace=0.45)
    for ax, (name, var) in zip(
        axes,
        (("e (normalised)", engine.e), ("ė (normalised)", engine.de), ("u (normalised)", engine.u)),
        strict=True,
    ):
        grid = var.grid
        for label, mu in zip(var.labels, var.table, strict=True):
            ax.plot(grid, mu, label=label)
        ax.set_ylabel("membership")
        ax.set_xlabel(name)
        ax.legend(ncol=7, fontsize=7, loc="upper center")
        ax.grid(alpha=0.3)
    fig.suptitle("Membership functions")
    return fig


def control_surface_figure(engines: dict[str, Any], n: int = 121) -> Figure:
    """Control surfaces u(e, de) of engines side by side (no-fire regions show as 0)."""
    import numpy as np

    fig, axes = plt.subplots(1, len(engines), figsize=(5.2 * len(engines), 4.6), squeeze=False)
    fixed_layout(fig, left=0.05, right=0.98, top=0.86, bottom=0.11, wspace=0.3)
    x = np.linspace(-1, 1, n)
    e, de = np.meshgrid(x, x)
    for ax, (name, engine) in zip(axes[0], engines.items(), strict=True):
        u = engine(e, de)
        fired = engine.firing(e, de).max(axis=-1) > 0
        im = ax.contourf(e, de, u, levels=np.linspace(-1, 1, 21), cmap="RdBu_r")
        ax.contour(e, de, fired.astype(float), levels=[0.5], colors="k", linewidths=0.8)
        ax.set_title(f"{name} ({len(engine.rules)} rules)")
        ax.set_xlabel("normalised e")
        ax.set_ylabel("normalised ė")
        fig.colorbar(im, ax=ax, label="u (normalised)")
    fig.suptitle("Control surfaces (black line: edge of the region where some rule fires)")
    return fig


def comparison_figure(
    t: np.ndarray,
    qa: np.ndarray,
    qb: np.ndarray,
    reference: np.ndarray,
    joints: tuple[int, ...],
    names: tuple[str, str],
    title: str,
    window: float | None = None,
) -> Figure:
    """Two controllers on many plants (``twolink compare``): per moving joint, every
    plant's θ under each (thin) with the median over plants (bold, each controller in its
    colour and dash, :data:`~twolink.simulation.vocabulary.CONTROLLER_STYLES`; A on top,
    dashed where the two would share a dash, so that equal medians both show) and the
    reference (black dashed); below, the difference panel, θ_A − θ_B plant by plant with
    its median and the 5-95 % band: the paired difference the table judges. The two
    upper panels show the first ``window`` seconds (the transient); the bottom one the
    difference over the whole run (left out where the window is the whole run).
    ``qa``, ``qb``: (plants, time, 2); ``reference``: (time, 2)."""
    a, b = names
    for j in joints:
        joint_index(j)
    window = float(t[-1]) if window is None else min(window, float(t[-1]))
    whole = window >= float(t[-1])  # the transient panels already show the whole run
    rows, heights = (2, (2, 1.2)) if whole else (3, (2, 1.2, 1))
    fig, axes = plt.subplots(
        rows, len(joints), figsize=(6.5 * len(joints), 2.7 * rows), squeeze=False,
        height_ratios=heights, layout="constrained",
    )  # fmt: skip
    styles = controller_styles([a, b])  # each its own colour and dash, as everywhere
    if styles[a][1] == styles[b][1]:  # A on top must not hide B's equal median
        styles[a] = (styles[a][0], ":" if styles[b][1] == "--" else "--")
    colours = {n: c for n, (c, _) in styles.items()}
    for col, j in enumerate(joints):
        ax, ax_d, ax_all = (*axes[:, col], None) if whole else axes[:, col]
        for name, q in ((b, qb), (a, qa)):
            style = styles[name][1]
            ax.plot(t, q[:, :, j - 1].T, color=colours[name], lw=0.5, alpha=0.15)
            ax.plot(t, np.nanmedian(q[:, :, j - 1], axis=0), linestyle=style, color=colours[name],
                    lw=1.8, label=f"{name}: median of {len(q)} plants")  # fmt: skip
        ax.plot(t, reference[:, j - 1], "k:", lw=1.2, label="reference")
        ax.set_ylabel(f"θ{j} [rad]")
        ax.set_title(f"θ{j}" + ("" if whole else f", the first {window:.3g} s"), fontsize=10)
        d = qa[:, :, j - 1] - qb[:, :, j - 1]
        low, high = np.nanpercentile(d, [5, 95], axis=0)
        for axis, span in ((ax_d, window), (ax_all, float(t[-1])))[: 1 if whole else 2]:
            shown = t <= span
            axis.plot(t[shown], d[:, shown].T, color="0.5", lw=0.5, alpha=0.2)
            axis.fill_between(t[shown], low[shown], high[shown], color="tab:purple", alpha=0.25,
                              label="5-95 % of plants")  # fmt: skip
            axis.plot(t[shown], np.nanmedian(d[:, shown], axis=0), color="tab:purple", lw=1.5,
                      label="median")  # fmt: skip
            axis.axhline(0.0, color="k", lw=0.8)
            axis.set_ylabel(f"{a} − {b} [rad]")
        ax.set_xlim(0.0, window)
        ax_d.set_xlim(0.0, window)
        ax_d.set_title(f"θ{j}: {a} − {b}, plant by plant", fontsize=10)
        (ax_d if whole else ax_all).set_xlabel("t [s]")
        if not whole:
            ax_all.set_title(f"the same over the whole run ({t[-1]:.3g} s)", fontsize=10)
        for axis in (ax, ax_d, *([] if whole else [ax_all])):
            axis.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8)
        ax_d.legend(loc="best", fontsize=8)
    fig.suptitle(title)
    return fig
