"""``twolink reproduce``: the paper's results section, run end to end.

Reads the reproduction manifest (``runs/paper/reproduce.toml``): which scenario files
make which paper table, which controllers to compare, on which plant variants. Designs
the FCM rule base (or reuses the one already in the output folder when its design
config is unchanged), runs every experiment with every controller on every variant
(in a process pool), and writes per-run folders, the report, figures and rerun
recordings. Everything written is written atomically, so an interrupted reproduction
leaves only whole files, and running it again completes it.
"""

from __future__ import annotations

import functools
import json
import math
import os
import sys
import time
from concurrent.futures import as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from twolink.figures.hunting import HUNTING_FIGURE, save_hunting_figure
from twolink.foundation.interrupts import raise_if_dropped
from twolink.foundation.io import SEAL_NAME, seal_intact, to_toml
from twolink.simulation.config import FUZZY_KINDS, ConfigError, Scenario, load_scenario, merge
from twolink.simulation.experiment import (
    build_controller,
    iter_scenarios,
    measure,
)
from twolink.simulation.links_sim import LinkRun, scenario_tip_metrics
from twolink.simulation.outcome import classify_run
from twolink.simulation.sim import Trajectory
from twolink.simulation.vocabulary import joint_values
from twolink.studies.judgments.claims_studies import raw_steps, run_claims
from twolink.studies.reproduction.choices import describe_choices
from twolink.studies.reproduction.hero import HERO_FIGURE, hero
from twolink.studies.reproduction.manifest import (
    DEFAULT_MANIFEST,
    Manifest,
    RunSpec,
    load_manifest,
)
from twolink.studies.reproduction.quiet import quietly, warnings_section
from twolink.studies.reproduction.report_sections import links_section
from twolink.studies.reproduction.reproduce_figures import design_figures, response_figure
from twolink.studies.reproduction.run_folder import portable_config, write_run


def plan(
    manifest: Manifest,
    rule_base: Path | None,
    centres=(),
    overrides: dict[str, Any] | None = None,
    centre_labels=(),
) -> list[RunSpec]:
    """Every run of the reproduction, in report order; ``overrides`` (``--set``) are merged
    over every run's scenario and variant, under the controller's own keys. ``rule_base``
    is the designed rule base (None before the design: the paper's stands in, to
    validate the scenarios)."""
    centres = tuple(tuple(map(float, c)) for c in centres)
    labels = tuple(str(n) for n in centre_labels)
    specs = []
    for variant in manifest.variants:
        for exp in manifest.experiments:
            for name, ctrl in manifest.controllers.items():
                ctrl = dict(ctrl)
                if ctrl.get("rule_base") == "designed":  # before the design: the paper's
                    ctrl["rule_base"] = str(rule_base.resolve()) if rule_base else "paper"
                # --set over the variant, and each controller's own keys over both: they
                # are what make it that controller (CTC-paper's gains, FCM-CTC's rules)
                run = merge(merge(variant.overrides, overrides or {}), {"controller": ctrl})
                if variant.raw_steps:
                    run = merge(run, {"reference": raw_steps(exp.scenario)})
                fuzzy = run["controller"].get("kind", "ctc") in FUZZY_KINDS
                specs.append(
                    RunSpec(exp, variant, name, run, *((centres, labels) if fuzzy else ()))
                )
    return specs


def _execute(
    specs: list[RunSpec], out: Path, trace: bool, model_g: float | None = None
) -> list[dict[str, Any]]:
    """Run specs as one batch of arms (:mod:`twolink.simulation.batch`) under the gravity
    ``model_g`` and write their folders; returns their metrics rows (a worker task)."""
    scenarios = [load_scenario(sp.experiment.scenario, sp.overrides) for sp in specs]
    controllers = [build_controller(s) for s in scenarios]
    rows: list[dict[str, Any]] = [{}] * len(specs)
    # written as each batch ends
    for i, traj in iter_scenarios(scenarios, controllers, model_g=model_g, link_runs=True):
        spec, scenario, controller = specs[i], scenarios[i], controllers[i]
        if isinstance(traj, Exception):  # validated before: MuJoCo refused this arm
            raise traj
        tip, bent = None, None
        if isinstance(traj, LinkRun):  # links that bend: the tip's measures and shape too
            tip, bent = scenario_tip_metrics(scenario, traj).to_dict(), {"bent": traj.points}
            traj = traj.trajectory
        metrics = measure(scenario, traj, controller)
        write_run(
            out / spec.folder,
            scenario,
            traj,
            metrics,
            plots=False,
            trace=trace,
            controller=controller,
            centres=spec.centres,
            centre_labels=spec.centre_labels,
            prefix=spec.folder,
            name=spec.controller,
            more_metrics={"tip": tip} if tip is not None else None,
            more_extras=bent,
        )
        rows[i] = _row(spec, scenario, traj.status, metrics, tip)
    return rows


