"""The flexible-joint map: joint stiffness x closed-loop bandwidth, per controller.

A sweep over ``k`` and ``wn`` (``runs/sweeps/flexible_map.toml``) gives one run per
(stiffness, bandwidth, controller). Each cell is classified (:func:`map_cells`):

- ``settled``: met the spec (``twolink.simulation.outcome``: within 2 % of the move at the end),
  with Ts to the target and Mp, the worse of the moving joints;
- ``off target``: bounded, not settled (a slow or biased response);
- ``unstable``: not settled, its loop linearised at the target unstable (σ > 0,
  :mod:`twolink.simulation.stability`), though the run may still end calm;
- ``limit cycle``: not settled, with an oscillation larger than the 2 % band at the end
  of the run (``oscillation_rad``; a linearly unstable loop held bounded by the torque
  limit);
- ``diverged``: the simulation left its bounds (or failed).

:func:`flexible_map_table` says, per controller and bandwidth, the softest joint at which
it still meets the spec (every stiffer one too), and the softest at which Ts and Mp stay
within the rigid arm's (:func:`rigid_reference`); :func:`flexible_map_figure` draws one
heatmap per controller.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from twolink.arm.params import TWIST_LIMIT
from twolink.sweep.figures import pyplot
from twolink.sweep.results import load_results, sweep_meta

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from twolink.sweep.plan import SweepPlan

__all__ = ["CELL_KINDS", "disagreements", "flexible_map_figure", "flexible_map_table",
           "map_cells", "rigid_reference"]  # fmt: skip

CELL_KINDS = ("settled", "off target", "unstable", "limit cycle", "diverged")
BAND = 0.02  # the 2 % band, as a share of the move (the spec's)
# "Within the rigid arm's values": Ts at most this much later, Mp at most this much higher.
TS_MARGIN = (1.1, 0.05)  # factor, s
MP_MARGIN = 1.0  # percentage points


def _frame(results: pd.DataFrame | str | Path) -> pd.DataFrame:
    r = results if isinstance(results, pd.DataFrame) else load_results(results)
    varied = sweep_meta(r).parameters
    for p in ("k", "wn"):
        if p not in varied:
            raise ValueError(
                f"a flexible map sweeps 'k' and 'wn'; this sweep varied {list(varied)}"
            )
    return r


def _worst(r: pd.DataFrame, joints: tuple[int, ...], key: str) -> np.ndarray:
    cols = [r[f"joint{j}_{key}"].to_numpy(float) for j in joints]
    stacked = np.vstack(cols) if cols else np.full((1, len(r)), np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN column: NaN
        return np.where(np.isnan(stacked).any(axis=0), np.nan, np.nanmax(stacked, axis=0))


def map_cells(results: pd.DataFrame | str | Path, move: float = 1.0) -> pd.DataFrame:
    """One row per (controller, k, wn): ``kind`` (:data:`CELL_KINDS`), ``Ts`` (to the
    target, s) and ``Mp`` (%) of the worse moving joint, ``torque`` (peak, N m) and
    ``twist`` (the largest spring twist, rad) over both joints. ``move`` [rad] is the
    largest step, whose 2 % is the band a limit cycle exceeds."""
    r = _frame(results)
    joints = sweep_meta(r).joints
    osc = _worst(r, joints, "oscillation_rad")
    met = r["outcome"].to_numpy(str) == "met spec"  # a decaying oscillation can meet it
    sigma = r["joint1_linear_growth_1_s"].to_numpy(float)
    kind = np.where(osc > BAND * move, "limit cycle", "off target")
    kind = np.where(sigma > 0, "unstable", kind)  # σ decides where the loop has one
    kind = np.where(met, "settled", kind)
    kind = np.where(r["status"].to_numpy(str) != "ok", "diverged", kind)
    # Simulation against linear stability, where the loop has a growth rate σ at the
    # target: a run that ends calm (in band, not growing) on a loop with σ > 0 (the
    # unstable mode still too small to see), or one whose error grows at the end of a
    # loop with σ < 0. (A stable loop still outside the band at the end is slow, no
    # disagreement.)
    tail = _worst(r, (1, 2), "tail_error_rad")
    growth = _worst(r, (1, 2), "tail_growth")
    ok = r["status"].to_numpy(str) == "ok"
    calm = ok & (tail <= BAND * move) & (growth <= 1.25)
    growing = ok & (growth > 1.25)
    disagree = np.isfinite(sigma) & ((calm & (sigma > 0)) | (growing & (sigma < 0)))
    return pd.DataFrame({
        "controller": r["controller"].to_numpy(str),
        "k": r["k"].to_numpy(float),
        "wn": r["wn"].to_numpy(float),
        "kind": kind,
        "Ts": _worst(r, joints, "settling_time_target_s"),
        "Mp": _worst(r, joints, "overshoot_pct"),
        "torque": _worst(r, (1, 2), "torque_peak_Nm"),
        "twist": _worst(r, (1, 2), "max_twist_rad"),
        "sigma": sigma,
        "growth": growth,
        "disagree": disagree,
    })  # fmt: skip


def disagreements(cells: pd.DataFrame) -> list[str]:
    """The report's lines on cells where the simulated run and linear stability at the
    target disagree (:func:`map_cells`' ``disagree``): a run that ends calm on a loop
    that is linearly unstable (the mode still too small to see), or the reverse."""
    odd = cells[cells["disagree"]]
    if odd.empty:
        return ["Simulation and linear stability at the target agree in every cell."]
    lines = [
        f"Simulation and linear stability at the target disagree in {len(odd)} cells (the "
        "outcome counts the linear verdict: a calm end of a linearly unstable loop is off "
        "target):",
        "",
        "| controller | k [N·m/rad] | ωn [rad/s] | σ [1/s] | simulated |",
        "|---|---|---|---|---|",
    ]
    for c in odd.itertuples():
        sim = "calm at the end" if c.sigma > 0 else f"error growing ×{c.growth:.3g} at the end"
        lines.append(f"| {c.controller} | {c.k:g} | {c.wn:g} | {c.sigma:+.3g} | {sim} |")
    return lines


def rigid_reference(plan: SweepPlan, controller: str = "CTC") -> dict[float, tuple[float, float]]:
    """Ts [s] and Mp [%] (worse moving joint) of ``controller`` on the rigid arm, per
    bandwidth of the map's ``wn`` grid: what "within the rigid arm's values" compares to."""
    from twolink.simulation.config import scenario_from_dict
    from twolink.simulation.experiment import iter_scenarios, measure

    wn_grid = [float(wn) for wn in next(p.values for p in plan.parameters if p.name == "wn")]
    scenarios = []
    for wn in wn_grid:
        data = plan.controller_data(controller, {"wn": wn})
        # The rigid arm: no springs, and so no error in them (the masses' and g's stay).
        plant = {k: v for k, v in data.get("plant", {}).items() if k != "flexibility"}
        if "scale" in plant:
            plant["scale"] = {k: v for k, v in plant["scale"].items() if k not in ("k", "j")}
        data["plant"] = plant
        scenarios.append(scenario_from_dict(data, plan.file))
    out = {}
    for i, traj in iter_scenarios(scenarios):  # one batch: each arm as run_scenario's
        if isinstance(traj, Exception):
            raise traj
        m = measure(scenarios[i], traj)
        ts = [m.settling_target[j - 1] for j in plan.joints]
        mp = [m.step[j - 1].overshoot for j in plan.joints]
        out[wn_grid[i]] = (max(ts), max(mp))
    return {wn: out[wn] for wn in wn_grid}


def _matches_rigid(ts: float, mp: float, rigid: tuple[float, float]) -> bool:
    rts, rmp = rigid
    return ts <= TS_MARGIN[0] * rts + TS_MARGIN[1] and mp <= rmp + MP_MARGIN


def _softest(cells: pd.DataFrame, ok: np.ndarray) -> float:
    """The smallest k such that every k at or above it is ``ok`` (NaN if the stiffest is
    not): the map's edge seen from the stiff end."""
    order = np.argsort(-cells["k"].to_numpy(float))
    k = cells["k"].to_numpy(float)[order]
    good = ok[order]
    if not good.size or not good[0]:
        return math.nan
    bad = np.flatnonzero(~good)
    return float(k[bad[0] - 1] if bad.size else k[-1])


def _fmt_k(k: float) -> str:
    return "—" if math.isnan(k) else f"{k:.4g}"


def flexible_map_table(
    results: pd.DataFrame | str | Path,
    rigid: Mapping[float, tuple[float, float]] | None = None,
    move: float = 1.0,
) -> str:
    """Markdown table: per bandwidth (rows) and controller (columns), the softest joint
    stiffness [N m/rad] down to which the controller meets the spec at every stiffer
    joint, and in brackets the softest down to which its Ts and Mp also stay within the
    rigid arm's (``rigid``: {wn: (Ts, Mp)}, e.g. :func:`rigid_reference`; Ts at most 10 %
    + 0.05 s later, Mp at most 1 point higher). "—": not even at the stiffest joint;
    "never": the rigid arm's Ts, where it never settles to the target."""
    r = _frame(results)
    cells = map_cells(r, move)
    controllers = sweep_meta(r).controllers
    head = ["ωn [rad/s]"]
    if rigid is not None:
        head.append("rigid arm Ts [s], Mp [%]")
    head += [f"{c}: k ≥ (rigid-like k ≥)" if rigid is not None else f"{c}: k ≥"
             for c in controllers]  # fmt: skip
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for wn in np.unique(cells["wn"]):
        row = [f"{wn:g}"]
        if rigid is not None:
            rts, rmp = rigid[float(wn)]
            # NaN Ts: the rigid arm never enters the band (a model error it cannot hold)
            row.append(f"{'never' if math.isnan(rts) else f'{rts:.3g}'}, {rmp:.2g}")
        for c in controllers:
            sub = cells[(cells["controller"] == c) & (cells["wn"] == wn)]
            met = (sub["kind"] == "settled").to_numpy()
            text = _fmt_k(_softest(sub, met))
            if rigid is not None:
                pairs = zip(sub["Ts"], sub["Mp"], strict=True)
                like = met & np.array(
                    [_matches_rigid(ts, mp, rigid[float(wn)]) for ts, mp in pairs]
                )
                text += f" ({_fmt_k(_softest(sub, like))})"
            row.append(text)
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines) + "\n"


