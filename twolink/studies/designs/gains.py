"""The gain study: how fast may the computed-torque loop be, and how fast must it be?

A grid of natural frequencies ωn (and damping ratios ζ) for the error dynamics
``ë + 2ζωn ė + ωn² e = 0`` (``kp = ωn²``, ``kd = 2ζωn``), each run on the nominal arm and on
plants drawn from the robustness sweep's uncertainty distribution, under the actuator
torque limit, on a step and on a smooth (quintic) reference of the same move. Measured
per run: the error under mismatch, overshoot, settling time to the target, the torque
demand (nominal arm, no limit) and the time spent at the limit; the integral CTC's
overshoot shows its windup. :func:`choose` applies the design rule of ``docs/control.md``
to the table; ``runs/paper/gains.toml`` is the study the reproduction runs.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from twolink.arm.params import Flexibility
from twolink.foundation.shipped import locate, runs_dir
from twolink.simulation.config import (
    ConfigError,
    TomlTable,
    expect_kind,
    merge,
    read_toml,
    scenario_from_dict,
)
from twolink.simulation.metrics import step_metrics, torque_measures

__all__ = [
    "GainStudy",
    "Choice",
    "choose",
    "load_study",
    "report_section",
    "save_study",
    "table_path",
    "gain_table",
    "load_gain_study",
    "run_gain_study",
    "tradeoff_figure",
]

DEFAULT_STUDY = runs_dir() / "paper" / "gains.toml"  # package data


@dataclass(frozen=True)
class GainStudy:
    """A gain study as its file describes it (``runs/paper/gains.toml``).

    Attributes
    ----------
    source : str
        The file it was read from.
    sweep : Path
        The sweep file whose base scenario, move and uncertainty distribution it uses.
    plants : int
        Plants drawn from that distribution (sample 0, 1, ...), besides the nominal arm.
    natural_frequencies, damping_ratios : tuple of float
        The grid [rad/s] and [-].
    integral_ratio : float
        ``ki = integral_ratio * ωn³`` for the integral CTC (docs/control.md).
    torque_limit : (float, float)
        Actuator limit per joint [N m].
    move_time : float
        Duration of the quintic that replaces the step [s].
    duration : float
        Length of each run [s].
    error_bound : float
        The design rule's bound on the final error of each joint [rad].
    quantile : float
        The share of plants that must meet it (0.95: the 95th percentile).
    sensor : dict
        The ``[sensor]`` table every run sees (docs/sensors.md); empty: the true state.
    torque_step_share : float
        The rule's bound on torque activity: the nominal arm's mean torque change per
        control period, Σ|Δτ| / periods, at most this share of each joint's limit.
    """

    source: str
    sweep: Path
    plants: int
    natural_frequencies: tuple[float, ...]
    damping_ratios: tuple[float, ...]
    integral_ratio: float
    torque_limit: tuple[float, float]
    move_time: float
    duration: float
    error_bound: float
    quantile: float
    sensor: dict = field(default_factory=dict)
    torque_step_share: float = math.inf

    def digest(self) -> str:
        """What decides the study's results: every run's scenario data and the rule's
        settings (not the files' bytes: a comment or the gains the study chose, written
        into the base scenario, do not make it stale)."""
        settings = {k: v for k, v in asdict(self).items() if k not in ("source", "sweep")}
        blob = json.dumps([settings, list(_plans(self))], sort_keys=True, default=str)
        return hashlib.sha256(blob.encode()).hexdigest()


def _numbers(t: TomlTable, key: str) -> tuple[float, ...]:
    values = t.raw(key)
    if not isinstance(values, list) or not values:
        t.fail(key, f"must be a non-empty list of numbers, got {values!r}")
    return tuple(sorted({t._checked(key, v, positive=True) for v in values}))


def load_gain_study(path: str | Path = DEFAULT_STUDY, overrides: dict | None = None) -> GainStudy:
    """Read and validate a gain-study file (or a shipped one's name); errors name the
    file and key."""
    path = locate(path)
    data = merge(read_toml(path), overrides or {})
    expect_kind(data, path, "gains")
    t = TomlTable(data, "", str(path))
    sweep = path.parent / t.string("sweep", "")
    if not t.data.get("sweep") or not sweep.is_file():
        t.fail("sweep", f"must name a sweep file, got {t.data.get('sweep')!r}")
    quantile = t.number("quantile", 0.95, positive=True)
    if quantile > 1:
        t.fail("quantile", f"must be in (0, 1], got {quantile!r}")
    plants = t.integer("plants", 20)
    if plants < 1:
        t.fail("plants", f"must be >= 1, got {plants!r}")
    from twolink.sweep.plan import too_many_samples  # (lazily, as load_sweep here)

    if problem := too_many_samples(plants):  # drawn from one sweep
        t.fail("plants", problem)
    study = GainStudy(
        source=str(path),
        sweep=sweep,
        plants=plants,
        natural_frequencies=_numbers(t, "natural_frequencies"),
        damping_ratios=_numbers(t, "damping_ratios"),
        integral_ratio=t.number("integral_ratio", 0.25, positive=True),
        torque_limit=t.pair("torque_limit", (math.inf, math.inf), positive=True),
        move_time=t.number("move_time", 2.0, positive=True),
        duration=t.number("duration", 8.0, positive=True),
        error_bound=t.number("error_bound", 0.05, positive=True),
        quantile=quantile,
        sensor=dict(t.table("sensor").data),
        torque_step_share=t.number("torque_step_share", math.inf, positive=True, allow_inf=True),
    )
    t.done()
    # The sensor table is a scenario's: validated as one (errors name this file).
    scenario_from_dict({"sensor": study.sensor, "reference": _STILL}, str(path))
    return study


_STILL = {j: {"kind": "step", "final": 0.0} for j in ("joint1", "joint2")}

# Controllers of the study: name -> (kind, uses integral action).
CONTROLLERS = {"CTC": "ctc", "CTC-I": "ctc_integral"}


def _gains(wn: float, zeta: float, kind: str, integral_ratio: float) -> dict[str, Any]:
    gains: dict[str, Any] = {"kind": kind, "kp": wn * wn, "kd": 2.0 * zeta * wn}
    if kind == "ctc_integral":
        gains["ki"] = integral_ratio * wn**3
    return gains


def _references(base: dict[str, Any], move_time: float) -> dict[str, dict[str, Any]]:
    """The sweep's move as a step and as a quintic of ``move_time`` seconds."""
    step, smooth = {}, {}
    for joint, ref in base["reference"].items():
        step[joint] = {"kind": "step", "initial": ref.get("initial", 0.0), "final": ref["final"]}
        smooth[joint] = {**step[joint], "kind": "quintic", "duration": move_time}
    return {"step": step, "quintic": smooth}


def _plans(study: GainStudy):
    """Every run of the study: (row labels, scenario data)."""
    from twolink.sweep import load_sweep

    plan = load_sweep(study.sweep, {"samples": study.plants})
    plants = [("nominal", plan.base)]
    for i in range(study.plants):
        values, noise_seed = plan.draw(i)
        plants.append((f"plant {i}", plan.sample_data(values, noise_seed)))
    references = _references(plan.base, study.move_time)
    for name, kind in CONTROLLERS.items():
        zetas = study.damping_ratios if kind == "ctc" else (1.0,)
        for zeta in zetas:
            for wn in study.natural_frequencies:
                gains = _gains(wn, zeta, kind, study.integral_ratio)
                for ref_name, ref in references.items():
                    for plant_name, data in plants:
                        for limited in (True, False) if plant_name == "nominal" else (True,):
                            limit = list(study.torque_limit) if limited else math.inf
                            labels = {
                                "controller": name,
                                "wn": wn,
                                "zeta": zeta,
                                "reference": ref_name,
                                "plant": plant_name,
                                "limited": limited,
                            }
                            # The study's controller and move replace the base's whole.
                            controller = {**gains, "torque_limit": limit}
                            run = {"controller": controller, "reference": ref}
                            if study.sensor:
                                run["sensor"] = study.sensor
                            yield labels, {**data, **run, "duration": study.duration}


def _row(labels: dict[str, Any], s: Any, traj: Any, limit: tuple[float, float]) -> dict[str, Any]:
    row = dict(labels, status=traj.status)
    e_final = np.abs(traj.e[-1]) if len(traj.t) else np.full(2, np.nan)
    for j in range(2):
        n = j + 1
        row[f"final_error{n}"] = float(e_final[j]) if traj.status == "ok" else math.nan
        row[f"torque_peak{n}"] = float(np.max(np.abs(traj.tau[:, j]))) if len(traj.t) else math.nan
        variation = float(torque_measures(traj.tau[:, j]).variation) if len(traj.t) else math.nan
        row[f"torque_variation{n}"] = variation
        row[f"torque_step{n}"] = variation / max(1, len(traj.t) - 1)
        at_limit = np.abs(traj.tau[:, j]) >= limit[j] * (1 - 1e-9)
        row[f"saturated{n}"] = float(np.mean(at_limit)) if labels["limited"] else 0.0
        target, start = s.reference.final[j], s.q0[j]
        if traj.status == "ok" and target != start:
            m = step_metrics(traj.t, traj.q[:, j], target, y0=start, final_value=target)
            row[f"overshoot{n}"] = m.overshoot
            row[f"settling{n}"] = m.settling_time
        else:
            row[f"overshoot{n}"] = row[f"settling{n}"] = math.nan
    return row


def _run_chunk(
    source: str, items: list[tuple[dict[str, Any], dict[str, Any]]], model_g: float | None = None
) -> list[dict]:
    """Run ``items`` (labels, scenario data) as batches under the gravity ``model_g``; one
    row each, in order."""
    from twolink.simulation.experiment import iter_scenarios

    scenarios = [scenario_from_dict(data, source) for _, data in items]
    rows: list[dict[str, Any]] = [{}] * len(items)
    for i, traj in iter_scenarios(scenarios, model_g=model_g):
        if isinstance(traj, Exception):
            raise ConfigError(f"{source}: run {items[i][0]} failed: {traj}")
        limit = scenarios[i].controller.torque_limit
        rows[i] = _row(items[i][0], scenarios[i], traj, limit)
    return rows


def run_gain_study(study: GainStudy, pool: Any = None, progress: bool = False) -> pd.DataFrame:
    """Run every (controller, ωn, ζ, reference, plant) of the study on the batch engine,
    in chunks on ``pool`` (a :mod:`twolink.foundation.executors` executor) or in this process.

    Returns one row per run (columns: the labels, ``status``, and per joint n
    ``final_error{n}`` [rad], ``overshoot{n}`` [%], ``settling{n}`` (to the target) [s],
    ``torque_peak{n}`` [N m], ``torque_variation{n}`` (Σ|Δτ|) [N m] and ``torque_step{n}``
    (that over the control periods) [N m], ``saturated{n}`` (fraction of samples at the
    limit)).
    """
    from tqdm import tqdm

    from twolink.sweep import load_sweep

    items = list(_plans(study))
    chunks = max(1, 4 * getattr(pool, "workers", 1))
    size = -(-len(items) // chunks)
    parts = [items[i : i + size] for i in range(0, len(items), size)]
    # the sweep's gravity for every chunk: a plant runs as in the sweep, whatever its chunk
    model_g = load_sweep(study.sweep, {"samples": study.plants}).model_gravity()
    rows: list[dict[str, Any]] = []
    with tqdm(total=len(items), unit="run", disable=not progress, desc="gain study") as bar:
        if pool is None:
            for part in parts:
                rows += _run_chunk(study.source, part, model_g)
                bar.update(len(part))
        else:
            futures = [pool.submit(_run_chunk, study.source, part, model_g) for part in parts]
            for future, part in zip(futures, parts, strict=True):
                rows += future.result()
                bar.update(len(part))
    return pd.DataFrame(rows)


def n_runs(study: GainStudy) -> int:
    """How many runs :func:`run_gain_study` makes."""
    n_ctc = len(study.damping_ratios) + 1  # CTC at each ζ, CTC-I at ζ = 1
    per_gain = 2 * (study.plants + 2)  # two references; nominal limited and unlimited
    return n_ctc * len(study.natural_frequencies) * per_gain


def _larger(a: float, b: float) -> float:
    """The larger of two values, ignoring NaN (NaN only if both are: never settled)."""
    values = [v for v in (a, b) if not math.isnan(v)]
    return max(values) if values else math.nan


def gain_table(results: pd.DataFrame, quantile: float) -> pd.DataFrame:
    """One row per (controller, ζ, ωn, reference): the quantities the design rule reads.

    ``error_q``: the ``quantile`` over the drawn plants of the larger joint's final error
    [rad] (a diverged run counts as an infinite error); ``error_median`` likewise;
    ``demand1/2``: the nominal arm's peak torque without a limit [N m]; ``step1/2``: the
    nominal arm's mean torque change per control period under the limit, Σ|Δτ| / periods
    [N m], what the sensor's noise does to the actuator; ``saturated``: the
    median over the plants of the larger joint's time at the limit [fraction];
    ``overshoot``: the nominal arm's larger overshoot [%] under the limit; ``settling``: the
    nominal arm's later settling time to the target [s].
    """
    keys = ["controller", "zeta", "wn", "reference"]
    out = []
    for key, g in results.groupby(keys, sort=True):
        drawn = g[(g.plant != "nominal") & g.limited]
        err = drawn[["final_error1", "final_error2"]].max(axis=1).fillna(np.inf)
        nominal = g[(g.plant == "nominal") & g.limited].iloc[0]
        demand = g[(g.plant == "nominal") & ~g.limited].iloc[0]
        sat = drawn[["saturated1", "saturated2"]].max(axis=1)
        out.append(
            dict(
                zip(keys, key, strict=True),
                error_q=float(np.quantile(err, quantile)),
                error_median=float(np.median(err)),
                demand1=float(demand.torque_peak1),
                demand2=float(demand.torque_peak2),
                step1=float(nominal.torque_step1),
                step2=float(nominal.torque_step2),
                saturated=float(np.median(sat)),
                overshoot=_larger(nominal.overshoot1, nominal.overshoot2),
                settling=_larger(nominal.settling1, nominal.settling2),
                diverged=int((drawn.status != "ok").sum()),
            )
        )
    return pd.DataFrame(out)


@dataclass(frozen=True)
class Choice:
    """The operating point the design rule picks, and why."""

    wn: float
    zeta: float
    ki: float
    reason: str
    # CTC's linear growth rate at the chosen gains on realistic joints [1/s] (the rule
    # assumes rigid ones), and the largest ωn of the grid at which it is stable there.
    realistic_growth: float = math.nan
    realistic_stable_up_to: float = math.nan

    def stiffness_note(self) -> str:
        """What the choice assumes about the joints, and what that means on real ones."""
        if math.isnan(self.realistic_growth):
            return ""
        joints = Flexibility.realistic()
        where = (
            f"realistic joints (k = {joints.k[0]:g} / {joints.k[1]:g} N·m/rad, rotor inertia "
            f"{joints.j[0]:g} / {joints.j[1]:g} kg·m², damping ratio "
            f"{joints.damping_ratio[0]:.2g}; docs/model.md)"
        )
        if self.realistic_growth < 0:
            return (
                f"The rule assumes rigid joints (CTC's model); on {where} CTC at these gains "
                f"is linearly stable (σ = {self.realistic_growth:.3g} s⁻¹)."
            )
        up_to = (
            f"it is stable there only up to ωn = {self.realistic_stable_up_to:g} rad/s of the grid"
            if not math.isnan(self.realistic_stable_up_to)
            else "no ωn of the grid is stable there"
        )
        return (
            f"The rule assumes rigid joints (CTC's model). **On {where} CTC at these gains is "
            f"unstable** (linear growth σ = +{self.realistic_growth:.3g} s⁻¹ at the target); "
            f"{up_to}. On such joints use the flexible-joint laws (docs/control.md, "
            '"Flexible-joint controllers"; the reproduction\'s flexible-joint map).'
        )


def choose(table: pd.DataFrame, study: GainStudy) -> Choice:
    """The design rule (docs/control.md): ζ = 1 and the smallest ωn of the grid at which,
    on the smooth reference, CTC keeps the ``quantile`` of its final error over the drawn
    plants within ``error_bound`` on both joints and the nominal arm's torque demand
    within the limit (no saturation). The smallest such ωn needs the least torque and
    amplifies measurement noise least. Raises ValueError if no ωn of the grid qualifies."""
    rows = table[(table.controller == "CTC") & (table.zeta == 1.0) & (table.reference == "quintic")]
    lim1, lim2 = study.torque_limit
    share = study.torque_step_share
    quiet = (rows.step1 <= share * lim1) & (rows.step2 <= share * lim2)
    ok = rows[
        (rows.error_q <= study.error_bound)
        & (rows.demand1 <= lim1)
        & (rows.demand2 <= lim2)
        & (quiet if math.isfinite(share) else True)
    ].sort_values("wn")
    if ok.empty:
        raise ValueError(
            f"{study.source}: no ωn of the grid meets the design rule (error "
            f"<= {study.error_bound} rad on {study.quantile:.0%} of plants within the torque limit"
            + (f", torque steps within {share:.0%} of it" if math.isfinite(share) else "")
            + ")"
        )
    best = ok.iloc[0]
    wn = float(best.wn)
    activity = ""
    if math.isfinite(share):
        activity = (
            f" and a mean torque step per control period of ({best.step1:.3g}, "
            f"{best.step2:.3g}) N m within {share:.0%} of it"
        )
    reason = (
        f"ζ = 1, ωn = {wn:g} rad/s: the smallest ωn of the grid whose quintic move keeps the "
        f"{study.quantile:.0%} quantile of the final error over {study.plants} drawn plants at "
        f"{best.error_q:.3g} rad (bound {study.error_bound:g}) with a nominal torque demand of "
        f"({best.demand1:.3g}, {best.demand2:.3g}) N m within the limit ({lim1:g}, {lim2:g})"
        f"{activity}"
    )
    growth = realistic_growth(study, study.natural_frequencies)
    stable = [w for w, g in growth.items() if g < 0]
    return Choice(
        wn=wn,
        zeta=1.0,
        ki=study.integral_ratio * wn**3,
        reason=reason,
        realistic_growth=growth[wn],
        realistic_stable_up_to=max(stable) if stable else math.nan,
    )


def realistic_growth(study: GainStudy, wns: Sequence[float]) -> dict[float, float]:
    """CTC's (ζ = 1) linear growth rate σ [1/s] at each ωn of ``wns`` on the nominal arm with
    realistic joints (:meth:`Flexibility.realistic`), at the target of the study's quintic
    move (:func:`twolink.simulation.stability.closed_loop_growth`; measured with the true
    state: a sensor's lag only takes phase away)."""
    from twolink.simulation.experiment import build_controller, build_plant
    from twolink.simulation.stability import closed_loop_growth
    from twolink.sweep import load_sweep

    base = load_sweep(study.sweep, {"samples": 1}).base
    joints = Flexibility.realistic()
    flexibility = {"k": list(joints.k), "d": list(joints.d), "j": list(joints.j)}
    out = {}
    for wn in wns:
        data = merge(
            base,
            {
                "plant": {"flexibility": flexibility},
                "controller": _gains(wn, 1.0, "ctc", study.integral_ratio),
            },
        )
        data.pop("sensor", None)
        data["reference"] = _references(base, study.move_time)["quintic"]
        s = scenario_from_dict(data, study.source)
        out[wn] = closed_loop_growth(s, build_plant(s), build_controller(s))
    return out


def tradeoff_figure(table: pd.DataFrame, study: GainStudy, choice: Choice | None, path: Path):
    """The trade-off figure: error under mismatch, torque demand, saturation and overshoot
    against ωn, for the step and the quintic move."""
    from twolink.figures.plots import plt, save_figure

    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5), sharex=True)
    ax_err, ax_tau, ax_sat, ax_mp = axes.ravel()
    styles = {"step": "--", "quintic": "-"}
    for (ctrl, zeta, ref), g in table.groupby(["controller", "zeta", "reference"]):
        g = g.sort_values("wn")
        label = f"{ctrl} ζ={zeta:g}, {ref}"
        kw = dict(ls=styles[ref], marker="o", ms=3, label=label)
        ax_err.plot(g.wn, g.error_q.clip(1e-7, 10), **kw)
        if ctrl == "CTC":
            ax_tau.plot(g.wn, g.demand1, **kw)
        ax_sat.plot(g.wn, 100 * g.saturated, **kw)
        ax_mp.plot(g.wn, g.overshoot, **kw)
    ax_err.axhline(study.error_bound, color="k", lw=0.8)
    ax_err.set(
        yscale="log",
        ylabel=f"final error, {study.quantile:.0%} of plants [rad] (floor 1e-7)",
        title="error under mismatch",
    )
    ax_tau.axhline(study.torque_limit[0], color="k", lw=0.8)
    ax_tau.set(yscale="log", ylabel="joint 1 peak torque demand [N m]", title="torque demand")
    ax_sat.set(ylabel="time at the torque limit, median [%]", title="saturation")
    ax_mp.set(ylabel="overshoot, nominal arm [%]", title="overshoot (windup shows here)")
    ax_mp.set_yscale("symlog", linthresh=1.0)
    ax_mp.set_ylim(bottom=0)
    for ax in axes.ravel():
        ax.set_xscale("log")
        ax.grid(True, which="both", alpha=0.3)
        if choice is not None:
            ax.axvline(choice.wn, color="tab:red", lw=1, alpha=0.6)
    for ax in axes[1]:
        ax.set_xlabel("natural frequency ωn [rad/s]")
    ax_err.legend(fontsize=7)
    fig.suptitle("Gain study: computed-torque bandwidth against error, torque and saturation")
    fig.tight_layout()
    save_figure(fig, path)  # atomic, as every output
    return path


