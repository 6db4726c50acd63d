"""The reproduction manifest (``runs/paper/reproduce.toml``): what ``twolink reproduce``
runs and how the report reads it.

Which scenario files make which paper table, the paper's values for each, the
controllers to compare (and which two the paper's claim is about), and the plant
variants. Read and validated here, before anything runs, by both the reproduction and
its report.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from twolink.foundation.io import unsafe_name_problem
from twolink.foundation.shipped import locate, runs_dir
from twolink.simulation.config import TomlTable, expect_kind, read_toml
from twolink.simulation.vocabulary import STEP_KEYS, metric

DEFAULT_MANIFEST = runs_dir() / "paper" / "reproduce.toml"  # package data
# The paper's tables name their columns by symbol; the manifest's paper values do too.
PAPER_SYMBOLS = tuple(metric(k).symbol for k in STEP_KEYS)  # Tp, Td, Tr, Ts, Mp, ess


@dataclass(frozen=True)
class Experiment:
    """One experiment of the paper: a scenario, the joint it reports, the paper's values."""

    title: str
    scenario: Path
    joint: int
    table: int | None = None
    figure: int | None = None
    paper: dict[str, dict[str, float]] = field(default_factory=dict)
    name: str | None = None  # an experiment beyond the paper: no table or figure of its own

    def paper_value(self, controller: str, key: str) -> float | None:
        """The paper's value of metric ``key`` for ``controller``, in the key's unit (its
        tables give Mp as a fraction); None where the paper gives none."""
        m = metric(key)
        value = self.paper.get(controller, {}).get(m.symbol)
        return None if value is None else value * m.paper_scale

    @property
    def key(self) -> str:
        if self.table:
            return f"table{self.table}"
        return f"figure{self.figure}" if self.figure else str(self.name)

    @property
    def label(self) -> str:
        """How the report heads it: "Table 2", "Figure 6", or "Beyond the paper"."""
        if self.table:
            return f"Table {self.table}"
        return f"Figure {self.figure}" if self.figure else "Beyond the paper"


@dataclass(frozen=True)
class Variant:
    """A plant or regime every experiment runs in: scenario ``overrides``, and with
    ``raw_steps`` the paper's own references (each smooth move replaced by the raw step
    between the same angles; ramps stay ramps), its claims judged on the claims study's
    plants in that regime too."""

    name: str
    title: str
    overrides: dict[str, Any]
    raw_steps: bool = False


@dataclass(frozen=True)
class Manifest:
    """A validated manifest.

    Attributes
    ----------
    path, design, flexible_study : Path
        The manifest, its design file and its optional stiffness-study sweep file.
    controllers : dict
        Name (as the report and the result folders spell it) -> ``[controller]`` keys.
    variants, experiments : tuple
        Plant variants, and the paper's experiments in report order.
    proposed, baseline : str
        The two controllers of the paper's claim ("proposed beats baseline"): names of
        ``controllers``. The report's claims table and commentary compare these two.
    claims_study : Path or None
        A sweep file whose plants judge the claim with confidence intervals
        (:mod:`twolink.studies.judgments.claims`); it must run ``proposed`` and ``baseline`` by
        those names.
    lab_study : Path or None
        The lab arm's sweep file (the claims study's plants with friction and a
        disturbance), judged as the claims study; it must run ``proposed`` and ``baseline``.
    gain_study : Path or None
        The gain-study file (:mod:`twolink.studies.designs.gains`) whose trade-off the report shows.
    """

    path: Path
    design: Path
    flexible_study: Path | None
    controllers: dict[str, dict[str, Any]]
    variants: tuple[Variant, ...]
    experiments: tuple[Experiment, ...]
    proposed: str = "FCM-CTC"
    baseline: str = "CTC"
    claims_study: Path | None = None
    gain_study: Path | None = None
    calibration: Path | None = (
        None  # twolink.studies.designs.calibrate's study file, rerun by the report
    )
    # The flexible-joint map's third axis: the plant's [plant.scale] factors against every
    # controller's model (masses, g, and the joints' k and j); empty: the exact model only.
    flexible_model_error: dict[str, float] = field(default_factory=dict)
    # The lab arm (docs/reproduction.md): the claims study's plants with friction and a
    # disturbance, a sweep file run and judged as the claims study is.
    lab_study: Path | None = None