def flexible_map_figure(results: pd.DataFrame | str | Path, move: float = 1.0) -> Figure:
    """One heatmap per controller: stiffness k across (stiff on the left), bandwidth ωn
    up; a settled cell's colour is its Ts to the target (number: Mp in %), an off-target
    cell is grey, a limit cycle or divergence is a red ×; a dot marks a spring twisted
    beyond ``TWIST_LIMIT``."""
    from matplotlib.colors import ListedColormap

    plt = pyplot()
    r = _frame(results)
    cells = map_cells(r, move)
    controllers = sweep_meta(r).controllers
    ks = np.unique(cells["k"])[::-1]
    wns = np.unique(cells["wn"])
    ncols = min(3, len(controllers))
    nrows = -(-len(controllers) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.2 * ncols, 3.4 * nrows), squeeze=False,
                             layout="constrained")  # fmt: skip
    settled = cells[cells["kind"] == "settled"]["Ts"]
    vmax = float(np.nanmax(settled)) if settled.notna().any() else 1.0
    image: Any = None
    for ax, c in zip(axes.ravel(), controllers, strict=False):
        sub = cells[cells["controller"] == c]
        ts = np.full((len(wns), len(ks)), np.nan)
        grey = np.full_like(ts, np.nan)
        for row in sub.itertuples():
            i, j = int(np.searchsorted(wns, row.wn)), int(np.flatnonzero(ks == row.k)[0])
            if row.kind == "settled":
                ts[i, j] = row.Ts
                ax.text(j, i, f"{row.Mp:.0f}", ha="center", va="center", fontsize=6)
            elif row.kind == "off target":
                grey[i, j] = 1.0
            else:
                ax.plot(j, i, "x", color="red", ms=7, mew=2)
            if row.twist > TWIST_LIMIT:
                ax.plot(j + 0.32, i + 0.3, ".", color="black", ms=3)
        ax.imshow(grey, cmap=ListedColormap(["0.8"]), origin="lower", aspect="auto")
        image = ax.imshow(ts, cmap="viridis", origin="lower", aspect="auto", vmin=0, vmax=vmax)
        ax.set_xticks(range(len(ks)), [f"{k:.3g}" for k in ks], rotation=45, fontsize=7)
        ax.set_yticks(range(len(wns)), [f"{w:g}" for w in wns], fontsize=7)
        ax.set_xlabel("joint stiffness k [N·m/rad]")
        ax.set_ylabel("bandwidth ωn [rad/s]")
        ax.set_title(c)
    for ax in axes.ravel()[len(controllers) :]:
        ax.set_visible(False)
    if image is not None:
        fig.colorbar(image, ax=axes.ravel().tolist(), label="Ts to the target [s]")
    fig.suptitle(
        "Flexible joints: settled (colour Ts, number Mp %), grey off target, × unstable, a "
        "limit cycle or diverged, "
        f"· twist > {TWIST_LIMIT} rad",
        fontsize=9,
    )
    return fig