def summary_lines(table: pd.DataFrame, choice: Choice, wns: Sequence[float] = ()) -> list[str]:
    """A markdown table of the rule's quantities at ζ = 1 for CTC, quintic vs step."""
    rows = table[(table.controller == "CTC") & (table.zeta == 1.0)]
    lines = [
        "| ωn [rad/s] | reference | error, quantile [rad] | demand θ1 / θ2 [N m] "
        "| torque step θ1 / θ2 [N m] | time at limit [%] | overshoot [%] | Ts to target [s] |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for _, r in rows.sort_values(["wn", "reference"]).iterrows():
        if wns and r.wn not in wns:
            continue
        mark = " **(chosen)**" if r.wn == choice.wn and r.reference == "quintic" else ""
        lines.append(
            f"| {r.wn:g}{mark} | {r.reference} | {r.error_q:.3g} | {r.demand1:.3g} / "
            f"{r.demand2:.3g} | {r.get('step1', math.nan):.3g} / {r.get('step2', math.nan):.3g} "
            f"| {100 * r.saturated:.3g} | {r.overshoot:.3g} | {r.settling:.3g} |"
        )
    return lines


def sensor_text(study: GainStudy) -> str:
    """The study's sensor in words."""
    from twolink.simulation.sensor import Sensor

    return Sensor(**study.sensor).describe()


def table_path(study: GainStudy) -> Path:
    """Where a study's shipped table lives: beside its file (``gains.toml`` -> ``gains.csv``,
    with ``gains.json`` holding its digest and choice)."""
    return Path(study.source).with_suffix(".csv")


def save_study(table: pd.DataFrame, study: GainStudy, choice: Choice, path: Path) -> Path:
    """Write the study's table (CSV) and, beside it (``.json``), its digest and choice."""
    from twolink.foundation.io import atomic_write_json, atomic_write_text

    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, table.to_csv(index=False))
    meta = {"study": Path(study.source).name, "digest": study.digest(), "choice": asdict(choice)}
    atomic_write_json(path.with_suffix(".json"), meta)
    return path


