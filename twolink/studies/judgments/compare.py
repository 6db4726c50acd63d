"""Two controllers on one scenario in one call (``twolink compare``, ``twolink.compare``):
the paired table with its verdicts, an overlay figure with a difference panel, and one
rerun recording (docs/compare.md).

The plants are drawn as the shipped robustness sweep draws them (``sweeps/robustness``'s
``[parameters]``: masses and lengths off by drawn factors, gravity, a payload the
controllers do not know about), or are the user's own, a table of one row per plant
(``plants=`` a CSV file or a DataFrame: :mod:`twolink.sweep.plants_csv`), run as the
sweep's ``listed`` parameters; the scenario is run as it stands (its reference, duration
and sensor). ``A`` is judged against ``B``, plant by plant, with
:func:`twolink.studies.judgments.claims.paired_claims`:
"better" means A's metric is lower than B's by more than the practical tolerance on the
typical plant (the verdict rule of docs/statistics.md, Holm-corrected over the table).
The sweep this runs is written as a file (``compare.toml``) so that ``twolink sweep`` can
rerun it.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Sequence
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from twolink.foundation.io import atomic_write_text, toml_table, toml_value
from twolink.foundation.shipped import locate, runs_dir
from twolink.simulation.config import CONTROLLER_KINDS, ConfigError, read_toml, scenario_from_dict

__all__ = [
    "Comparison",
    "NothingToJudge",
    "compare",
    "controller_table",
    "format_claims",
    "minimum_plants",
    "too_few",
]

PLANTS = runs_dir() / "sweeps" / "robustness.toml"  # whose [parameters] draw the plants
FIGURE_EVERY = 10  # the figure's time grid: every 10th sample (100 Hz of the 1 kHz loop)
SHOWN = {  # the paired table's columns as printed, in this order (others are in the CSV)
    "joint": "joint",
    "metric": "metric",
    "n": "n",
    "better": "better",
    "worse": "worse",
    "equal": "equal",
    "proposed_median": "median A",
    "baseline_median": "median B",
    "estimate": "A − B",
    "ci_low": "CI low",  # at ci_level (Bonferroni over the table): the verdict's
    "ci_high": "CI high",
    "margin_p_adjusted": "p margin (Holm)",
    "verdict": "verdict",
}  # each row's reading (the verdict in words) is printed under the table


@dataclass(frozen=True)
class Comparison:
    """What :func:`compare` found: ``claims`` (the paired table, one row per joint and
    metric: docs/statistics.md), ``results`` (the sweep's table, one row per plant and
    controller), how many plants each met the spec on, the figure, where written the
    folder, and where the plants were the user's own the file they came from
    (``plants_file``; "plants (a DataFrame)" for a DataFrame). ``str()`` prints the table
    with its header."""

    scenario: str
    a: str
    b: str
    plants: int
    claims: pd.DataFrame
    results: pd.DataFrame
    met_spec: dict[str, int]
    figure: Any = field(repr=False)
    folder: Path | None = None
    plants_file: str | None = None  # the user's plants (a file, or a DataFrame), if given

    def __str__(self) -> str:
        whose = f" of {self.plants_file}" if self.plants_file else ""
        head = (
            f"{self.a} against {self.b} on {self.plants} plants{whose}, {self.scenario} "
            f"(better: {self.a} lower beyond the tolerance; docs/statistics.md)"
        )
        met = ", ".join(f"{n} {self.met_spec[n]}" for n in (self.a, self.b))
        short = too_few(self.plants, judged_rows(self.claims), listed=bool(self.plants_file))
        return f"{head}\n{format_claims(self.claims)}\nmet the spec: {met} of {self.plants}" + (
            f"\n{short}" if short else ""
        )

    def _repr_html_(self) -> str:
        return self.claims.to_html(index=False)


def controller_table(name: str) -> dict[str, Any]:
    """The ``[controller]`` overrides a name stands for: a controller of the shipped
    reproduction (``CTC``, ``FCM-CTC``, ``PD-G``, ``CTC-I``, ``CTC-paper``, ``fuzzy-PD``,
    ``FCM-CTC-continuous``) or a controller kind (``ctc``, ``fcm_ctc``, ...)."""
    from twolink.studies.reproduction.manifest import DEFAULT_MANIFEST

    shipped = read_toml(DEFAULT_MANIFEST).get("controllers", {})
    if name in shipped:
        return dict(shipped[name])
    if name in CONTROLLER_KINDS:
        return {"kind": name}
    raise ConfigError(
        f"controller {name!r}: not a shipped controller ({', '.join(shipped)}) nor a kind "
        f"({', '.join(CONTROLLER_KINDS)})"
    )


def sweep_text(
    scenario: Path,
    a: str,
    b: str,
    plants: int,
    seed: int,
    overrides: dict | None = None,
    parameters: dict[str, Any] | None = None,
    whose: str = "the robustness sweep's plants",
) -> str:
    """The sweep :func:`compare` runs, as a file ``twolink sweep`` reads: ``plants``
    samples of ``parameters`` (by default the shipped robustness sweep's draws)."""
    if parameters is None:
        parameters = read_toml(PLANTS)["parameters"]
    lines = [
        "".join(  # a comment: a file's name with a line break ends no line here
            c if c.isprintable() else "?" for c in f"# twolink compare: {a} against {b} on {whose}"
        ),
        f"name = {toml_value('compare')}",
        f"scenario = {toml_value(str(scenario.resolve()))}",
        f"samples = {plants}",
        f"seed = {seed}",
        "",
    ]
    toml_table(lines, "parameters", parameters)
    if overrides:  # keys of the scenario, as --set gives them
        lines.append("")
        toml_table(lines, "overrides", overrides)
    for name in (a, b):
        lines.append("")
        toml_table(lines, f'controllers."{name}"', controller_table(name))
    return "\n".join(lines) + "\n"


def judged_rows(claims: pd.DataFrame) -> int:
    """The m of a paired table's Bonferroni level: its rows whose typical plant is judged
    (docs/statistics.md)."""
    from twolink.studies.judgments.claims_words import NOT_JUDGED

    return int((claims["typical"] != NOT_JUDGED).sum())


def minimum_plants(rows: int, limit: int = 1000) -> tuple[int, int]:
    """The fewest plants on which the typical plant can be judged in a table of ``rows``
    judged rows: the verdict rule itself (:func:`~twolink.studies.judgments.claims.judge_rows`,
    docs/statistics.md: the typical plant's interval at 1 − 5 %/rows) asked on its most
    favourable samples: "equivalent" on identical plants (every difference 0), "better" on
    plants all beyond the margin. With fewer plants the typical plant is "undecided"
    whatever the controllers do (identical plants still read "equal")."""
    from twolink.studies.judgments.claims import judge_rows

    rows = max(rows, 1)

    def verdicts(d: np.ndarray) -> set:
        a = np.tile(d, (rows, 1))
        zero, none = np.zeros(rows), np.zeros(rows, bool)
        judged = judge_rows(a, np.zeros_like(a), np.ones(rows), zero, none)
        return set(judged["typical"])

    equivalent = differ = 0
    for n in range(2, limit + 1):
        if not equivalent and verdicts(np.zeros(n)) == {"equivalent"}:
            equivalent = n
        if not differ and verdicts(-2.0 - np.arange(n) / n) == {"better"}:
            differ = n
        if equivalent and differ:
            return equivalent, differ
    raise ValueError(f"no verdict possible on up to {limit} plants")


def too_few(plants: int, rows: int, listed: bool = False) -> str:
    """The line that says a table has too few plants for a verdict, and how many would do;
    "" where there are enough for every verdict of the typical plant. ``listed``: the
    plants are the rows of the user's plants file, which more rows would add to."""
    equivalent, differ = minimum_plants(rows)
    tests = (
        f"with the typical plant's interval at 1 − 5 %/{rows} over {rows} rows, "
        f'"equivalent" needs at least {equivalent} plants and "better" or "worse" {differ}'
    )
    more = "more rows in the plants file" if listed else "--plants N"
    if plants < equivalent:
        return f"too few plants for any verdict ({plants}): {tests} ({more})"
    if plants < differ:
        return f'too few plants for "better" or "worse" ({plants}): {tests} ({more})'
    return ""


def check_plants(plants: int) -> None:
    """ConfigError, one line, where ``plants`` is not 1 to the most a sweep holds."""
    from twolink.sweep.plan import too_many_samples

    if isinstance(plants, bool) or not isinstance(plants, int | np.integer):
        raise ConfigError(
            f"compare: plants must be a number of plants, a CSV file of plants or a "
            f"DataFrame, got {plants!r}"
        )
    if plants < 1:
        raise ConfigError(f"compare: plants must be >= 1, got {plants}")
    if problem := too_many_samples(plants):
        raise ConfigError(f"compare: -n/--plants: {problem}")


Plants = int | str | Path | pd.DataFrame  # a number drawn, or a table of the user's own


def compare_sweep(
    path: Path, a: str, b: str, plants: Plants, seed: int, overrides: dict | None = None
) -> tuple[str, int, str | None]:
    """The sweep file :func:`compare` writes (``compare.toml``), its number of plants and
    the user's plants' source (None where they are drawn). ``plants``: a number drawn as
    the robustness sweep draws them, or a table of one row per plant (a CSV file or a
    DataFrame, :func:`twolink.sweep.plants_csv.read_plants`), each column a ``listed``
    parameter; the parameters it has no column for stay nominal. ConfigError (one line,
    naming the file) for bad plants, before anything runs."""
    from twolink.simulation.config import MAX_TOML_BYTES
    from twolink.sweep.plants_csv import listed_parameters, plants_source, read_plants

    if not isinstance(plants, str | Path | pd.DataFrame):
        check_plants(plants)
        return sweep_text(path, a, b, int(plants), seed, overrides), int(plants), None
    source = plants_source(plants)
    table = read_plants(plants)
    whose = f"the plants of {source}" if isinstance(plants, pd.DataFrame) else f"{source}'s plants"
    text = sweep_text(path, a, b, len(table), seed, overrides, listed_parameters(table), whose)
    if (size := len(text.encode())) > MAX_TOML_BYTES:
        raise ConfigError(
            f"{source}: its {len(table):,} plants make a sweep file (compare.toml) of "
            f"{size:,} bytes, more than the {MAX_TOML_BYTES:,} a sweep file may hold: "
            "give fewer rows or columns, or split it into several files"
        )
    check_rows(text, source)
    return text, len(table), source


def check_rows(text: str, source: str) -> None:
    """ConfigError, one line naming ``source``, its row and column, where a plant of the
    sweep ``text`` is one the run would refuse: each row is built as the sweep builds it
    (the scenario of the sample, then its MuJoCo model), before anything runs."""
    from twolink import sweep

    with tempfile.TemporaryDirectory(prefix="twolink-plants-") as tmp:
        atomic_write_text(Path(tmp) / "compare.toml", text)
        plan = sweep.load_sweep(Path(tmp) / "compare.toml")
    for i in range(plan.samples):
        values, noise_seed = plan.draw(i)
        if problem := plant_problem(plan, values, noise_seed):
            alone = [c for c in values if plant_problem(plan, {c: values[c]}, noise_seed)]
            where = f"column {alone[0]!r}" if alone else f"columns {', '.join(values)} together"
            raise ConfigError(f"{source}: row {i + 1} under the header, {where}: {problem}")


def plant_problem(plan: Any, values: dict[str, float], noise_seed: int) -> str:
    """Why the sweep ``plan`` could not run the plant of ``values``: its scenario or its
    MuJoCo model refused (as :func:`twolink.sweep.chunks` builds them); "" where it can."""
    from twolink.simulation.experiment import build_plant

    try:
        build_plant(scenario_from_dict(plan.sample_data(values, noise_seed), plan.file))
    except ConfigError as exc:
        return str(exc).removeprefix(f"{plan.file}: ")
    except ValueError as exc:  # MuJoCo's compiler (a mass below its mjMINVAL)
        return str(exc)
    return ""


def comparison_source(
    path: Path, a: str, b: str, plants: Plants, seed: int, overrides: dict | None = None
) -> str:
    """What a comparison's folder records it holds (its owner record's source): the
    scenario, the pair, the plants (drawn: their number and seed; the user's: the file),
    the seed and the overrides. A comparison of other plants into a folder the command
    picked is refused by it (docs/compare.md, "Where it writes")."""
    if isinstance(plants, str | Path):
        whose = f"the plants of {os.path.abspath(plants)}"
    elif isinstance(plants, pd.DataFrame):
        whose = f"{len(plants)} plants of a DataFrame"
    else:
        whose = f"{plants} drawn plants"
    told = f", --set {toml_value(overrides)}" if overrides else ""
    return f"{path.resolve()}: {a} against {b} on {whose}, seed {seed}{told}"


def default_folder(scenario: str, a: str, b: str, plants: Plants, seed: int) -> Path:
    """The command's folder of a comparison, one per pair and plants, so a comparison of
    other plants keeps the first one's results: ``results/compare/<scenario>_<A>_vs_<B>``
    then ``_<N>_plants`` (drawn; ``_seed<S>`` with another seed than 0) or ``_<file>``
    (the plants file's name without ``.csv``)."""
    from twolink.foundation.io import unsafe_name_problem

    if isinstance(plants, str | Path):
        kind = Path(plants).stem
    else:
        kind = f"{plants}_plants" + (f"_seed{seed}" if seed else "")
    name = f"{Path(scenario).stem}_{a}_vs_{b}_{kind}"
    if unsafe_name_problem(name):
        name = "comparison" if unsafe_name_problem(f"comparison_{kind}") else f"comparison_{kind}"
    return Path("results") / "compare" / name


def compare(
    scenario: str | Path,
    a: str,
    b: str,
    plants: Plants = 50,
    *,
    out: str | Path | None = None,
    seed: int = 0,
    workers: int | None = 1,
    metrics: Sequence[str] | None = None,
    overrides: dict[str, Any] | None = None,
    trace: bool = True,
    progress: bool = False,
) -> Comparison:
    """Judge controller ``a`` against ``b`` on ``scenario`` (a file or a shipped name,
    ``theta1_step``) over ``plants``: a number of plants drawn as the robustness sweep
    draws them, or the user's own, a CSV file or a DataFrame of one row per plant and one
    column per sweep parameter (``m1``, ``payload``, ...; the parameters it lacks stay
    nominal; docs/compare.md, "Your own plants"). It gives the paired table with verdicts
    (:func:`twolink.studies.judgments.claims.paired_claims`), an overlay figure of every plant with
    the difference panel, and (with ``out`` and ``trace``) one rerun recording of the two
    on the nominal plant. With ``out`` it writes there (``claims.csv``, ``compare.png``,
    ``compare.rrd``, ``compare.toml`` and the sweep in ``sweep/``), refusing a folder it
    did not write (docs/reliability.md); without, nothing is written. ``workers``: 1 runs
    in this process, None on all cores. ``overrides``: keys of the scenario changed for
    both (``{"controller": {"kp": 9.0, "kd": 6.0}}``, as ``--set`` gives them)."""
    from twolink import sweep
    from twolink.foundation.io import owned_output
    from twolink.studies.judgments.claims import CLAIM_METRICS, paired_claims
    from twolink.studies.judgments.claims_studies import reference_values

    if a == b:
        raise ConfigError(f"compare: give two different controllers, got {a!r} twice")
    path = locate(scenario)
    read_toml(path)  # a missing or broken scenario is named here, before anything runs
    held_for = comparison_source(path, a, b, plants, seed, overrides)
    text, plants, source = compare_sweep(path, a, b, plants, seed, overrides)
    with tempfile.TemporaryDirectory(prefix="twolink-compare-") as tmp:
        folder = Path(out) if out is not None else Path(tmp)
        holder = owned_output(folder, "compare", held_for) if out else nullcontext()
        with holder:
            atomic_write_text(folder / "compare.toml", text)
            plan = sweep.load_sweep(folder / "compare.toml")
            executor = "inprocess" if workers == 1 else "process"
            outcome = sweep.run_sweep(
                plan, folder / "sweep", executor=executor, workers=workers, plots=False,
                progress=progress, replace_other=True,
            )  # fmt: skip
            refuse_unjudgeable(outcome.results, a, b, folder / "sweep" if out else None)
            nominal = plan.nominal_scenario()
            table = paired_claims(
                outcome.results, a, b, tuple(metrics or CLAIM_METRICS), plan.joints,
                reference_values(nominal, plan.joints),
            )  # fmt: skip
            runs = _plant_runs(plan, (a, b))
            figure = _figure(runs, plan, nominal, a, b)
            met = {n: int(outcome.summary[n]["met_spec"]) for n in (a, b)}
            if out is not None:
                _write(folder, table, figure, runs, plan, a, b, trace)
    return Comparison(
        str(scenario), a, b, plants, table, outcome.results, met, figure,
        Path(out) if out is not None else None, source,
    )  # fmt: skip


class NothingToJudge(RuntimeError):
    """No plant ran to its end under both controllers (every one diverged or failed):
    there are no metrics to judge."""


def refuse_unjudgeable(results: pd.DataFrame, a: str, b: str, kept: Path | None) -> None:
    """Raise :class:`NothingToJudge` (one line) where no plant of the sweep's ``results``
    ran to its end ("ok") under both ``a`` and ``b``: a diverged run's metrics are those
    of a runaway, no plant's answer."""
    ok = results[results["status"] == "ok"]
    both = set(ok.loc[ok["controller"] == a, "sample"]) & set(
        ok.loc[ok["controller"] == b, "sample"]
    )
    if both:
        return
    bad = results[results["status"] != "ok"]
    first = str(bad["message"].iloc[0]).splitlines()[0][:120] if len(bad) else ""
    plants = results["sample"].nunique()
    where = f"; the sweep's table is in {kept}" if kept is not None else ""
    raise NothingToJudge(
        f"no plant ran to its end under both {a} and {b} ({len(bad)} of {len(results)} runs "
        f"on {plants} plants diverged or failed; first: {first}): nothing to judge{where}"
    )


def _plant_runs(plan: Any, names: Sequence[str]) -> dict[str, Any]:
    """Every plant's trajectory under each controller (as the sweep ran them), on the
    figure's grid, and the nominal plant's whole trajectories for the recording."""
    from twolink.simulation.experiment import build_controller, iter_scenarios

    arms, labels = [], []
    for name in names:
        controller = build_controller(scenario_from_dict(plan.controller_data(name), plan.file))
        arms.append((plan.nominal_scenario(), controller))
        labels.append((name, None))
        for i in range(plan.samples):
            values, noise_seed = plan.draw(i)
            s = scenario_from_dict(plan.sample_data(values, noise_seed), plan.file)
            # as the sweep does (run_chunk): a flexible-joint law models each plant's joints
            law = controller
            if getattr(controller, "needs_motor", False):
                law = controller.with_joints(s.plant.flexibility)
            arms.append((s, law))
            labels.append((name, i))
    angles: dict[str, list[np.ndarray]] = {n: [] for n in names}
    nominal: dict[str, Any] = {}
    t = None
    for k, traj in iter_scenarios([s for s, _ in arms], [c for _, c in arms]):
        name, i = labels[k]
        if isinstance(traj, Exception):
            continue
        if i is None:
            nominal[name] = traj
            continue
        grid = traj.t[::FIGURE_EVERY]
        t = grid if t is None or len(grid) > len(t) else t
        angles[name].append(traj.q[::FIGURE_EVERY])
    s = plan.nominal_scenario()
    reference = s.reference.sample(t)[0] if t is not None else None
    return {"t": t, "angles": angles, "nominal": nominal, "reference": reference, "start": s.q0}


def _padded(series: list[np.ndarray], n: int) -> np.ndarray:
    """(plants, n, 2): runs cut short (diverged) are NaN past their end."""
    out = np.full((len(series), n, 2), np.nan)
    for k, q in enumerate(series):
        out[k, : len(q)] = q[:n]
    return out


def _figure(runs: dict[str, Any], plan: Any, nominal: Any, a: str, b: str) -> Any:
    from twolink.figures.plots import comparison_figure

    t = runs["t"]
    qa, qb = (_padded(runs["angles"][n], len(t)) for n in (a, b))
    reference = runs["reference"]
    title = f"{nominal.name}: {a} against {b} on {plan.samples} plants"
    return comparison_figure(
        t, qa, qb, reference, plan.joints, (a, b), title, window(runs, t, plan.joints)
    )


def window(runs: dict[str, Any], t: np.ndarray, joints: Sequence[int]) -> float:
    """The transient the figure's upper panels show: until the moving joints of every
    plant stay within 2 % of their step of the reference, under both controllers, plus
    half of that again (at least 1 s; the whole run where some plant never settles)."""
    cols = [j - 1 for j in joints]
    settled = 0.0
    for q in runs["angles"].values():
        for angles in q:
            ref = runs["reference"][: len(angles), cols]
            step = np.maximum(np.abs(ref[-1] - np.asarray(runs["start"])[cols]), 1e-9)
            outside = np.abs(angles[:, cols] - ref) > 0.02 * step
            last = np.nonzero(outside.any(axis=1))[0]
            settled = max(settled, float(t[last[-1]]) if last.size else 0.0)
    return max(1.0, 1.5 * settled)


def _write(folder, table, figure, runs, plan, a, b, trace) -> None:
    from twolink.figures.plots import save_figure

    atomic_write_text(folder / "claims.csv", table.to_csv(index=False))
    atomic_write_text(folder / "claims.md", format_claims(table) + "\n")
    save_figure(figure, folder / "compare.png")
    save_figure(forest_figure(table, plan, a, b), folder / "forest.png")
    if trace and len(runs["nominal"]) == 2:
        from twolink.tracing.comparison import ExperimentRuns, write_comparison

        name = plan.nominal_scenario().name
        experiments = [
            ExperimentRuns(f"joint{j}", f"θ{j}: {name}", j, {n: runs["nominal"][n] for n in (a, b)})
            for j in plan.joints
        ]
        write_comparison(folder / "compare.rrd", experiments, pair=(a, b))


def forest_figure(table: pd.DataFrame, plan: Any, a: str, b: str) -> Any:
    """The paired table as the reproduction's answer figure draws it
    (:func:`twolink.figures.answer.answer_figure`): per joint and metric the typical shift
    in tolerances with its interval, the shares of plants better and worse, the verdict."""
    from twolink.figures.answer import answer_figure

    name = plan.nominal_scenario().name
    question = f"Does {a} lower each metric against {b}? {plan.samples} plants"
    short = too_few(plan.samples, judged_rows(table))
    question += f"\n{short.split(':')[0]}" if short else ""  # the figure says it too
    return answer_figure([(name, {b: table})], a, question)


def format_claims(table: pd.DataFrame) -> str:
    """The paired table as text: the columns of :data:`SHOWN` that it has, then each row's
    verdict in words where the table gives them (its ``reading``)."""
    shown = table[[c for c in SHOWN if c in table.columns]].rename(columns=SHOWN)
    text = shown.to_string(index=False, float_format=lambda v: f"{v:.4g}", na_rep="—")
    if "reading" in table.columns:
        words = [
            f"  θ{row.joint} {row.metric}: "
            + (
                row.reading
                if row.reading.startswith(row.verdict)
                else f"{row.verdict}: {row.reading}"
            )
            for row in table.itertuples()
            if isinstance(row.reading, str) and row.reading
        ]
        text += "\n" + "\n".join(words)
    return text
