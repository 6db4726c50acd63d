"""The paper's FCM rule-base design (section 3.1, steps 1-6), as data in and data out.

1-2. Run the closed loop with the full heuristic 7x7 fuzzy-CTC on the design
     scenarios (``runs/paper/design.toml``): steps up and down on both joints, coupled
     moves (both joints at once, opposite signs) and disturbed starts, so that the data
     visit all four quadrants of the phase plane.
3.   Collect the phase-plane trajectory (e, de) of both joints of every run, in the
     engine's normalised input space (ke e, kde de), clipped to its universe. Each
     sample gets a weight: by default its distance from the origin |e| + |de| (the
     settled tail, where a run spends most of its samples, weighs next to nothing);
     ``settled = "trim"`` drops the samples within ``settled_radius`` of the origin
     instead, ``"keep"`` weighs all alike.
4.   Cluster it with weighted Fuzzy C-Means (c, m, epsilon from the design file, seeded).
5.   Overlay the linguistic trajectory: the dominant fired rule at each sample.
6.   Keep, for each cluster, the rule with the highest weighted, membership-weighted
     firing strength, sum_i w_i u_ij^m f_ir / sum_i w_i u_ij^m: the rule that carries
     the trajectory near that centre. Drop the rest. Then odd symmetry,
     u(-e, -de) = -u(e, de): ``symmetry = "enforce"`` adds each kept rule's mirror
     (-e, -de -> -u); ``"check"`` only reports the missing mirrors and the surface's
     largest asymmetry.

Then the designed FCM-CTC runs beside CTC on held-out moves (``validation``: scenarios
that are not design runs) and the metrics of both are kept with the design.

The result is written as a rule-base TOML file with the evidence (centres, per-rule
firing counts and scores, the linguistic trajectory's segments, the settled tail, the
quadrants, the symmetry check, the held-out table) and a hash of the design inputs, so a
reproduction can tell whether a saved design is still current.
"""

from __future__ import annotations

import hashlib
import json
import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from twolink.controllers.fcm import FCMResult, fcm
from twolink.controllers.fuzzy import (
    MIRROR_LABELS,
    MamdaniEngine,
    Rule,
    load_rule_base,
    save_rule_base,
)
from twolink.foundation.io import SEAL_NAME, atomic_path, atomic_write_text, seal_intact, write_seal
from twolink.foundation.shipped import clone_root, locate, runs_dir
from twolink.simulation.config import (
    ConfigError,
    Scenario,
    TomlTable,
    controller_from_table,
    expect_kind,
    load_scenario,
    read_toml,
)
from twolink.simulation.experiment import build_controller, run_scenarios
from twolink.studies.designs.design_checks import (
    SymmetryCheck,
    ValidationRow,
    check_symmetry,
    validate,
    validation_csv,
    validation_rows,
    with_mirrors,
)

DEFAULT_DESIGN = runs_dir() / "paper" / "design.toml"  # package data
# The docs `twolink design --install` updates: the clone's (a wheel ships no docs).
DOCS = (clone_root() or Path(".")) / "docs" / "fuzzy.md"
DOCS_BEGIN = "<!-- designed rule base: written by `twolink design --install` -->"
DOCS_END = "<!-- end of the designed rule base -->"
DECIMATE = 2  # cluster every 2nd sample (500 Hz): a stiff loop settles in ~0.4 s
FUZZY_KINDS = ("fuzzy_ctc", "fcm_ctc")  # controllers with a fuzzy engine to design from
MAX_CLUSTERS = 49  # the rules of the 7x7 table: each cluster keeps one rule
SETTLED_MODES = ("weight", "trim", "keep")
SYMMETRY_MODES = ("enforce", "check")
QUADRANTS = ("e>0 de>0", "e>0 de<0", "e<0 de>0", "e<0 de<0")
VERSION = 2  # of the design procedure: part of the digest


