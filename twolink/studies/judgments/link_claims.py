"""The flexible-link claims: which law wins where on drawn plants of the arm whose links
bend (docs/flexible_links.md, "Claims on drawn plants").

``python -m twolink.studies.judgments.link_claims --out DIR`` (``--plants N``, ``--install``:
into runs/flexible_links/) draws the plants of ``runs/sweeps/flexible_links.toml`` (the
links' E I times ``ei_scale``, a ``payload`` at the tip; :meth:`SweepPlan.draw`, the sweep's
own draws) and runs four laws on each, all modelling the nominal links:

- ``CTC``, the paper's computed torque on the hub angles (the sweep's ``CTC``);
- ``FCM-CTC``, the designed rule base (the sweep's ``FCM-CTC``);
- ``two-time-scale``, :class:`TwoTimeScaleControl` with ks = :data:`KS` (strain rate);
- ``two-time-scale + ZV``, the same on a :func:`zv_shaped` reference, shaped at the
  nominal loop's mode (:func:`shaper_mode`: read once, as the docs do; so it tests the
  shaper's robustness to plants it was not tuned on).

Each run is measured at the tip (:class:`TipMetrics`) and at the hubs (IAE and peak |τ|
per joint), every law against the move asked for (the unshaped reference); the
residual is taken after the law's own reference ends. Each law is judged against CTC,
paired per plant, by the claims statistics (:func:`claims.judge_rows`: the
Hodges-Lehmann shift with its interval, the counts beyond a tolerance, the verdict),
on all plants and on each ``ei_scale`` half (:data:`HALVES`).
"""

from __future__ import annotations

import copy
import json
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from twolink.studies.judgments.claims import TOLERANCES, judge_rows

__all__ = [
    "BASELINE",
    "HALVES",
    "KS",
    "LAWS",
    "METRICS",
    "SHIPPED",
    "SWEEP",
    "LinkClaims",
    "judge_links",
    "link_claims",
    "load_runs",
    "main",
    "measure_run",
    "plant_scenarios",
    "shaper_mode",
    "table_lines",
]

SWEEP = "sweeps/flexible_links"  # the shipped sweep file that draws the plants
SHIPPED = ("flexible_links", "claims.csv")  # under runs/: the verdicts
SHIPPED_RUNS = ("flexible_links", "claims_runs.csv")  # the runs they judge
BASELINE = "CTC"
KS = 0.01  # s: the strain-rate gain of the docs' linearisation (ζ 0.10 -> 0.63 at 30 Hz)
TWO_TIME_SCALE, SHAPED = "two-time-scale", "two-time-scale + ZV"
LAWS = ("CTC", "FCM-CTC", TWO_TIME_SCALE, SHAPED)
TIP = ("tip_error_m", "final_tip_error_m", "residual_vibration_m", "vibration_settling_time_s")
HUBS = ("joint1_iae_rad_s", "joint2_iae_rad_s", "joint1_torque_peak_Nm", "joint2_torque_peak_Nm")
METRICS = TIP + HUBS
# The tip's tolerances, chosen as the step metrics' (claims.TOLERANCES): a distance of
# 0.5 mm (the 1 mm band the settling time is read in, halved; 1 mrad of the hubs moves the
# 1.4 m reach's tip by 1.4 mm), a time of 10 control periods. The hubs' are the step
# metrics' own: 1 mrad·s of IAE, 0.5 N·m of peak |τ|.
TIP_TOLERANCES = {
    "tip_error_m": 5e-4,
    "final_tip_error_m": 5e-4,
    "residual_vibration_m": 5e-4,
    "vibration_settling_time_s": 0.01,
}
TOLERANCE = {
    **TIP_TOLERANCES,
    **{k: TOLERANCES[k.partition("_")[2]] for k in HUBS},
}
# A tip that still swings at the run's end never settled (NaN): it counts against it,
# as a settling time never reached does (claims.REACHED).
REACHED = ("vibration_settling_time_s",)
# Where: all plants, and the plants stiffer or softer than the laws' model.
HALVES = {"all": (0.0, math.inf), "ei_scale < 1": (0.0, 1.0), "ei_scale >= 1": (1.0, math.inf)}