def _check_run(manifest: Manifest, spec: RunSpec) -> None:
    """Load a run's scenario; a bad key is blamed on where it was written: the experiment's
    scenario file, the manifest's variant overrides or controller table, or ``--set``."""
    try:
        load_scenario(spec.experiment.scenario, spec.overrides)
    except ConfigError as exc:
        scenario = spec.experiment.scenario
        load_scenario(scenario)  # the scenario file's own mistake: its own error
        where = manifest.path
        for key, part in (
            (f"variants.{spec.variant.name}.overrides", spec.variant.overrides),
            (f"controllers.{spec.controller}", {"controller": spec.overrides["controller"]}),
        ):
            try:
                load_scenario(scenario, part)
            except ConfigError:
                raise ConfigError(f"{where}: {key}: {exc}") from None
        raise  # --set


# The other joint's metrics in a row (``other_<key>``): its largest deviation and final
# error, defined whether it moves or is held (a held joint has no step metrics).
OTHER_JOINT_KEYS = ("max_error_rad", "final_error_rad")


def _reference_kind(scenario: Scenario, joint: int) -> str:
    """A joint's reference kind ("step", "ramp", ...), "held" where it does not move."""
    ref = getattr(scenario.reference, f"joint{joint}")
    start = scenario.q0[joint - 1]
    held = ref.final == start and getattr(ref, "initial", start) == start  # NaN: not held
    return "held" if held else ref.kind


def _row(
    spec: RunSpec, scenario: Scenario, status: str, metrics: Any, tip: dict | None = None
) -> dict[str, Any]:
    """The metrics row of one run: the report's and metrics.csv's. Every metric of the
    experiment's joint, then the other joint's reference ("held" where it holds its start)
    and its :data:`OTHER_JOINT_KEYS`, so both joints are reported; then the tip's measures
    where the links bend (``tip``: :meth:`TipMetrics.to_dict`)."""
    joint = spec.experiment.joint
    other = joint_values(metrics, 3 - joint)
    return {
        "variant": spec.variant.name,
        "experiment": spec.experiment.key,
        "controller": spec.controller,
        "joint": joint,
        "reference": _reference_kind(scenario, joint),
        "status": status,
        "outcome": classify_run(scenario, metrics),
        **joint_values(metrics, joint),
        "other_reference": _reference_kind(scenario, 3 - joint),
        **{f"other_{key}": other[key] for key in OTHER_JOINT_KEYS},
        **(tip or {}),
    }


def finished_row(spec: RunSpec, scenario: Scenario, out: Path, trace: bool) -> dict | None:
    """The row of a run already in ``out`` whole and of this very scenario (its saved
    config.toml is the one this run would write), measured again from its saved
    trajectory; None where the run must be computed. (Changes to the package's code are
    not detected: use a fresh --out after changing a controller or the plant.)"""
    folder = out / spec.folder
    needed = ("config.toml", "trajectory.npz", "metrics.json", *(["trace.rrd"] if trace else []))
    if not folder.is_dir():
        return None
    if not seal_intact(folder, needed):
        # unsealed (cut short, or an older twolink's): quietly; a broken seal: say so
        if (folder / SEAL_NAME).exists():
            print(
                f"{folder}: damaged, edited or incomplete since twolink wrote it; computed again",
                file=sys.stderr,
            )
        return None
    try:
        if (folder / "config.toml").read_text() != to_toml(portable_config(scenario, folder)):
            return None
        traj = Trajectory.load(folder / "trajectory.npz")
        tip = None
        if scenario.links is not None:  # bending links: the tip's measures, as written
            tip = json.loads((folder / "metrics.json").read_text()).get("tip")
            if tip is not None:  # metrics.json writes NaN (not measured) as null
                tip = {key: math.nan if v is None else v for key, v in tip.items()}
    except Exception:  # noqa: BLE001 (sealed yet unreadable, e.g. an older format: recompute)
        return None
    if scenario.links is not None and tip is None:
        return None
    return _row(spec, scenario, traj.status, measure(scenario, traj), tip)


