"""The paper's FCM rule-base design (section 3.1, steps 1-6), as data in and data out.

1-2. Run the closed loop with the full heuristic 7x7 fuzzy-CTC on the design
     scenarios (``runs/paper/design.toml``).
3.   Collect the phase-plane trajectory (e, de) of each scenario's moving joint, in
     the engine's normalised input space (ke e, kde de), clipped to its universe.
4.   Cluster it with Fuzzy C-Means (c, m, epsilon from the design file, seeded).
5.   Overlay the linguistic trajectory: the dominant fired rule at each sample.
6.   Keep, for each cluster, the rule with the highest membership-weighted firing
     strength, sum_i u_ij^m f_ir / sum_i u_ij^m: the rule that carries the trajectory
     near that centre. Drop the rest.

The result is written as a rule-base TOML file with the evidence (centres, per-rule
firing counts and scores, the linguistic trajectory's segments) and a hash of the
design inputs, so a reproduction can tell whether a saved design is still current.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from controllers.fcm import FCMResult, fcm
from controllers.fuzzy import MamdaniEngine, Rule, load_rule_base, save_rule_base
from twolink.config import (
    Scenario,
    TomlTable,
    controller_from_table,
    expect_kind,
    load_scenario,
    read_toml,
)
from twolink.experiment import build_controller, run_scenario
from twolink.io import atomic_path

DEFAULT_DESIGN = Path(__file__).resolve().parents[1] / "runs" / "paper" / "design.toml"
DECIMATE = 10  # cluster every 10th sample (100 Hz): the shape of the trajectory, 10x cheaper
FUZZY_KINDS = ("fuzzy_ctc", "fcm_ctc")  # controllers with a fuzzy engine to design from
MAX_CLUSTERS = 49  # the rules of the 7x7 table: each cluster keeps one rule


@dataclass(frozen=True)
class DesignConfig:
    """What the design procedure runs: scenarios, clustering settings, seed."""

    scenarios: tuple[Scenario, ...]
    clusters: int = 5
    fuzzifier: float = 2.0
    tolerance: float = 1e-5
    max_iter: int = 500
    seed: int = 0
    source: str = ""

    def digest(self) -> str:
        """A hash of everything the design depends on (resolved scenarios + settings)."""
        blob = json.dumps(
            {
                "scenarios": [s.to_dict() for s in self.scenarios],
                "settings": [
                    self.clusters,
                    self.fuzzifier,
                    self.tolerance,
                    self.max_iter,
                    self.seed,
                ],
                "version": 1,
            },
            sort_keys=True,
            default=str,
        )
        return hashlib.sha256(blob.encode()).hexdigest()[:16]


def load_design_config(path: str | Path = DEFAULT_DESIGN) -> DesignConfig:
    """Read a design file; its scenarios run with its ``controller`` overrides.

    Everything the design would stumble on later is refused here, naming the design file
    and the key: a missing scenario file, a controller without a fuzzy engine, more
    clusters than the design runs give points (or than :data:`MAX_CLUSTERS`),
    ``max_iter`` < 1.
    """
    path = Path(path)
    data = read_toml(path)
    expect_kind(data, path, "design")
    t = TomlTable(data, "", str(path))
    names = t.raw("scenarios", [])
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        t.fail("scenarios", "must be a non-empty list of scenario file paths")
    controller = t.raw("controller", {"kind": "fuzzy_ctc"})
    if not isinstance(controller, dict):
        t.fail("controller", "must be a table of [controller] keys")
    controller_from_table(TomlTable(controller, "controller", str(path)))  # its own keys
    files = [path.parent / n for n in names]
    for file in files:
        if file.is_dir():
            t.fail("scenarios", f"{file}: is a folder, not a scenario file")
        if not file.is_file():
            t.fail("scenarios", f"{file}: no such file (relative to the design file)")
    scenarios = tuple(load_scenario(f, {"controller": controller}) for f in files)
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
    points = sum(len(range(0, round(s.duration / s.control_dt) + 1, DECIMATE)) for s in scenarios)
    if clusters > points:
        t.fail(
            "clusters",
            f"at most the {points} phase-plane points the design runs give (every "
            f"{DECIMATE}th control sample of {names}), got {clusters}",
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
    )
    t.done()
    return config


@dataclass(frozen=True)
class DesignResult:
    """The designed rule base and the evidence for it.

    Attributes
    ----------
    rules : kept rules, in the 7x7 table's order
    engine : the full 7x7 engine the design ran with
    points : (N, 2) phase-plane samples (normalised e, de) that were clustered
    linguistic : (N,) index into ``engine.rules`` of the dominant fired rule per sample
    clustering : the FCM result (centres in the normalised plane)
    scores : (c, R) membership-weighted firing strength of each rule in each cluster
    kept : (c,) index of the rule kept for each cluster
    digest : hash of the design inputs
    splits : sample indices where one design run's trajectory ends and the next begins
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