def plant_scenarios(plants: int, sweep: Any = None) -> tuple[Any, list[tuple[dict, Any]]]:
    """The sweep plan and its first ``plants`` samples: ``(values, scenario)`` each, the
    sweep's own draws (``plan.draw(i)``, ``plan.sample_data``)."""
    from twolink.foundation.shipped import locate
    from twolink.simulation.config import scenario_from_dict
    from twolink.sweep.plan import load_sweep

    plan = sweep if sweep is not None else load_sweep(locate(SWEEP))
    out = []
    for i in range(plants):
        values, noise_seed = plan.draw(i)
        out.append((values, scenario_from_dict(plan.sample_data(values, noise_seed), plan.file)))
    return plan, out


def shaper_mode(nominal: Any, ks: float = KS) -> tuple[float, float]:
    """(f [Hz], ζ) the shaper is tuned to: of the nominal loop's two slowest modes (the
    hubs' loop, split by the links; MuJoCo's linearisation at rest, the laws' own links,
    no payload), the less damped one, the mode that swings the tip."""
    from twolink.arm.links import build_links_model, law_gain, linear_modes
    from twolink.controllers.flexible_links import TwoTimeScaleControl
    from twolink.foundation.references import ArmReference, Step

    links = nominal.links.with_arm(nominal.arm)
    still = ArmReference(Step(final=0.0), Step(final=0.0))
    law = TwoTimeScaleControl(
        links, still, kp=nominal.controller.kp, kd=nominal.controller.kd, ks=ks, g=0.0
    )
    model = build_links_model(links, g=0.0, timestep=1e-5, visual=False)
    w, z = linear_modes(model, feedback=law_gain(law, links.segments, model.nv))
    k = int(np.argmin(z[:2]))
    return float(w[k] / (2 * math.pi)), float(z[k])


def laws(plan: Any, mode: tuple[float, float]) -> dict[str, Any]:
    """The four laws of :data:`LAWS`, built once on the nominal scenario (the laws' model):
    the sweep's two kinds as the sweep builds them, the two-time-scale law, and the same
    on the reference shaped at ``mode``."""
    from twolink.controllers.flexible_links import TwoTimeScaleControl, zv_shaped
    from twolink.simulation.config import scenario_from_dict
    from twolink.simulation.experiment import build_controller

    out = {}
    for name in LAWS[:2]:
        out[name] = build_controller(scenario_from_dict(plan.controller_data(name), plan.file))
    s = plan.nominal_scenario()
    links = s.links.with_arm(s.arm)
    gains = {"kp": s.controller.kp, "kd": s.controller.kd, "g": s.arm.g}
    limit = s.controller.torque_limit
    out[TWO_TIME_SCALE] = TwoTimeScaleControl(
        links, s.reference, ks=KS, torque_limit=limit, **gains
    )
    out[SHAPED] = TwoTimeScaleControl(
        links, zv_shaped(s.reference, *mode), ks=KS, torque_limit=limit, **gains
    )
    return out


def measure_run(s: Any, run: Any, controller: Any) -> dict[str, Any]:
    """One run's measures (:data:`METRICS`): the tip's against the move asked for (the
    scenario's reference: a shaped law pays for its lag), the residual after the law's own
    reference ends, the hubs' IAE against that move and peak |τ|, and the share of samples
    where a fuzzy law's term acts (NaN for the others); NaN where it diverged."""
    from twolink.simulation.experiment import fuzzy_active_share
    from twolink.simulation.links_sim import tip_metrics
    from twolink.simulation.metrics import error_measures, torque_measures
    from twolink.simulation.outcome import reference_end

    traj = run.trajectory
    row: dict[str, Any] = {"status": traj.status}
    if not traj.ok:
        return row | dict.fromkeys((*METRICS, "fuzzy_active_share"), math.nan)
    q_ref, qd_ref, qdd_ref = s.reference.sample(traj.t)
    asked = replace(traj, q_ref=q_ref.reshape(-1, 2), qd_ref=qd_ref.reshape(-1, 2),
                    qdd_ref=qdd_ref.reshape(-1, 2))  # fmt: skip
    rest = reference_end(controller.reference)
    tip = tip_metrics(replace(run, trajectory=asked), s.plant_params, rest)
    errors, torque = error_measures(traj.t, asked.e), torque_measures(traj.tau)
    row["fuzzy_active_share"] = float(np.mean(fuzzy_active_share(controller, traj)))
    for j in (0, 1):
        row[f"joint{j + 1}_iae_rad_s"] = float(errors.iae[j])
        row[f"joint{j + 1}_torque_peak_Nm"] = float(torque.peak[j])
    return row | tip.to_dict()