def run_all(
    specs: list[RunSpec],
    out: Path,
    pool: Any,
    trace: bool = True,
    scenarios: dict[str, Scenario] | None = None,
    busy: int = 0,
) -> tuple[list[dict[str, Any]], dict[Any, list[int]]]:
    """Submit every spec not already done to ``pool`` (a :mod:`twolink.foundation.executors`
    executor), in one batch of arms per worker.

    With ``scenarios`` (by spec folder), a run already whole in ``out`` for the same
    scenario is reused, not computed again (:func:`finished_row`): an interrupted
    reproduction resumes per run. Returns the rows known now (``{}`` where pending) and
    the pending futures with the spec indices each computes; each future's result is
    (rows, the warnings its runs raised: :func:`twolink.studies.reproduction.quiet.quietly`).
    """
    from twolink.simulation.batch import model_gravity

    rows: list[dict[str, Any]] = [{}] * len(specs)
    todo = []
    for i, spec in enumerate(specs):
        row = finished_row(spec, scenarios[spec.folder], out, trace) if scenarios else None
        if row is None:
            todo.append(i)
        else:
            rows[i] = row
    # A batch's cost per step is mostly fixed up to ~100 arms: as few batches as keep the
    # workers busy (one worker is left to the flexible study when it runs beside).
    batches = max(1, min(len(todo), pool.workers - busy))
    # one gravity for every batch, from all the specs: a run does not depend on its share
    model_g = model_gravity(
        [
            (
                scenarios[sp.folder]
                if scenarios
                else load_scenario(sp.experiment.scenario, sp.overrides)
            ).plant_params.g
            for sp in specs
        ]
    )
    pending = {}
    for b in range(batches):
        share = todo[b::batches]
        if share:
            # its warnings recorded, not printed (quiet.py): (rows, warning lines)
            task = pool.submit(quietly, _execute, [specs[i] for i in share], out, trace, model_g)
            pending[task] = share
    return rows, pending


def load_trajectory(out: Path, spec: RunSpec) -> Trajectory:
    return Trajectory.load(out / spec.folder / "trajectory.npz")