@dataclass(frozen=True)
class DesignConfig:
    """What the design procedure runs: scenarios, clustering settings, seed, and the
    held-out runs that validate the result."""

    scenarios: tuple[Scenario, ...]
    clusters: int = 5
    fuzzifier: float = 2.0
    tolerance: float = 1e-5
    max_iter: int = 500
    seed: int = 0
    source: str = ""
    validation: tuple[Scenario, ...] = ()
    settled: str = "weight"
    settled_radius: float = 0.05
    symmetry: str = "enforce"

    def digest(self) -> str:
        """A hash of everything the design depends on (resolved scenarios + settings)."""
        blob = json.dumps(
            {
                "scenarios": [s.to_dict() for s in self.scenarios],
                "validation": [s.to_dict() for s in self.validation],
                "settings": [
                    self.clusters,
                    self.fuzzifier,
                    self.tolerance,
                    self.max_iter,
                    self.seed,
                    self.settled,
                    self.settled_radius,
                    self.symmetry,
                ],
                "version": VERSION,
            },
            sort_keys=True,
            default=str,
        )
        return hashlib.sha256(blob.encode()).hexdigest()[:16]


def largest_move(scenarios: Sequence[Scenario]) -> float:
    """The largest |target - start| of any joint of any scenario [rad] (E of the scaling)."""
    return max(
        (abs(f - q) for s in scenarios for f, q in zip(s.reference.final, s.q0, strict=True)),
        default=0.0,
    )


def _scenario_files(t: TomlTable, key: str, path: Path, required: bool) -> list[Path]:
    names = t.raw(key, [])
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        t.fail(key, f"must be a {'non-empty ' if required else ''}list of scenario file paths")
    if required and not names:
        t.fail(key, "must be a non-empty list of scenario file paths")
    files = [path.parent / n for n in names]
    for file in files:
        if file.is_dir():
            t.fail(key, f"{file}: is a folder, not a scenario file")
        if not file.is_file():
            t.fail(key, f"{file}: no such file (relative to the design file)")
    return files


def load_design_config(path: str | Path = DEFAULT_DESIGN) -> DesignConfig:
    """Read a design file; its scenarios run with its ``controller`` overrides.

    Everything the design would stumble on later is refused here, naming the design file
    and the key: a missing scenario file, a controller without a fuzzy engine, more
    clusters than the design runs give points (or than :data:`MAX_CLUSTERS`),
    ``max_iter`` < 1, a held-out run that is also a design run.
    """
    path = locate(path)
    data = read_toml(path)
    expect_kind(data, path, "design")
    t = TomlTable(data, "", str(path))
    files = _scenario_files(t, "scenarios", path, required=True)
    held_out = _scenario_files(t, "validation", path, required=False)
    controller = t.raw("controller", {"kind": "fuzzy_ctc"})
    if not isinstance(controller, dict):
        t.fail("controller", "must be a table of [controller] keys")
    controller_from_table(TomlTable(controller, "controller", str(path)))  # its own keys
    both = {f.resolve() for f in files} & {f.resolve() for f in held_out}
    if both:
        t.fail("validation", f"held-out runs must not be design runs: {sorted(map(str, both))}")
    scenarios = tuple(load_scenario(f, {"controller": controller}) for f in files)
    validation = tuple(load_scenario(f, {"controller": controller}) for f in held_out)
    for s in scenarios:
        if s.controller.kind not in FUZZY_KINDS:
            t.fail(
                "controller.kind",
                f"must be one of {list(FUZZY_KINDS)} (the design clusters a fuzzy "
                f"controller's phase plane), got {s.controller.kind!r} for {s.source}",
            )
    clusters = t.integer("clusters", 5)
    if clusters < 2:
        t.fail("clusters", f"must be >= 2, got {clusters}")
    if clusters > MAX_CLUSTERS:
        t.fail(
            "clusters",
            f"at most {MAX_CLUSTERS} (the 7x7 table's rules: each cluster keeps one), "
            f"got {clusters}",
        )
    points = 2 * sum(
        len(range(0, round(s.duration / s.control_dt) + 1, DECIMATE)) for s in scenarios
    )
    if clusters > points:
        t.fail(
            "clusters",
            f"at most the {points} phase-plane points the design runs give (both joints, "
            f"every {DECIMATE}th control sample of {[f.name for f in files]}), got {clusters}",
        )
    fuzzifier = t.number("fuzzifier", 2.0)
    if not fuzzifier > 1:
        t.fail("fuzzifier", f"must be > 1, got {fuzzifier}")
    max_iter = t.integer("max_iter", 500)
    if max_iter < 1:
        t.fail("max_iter", f"must be >= 1, got {max_iter}")
    config = DesignConfig(
        scenarios=scenarios,
        clusters=clusters,
        fuzzifier=fuzzifier,
        tolerance=t.number("tolerance", 1e-5, positive=True),
        max_iter=max_iter,
        seed=t.integer("seed", 0),
        source=str(path),
        validation=validation,
        settled=t.string("settled", "weight", SETTLED_MODES),
        settled_radius=t.number("settled_radius", 0.05, minimum=0.0),
        symmetry=t.string("symmetry", "enforce", SYMMETRY_MODES),
    )
    t.done()
    return config