def _plant_rows(task: tuple[int, dict, Any, dict[str, Any]]) -> list[dict[str, Any]]:
    """Every law on one plant, in one MuJoCo model at the plant's own physics step (each
    run equals :func:`run_links`'s alone: docs/flexible_links.md, "Many arms in one model")."""
    from twolink.simulation.links_sim import links_timestep, plant_links, simulate_links_batch

    i, values, s, built = task
    controllers = [copy.deepcopy(built[name]) for name in LAWS]
    arm = (plant_links(s), s.plant.payload)
    runs = simulate_links_batch(
        [arm] * len(LAWS), controllers, s.duration, s.control_dt, links_timestep(s),
        s.plant_params.g, q0=[s.q0] * len(LAWS), qd0=[s.qd0] * len(LAWS),
    )  # fmt: skip
    return [
        {"sample": i, "controller": name, **values, **measure_run(s, run, c)}
        for name, run, c in zip(LAWS, runs, controllers, strict=True)
    ]


@dataclass(frozen=True)
class LinkClaims:
    """The study's result: per (plant, law) its measures (``runs``), the verdicts
    (``claims``, :func:`judge_links`), the shaper's (f, ζ) and the wall time [s]."""

    runs: pd.DataFrame
    claims: pd.DataFrame
    mode: tuple[float, float]
    wall_s: float
    workers: int


def link_claims(
    plants: int = 100,
    sweep: Any = None,
    duration: float | None = None,
    workers: int = 1,
    keep: Path | None = None,
) -> LinkClaims:
    """Run :data:`LAWS` on the first ``plants`` plants of the sweep (default the shipped
    ``runs/sweeps/flexible_links.toml``; ``duration`` overrides the runs' length) on
    ``workers`` processes, and judge them (:func:`judge_links`); ``keep``: a CSV file the
    runs are written to before they are judged."""
    start = time.perf_counter()
    plan, drawn = plant_scenarios(plants, sweep)
    if duration is not None:
        drawn = [(v, replace(s, duration=duration)) for v, s in drawn]
    mode = shaper_mode(plan.nominal_scenario())
    built = laws(plan, mode)
    tasks = [(i, v, s, built) for i, (v, s) in enumerate(drawn)]
    if workers > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(workers) as pool:
            chunks = list(pool.map(_plant_rows, tasks))
    else:
        chunks = [_plant_rows(t) for t in tasks]
    runs = pd.DataFrame([row for rows in chunks for row in rows])
    wall = time.perf_counter() - start
    if keep is not None:
        from twolink.foundation.io import atomic_write_text

        keep.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(keep, runs.to_csv(index=False))
    return LinkClaims(runs, judge_links(runs), mode, wall, workers)