def flexible_study(
    sweep_file: Path, out: Path, model_error: dict[str, float] | None = None
) -> list[str]:
    """Run the flexible-joint sweep into ``out/flexible_study`` in this process (a worker
    task: its arms are one or two batches); its report section. A sweep over ``k`` and
    ``wn`` is the stiffness x bandwidth map (``twolink.sweep.flexmap``), with the rigid
    arm's Ts and Mp under CTC as its yardstick; a sweep over ``k`` alone, the stiffness
    study. With ``model_error`` ([plant.scale] factors) the same sweep on plants that
    differ from every controller's model, into ``out/flexible_study_error``."""
    from twolink import sweep
    from twolink.figures import plots

    name = "flexible_study_error" if model_error else "flexible_study"
    overrides = {"overrides": {"plant": {"scale": dict(model_error)}}} if model_error else None
    plan = sweep.load_sweep(sweep_file, overrides)
    # One thread: this is one task of the reproduction's pool, beside the others.
    outcome = sweep.run_sweep(
        plan,
        out / name,
        executor="inprocess",
        workers=1,
        plots=False,
        replace_other=True,  # the reproduction's own folder: a changed study is rerun
    )
    figure = out / f"figures/{name}.png"
    if "wn" not in plan.parameter_names:
        plots.save_figure(sweep.flexible_study_figure(outcome.results), figure)
        return ["", "## Beyond the paper: flexible joints from stiff to soft", "",
                f"On Spong's flexible-joint arm, k swept from stiff to soft ({sweep_file.name}). "
                "Medians per stiffness:", "", sweep.flexible_study_table(outcome.results), "",
                "![flexible study](figures/flexible_study.png)"]  # fmt: skip
    plots.save_figure(sweep.flexible_map_figure(outcome.results, plan.step), figure)
    rigid = sweep.rigid_reference(plan, plan.controller_names[0])
    if model_error:
        error = ", ".join(f"{k} ×{v:.3g}" for k, v in sorted(model_error.items()))
        return [
            "",
            "## Beyond the paper: flexible joints with model error",
            "",
            f"The same map on plants that differ from every controller's model ({error}: "
            "the masses and gravity as the robustness sweep's worst, the joints softer than "
            "identified; the flexible-joint laws model the nominal joints). Per bandwidth, the "
            "softest k down to which each controller meets the spec at every stiffer joint "
            "(in brackets: with the rigid arm's Ts and Mp, as above); each cell's outcome "
            "comes with its linear stability at the target (red ×):",
            "",
            sweep.flexible_map_table(outcome.results, rigid, plan.step),
            "",
            f"![flexible study with model error](figures/{name}.png)",
            "",
            *sweep.disagreements(sweep.map_cells(outcome.results, plan.step)),
        ]
    return [
        "",
        "## Beyond the paper: flexible joints, stiffness x bandwidth",
        "",
        f"Every controller on Spong's flexible-joint arm ({sweep_file.name}: realistic rotor "
        "inertia and a joint damping ratio of 0.02 at every stiffness; every run starts at "
        "rest, its springs holding the arm), the joint stiffness "
        "k from stiff to soft against the closed loop's bandwidth ωn (ζ = 1). Per bandwidth, "
        "the softest k down to which each controller meets the spec at every stiffer joint, "
        f"and in brackets down to which its Ts and Mp also stay within the rigid arm's "
        f"({plan.controller_names[0]}, no springs: Ts at most 10 % + 0.05 s later, Mp at most "
        "1 point higher); — where even the stiffest joint fails (docs/control.md, "
        '"The stiffness x bandwidth map"):',
        "",
        sweep.flexible_map_table(outcome.results, rigid, plan.step),
        "",
        "Red ×: unstable (a torque-limited limit cycle, diverged, or linearly unstable at the "
        "target however calm the run's end); grey: bounded but off "
        "target; colour: Ts to the target, number: Mp [%]; a dot: a spring twisted beyond "
        "0.2 rad, no physical joint (docs/model.md).",
        "",
        "![flexible study](figures/flexible_study.png)",
        "",
        *sweep.disagreements(sweep.map_cells(outcome.results, plan.step)),
    ]


def _stopped(folder: Path) -> list[str]:
    """The runs of a sweep folder that diverged or stopped early: "CTC, sample 12"."""
    from twolink import sweep

    results = sweep.load_results(folder)
    bad = results[results["status"] != "ok"]
    return [f"{r.controller}, sample {r.sample}" for r in bad.itertuples()]


def _say_warnings(warned: list[tuple[str, list[str], list[str]]], progress: bool) -> None:
    """One terminal line for what the tasks warned, where the report names it."""
    count = sum(len(lines) for _, lines, _ in warned)
    if count and progress:
        runs = sum(len(r) for _, lines, r in warned if lines)
        print(
            f"{count} warnings from the runs (expected where a run is driven past its "
            f"stability limit; {runs} runs stopped as diverged): recorded in report.md, "
            '"Warnings the runs raised"',
            file=sys.stderr,
        )


def _advance(bar: Any, n: int, _future: Any) -> None:
    bar.update(n)  # from the pool's thread, as a batch of runs finishes


class _Phases:
    """A status line on stderr as each phase of the reproduction starts, with the time
    since the start: "[3/6] +12.4 s figures" (where the time goes, at a glance)."""

    def __init__(self, on: bool, total: int) -> None:
        self.on, self.total, self.done = on, total, 0
        self.start = time.perf_counter()

    def __call__(self, what: str) -> None:
        raise_if_dropped()  # a Ctrl-C stops the reproduction at the next phase at the latest
        self.done += 1
        if self.on:
            elapsed = f"+{time.perf_counter() - self.start:.1f} s"
            print(f"[{self.done}/{self.total}] {elapsed} {what}", file=sys.stderr, flush=True)


@dataclass(frozen=True)
class Reproduction:
    """What a reproduction produced: where, the metric rows, and whether it re-designed."""

    out: Path
    rows: list[dict[str, Any]]
    designed: bool
    rule_base: Path


