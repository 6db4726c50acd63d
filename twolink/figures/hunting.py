"""Stick-slip hunting beside a clean stop (docs/reproduction.md, "The lab arm"): CTC with
integral action and CTC on the same arm with friction at the harsh end of the lab arm's
ranges, the base scenario's gains, a 0.5 rad step of θ1 held for 20 s. The integrator winds up to
breakaway, the joint slips past the target and sticks again; CTC stops short by its dead
band and stays there (docs/model.md, "Friction")."""

from __future__ import annotations

from pathlib import Path

from twolink.figures.plots import fixed_layout, plt, save_figure
from twolink.simulation.vocabulary import controller_styles

__all__ = [
    "HUNTING_FIGURE",
    "HUNTING_FRICTION",
    "hunting_figure",
    "hunting_runs",
    "save_hunting_figure",
]

HUNTING_FIGURE = "figures/hunting.png"
# The harsh end of runs/sweeps/lab.toml's ranges (most friction, sharpest dip):
# F_c (2, 0.5) N m, F_s = 1.5 F_c, v_s = 0.01 rad/s
HUNTING_FRICTION = {"coulomb": [2.0, 0.5], "breakaway": [3.0, 0.75], "stribeck_velocity": 0.01}
CONTROLLERS = {"CTC-I": "ctc_integral", "CTC": "ctc"}


def hunting_runs(seconds: float = 20.0) -> dict:
    """Name -> trajectory of each controller on the base scenario with
    :data:`HUNTING_FRICTION` and a 0.5 rad step of θ1 (θ2 held at 0)."""
    from twolink.simulation.config import load_scenario
    from twolink.simulation.experiment import run_scenario

    runs = {}
    for name, kind in CONTROLLERS.items():
        s = load_scenario(
            "paper/base",
            {
                "duration": seconds,
                "plant": {"friction": HUNTING_FRICTION},
                "reference": {"joint1": {"kind": "step", "final": 0.5}},
                "controller": {"kind": kind},
            },
        )
        runs[name] = run_scenario(s)
    return runs


def hunting_figure(runs: dict) -> plt.Figure:
    """Each joint's error [mrad] against time, one curve per controller."""
    fig, axes = plt.subplots(2, 1, figsize=(8.0, 5.5), sharex=True)
    styles = controller_styles(list(runs))
    for j, ax in enumerate(axes):
        for name, run in runs.items():
            e = run.q_ref[:, j] - run.q[:, j]
            colour, dash = styles[name]
            ax.plot(run.t, 1e3 * e, color=colour, ls=dash, label=name)
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.set_ylabel(f"e{j + 1} [mrad]")
        ax.grid(alpha=0.3)
    axes[0].set_ylim(-30, 30)
    axes[1].set_ylim(-30, 30)
    axes[-1].set_xlabel("t [s]")
    axes[0].legend(loc="upper right")
    f = HUNTING_FRICTION
    fig.suptitle(
        "Friction on the nominal arm: CTC-I hunts (stick-slip), CTC stops short\n"
        f"F_c = {f['coulomb']} N·m, F_s = {f['breakaway']} N·m, v_s = "
        f"{f['stribeck_velocity']} rad/s; θ1 steps 0.5 rad at t = 0",
        fontsize=10,
    )
    return fixed_layout(fig, top=0.88, bottom=0.1, left=0.1, right=0.97, hspace=0.12)


def save_hunting_figure(path: str | Path) -> None:
    """Run :func:`hunting_runs` and save :func:`hunting_figure` at ``path``."""
    save_figure(hunting_figure(hunting_runs()), path)
