"""The ``twolink`` command line.

Exit codes: 0 ok, 1 a run failed or diverged (or a check failed), 2 bad input (or an
output folder twolink may not write into), 3 an output could not be written (disk full, no
permission, file-size limit), 130 Ctrl-C, 143 SIGTERM (docs/reliability.md).
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from pathlib import Path

import click

from twolink.foundation.executors import (
    EXECUTORS,
    SWEEP_PRELOAD,
    open_executor,
    prestart_fork_server,
)
from twolink.foundation.interrupts import (
    CTRL_C_RECEIVED,
    command_ending,
    command_starting,
    forget_escaped_interrupt,
    on_ctrl_c,
    resend_dropped_ctrl_c,
)
from twolink.foundation.io import ForeignOutput, OutputBusy, WriteFailed
from twolink.foundation.shipped import LinkLoop, NameTooLong, NotAClone, install_target, locate
from twolink.interface.cli_options import (
    backend_option,
    install_option,
    no_plots_option,
    no_trace_option,
    out_file_option,
    out_folder_option,
    samples_option,
    seed_option,
    set_option,
    workers_option,
)
from twolink.interface.cli_output import (
    done_line,
    format_metrics,
    format_tip_metrics,
    own_output,
    sweep_exits,
)
from twolink.interface.cli_output import fail_input as _fail_input


def interrupted_exit() -> None:
    """End an interrupted command: one line, exit 130 (Ctrl-C) or 143 (SIGTERM)."""
    command_ending()  # a signal more, or a Ctrl-C resent, no longer raises
    signum = CTRL_C_RECEIVED[0] if CTRL_C_RECEIVED else signal.SIGINT
    what = "terminated (SIGTERM)" if signum == signal.SIGTERM else "interrupted"
    click.echo(f"{what}: files written so far are whole; rerun to complete", err=True)
    sys.exit(128 + int(signum))


class _Group(click.Group):
    """Ctrl-C ends every command with exit 130 and one line, in every phase (click's own
    handling says "Aborted!" and exits 1, which this CLI means as "a run diverged").

    A Ctrl-C that lands inside a compiled extension can come out as another exception
    (pybind11 reports a KeyboardInterrupt raised while it converts arguments as a
    TypeError, e.g. in matplotlib's transforms): once a Ctrl-C was received, whatever
    error ends the command is reported as the interruption it is. One that Python drops
    is sent again (:func:`resend_dropped_ctrl_c`)."""

    def main(self, *args, standalone_mode: bool = True, **kwargs):
        if not standalone_mode:
            return super().main(*args, standalone_mode=False, **kwargs)
        command_starting()
        previous = signal.getsignal(signal.SIGINT)
        # Not where Ctrl-C is ignored, and only where handlers can be set (the main thread).
        main_thread = threading.current_thread() is threading.main_thread()
        if previous is signal.default_int_handler and main_thread:
            signal.signal(signal.SIGINT, on_ctrl_c)
        # SIGTERM goes the way of Ctrl-C (temporaries removed, one line), with exit 143.
        previous_term = signal.getsignal(signal.SIGTERM)
        if previous_term is signal.SIG_DFL and main_thread:
            signal.signal(signal.SIGTERM, on_ctrl_c)
        previous_hook, sys.unraisablehook = sys.unraisablehook, resend_dropped_ctrl_c
        try:
            code = super().main(*args, standalone_mode=False, **kwargs)
        except click.exceptions.Abort:
            interrupted_exit()
        except click.ClickException as exc:
            exc.show()
            sys.exit(exc.exit_code)
        except (ForeignOutput, OutputBusy, NotAClone, LinkLoop, NameTooLong) as exc:
            click.echo(f"error: {exc}", err=True)
            sys.exit(2)
        except WriteFailed as exc:
            click.echo(f"error: {exc}; results written before are whole", err=True)
            sys.exit(3)
        except Exception:
            if not CTRL_C_RECEIVED:
                raise
            interrupted_exit()
        finally:
            command_ending()  # before the handlers go: a resend now would find Python's
            if signal.getsignal(signal.SIGINT) is on_ctrl_c:
                signal.signal(signal.SIGINT, previous)
            if signal.getsignal(signal.SIGTERM) is on_ctrl_c:
                signal.signal(signal.SIGTERM, previous_term)
            sys.unraisablehook = previous_hook
            forget_escaped_interrupt()  # else `python -m twolink` ends by SIGINT, not 130
            CTRL_C_RECEIVED.clear()  # the command is over: none is pending for later code
        sys.exit(code if isinstance(code, int) else 0)


@click.group(
    cls=_Group,
    context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100},
)
@click.version_option(package_name="twolink", prog_name="twolink")
def main() -> None:
    """A two-link arm in MuJoCo with the paper's CTC and FCM fuzzy controllers.

    \b
    Examples:
      twolink reproduce                          # the paper's tables and figures
      twolink run paper/theta1_step              # one shipped scenario (or a file)
      twolink sweep sweeps/robustness -n 50
    """


@main.command(short_help="Check the analytic dynamics against MuJoCo's.")
# ~5 ms a sample (a model built per arm): 10^5 in ~8 min
@samples_option("Random arms and states (at most 10^5).", most=10**5, default=1000)
@seed_option("Seed of the random draws.")
def validate(samples: int, seed: int) -> None:
    """Check the analytic M, H, G against MuJoCo's own dynamics; exit 1 on any failure.

    \b
    Examples:
      twolink validate                 # 1000 random arms
      twolink validate -n 100 --seed 3
    """
    from twolink.arm.validation import format_table
    from twolink.arm.validation import validate as run_checks

    checks = run_checks(samples, seed)
    click.echo(format_table(checks))
    if not all(c.passed for c in checks):
        sys.exit(1)


@main.command(short_help="Run one scenario file.")
@click.argument("scenario", type=click.Path(path_type=Path))
@out_folder_option("Output folder [default: results/<scenario file name without .toml>].")
@set_option("the scenario", "controller.kp=25")
@no_plots_option()
@no_trace_option("Skip the rerun recording (trace.rrd).")
def run(
    scenario: Path, out: Path | None, settings: tuple[str, ...], no_plots: bool, no_trace: bool
) -> None:
    """Run one scenario file (or a shipped one by its name: paper/theta1_step, the path
    under the shipped runs without .toml; a real path wins) and write its results folder.

    \b
    Examples:
      twolink run paper/theta1_step               # a shipped scenario by its name
      twolink run my_scenario.toml --out /tmp/step --no-trace

    Exit 0 when the run completes, 1 when it diverged (what was computed is kept),
    2 on a bad scenario file.
    """
    from twolink.simulation.config import ConfigError, load_scenario, parse_set
    from twolink.simulation.experiment import (
        build_controller,
        build_plant,
        measure,
        run_scenario,
    )
    from twolink.studies.reproduction.run_folder import write_run

    scenario = locate(scenario)  # a real path, else a shipped scenario's name
    folder = out or Path("results") / Path(scenario).stem
    try:
        s = load_scenario(scenario, parse_set(settings))
        controller = build_controller(s)
        plant = build_plant(s)
    except (ConfigError, OSError) as exc:
        _fail_input(str(exc))
    except ValueError as exc:  # a rule base with bad labels; an arm MuJoCo refuses
        _fail_input(f"{scenario}: {exc}")
    own_output(folder, "run", str(Path(scenario).resolve()), default=out is None)
    engine = getattr(controller, "engine", None)
    if engine is not None:
        from twolink.controllers.fuzzy import uncovered_fraction

        gap = uncovered_fraction(engine)
        if gap > 0:
            click.echo(
                f"warning: {scenario}: controller.rule_base: no rule fires on {100 * gap:.0f} % "
                "of the (e, de) input box; there the fuzzy term is 0 (CTC alone acts)",
                err=True,
            )
    tip, bent = None, None
    if s.links is None:
        traj = run_scenario(s, controller, plant)
    else:  # links that bend: the tip's measures and the bent arm's points too
        from twolink.simulation.links_sim import run_links, scenario_tip_metrics

        link_run = run_links(s, controller)
        traj, tip = link_run.trajectory, scenario_tip_metrics(s, link_run).to_dict()
        bent = {"bent": link_run.points}
    metrics = measure(s, traj, controller)
    folder = write_run(
        folder,
        s,
        traj,
        metrics,
        plots=not no_plots,
        trace=not no_trace,
        controller=controller,
        more_metrics={"tip": tip} if tip is not None else None,
        more_extras=bent,
    )
    from twolink.simulation.outcome import SuccessSpec, classify_run, reasons, settling_window

    click.echo(format_metrics(metrics))
    if tip is not None:
        click.echo(format_tip_metrics(tip))
    spec = SuccessSpec()
    click.echo(
        f"outcome: {classify_run(s, metrics, spec)} (spec: the reference finished, every "
        f"joint within {100 * spec.final_error:g} % of the step of its target over the last "
        f"{settling_window(s.duration):g} s, its error not growing there (at most "
        f"×{spec.max_tail_growth:g}), overshoot at most {spec.max_overshoot_pct:g} %)"
    )
    if traj.ok:
        for reason in reasons(s, metrics, spec):
            click.echo(f"  off target: {reason}")
    for warning in metrics.warnings:  # physically meaningless states (docs/model.md)
        click.echo(f"warning: {warning}")
    click.echo(f"results in {folder}")
    if not no_trace:
        from twolink.simulation.experiment import TRACE_EVERY

        rate = 1.0 / (s.control_dt * TRACE_EVERY)
        click.echo(
            f"recording: {folder / 'trace.rrd'} at {rate:g} Hz (every {TRACE_EVERY}th sample; "
            f"trajectory.npz has all); view it with: rerun {folder / 'trace.rrd'} "
            "(no display: rerun --serve-web FILE)"
        )
    if not traj.ok:
        click.echo(f"run diverged: {traj.message}", err=True)
        sys.exit(1)


@main.command(short_help="Design the reduced FCM rule base.")
@click.option(
    "--config",
    "config_path",
    type=click.Path(path_type=Path),
    default=None,
    help="Design file [default: runs/paper/design.toml].",
)
@out_file_option("Rule-base file to write [default: results/design/rule_base.toml].")
@install_option('Write the shipped rule base that `rule_base = "designed"` selects instead.')
@click.option(
    "--figure",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="Also save the phase-plane figure (the paper's Figure 2) here, and the "
    "cluster-validity figure (PC, PE, XB for c = 2..10) beside it as <stem>_validity.png.",
)
def design(config_path: Path | None, out: Path | None, install: bool, figure: Path | None) -> None:
    """Design the reduced FCM rule base (the paper's steps 1-6) and write it with evidence.

    \b
    Examples:
      twolink design                       # into results/design/rule_base.toml
      twolink design --figure phase.png    # also the paper's Figure 2, phase_validity.png
      twolink design --install             # update controllers/rulebases/designed.toml
    """
    from twolink.foundation.io import check_output_file
    from twolink.simulation.config import RULEBASE_DIR, ConfigError
    from twolink.studies.designs.design import DEFAULT_DESIGN, load_design_config, write_design
    from twolink.studies.designs.design import design as run_design

    if install and out is not None:
        _fail_input("--install writes the shipped designed rule base; it takes no --out")
    target = (
        install_target(RULEBASE_DIR / "designed.toml")
        if install
        else out or Path("results/design/rule_base.toml")
    )
    try:
        config = load_design_config(config_path or DEFAULT_DESIGN)
        check_output_file(target, "--out", ours_only=not install)
        if figure:
            from twolink.interface.cli_fuzzy import validity_figure_path

            check_output_file(figure, "--figure")
            check_output_file(validity_figure_path(figure), "--figure")
    except (ConfigError, OSError) as exc:
        _fail_input(str(exc))
    try:
        result = run_design(config)
    except ConfigError as exc:
        _fail_input(str(exc))
    path = write_design(result, target)
    for j, i in enumerate(result.kept):
        rule = result.engine.rules[i]
        c = result.clustering.centers[j]
        click.echo(
            f"cluster {j}: centre ({c[0]:+.3f}, {c[1]:+.3f})  rule {' '.join(rule)}"
            f"  score {result.scores[j, i]:.3f}"
        )
    added = [r for r in result.rules if r not in result.clustered_rules]
    quadrants = ", ".join(f"{q} {n}" for q, n in result.quadrant_counts.items())
    click.echo(
        f"samples {len(result.points)}: {result.settled_count} settled (|e|+|de| < "
        f"{result.settled_radius:g}, {100 * result.settled_weight_share:.1f} % of the weight, "
        f"{result.settled!r}), {result.trimmed_count} weigh nothing; outside: {quadrants}"
    )
    click.echo(
        f"symmetry {result.symmetry!r}: {len(added)} mirror rules added, surface asymmetry "
        f"{result.symmetry_of(result.rules).max_asymmetry:.3g}"
    )
    for row in result.validation:
        click.echo(
            f"held out: {row.file:22s} {row.controller:11s} ωn ×{row.wn_scale:<5.3g} "
            f"Mp {row.overshoot_pct:6.3g} %  "
            f"Ts {row.settling_s:6.3g} s  IAE {row.iae:8.3g} rad s  peak tau "
            f"{row.peak_torque_Nm:6.3g} N m"
        )
    click.echo(f"{len(result.rules)} rules kept -> {path}")
    if install:
        from twolink.studies.designs.design import DOCS, update_docs

        update_docs(path, DOCS)
        click.echo(f"designed rule base tables -> {DOCS}")
    if figure:
        from twolink.figures.plots import phase_plane_figure, save_figure

        save_figure(phase_plane_figure(result), figure)
        click.echo(f"phase plane -> {figure}")
        from twolink.interface.cli_fuzzy import validity_figure_path, write_validity_figure

        rows = write_validity_figure(result, validity_figure_path(figure))
        indices = "; ".join(
            f"c={r.clusters} PC {r.pc:.3f} PE {r.pe:.3f} XB {r.xb:.3g}" for r in rows
        )
        click.echo(
            f"cluster validity (design c = {result.clustering.n_clusters}): {indices}"
            f" -> {validity_figure_path(figure)}"
        )


@main.command(short_help="Run the gain study and apply its design rule.")
@click.argument("study_file", required=False, type=click.Path(path_type=Path))
@out_folder_option(
    "Folder for the table (gains.csv), its choice (gains.json) and the trade-off figure.",
    Path("results/gains"),
)
@install_option(
    "Also write the study's shipped table (runs/paper/gains.csv) that the reproduction reads."
)
@workers_option()
@set_option("the study file", "plants=10")
def gains(study_file: Path | None, out: Path, install: bool, workers: int | None, settings) -> None:
    """Run the gain study (ωn, ζ against error under mismatch, torque and saturation) and
    print the operating point its design rule picks (docs/control.md).

    \b
    Examples:
      twolink gains                             # runs/paper/gains.toml -> results/gains/
      twolink gains --set plants=10             # a quicker, coarser study
      twolink gains --install                   # update runs/paper/gains.csv
    """
    from twolink.simulation.config import ConfigError, parse_set
    from twolink.studies.designs import gains as study_module

    try:
        study = study_module.load_gain_study(
            study_file or study_module.DEFAULT_STUDY, parse_set(settings)
        )
    except (ConfigError, OSError) as exc:
        _fail_input(str(exc))
    if install:
        install_target(study_module.table_path(study))
    own_output(out, "gains", str(study.source))
    click.echo(f"gain study: {study_module.n_runs(study)} runs ({study.source})", err=True)
    if install and parse_set(settings):
        _fail_input("--install writes the shipped table of the study file as it is; drop --set")
    with open_executor("process", workers, preload=SWEEP_PRELOAD) as pool:
        results = study_module.run_gain_study(study, pool, progress=True)
    table = study_module.gain_table(results, study.quantile)
    try:
        choice = study_module.choose(table, study)
    except ValueError as exc:
        choice = None
        click.echo(f"error: {exc}", err=True)
    if choice is not None:
        study_module.save_study(table, study, choice, out / "gains.csv")
        if install:
            study_module.save_study(table, study, choice, study_module.table_path(study))
    study_module.tradeoff_figure(table, study, choice, out / "gain_tradeoff.png")
    if choice is None:
        sys.exit(1)
    click.echo("\n".join(study_module.summary_lines(table, choice)))
    click.echo(f"\n{choice.reason}")
    if choice.stiffness_note():
        click.echo(choice.stiffness_note().replace("**", ""))
    click.echo(f"kp = {choice.wn**2:g}, kd = {2 * choice.zeta * choice.wn:g}, ki = {choice.ki:g}")
    click.echo(f"-> {out}" + (f" and {study_module.table_path(study)}" if install else ""))


@main.command(short_help="Fit the paper's unstated parameters to its tables.")
@click.argument("study_file", required=False, type=click.Path(path_type=Path))
@out_folder_option(
    "Folder for calibrated.toml and the profile figure (calibration_profile.png).",
    Path("results/calibrate"),
)
@install_option(
    "Also write the shipped result (runs/paper/calibrated.toml) that the report reruns."
)
@set_option("the study file", "maxiter=2")
def calibrate(study_file: Path | None, out: Path, install: bool, settings) -> None:
    """Fit the paper's unstated parameters (gains, step and ramp sizes, model mismatch,
    fuzzy scaling) to its nominal tables by differential evolution (docs/reproduction.md,
    "Calibrating to the paper's tables").

    \b
    Examples:
      twolink calibrate                     # runs/paper/calibrate.toml -> results/calibrate/
      twolink calibrate --set maxiter=2 --set popsize=4   # a tiny, quick fit
      twolink calibrate --install                   # update runs/paper/calibrated.toml
    """
    from twolink.simulation.config import ConfigError, parse_set
    from twolink.studies.designs import calibrate as cal
    from twolink.studies.designs import calibration_report

    try:
        study = cal.load_calibration(study_file or cal.DEFAULT_STUDY, parse_set(settings))
    except (ConfigError, OSError) as exc:
        _fail_input(str(exc))
    if install:
        install_target(cal.result_path(study))
    own_output(out, "calibrate", str(Path(study.source).resolve()))
    if install and parse_set(settings):
        _fail_input("--install writes the shipped result of the study file as it is; drop --set")
    result = cal.calibrate(study, log=lambda msg: click.echo(msg, err=True))
    cal.save_result(result, out / "calibrated.toml")
    calibration_report.profile_figure(study, result, out / "calibration_profile.png")
    if install:
        cal.save_result(result, cal.result_path(study))
    click.echo("\n".join(calibration_report.summary_lines(study, result, result["rows"])))
    click.echo(f"-> {out}" + (f" and {cal.result_path(study)}" if install else ""))


@main.command(short_help="Reproduce the paper's tables and figures.")
@out_folder_option("Output folder.", Path("results/reproduce"))
@click.option(
    "--manifest",
    type=click.Path(path_type=Path),
    default=None,
    help="Reproduction manifest [default: runs/paper/reproduce.toml].",
)
@workers_option()
@no_trace_option("Skip the rerun recordings.")
@set_option(
    "every experiment's scenario (a controller's own keys in the manifest win)", "duration=12"
)
def reproduce(
    out: Path, manifest: Path | None, workers: int | None, no_trace: bool, settings: tuple[str, ...]
) -> None:
    """Reproduce the paper's Tables 2-8 and figures: report, CSV/JSON, PNGs, .rrd.

    \b
    Examples:
      twolink reproduce                          # into results/reproduce
      twolink reproduce --out /tmp/r --no-trace  # elsewhere, without recordings
    """
    if (workers or os.cpu_count() or 1) > 1:  # the workers' server imports beside us
        prestart_fork_server()
    from twolink.simulation.config import ConfigError, parse_set
    from twolink.studies.reproduction.reproduce import DEFAULT_MANIFEST
    from twolink.studies.reproduction.reproduce import reproduce as run_reproduction

    try:
        result = run_reproduction(
            manifest or DEFAULT_MANIFEST,
            out,
            workers,
            trace=not no_trace,
            overrides=parse_set(settings),
        )
    except (WriteFailed, ForeignOutput, OutputBusy):
        raise  # exit 3 / 2, by the group
    except (ConfigError, OSError) as exc:
        _fail_input(str(exc))
    except KeyboardInterrupt:
        interrupted_exit()
    from twolink.studies.judgments.plain import runs_line
    from twolink.studies.reproduction.manifest import load_manifest

    failed = [r for r in result.rows if r["status"] != "ok"]
    plan = load_manifest(manifest or DEFAULT_MANIFEST)
    click.echo(runs_line(result.rows, plan, str(out / "summary.md")))
    click.echo(f"{'designed' if result.designed else 'reused'} rule base {result.rule_base}")
    click.echo(f"report:     {out / 'report.md'}")
    click.echo(f"metrics:    {out / 'metrics.csv'}, {out / 'metrics.json'}")
    click.echo(f"figures:    {out / 'figures'}")
    if not no_trace:
        from twolink.simulation.experiment import TRACE_EVERY
        from twolink.tracing.comparison import COMPARISON_EVERY

        click.echo(
            f"recordings: {out / 'reproduction.rrd'} (a tab per experiment, its controllers "
            f"side by side, every {COMPARISON_EVERY}th sample) and a trace.rrd per run (every "
            f"{TRACE_EVERY}th); trajectory.npz has all"
        )
        click.echo(
            f"view:       rerun {out / 'reproduction.rrd'}   "
            "(no display: rerun --serve-web FILE, then open http://localhost:9090)"
        )
    if failed:
        click.echo(f"{len(failed)} run(s) diverged: see the report", err=True)
    click.echo(done_line())


@main.command("sweep", short_help="Run a Monte Carlo sweep file.")
@click.argument("sweep_file", type=click.Path(path_type=Path))
@out_folder_option("Output folder [default: results/sweeps/<sweep name>].")
@click.option(
    "--executor",
    type=click.Choice(EXECUTORS),
    default=None,
    help="Where samples run [default: the sweep file's, else process].",
)
@workers_option("Worker processes [default: all cores].")
@click.option("--scheduler", default=None, help="Dask scheduler address (implies dask).")
@samples_option("Override N.")
@click.option("--fresh", is_flag=True, help="Discard chunks already in --out.")
@no_plots_option()
@click.option("--progress/--no-progress", default=True, show_default=True)
@backend_option('MuJoCo on the CPU (default), or MJX (MuJoCo in JAX; pip install "twolink[mjx]").')
@click.option("--precision", type=click.Choice(["float64", "float32"]), default="float64",
              help="MJX's floating point (float32: its error in docs/batch.md).")  # fmt: skip
@set_option("the sweep file", "overrides.duration=3")
def sweep_command(
    sweep_file: Path,
    out: Path | None,
    executor: str | None,
    workers: int | None,
    scheduler: str | None,
    samples: int | None,
    fresh: bool,
    no_plots: bool,
    progress: bool,
    backend: str,
    precision: str,
    settings: tuple[str, ...],
) -> None:
    """Run a Monte Carlo sweep file (or a shipped one by its name, as sweeps/robustness):
    every controller on N drawn plants.

    \b
    Examples:
      twolink sweep sweeps/robustness -n 50       # a shipped sweep by its name
      twolink sweep sweeps/robustness --executor dask --workers 4

    Resumable: rerun the same command to compute only the chunks not yet in --out.
    Exit 0 when the table is written (diverged samples are results, not failures),
    1 when the executor fails, 2 on bad input, 130/143 when stopped by SIGINT/SIGTERM.
    """
    from twolink.foundation.io import check_output_folder, check_ownership
    from twolink.simulation.config import ConfigError, merge, parse_set
    from twolink.sweep import SweepOutputError, format_summary, load_sweep, run_sweep

    try:
        overrides = merge(parse_set(settings), {"samples": samples} if samples else {})
        plan = load_sweep(sweep_file, overrides)
    except ConfigError as exc:
        _fail_input(str(exc))
    if scheduler and executor not in (None, "dask"):
        _fail_input(f"--scheduler needs --executor dask, not {executor}")
    if backend == "cpu" and precision != "float64":
        _fail_input("--precision is MJX's (--backend mjx); the CPU engine runs in float64")
    engine = backend if precision == "float64" else f"{backend}-{precision}"
    out = out or Path("results") / "sweeps" / plan.name
    try:
        check_output_folder(out)
        check_ownership(out, "sweep", plan.file)
    except OSError as exc:
        _fail_input(str(exc))
    try:
        with sweep_exits(out):
            outcome = run_sweep(
                plan,
                out,
                executor=executor,
                workers=workers,
                scheduler=scheduler,
                progress=progress,
                plots=not no_plots,
                fresh=fresh,
                backend=engine,
            )
    except (SweepOutputError, OutputBusy, ForeignOutput) as exc:
        _fail_input(str(exc))
    except ValueError as exc:  # inconsistent executor options
        _fail_input(str(exc))
    click.echo(format_summary(outcome.summary))
    click.echo(
        f"{plan.samples} samples x {len(plan.controllers)} controllers: "
        f"{len(outcome.computed)} chunks computed, {len(outcome.reused)} reused; "
        f"results in {outcome.table}"
    )
    click.echo(done_line())


from twolink.interface.cli_compare import compare_command  # noqa: E402
from twolink.interface.cli_fuzzy import coverage_command, fis_command  # noqa: E402
from twolink.interface.cli_models import models  # noqa: E402
from twolink.interface.cli_studies import (  # noqa: E402
    frontier_command,
    regimes_command,
    search_command,
)

main.add_command(compare_command)
main.add_command(models)
main.add_command(coverage_command)
main.add_command(fis_command)
main.add_command(regimes_command)
main.add_command(frontier_command)
main.add_command(search_command)


if __name__ == "__main__":
    main()