def reproduce(
    manifest_path: str | Path = DEFAULT_MANIFEST,
    out: str | Path = "results/reproduce",
    workers: int | None = None,
    trace: bool = True,
    progress: bool = True,
    overrides: dict[str, Any] | None = None,
) -> Reproduction:
    """Design (or reuse) the FCM rule base, run every experiment, write everything.

    ``overrides`` (the command's ``--set``) change every experiment's scenario, not the
    design runs nor the flexible-joint study."""
    from twolink import sweep
    from twolink.foundation.io import check_output_folder, check_ownership, owned_output
    from twolink.studies.designs.design import load_design_config

    out = Path(out)
    manifest = load_manifest(manifest_path)
    config = load_design_config(manifest.design)
    # Bad input is found before any work: every run's scenario (the paper's rule base
    # standing in for the one not yet designed), the study's sweep file, the folder.
    for sp in plan(manifest, None, (), overrides):
        _check_run(manifest, sp)
    if manifest.flexible_study is not None:
        sweep.load_sweep(manifest.flexible_study)
    for key in ("claims_study", "lab_study"):  # each judged by the claim's two names
        study = getattr(manifest, key)
        names = () if study is None else sweep.load_sweep(study).controller_names
        missing = [n for n in (manifest.proposed, manifest.baseline) if n not in names]
        if study is not None and missing:
            raise ConfigError(
                f"{manifest.path}: {key}: {study.name} must run "
                f"{missing} by name (it runs {list(names)})"
            )
    check_output_folder(out)
    source = str(manifest.path.resolve())
    check_ownership(out, "reproduce", source)
    # One reproduction at a time per folder: a second one into it stops at once.
    with owned_output(out, "reproduce", source):
        return _reproduce(manifest, config, out, workers, trace, progress, overrides)


def _reproduce(
    manifest: Manifest,
    config: Any,
    out: Path,
    workers: int | None,
    trace: bool,
    progress: bool,
    overrides: dict[str, Any] | None,
) -> Reproduction:
    """:func:`reproduce` once its inputs are checked and its folder is held."""
    from twolink.foundation.executors import open_executor
    from twolink.foundation.io import atomic_write_json, atomic_write_text
    from twolink.studies.designs.design import design_or_load
    from twolink.studies.designs.search import search_closing
    from twolink.studies.reproduction import answer, report
    from twolink.studies.reproduction.report_sections import design_section, oscillation_section

    phase = _Phases(progress, 4)
    workers = workers or os.cpu_count() or 1
    kind = "inprocess" if workers <= 1 else "process"
    # The pool starts first: its workers import while the design runs. Left by Ctrl-C or
    # any failure, it stops its tasks at once (SweepExecutor.__exit__); written files are whole.
    with open_executor(kind, workers) as pool:
        study, mismatched = _start_flexible_studies(pool, manifest, out)
        warned: list[tuple[str, list[str], list[str]]] = []  # per task: its warnings, runs
        phase("design: the FCM rule base (reused when its inputs are unchanged)")
        result, designed = design_or_load(config, out / "design")
        rule_base = out / "design" / "rule_base.toml"
        specs = plan(
            manifest, rule_base, result.clustering.centers, overrides, centre_rules(result)
        )
        scenarios = {sp.folder: load_scenario(sp.experiment.scenario, sp.overrides) for sp in specs}
        phase(_runs_phase(len(specs), study is not None, manifest))
        # Resume per run, unless the design was just made: its rule base's runs are new.
        rows, pending = run_all(
            specs, out, pool, trace, None if designed else scenarios, busy=study is not None
        )
        # A task, not drawn here: the main process then never imports matplotlib, and
        # the runs do not wait for the validity sweep.
        design_evidence = pool.submit(design_figures, result, out)
        drawing = [design_evidence]

        def draw(function: Any, *args: Any) -> None:  # a figure, as a task of the pool
            drawing.append(pool.submit(function, *args))

        claims, claim_tables = _collect_runs(
            manifest, out, pool, progress, specs, rows, pending, warned
        )
        summary: list[str] = []
        if claim_tables:  # the answer at a glance: summary.md and its figures
            summary = answer.answer_at_a_glance(out, manifest, claim_tables, draw)
        phase(
            "figures: responses, phase plane, membership functions, control surfaces"
            + (f"; and reproduction.rrd ({len(specs)} runs) beside them" if trace else "")
            + ", in the pool"
        )
        gain_section, figures, trajectories = _draw_figures(
            pool, manifest, specs, out, trace, drawing
        )
        sections = oscillation_section(specs, scenarios, trajectories, rows) + gain_section
        more, calibrated = _calibration(manifest, out, draw)
        sections += more
        validity = design_evidence.result()
        sections += design_section(result, specs, scenarios, rows, validity)
        sections += _flexible_sections(out, study, mismatched, warned, rows, manifest)
        sections += warnings_section(warned)
        _say_warnings(warned, progress)
        for fut in drawing:
            fut.result()
    phase("report: report.md, metrics.csv, metrics.json")
    text = report.render(
        rows, manifest, describe_choices(specs, scenarios, config), figures, sections,
        lead_sections=claims, calibrated=calibrated, claims_tables=claim_tables,
        closing=search_closing(out), summary=summary,
    )  # fmt: skip
    atomic_write_text(out / "report.md", text)
    atomic_write_text(out / "metrics.csv", report.rows_to_csv(rows))
    atomic_write_json(out / "metrics.json", rows)
    return Reproduction(out, rows, designed, rule_base)