# ----------------------------------------------------------------------------- symmetry


# ----------------------------------------------------------------------------- the design


@dataclass(frozen=True)
class DesignResult:
    """The designed rule base and the evidence for it.

    Attributes
    ----------
    rules : the designed rule base: the clustered rules (and, with symmetry enforced,
        their mirrors), in the 7x7 table's order
    engine : the full 7x7 engine the design ran with
    points : (N, 2) phase-plane samples (normalised e, de) that were clustered
    linguistic : (N,) index into ``engine.rules`` of the dominant fired rule per sample
    clustering : the weighted FCM result (centres in the normalised plane)
    scores : (c, R) weighted, membership-weighted firing strength of each rule per cluster
    kept : (c,) index of the rule kept for each cluster
    digest : hash of the design inputs
    splits : sample indices where one run's (or joint's) trajectory ends and the next begins
    weights : (N,) the samples' weights in the clustering and the scores
    settled : how the settled tail was handled ("weight", "trim" or "keep")
    settled_radius : |e| + |de| below which a sample counts as settled
    symmetry : "enforce" or "check"
    validation : the held-out runs' metrics, CTC and FCM-CTC
    scaling : (ke, kde, ku) of the design runs' controller
    move : the largest design move [rad]
    """

    rules: tuple[Rule, ...]
    engine: MamdaniEngine
    points: np.ndarray
    linguistic: np.ndarray
    clustering: FCMResult
    scores: np.ndarray
    kept: np.ndarray
    digest: str
    splits: tuple[int, ...] = ()
    weights: np.ndarray | None = None
    settled: str = "keep"
    settled_radius: float = 0.05
    symmetry: str = "check"
    validation: tuple[ValidationRow, ...] = ()
    scaling: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    move: float = math.nan

    @property
    def sample_weights(self) -> np.ndarray:
        return np.ones(len(self.points)) if self.weights is None else np.asarray(self.weights)

    @property
    def clustered_rules(self) -> tuple[Rule, ...]:
        """The rules the clusters keep, before any mirror is added, in table order."""
        return kept_rules(self.engine, self.kept)

    @property
    def radius(self) -> np.ndarray:
        """|e| + |de| of each sample (normalised)."""
        return np.abs(self.points).sum(axis=1)

    @property
    def settled_count(self) -> int:
        """Samples within ``settled_radius`` of the origin (the settled tail)."""
        return int(np.count_nonzero(self.radius < self.settled_radius))

    @property
    def trimmed_count(self) -> int:
        """Samples that weigh nothing in the design (trimmed, or exactly at the origin)."""
        return int(np.count_nonzero(self.sample_weights == 0))

    @property
    def settled_weight_share(self) -> float:
        """The settled tail's share of the total weight."""
        w = self.sample_weights
        return float(w[self.radius < self.settled_radius].sum() / w.sum())

    @property
    def quadrant_counts(self) -> dict[str, int]:
        """Samples outside the settled tail in each open quadrant of the (e, de) plane."""
        p = self.points[self.radius >= self.settled_radius]
        e, de = p[:, 0], p[:, 1]
        masks = (e > 0) & (de > 0), (e > 0) & (de < 0), (e < 0) & (de > 0), (e < 0) & (de < 0)
        return {q: int(np.count_nonzero(m)) for q, m in zip(QUADRANTS, masks, strict=True)}

    def symmetry_of(self, rules: Sequence[Rule]) -> SymmetryCheck:
        return check_symmetry(self.engine, rules)

    @property
    def firing_counts(self) -> dict[Rule, int]:
        """How many samples each rule dominated (the linguistic trajectory's histogram)."""
        counts = np.bincount(self.linguistic, minlength=len(self.engine.rules))
        return {r: int(n) for r, n in zip(self.engine.rules, counts, strict=True) if n}

    def segments(self) -> list[tuple[int, int, Rule]]:
        """The linguistic trajectory as runs: (first sample, last sample, rule)."""
        change = np.flatnonzero(np.diff(self.linguistic)) + 1
        starts = np.r_[0, change]
        ends = np.r_[change - 1, len(self.linguistic) - 1]
        return [
            (int(a), int(b), self.engine.rules[self.linguistic[a]])
            for a, b in zip(starts, ends, strict=True)
        ]