def judge_links(runs: pd.DataFrame, laws: Sequence[str] = LAWS[1:]) -> pd.DataFrame:
    """Each of ``laws`` against :data:`BASELINE` on every half of :data:`HALVES`, paired
    per plant, per metric of :data:`METRICS` at its :data:`TOLERANCE`: the rows of
    :func:`claims.judge_rows` (each (half, law) one Holm family), with ``where``, ``law``,
    ``opponent``, ``at`` (the tip, joint1, joint2) and ``metric`` first, and the verdict
    in words (``reading``)."""
    from twolink.studies.judgments.claims_words import reading

    base = runs[runs["controller"] == BASELINE].set_index("sample").sort_index()
    tables = []
    for where, (low, high) in HALVES.items():
        inside = base.index[(base["ei_scale"] >= low) & (base["ei_scale"] < high)]
        if len(inside):
            tables.append(_judge_half(runs, base.loc[inside], where, laws))
    table = pd.concat(tables, ignore_index=True)
    words = table.rename(columns={"law": "proposed"}).assign(reference=math.nan)
    table["reading"] = reading(words)
    return table


def _judge_half(
    runs: pd.DataFrame, base: pd.DataFrame, where: str, laws: Sequence[str]
) -> pd.DataFrame:
    """:func:`judge_links`' rows of one half's plants (``base``: CTC's rows by sample)."""
    a = []
    for law in laws:
        mine = runs[runs["controller"] == law].set_index("sample").reindex(base.index)
        a.append(mine[list(METRICS)].to_numpy(float).T)
    b = base[list(METRICS)].to_numpy(float).T
    width, count = len(METRICS), len(laws)
    out = judge_rows(
        np.concatenate(a),
        np.tile(b, (count, 1)),
        np.tile([TOLERANCE[m] for m in METRICS], count),
        np.repeat(np.arange(count), width),
        np.tile([m in REACHED for m in METRICS], count),
        np.full(count * width, len(base)),
    )
    at = [m.partition("_")[0] if m in HUBS else "tip" for m in METRICS]
    key = [m.partition("_")[2] if m in HUBS else m for m in METRICS]
    return pd.DataFrame({
        "where": where,
        "law": np.repeat(list(laws), width),
        "opponent": BASELINE,
        "at": np.tile(at, count),
        "metric": np.tile(key, count),
        **out,
    })  # fmt: skip


# ------------------------------------------------------------------------------ the table

# Each metric's name and the unit its sizes are shown in (factor from its own unit).
_SHOWN = {
    "tip_error_m": ("largest tip error", 1e3, "mm"),
    "final_tip_error_m": ("final tip error", 1e3, "mm"),
    "residual_vibration_m": ("residual vibration", 1e3, "mm"),
    "vibration_settling_time_s": ("tip settling time", 1e3, "ms"),
    "iae_rad_s": ("IAE", 1e3, "mrad·s"),
    "torque_peak_Nm": ("peak abs(τ)", 1.0, "N·m"),
}
_JOINTS = {"tip": "", "joint1": "θ1 ", "joint2": "θ2 "}


def _size(value: float, factor: float) -> str:
    v = value * factor
    if not math.isfinite(v):
        return "nan"
    return "0" if abs(v) < 5e-4 else f"{v:.3g}" if abs(v) < 100 else f"{v:.0f}"


def table_lines(claims: pd.DataFrame, where: str = "all") -> list[str]:
    """The markdown table of one half: per law and metric, better / worse of N, the
    typical plant's shift (law − CTC) with its interval in mm, ms, mrad·s or N·m, and the
    verdict."""
    lines = [
        "| law | metric | better / worse of N | shift [interval] | verdict |",
        "|---|---|---|---|---|",
    ]
    for r in claims[claims["where"] == where].itertuples(index=False):
        name, factor, unit = _SHOWN[r.metric]
        better = r.better + r.unreached_better
        worse = r.worse + r.unreached_worse
        low, high = _size(r.ci_low, factor), _size(r.ci_high, factor)
        shift = f"{_size(r.estimate, factor)} [{low}, {high}] {unit}"
        counts = f"{better} / {worse} of {r.plants}"
        lines.append(f"| {r.law} | {_JOINTS[r.at]}{name} | {counts} | {shift} | {r.verdict} |")
    return lines