def _draw_figures(
    pool: Any, manifest: Manifest, specs: list[RunSpec], out: Path, trace: bool, drawing: list
) -> tuple[list[str], dict[str, str], dict[str, Trajectory]]:
    """The figures and the combined recording as tasks of ``pool`` (added to ``drawing``):
    the recording first (the longest task left), the gain study's figure next (the slowest,
    ~1.5 s), then the responses and the README's figure (where the pair differ most).
    Returns the gain study's section, the response figures and the runs' trajectories."""
    from twolink.studies.designs.gains import report_section

    if trace:
        drawing.append(pool.submit(_combined_recording, out, specs))
    gain_section = []
    if manifest.gain_study is not None:
        draw = lambda function, *args: drawing.append(pool.submit(function, *args))  # noqa: E731
        gain_section = report_section(manifest.gain_study, out, pool, draw)
    figures = _draw_responses(pool, manifest, specs, out, drawing)
    trajectories = {sp.folder: load_trajectory(out, sp) for sp in specs}
    shown = hero(specs, trajectories, (manifest.proposed, manifest.baseline))
    if shown is not None:
        drawing.append(pool.submit(response_figure, out, *shown, out / HERO_FIGURE))
    if manifest.lab_study is not None:  # the lab arm's section shows hunting
        drawing.append(pool.submit(save_hunting_figure, out / HUNTING_FIGURE))
    return gain_section, figures, trajectories


def _runs_phase(runs: int, flexible: bool, manifest: Manifest) -> str:
    """The runs phase's line: what runs beside the experiments."""
    return (
        f"runs: {runs} experiments x controllers x variants, as batches of arms"
        + (" (and the flexible-joint study)" if flexible else "")
        + (
            f"; beside them the claims study ({manifest.claims_study.name})"
            if manifest.claims_study is not None
            else ""
        )
    )


def _calibration(manifest: Manifest, out: Path, draw: Any) -> tuple[list[str], Any]:
    """The shipped calibration rerun (a few runs): its report section and the report's
    calibrated column (none where the manifest names no calibration)."""
    if manifest.calibration is None:
        return [], None
    from twolink.studies.designs import calibration_report

    shipped = calibration_report.rerun_shipped(manifest.calibration)
    section = calibration_report.report_section(manifest.calibration, out, shipped, draw)
    return section, calibration_report.table_values(shipped)


def _start_flexible_studies(pool: Any, manifest: Manifest, out: Path) -> tuple[Any, Any]:
    """The flexible-joint studies as tasks of ``pool`` (their warnings recorded): they need
    nothing of the design (their FCM-CTC is the shipped designed rule base), so the workers
    start while it runs. None for a study the manifest does not name."""
    study = mismatched = None
    if manifest.flexible_study is not None:
        study = pool.submit(quietly, flexible_study, manifest.flexible_study, out)
    if manifest.flexible_model_error:
        mismatched = pool.submit(
            quietly, flexible_study, manifest.flexible_study, out, manifest.flexible_model_error
        )
    return study, mismatched