def phase_plane(
    scenarios: Sequence[Scenario], controllers: Sequence[Any]
) -> tuple[np.ndarray, tuple[int, ...]]:
    """(e, de) of both joints of every scenario under its controller, normalised by the
    controller's (ke, kde), clipped to the universe, every :data:`DECIMATE`-th sample;
    and the indices where one run's joint ends and the next begins."""
    parts = []
    trajectories = run_scenarios(scenarios, controllers)
    for s, c, traj in zip(scenarios, controllers, trajectories, strict=True):
        if isinstance(traj, Exception):
            raise RuntimeError(f"design run {s.source} failed: {traj}")
        if not traj.ok:
            raise RuntimeError(f"design run {s.source} diverged: {traj.message}")
        for j in range(2):
            pts = np.stack([c.ke * traj.e[::DECIMATE, j], c.kde * traj.de[::DECIMATE, j]], 1)
            parts.append(np.clip(pts, -1.0, 1.0))
    splits = tuple(int(x) for x in np.cumsum([len(p) for p in parts])[:-1])
    return np.concatenate(parts), splits


def sample_weights(points: np.ndarray, settled: str, radius: float) -> np.ndarray:
    """The design's weight of each normalised sample: ``"weight"``: |e| + |de|;
    ``"trim"``: 0 within ``radius`` of the origin (|e| + |de| < radius), else 1;
    ``"keep"``: 1."""
    r = np.abs(points).sum(axis=1)
    if settled == "weight":
        return r
    if settled == "trim":
        return (r >= radius).astype(float)
    if settled == "keep":
        return np.ones(len(points))
    raise ValueError(f"settled must be one of {SETTLED_MODES}, got {settled!r}")


def design(config: DesignConfig) -> DesignResult:
    """Run steps 1-6 of the paper's design procedure (deterministic for the seed), then
    the held-out validation."""
    controllers = [build_controller(s) for s in config.scenarios]
    engine = controllers[0].engine
    points, splits = phase_plane(config.scenarios, controllers)
    weights = sample_weights(points, config.settled, config.settled_radius)
    if np.count_nonzero(weights) < config.clusters:
        raise ConfigError(
            f"{config.source}: clusters: the design runs leave {np.count_nonzero(weights)} "
            f"samples outside the settled tail, fewer than the {config.clusters} clusters"
        )
    firing = engine.firing(points[:, 0], points[:, 1])  # (N, R)
    linguistic = np.argmax(firing, axis=1)
    clustering = fcm(
        points,
        config.clusters,
        m=config.fuzzifier,
        eps=config.tolerance,
        max_iter=config.max_iter,
        seed=config.seed,
        weights=weights,
    )
    w = weights[:, None] * clustering.memberships**config.fuzzifier  # (N, c)
    scores = (w.T @ firing) / w.sum(axis=0)[:, None]  # (c, R)
    kept = np.argmax(scores, axis=1)
    rules = final_rules(engine, kept, config.symmetry)
    c0 = controllers[0]
    return DesignResult(
        rules,
        engine,
        points,
        linguistic,
        clustering,
        scores,
        kept,
        config.digest(),
        splits,
        weights,
        config.settled,
        config.settled_radius,
        config.symmetry,
        validate(engine, rules, config.validation),
        (float(c0.ke), float(c0.kde), float(c0.ku)),
        largest_move(config.scenarios),
    )


