"""Matplotlib figures of finished results; computation never plots.

Uses the non-interactive Agg backend: runs are headless.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from twolink.io import atomic_path  # noqa: E402
from twolink.sim import Trajectory  # noqa: E402

JOINT_COLOURS = ("tab:blue", "tab:orange")


def save_figure(fig: Figure, path: str | Path, dpi: int = 110) -> None:
    """Save a figure as PNG atomically and close it."""
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=dpi, format="png", bbox_inches="tight")
    plt.close(fig)


def _per_joint(traj: Trajectory, title: str, ylabel: str, series) -> Figure:
    fig, axes = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True, constrained_layout=True)
    for j, ax in enumerate(axes):
        for label, values, style in series(j):
            ax.plot(traj.t, values, style, label=label, lw=1.4)
        ax.set_ylabel(f"joint {j + 1}: {ylabel}")
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(title)
    return fig


def run_figures(traj: Trajectory, title: str = "") -> dict[str, Figure]:
    """Angles vs reference, errors, and torques of one run."""
    note = "" if traj.ok else f" ({traj.status})"
    return {
        "angles": _per_joint(
            traj,
            f"{title}: joint angles{note}",
            "angle [rad]",
            lambda j: [
                ("reference", traj.q_ref[:, j], "k--"),
                (f"θ{j + 1}", traj.q[:, j], JOINT_COLOURS[j]),
            ],
        ),
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