def _collect_runs(
    manifest: Manifest,
    out: Path,
    pool: Any,
    progress: bool,
    specs: list[RunSpec],
    rows: list[dict[str, Any]],
    pending: dict[Any, list[int]],
    warned: list[tuple[str, list[str], list[str]]],
) -> tuple[list[str], list[Any]]:
    """The runs' rows into ``rows`` as their batches finish (their warnings and stopped
    runs into ``warned``), the claims studies beside them on the same pool; returns the
    claims' sections and tables. The runs' bar advances as batches finish, while the
    claims sweeps show their own."""
    from tqdm import tqdm

    claims: list[str] = []
    claim_tables: list[Any] = []
    initial = sum(bool(r) for r in rows)
    with tqdm(
        total=len(specs), initial=initial, desc="runs", unit="run", disable=not progress
    ) as bar:
        for fut, indices in pending.items():
            fut.add_done_callback(functools.partial(_advance, bar, len(indices)))
        if manifest.claims_study is not None:
            claims, claim_tables = run_claims(manifest, out, pool, progress)
        for fut in as_completed(pending):
            batch, lines = fut.result()
            for i, row in zip(pending[fut], batch, strict=True):
                rows[i] = row
            stopped = [
                specs[i].folder
                for i, r in zip(pending[fut], batch, strict=True)
                if r["status"] != "ok"
            ]
            warned.append((f"runs batch of {len(batch)}", lines, stopped))
    return claims, claim_tables


def _draw_responses(
    pool: Any, manifest: Manifest, specs: list[RunSpec], out: Path, drawing: list[Any]
) -> dict[str, str]:
    """Each experiment's response figure per variant, as tasks of ``pool`` (added to
    ``drawing``); returns "variant/experiment" -> its file."""
    figures: dict[str, str] = {}
    for variant in manifest.variants:
        for exp in manifest.experiments:
            runs = {
                sp.controller: sp.folder
                for sp in specs
                if sp.experiment is exp and sp.variant is variant
            }
            name = f"figures/{variant.name}_{exp.key}.png"
            title = f"{exp.label}: {exp.title}\n({variant.title})"
            drawing.append(pool.submit(response_figure, out, runs, exp.joint, title, out / name))
            figures[f"{variant.name}/{exp.key}"] = name
    return figures


def _flexible_sections(
    out: Path,
    study: Any,
    mismatched: Any,
    warned: list[tuple[str, list[str], list[str]]],
    rows: list[dict[str, Any]],
    manifest: Manifest,
) -> list[str]:
    """The flexible-joint studies' report sections once they end (their warnings and
    stopped runs into ``warned``), then the bending links' (from the runs' ``rows``)."""
    sections: list[str] = []
    for name, fut in (("flexible_study", study), ("flexible_study_error", mismatched)):
        if fut is not None:
            more, lines = fut.result()
            sections += more
            warned.append((f"{name}/", lines, _stopped(out / name)))
    return sections + links_section(rows, manifest)


def centre_rules(result: Any) -> list[str]:
    """Each FCM centre's name in the recordings: the rule the design kept for it
    (``"PS,NM→NS"``, :func:`twolink.controllers.fuzzy.engine.rule_label`)."""
    from twolink.controllers.fuzzy.engine import rule_label

    return [rule_label(result.engine.rules[k]) for k in result.kept]


def _combined_recording(out: Path, specs: list[RunSpec]) -> None:
    """reproduction.rrd: one tab per experiment, its controllers side by side
    (:func:`twolink.tracing.comparison.write_comparison`), from the runs' folders (a worker
    task: reading them here spares the pool's pipe the pickled trajectories)."""
    from twolink.tracing.comparison import ExperimentRuns, write_comparison

    experiments: dict[str, ExperimentRuns] = {}
    for sp in specs:
        prefix = f"{sp.variant.name}/{sp.experiment.key}"
        if prefix not in experiments:
            title = f"{sp.variant.name}: {sp.experiment.key}"
            experiments[prefix] = ExperimentRuns(prefix, title, sp.experiment.joint, {})
        experiments[prefix].runs[sp.controller] = load_trajectory(out, sp)  # type: ignore[index]
    write_comparison(out / "reproduction.rrd", list(experiments.values()))