def _claim_role(top: TomlTable, key: str, kind: str, controllers: dict[str, Any]) -> str:
    """The controller named by ``key``; by default the one controller of ``kind`` as the
    paper has it (our extensions, such as the continuous inference, are never the paper's)."""
    name = top.raw(key)
    if name is None:
        of_kind = [
            n
            for n, c in controllers.items()
            if c.get("kind", "ctc") == kind
            and c.get("fuzzy", {}).get("inference", "mamdani") == "mamdani"
        ]
        if len(of_kind) != 1:
            top.fail(
                key,
                f"missing: which controller of {list(controllers)} the paper's claim is "
                f"about (no single controller of kind {kind!r} to default to)",
            )
        return of_kind[0]
    if name not in controllers:
        top.fail(key, f"must name a controller of this manifest {list(controllers)}, got {name!r}")
    return name


def _referenced_file(top: TomlTable, key: str, name: str, base: Path, what: str) -> Path:
    """``name`` (the value of ``key``) relative to the manifest: a file, or an error that
    names the manifest and the key."""
    path = base / name
    if path.is_dir():
        top.fail(key, f"{path}: is a folder, not a {what}")
    if not path.is_file():
        top.fail(key, f"{path}: no such file (the {what}, relative to the manifest)")
    return path


def _paper_values(e: TomlTable, controllers: dict[str, Any]) -> dict[str, dict[str, float]]:
    """An experiment's ``paper.CONTROLLER = { SYMBOL = value }``: numbers (NaN: not given)."""
    pt = e.table("paper")
    paper: dict[str, dict[str, float]] = {}
    for ctrl in list(pt.data):
        if ctrl not in controllers:
            pt.fail(ctrl, f"not a controller of this manifest {list(controllers)}")
        ct = pt.table(ctrl)
        unknown = set(ct.data) - set(PAPER_SYMBOLS)
        if unknown:
            pt.fail(ctrl, f"unknown metric(s) {sorted(unknown)} (known: {list(PAPER_SYMBOLS)})")
        paper[ctrl] = {sym: ct.number(sym, math.nan, allow_nan=True) for sym in list(ct.data)}
        ct.done()
    pt.done()
    return paper


# optional sweep files the reproduction runs
SWEEP_KEYS = ("flexible_study", "claims_study", "lab_study")


def _sweep_file(top: TomlTable, key: str, manifest: Path) -> Path | None:
    """An optional sweep file named by ``key``, relative to the manifest, checked to exist."""
    study = top.raw(key)
    if study is not None and not isinstance(study, str):
        top.fail(key, f"must be a sweep file path, got {study!r}")
    return _referenced_file(top, key, study, manifest.parent, "sweep file") if study else None