def kept_rules(engine: MamdaniEngine, kept: np.ndarray) -> tuple[Rule, ...]:
    """The rules the clusters keep: each cluster's rule, once, in rule-table order."""
    return tuple(engine.rules[i] for i in sorted(set(np.asarray(kept).tolist())))


def final_rules(engine: MamdaniEngine, kept: np.ndarray, symmetry: str) -> tuple[Rule, ...]:
    """The designed rule base: the clusters' rules, with their mirrors where symmetry is
    enforced."""
    rules = kept_rules(engine, kept)
    return with_mirrors(engine, rules) if symmetry == "enforce" else rules


# ----------------------------------------------------------------------------- files


def _rule_text(rule: Rule) -> str:
    return " ".join(rule)


def _rule_md(text: str) -> str:
    """ "PS NS Z" as "PS, NS → Z" (a table cell)."""
    e, de, u = text.split()
    return f"{e}, {de} → {u}"


def _number(x: float, digits: int = 6) -> float:
    """``x`` to ``digits`` significant digits (as stored in a design's evidence)."""
    return float(f"{x:.{digits}g}")


def design_evidence(result: DesignResult) -> dict[str, Any]:
    """The evidence a designed rule base carries (plain data, as written to its TOML)."""
    rules = result.engine.rules
    clustered = result.clustered_rules
    before, after = result.symmetry_of(clustered), result.symmetry_of(result.rules)
    validation: dict[str, Any] = {}
    for row in result.validation:
        entry = validation.setdefault(row.file, {"name": row.run})
        entry[row.controller] = {k: _number(getattr(row, k)) for k in ValidationRow.COLUMNS}
    return {
        "digest": result.digest,
        "samples": int(len(result.points)),
        "settled": result.settled,
        "settled_radius": result.settled_radius,
        "settled_samples": result.settled_count,
        "settled_weight_share": _number(result.settled_weight_share),
        "trimmed_samples": result.trimmed_count,
        "quadrants": result.quadrant_counts,
        "largest_move_rad": _number(result.move),
        "scaling": dict(zip(("ke", "kde", "ku"), map(_number, result.scaling), strict=True)),
        "fcm_iterations": int(result.clustering.n_iter),
        "centres_e": result.clustering.centers[:, 0].round(6).tolist(),
        "centres_de": result.clustering.centers[:, 1].round(6).tolist(),
        "kept_per_cluster": [_rule_text(rules[i]) for i in result.kept],
        "kept_scores": [round(float(result.scores[j, i]), 6) for j, i in enumerate(result.kept)],
        "symmetry": {
            "mode": result.symmetry,
            "clustered_missing_mirrors": [_rule_text(r) for r in before.missing],
            "clustered_max_asymmetry": _number(before.max_asymmetry, 3),
            "added_mirrors": [_rule_text(r) for r in result.rules if r not in clustered],
            "missing_mirrors": [_rule_text(r) for r in after.missing],
            "max_asymmetry": _number(after.max_asymmetry, 3),
        },
        "firing_counts": {_rule_text(r): n for r, n in result.firing_counts.items()},
        "linguistic_segments": len(result.segments()),
        "validation": validation,
    }


def write_design(result: DesignResult, path: str | Path) -> Path:
    """Write the designed rule base with its evidence as TOML (atomically)."""
    evidence = design_evidence(result)
    return save_rule_base(
        path,
        result.rules,
        metadata={
            "source": {
                "what": "rules kept by the FCM design procedure (twolink design)",
                "convention": "e = theta_d - theta; u > 0 pushes theta up",
            },
            "evidence": evidence,
        },
    )