def load_study(study: GainStudy, path: Path | None = None) -> tuple[pd.DataFrame, Choice] | None:
    """The saved table and choice of ``study`` at ``path``, or None if absent or stale
    (the study file or its sweep file changed since)."""
    path = table_path(study) if path is None else path
    meta_path = path.with_suffix(".json")
    if not (path.is_file() and meta_path.is_file()):
        return None
    meta = json.loads(meta_path.read_text())
    if meta.get("digest") != study.digest():
        return None
    return pd.read_csv(path), Choice(**meta["choice"])


def report_section(path: Path, out: Path, pool: Any, draw: Any = None) -> list[str]:
    """The gain study's part of the report: its rule, trade-off figure and choice, from its
    shipped table (rerun on ``pool`` when stale), and whether the gains in use are its.
    ``draw(function, *args)`` draws the figure (the reproduction: a task of its pool, so
    that the main process never draws); default: here."""
    import twolink.studies.designs.gains as gains
    from twolink.sweep import load_sweep

    study = gains.load_gain_study(path)
    saved = gains.load_study(study)
    if saved is None:
        table = gains.gain_table(gains.run_gain_study(study, pool), study.quantile)
        choice, where = gains.choose(table, study), "rerun here: the shipped table was stale"
    else:
        (table, choice), where = saved, f"`{gains.table_path(study).name}`, shipped and current"
    gains.save_study(table, study, choice, out / "gains" / "gains.csv")
    (draw or _draw_here)(
        gains.tradeoff_figure, table, study, choice, out / "figures" / "gain_tradeoff.png"
    )
    used = load_sweep(study.sweep, {"samples": 1}).base.get("controller", {})
    kp, kd = choice.wn**2, 2 * choice.zeta * choice.wn
    in_use = used.get("kp") == kp and used.get("kd") == kd and used.get("ki") == choice.ki
    return [
        "",
        "## Choosing the gains (the gain study)",
        "",
        f"From `{path.name}` ({gains.n_runs(study)} runs; {where}; docs/control.md). The "
        f"actuator limit is {study.torque_limit[0]:g} / {study.torque_limit[1]:g} N·m. "
        f"**Rule**: ζ = 1 and the smallest ωn whose smooth (quintic) move keeps the final "
        f"error of both joints within {study.error_bound:g} rad on {study.quantile:.0%} of "
        f"{study.plants} drawn plants with the nominal torque demand within the limit"
        + (
            f" and its mean torque step per control period within {study.torque_step_share:.0%}"
            " of the limit"
            if math.isfinite(study.torque_step_share)
            else ""
        )
        + f". **Sensor**: {sensor_text(study)} (docs/sensors.md).",
        "",
        f"**Choice**: {choice.reason}. Kp = {kp:g}, Kd = {kd:g}, Ki = {choice.ki:g} (integral "
        "CTC). "
        + (
            "These are the gains of the base scenario every experiment extends."
            if in_use
            else "**The base scenario's gains differ from this choice**: "
            f"kp = {used.get('kp')}, kd = {used.get('kd')}, ki = {used.get('ki')}."
        ),
        *([f"**Joints**: {note}", ""] if (note := choice.stiffness_note()) else []),
        "",
        "![gain study](figures/gain_tradeoff.png)",
        "",
        *gains.summary_lines(table, choice, wns=(2.0, 5.0, 10.0, choice.wn, 25.0, 50.0)),
        "",
        "A raw step at a stiff ωn asks for far more torque than the actuator has, and CTC "
        "saturated no longer linearises the arm (overshoot grows with ωn); the quintic move "
        "asks for the same torque at every ωn. The steps of the experiments above are "
        "therefore quintic moves.",
    ]


def _draw_here(function: Any, *args: Any) -> None:
    function(*args)