def phase_plane(s: Scenario, engine_input: tuple[float, float]) -> np.ndarray:
    """(e, de) of the scenario's moving joint under its controller, normalised, clipped."""
    traj = run_scenario(s)
    if not traj.ok:
        raise RuntimeError(f"design run {s.source} diverged: {traj.message}")
    joint = next(j for j, (a, b) in enumerate(zip(s.q0, s.reference.final, strict=True)) if a != b)
    ke, kde = engine_input
    points = np.stack([ke * traj.e[:, joint], kde * traj.de[:, joint]], axis=1)
    return np.clip(points[::DECIMATE], -1.0, 1.0)


def design(config: DesignConfig) -> DesignResult:
    """Run steps 1-6 of the paper's design procedure (deterministic for the seed)."""
    controllers = [build_controller(s) for s in config.scenarios]
    engine = controllers[0].engine
    points = np.concatenate(
        [phase_plane(s, (c.ke, c.kde)) for s, c in zip(config.scenarios, controllers, strict=True)]
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
    )
    weights = clustering.memberships**config.fuzzifier  # (N, c)
    scores = (weights.T @ firing) / weights.sum(axis=0)[:, None]  # (c, R)
    kept = np.argmax(scores, axis=1)
    return DesignResult(
        kept_rules(engine, kept),
        engine,
        points,
        linguistic,
        clustering,
        scores,
        kept,
        config.digest(),
    )


def kept_rules(engine: MamdaniEngine, kept: np.ndarray) -> tuple[Rule, ...]:
    """The rule base the design keeps: each cluster's rule, once, in rule-table order."""
    return tuple(engine.rules[i] for i in sorted(set(np.asarray(kept).tolist())))


def write_design(result: DesignResult, path: str | Path) -> Path:
    """Write the designed rule base with its evidence as TOML (atomically)."""
    rules = result.engine.rules
    evidence: dict[str, Any] = {
        "digest": result.digest,
        "samples": int(len(result.points)),
        "fcm_iterations": int(result.clustering.n_iter),
        "centres_e": result.clustering.centers[:, 0].round(6).tolist(),
        "centres_de": result.clustering.centers[:, 1].round(6).tolist(),
        "kept_per_cluster": [" ".join(rules[i]) for i in result.kept],
        "kept_scores": [round(float(result.scores[j, i]), 6) for j, i in enumerate(result.kept)],
        "firing_counts": {" ".join(r): n for r, n in result.firing_counts.items()},
        "linguistic_segments": len(result.segments()),
    }
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
    """Write ``rule_base.toml`` (rules + evidence) and ``evidence.npz`` (the arrays)."""
    folder = Path(folder)
    c = result.clustering
    arrays = {
        "points": result.points,
        "linguistic": result.linguistic,
        "scores": result.scores,
        "kept": result.kept,
        "splits": np.array(result.splits, dtype=int),
        "centers": c.centers,
        "memberships": c.memberships,
        "initial_memberships": c.initial_memberships,
        "objective": c.objective,
        "fcm": np.array([c.n_iter, c.converged, c.m], dtype=float),
    }
    with atomic_path(folder / "evidence.npz") as tmp, open(tmp, "wb") as fh:
        np.savez(fh, **arrays)
    # the rule base last: its digest marks the pair as complete and current
    return write_design(result, folder / "rule_base.toml")


def load_design(config: DesignConfig, folder: str | Path) -> DesignResult | None:
    """The design saved in ``folder`` if it is whole, its digest matches and its rules are
    the ones its evidence keeps (an edited rule base is not reused), else None."""
    folder = Path(folder)
    try:
        saved = load_rule_base(folder / "rule_base.toml")
        if saved.metadata.get("evidence", {}).get("digest") != config.digest():
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
            engine = build_controller(config.scenarios[0]).engine
            if tuple(saved.rules) != kept_rules(engine, a["kept"]):
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
            )
    except (ValueError, OSError, KeyError):
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