def load_manifest(path: str | Path = DEFAULT_MANIFEST) -> Manifest:
    """Read and validate a reproduction manifest; errors name the file and the key.

    The files it names (design, flexible-joint study, experiments' scenarios) must exist:
    a missing one is refused here, naming the manifest's key, before anything runs.
    """
    path = locate(path)
    data = read_toml(path)
    expect_kind(data, path, "manifest")
    top = TomlTable(data, "", str(path))
    controllers = top.raw("controllers", {})
    if not isinstance(controllers, dict) or not controllers:
        top.fail("controllers", "needs at least one [controllers.NAME] table")
    for name, ctrl in controllers.items():
        if problem := unsafe_name_problem(name):
            top.fail(f"controllers.{name}", problem)
        if not isinstance(ctrl, dict):
            top.fail(f"controllers.{name}", "must be a table of [controller] keys")
    variants = []
    raw_variants = top.raw("variants", {"rigid": {}})
    if not isinstance(raw_variants, dict):
        top.fail("variants", f"must be a table of [variants.NAME] tables, got {raw_variants!r}")
    if not raw_variants:
        top.fail(
            "variants",
            "needs at least one [variants.NAME] table (without [variants]: the rigid arm only)",
        )
    for name, body in raw_variants.items():
        if problem := unsafe_name_problem(name):
            top.fail(f"variants.{name}", problem)
        v = TomlTable(body, f"variants.{name}", str(path))
        overrides = v.raw("overrides", {})
        if not isinstance(overrides, dict):
            v.fail("overrides", "must be a table of scenario keys")
        raw_steps = v.raw("raw_steps", False)
        if not isinstance(raw_steps, bool):
            v.fail("raw_steps", f"must be true or false, got {raw_steps!r}")
        variants.append(Variant(name, v.string("title", name), overrides, raw_steps))
        v.done()
    experiments = []
    folders: dict[str, int] = {}  # result folder -> the experiment that writes it
    raw = top.raw("experiment", [])
    if not isinstance(raw, list) or not raw:
        top.fail("experiment", "needs at least one [[experiment]]")
    for i, body in enumerate(raw):
        e = TomlTable(body, f"experiment[{i}]", str(path))
        table = e.raw("table")
        figure = e.raw("figure")
        for number in (table, figure):
            if number is not None and (
                isinstance(number, bool) or not isinstance(number, int) or number < 1
            ):
                e.fail("table", f"table and figure must be integers >= 1, got {number!r}")
        name = e.raw("name")
        if name is not None and (table is not None or figure is not None):
            e.fail("name", "names an experiment beyond the paper: give no table or figure")
        if name is not None and unsafe_name_problem(name):
            e.fail("name", unsafe_name_problem(name))
        if isinstance(name, str) and name.startswith(("table", "figure")):
            e.fail("name", f"must not start with table or figure (their folders), got {name!r}")
        if name is None and table is None and figure is None:
            e.fail("table", "an experiment needs a table or figure number (or a name)")
        scenario = path.parent / e.string("scenario", "")
        if not scenario.is_file():
            e.fail("scenario", f"no such file {scenario}")
        joint = e.integer("joint", 1)
        if joint not in (1, 2):
            e.fail("joint", f"must be 1 or 2, got {joint}")
        paper = _paper_values(e, controllers)
        experiment = Experiment(
            e.string("title", scenario.stem), scenario, joint, table, figure, paper, name
        )
        if experiment.key in folders:
            e.fail(
                "table" if table else "figure" if figure else "name",
                f"{experiment.key} is also experiment[{folders[experiment.key]}]'s: both "
                f"would write the folder <variant>/{experiment.key}",
            )
        folders[experiment.key] = i
        experiments.append(experiment)
        e.done()
    proposed = _claim_role(top, "proposed", "fcm_ctc", controllers)
    baseline = _claim_role(top, "baseline", "ctc", controllers)
    if proposed == baseline:
        top.fail("baseline", f"must differ from proposed ({proposed!r})")
    design = _referenced_file(
        top, "design", top.string("design", "design.toml"), path.parent, "design file"
    )
    flexible_study, claims_study, lab_study = (_sweep_file(top, key, path) for key in SWEEP_KEYS)
    gains = top.raw("gain_study")
    if gains is not None and not isinstance(gains, str):
        top.fail("gain_study", f"must be a gain-study file path, got {gains!r}")
    gain_study = None
    if gains:
        gain_study = _referenced_file(top, "gain_study", gains, path.parent, "gain-study file")
    cal = top.raw("calibration")
    if cal is not None and not isinstance(cal, str):
        top.fail("calibration", f"must be a calibration file path, got {cal!r}")
    calibration = (
        _referenced_file(top, "calibration", cal, path.parent, "calibration file") if cal else None
    )
    model_error = _model_error(top.table("flexible_model_error"))
    if model_error and flexible_study is None:
        top.fail("flexible_model_error", "needs a flexible_study to run with it")
    top.done()
    return Manifest(
        path,
        design,
        flexible_study,
        controllers,
        tuple(variants),
        tuple(experiments),
        proposed,
        baseline,
        claims_study,
        gain_study,
        calibration,
        model_error,
        lab_study,
    )


def _model_error(t: TomlTable) -> dict[str, float]:
    """``flexible_model_error``: [plant.scale] factors, checked as a scenario checks them."""
    from twolink.simulation.config import ARM_SCALE_KEYS, JOINT_SCALE_KEYS

    known = sorted(ARM_SCALE_KEYS + JOINT_SCALE_KEYS)
    out = {}
    for key in list(t.data):
        if key not in known:
            t.fail(key, f"unknown key (known here: {known})")
        out[key] = t.number(key, 1.0, positive=True)
    return out


@dataclass(frozen=True)
class RunSpec:
    """One simulation of the reproduction: experiment x variant x controller."""

    experiment: Experiment
    variant: Variant
    controller: str
    overrides: dict[str, Any]
    centres: tuple[tuple[float, float], ...] = ()  # FCM centres, for the phase-plane trace
    centre_labels: tuple[str, ...] = ()  # each centre's kept rule ("PS,NM→NS"), its name there

    @property
    def folder(self) -> str:
        return f"{self.variant.name}/{self.experiment.key}/{self.controller}"