def shipped_section() -> list[str]:
    """The shipped claims on drawn plants as a report section (the reproduction shows
    them beside its bending-link variant; rerunning them takes about 20 min on 2 cores)."""
    verdicts, _, record = shipped_paths()
    claims = pd.read_csv(verdicts)
    plants = int(json.loads(record.read_text())["plants"])
    return [
        "",
        "### The claims on drawn plants (shipped)",
        "",
        f"{plants} plants of `runs/sweeps/flexible_links.toml`: a horizontal arm whose links "
        "bend, E I × 0.5-1.5 and a payload of 0-0.5 kg that no law models "
        '(docs/flexible_links.md, "Claims on drawn plants"). Each law against CTC, paired '
        "per plant; the shift is the law's value minus CTC's. Shipped in "
        "`runs/flexible_links/claims.csv`; rerun with "
        "`python -m twolink.studies.judgments.link_claims --install`.",
        "",
        *table_lines(claims),
    ]


def shipped_paths() -> tuple[Path, Path, Path]:
    """The shipped verdicts, runs and their record (runs/flexible_links/claims.csv,
    claims_runs.csv, claims.json)."""
    from twolink.foundation.shipped import runs_dir

    verdicts = runs_dir().joinpath(*SHIPPED)
    return verdicts, runs_dir().joinpath(*SHIPPED_RUNS), verdicts.with_suffix(".json")


def load_runs(path: Path) -> pd.DataFrame:
    """A runs table written by :func:`main` (claims_runs.csv)."""
    return pd.read_csv(path)


def main(argv: list[str] | None = None) -> int:
    """``python -m twolink.studies.judgments.link_claims --out DIR`` (or ``--install``: into
    runs/flexible_links/): the runs (claims_runs.csv), the verdicts (claims.csv), the
    record (claims.json: plants, wall time, workers, the shaper's mode); the tables of
    docs/flexible_links.md on stdout. ``--reuse`` judges the shipped runs again."""
    import argparse
    import json

    from twolink.foundation.io import atomic_write_json, atomic_write_text
    from twolink.foundation.shipped import install_target

    parser = argparse.ArgumentParser(description=main.__doc__)
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--out", type=Path, help="the folder to write the results in")
    where.add_argument("--install", action="store_true", help="rewrite the shipped result")
    parser.add_argument("--plants", type=int, default=100, help="plants drawn (default 100)")
    parser.add_argument("--workers", type=int, default=1, help="processes (default 1)")
    parser.add_argument("--reuse", action="store_true", help="judge the shipped runs again")
    args = parser.parse_args(argv)
    if args.plants < 1 or args.workers < 1:
        parser.error("--plants and --workers must be at least 1")
    if args.install:
        paths = tuple(install_target(p) for p in shipped_paths())
    else:
        paths = tuple(args.out / p.name for p in shipped_paths())
    claims_path, runs_path, record_path = paths
    if args.reuse:
        shipped_claims, shipped_runs, shipped_record = shipped_paths()
        runs = load_runs(shipped_runs)
        record = json.loads(shipped_record.read_text())
        claims = judge_links(runs)
    else:
        result = link_claims(args.plants, workers=args.workers, keep=runs_path)
        runs, claims = result.runs, result.claims
        f, z = result.mode
        record = {"plants": args.plants, "laws": list(LAWS), "wall_s": result.wall_s,
                  "workers": result.workers,
                  "shaper": {"frequency_hz": f, "damping_ratio": z}}  # fmt: skip
    claims_path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(runs_path, runs.to_csv(index=False))
    atomic_write_text(claims_path, claims.to_csv(index=False))
    atomic_write_json(record_path, record)
    f, z = record["shaper"]["frequency_hz"], record["shaper"]["damping_ratio"]
    print(f"{record['plants']} plants, {len(LAWS)} laws, {record['wall_s']:.0f} s on "
          f"{record['workers']} worker(s); shaped at {f:.3f} Hz, ζ = {z:.3f}")  # fmt: skip
    for half in HALVES:
        print("", f"### {half}", "", *table_lines(claims, half), sep="\n")
    print(claims_path)
    return 0


if __name__ == "__main__":  # pragma: no cover - the study's command line
    raise SystemExit(main())