def save_design(result: DesignResult, folder: str | Path) -> Path:
    """Write ``evidence.npz`` (the arrays), ``validation.csv`` (the held-out table) and
    ``rule_base.toml`` (rules + evidence, last)."""
    folder = Path(folder)
    c = result.clustering
    arrays = {
        "points": result.points,
        "linguistic": result.linguistic,
        "scores": result.scores,
        "kept": result.kept,
        "splits": np.array(result.splits, dtype=int),
        "weights": result.sample_weights,
        "centers": c.centers,
        "memberships": c.memberships,
        "initial_memberships": c.initial_memberships,
        "objective": c.objective,
        "fcm": np.array([c.n_iter, c.converged, c.m], dtype=float),
    }
    with atomic_path(folder / "evidence.npz") as tmp, open(tmp, "wb") as fh:
        np.savez(fh, **arrays)
    atomic_write_text(folder / "validation.csv", validation_csv(result.validation))
    # the rule base next: its digest marks the set as current; the seal, last, as whole
    path = write_design(result, folder / "rule_base.toml")
    write_seal(folder, DESIGN_FILES)
    return path


DESIGN_FILES = ("evidence.npz", "validation.csv", "rule_base.toml")


def load_design(config: DesignConfig, folder: str | Path) -> DesignResult | None:
    """The design saved in ``folder`` if it is whole, its digest matches and its rules are
    the ones its evidence keeps (an edited rule base is not reused), else None."""
    folder = Path(folder)
    if not seal_intact(folder, DESIGN_FILES):
        if (folder / SEAL_NAME).exists():  # a broken seal: say so (unsealed: quietly)
            print(
                f"{folder}: damaged, edited or incomplete since twolink wrote it; designed again",
                file=sys.stderr,
            )
        return None
    try:
        saved = load_rule_base(folder / "rule_base.toml")
        evidence = saved.metadata.get("evidence", {})
        if evidence.get("digest") != config.digest():
            return None
        with np.load(folder / "evidence.npz") as a:
            n_iter, converged, m = a["fcm"]
            clustering = FCMResult(
                a["centers"],
                a["memberships"],
                a["initial_memberships"],
                a["objective"],
                int(n_iter),
                bool(converged),
                float(m),
            )
            controller = build_controller(config.scenarios[0])
            engine = controller.engine
            if tuple(saved.rules) != final_rules(engine, a["kept"], config.symmetry):
                return None  # the rules were edited: they are not what the evidence keeps
            return DesignResult(
                saved.rules,
                engine,
                a["points"],
                a["linguistic"],
                clustering,
                a["scores"],
                a["kept"],
                config.digest(),
                tuple(a["splits"].tolist()),
                a["weights"],
                config.settled,
                config.settled_radius,
                config.symmetry,
                validation_rows(evidence),
                (float(controller.ke), float(controller.kde), float(controller.ku)),
                largest_move(config.scenarios),
            )
    except Exception:  # noqa: BLE001 (sealed yet unreadable, e.g. an older format)
        return None  # missing, unreadable or stale: design afresh


def design_or_load(config: DesignConfig, folder: str | Path) -> tuple[DesignResult, bool]:
    """Reuse the design saved in ``folder`` if current; else run it and save it.

    Returns the design and whether it was newly run.
    """
    saved = load_design(config, folder)
    if saved is not None:
        return saved, False
    result = design(config)
    save_design(result, folder)
    return result, True


# ----------------------------------------------------------------------------- markdown


def _cell(x: float, digits: int = 3) -> str:
    return "—" if not math.isfinite(x) else f"{x:.{digits}g}"


def design_markdown(rules: Sequence[Rule], evidence: Mapping[str, Any]) -> list[str]:
    """A designed rule base and its evidence (:func:`design_evidence`, or the
    ``[evidence]`` of a saved design) as markdown: the rules beside the paper's Table 1,
    the data they came from, their symmetry, and the held-out table, CTC beside FCM-CTC.
    Used by the report's design section and docs/fuzzy.md."""
    from twolink.controllers.fuzzy import paper_fuzzy_pd

    ev = evidence
    sym = ev.get("symmetry", {})
    added = set(sym.get("added_mirrors", []))
    ours = [(_rule_text(r), "mirror" if _rule_text(r) in added else "cluster") for r in rules]
    paper = list(paper_fuzzy_pd().rules)
    # as the paper prints it: the shipped file mirrors its input labels on loading
    printed = [Rule(MIRROR_LABELS[r.e], MIRROR_LABELS[r.de], r.u) for r in paper]
    lines = [
        "| # | designed (e, ė → u) | from | paper's Table 1 as printed | Table 1 as we read it |",
        "|---|---|---|---|---|",
    ]
    for k in range(max(len(ours), len(paper))):
        a, src = ours[k] if k < len(ours) else ("", "")
        b = _rule_text(printed[k]) if k < len(paper) else ""
        c = _rule_text(paper[k]) if k < len(paper) else ""
        a, b, c = (_rule_md(x) if x else "" for x in (a, b, c))
        lines.append(f"| {k + 1} | {a} | {src} | {b} | {c} |")
    quadrants = ev.get("quadrants", {})
    scaling = ev.get("scaling", {})
    lines += [
        "",
        f"Data: {ev.get('samples', '?')} phase-plane samples (both joints of every design "
        f"run, normalised); {ev.get('settled_samples', '?')} lie within "
        f"{ev.get('settled_radius', '?')} of the origin (|e| + |ė|, the settled tail and the "
        f"held joints) and carry {100 * float(ev.get('settled_weight_share', math.nan)):.1f} % "
        f"of the weight (settled tail: {ev.get('settled', '?')!r}; "
        f"{ev.get('trimmed_samples', '?')} samples weigh nothing). Samples outside it per "
        "quadrant: "
        + ", ".join(f"{q}: {n}" for q, n in quadrants.items())
        + ". Scaling: "
        + ", ".join(f"{k} = {v:.4g}" for k, v in scaling.items())
        + f" (span E = 1/ke = {1 / float(scaling.get('ke', math.nan)):.3g} rad); largest "
        f"design move {ev.get('largest_move_rad', '?')} rad.",
        "",
        f"Odd symmetry ({sym.get('mode', '?')}): the clusters kept "
        f"{len(rules) - len(added)} rules, "
        + (
            "missing the mirrors of "
            + ", ".join(f"({_rule_md(r)})" for r in sym["clustered_missing_mirrors"])
            if sym.get("clustered_missing_mirrors")
            else "each with its mirror"
        )
        + f" (surface asymmetry max |u(e, ė) + u(−e, −ė)| = "
        f"{float(sym.get('clustered_max_asymmetry', math.nan)):.3g}); the rule base as "
        f"designed: {len(added)} mirrors added, asymmetry "
        f"{float(sym.get('max_asymmetry', math.nan)):.3g}.",
    ]
    rows = validation_rows(ev)
    if rows:
        lines += [
            "",
            "Held out (moves that are not design runs; nominal arm, same gains and scaling; "
            "CTC-matched: CTC with ωn scaled to spend FCM-CTC's peak torque on the move, "
            'docs/reproduction.md "A fair linear opponent"):',
            "",
            "| run | controller | ωn × | Mp [%] | Ts to target [s] | IAE [rad·s] | ess [rad] "
            "| peak τ [N·m] |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for r in rows:
            lines.append(
                f"| {r.run} | {r.controller} | {r.wn_scale:.3g} | {_cell(r.overshoot_pct)} "
                f"| {_cell(r.settling_s)} | {_cell(r.iae)} | {_cell(r.ess_rad, 2)} "
                f"| {_cell(r.peak_torque_Nm)} |"
            )
    return lines


def docs_block(rule_base_file: str | Path) -> str:
    """The markdown that docs/fuzzy.md shows for a saved designed rule base, between
    :data:`DOCS_BEGIN` and :data:`DOCS_END`."""
    saved = load_rule_base(rule_base_file)
    lines = design_markdown(saved.rules, saved.metadata.get("evidence", {}))
    return "\n".join([DOCS_BEGIN, "", *lines, "", DOCS_END])


def update_docs(rule_base_file: str | Path, docs: str | Path = DOCS) -> None:
    """Rewrite the designed rule base's block of ``docs`` from ``rule_base_file``."""
    docs = Path(docs)
    text = docs.read_text()
    start, end = text.index(DOCS_BEGIN), text.index(DOCS_END) + len(DOCS_END)
    atomic_write_text(docs, text[:start] + docs_block(rule_base_file) + text[end:])
