"""The linear frontier: the computed-torque loops a control engineer would tune, their
effort and their performance, and the fair opponent of the fuzzy term, the best of them
at FCM-CTC's effort (docs/reproduction.md, "The linear frontier").

Per regime of the claims study (its quintic moves; each ``raw_steps`` variant, the paper's
raw steps at its gains), on training plants drawn from the claims sweep's distribution
with a seed of their own (the claims' plants stay held out), the batch engine runs:

- **CTC on a grid of ωn and ζ** (Kp = ωn², Kd = 2ζωn), the actuator's limit as given;
- **CTC clipped at the budget**: the same law at higher ωn with its torque limited to
  FCM-CTC's peak torque per joint (the budget below): the high-gain, saturating loop a
  lab runs a torque-limited arm with (Spong, Hutchinson and Vidyasagar, *Robot Modeling
  and Control*, 2006, ch. 6, on saturation bounding the usable gain).

**Effort** per joint: the median over the plants of the peak |τ| and of Σ|Δτ| (the torque
variation behind the claims sweep's lab sensor). **Budget**: FCM-CTC's effort. A loop is
*within* it when each of its four effort values is at most FCM-CTC's plus the claims'
practical tolerance (0.5 N·m on peaks, 1 N·m on Σ|Δτ|:
:data:`twolink.studies.judgments.claims.TOLERANCES`).
**Performance index**: the median over the plants of IAE₁ + IAE₂ (rad·s; it grows with a
slow rise, an overshoot and an offset alike). **The opponent** (:data:`OPPONENT`): the loop
within the budget with the lowest index (ties: the lower largest effort ratio).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from twolink.foundation.shipped import runs_dir
from twolink.simulation.config import TomlTable, expect_kind, read_toml
from twolink.studies.designs import effort

__all__ = [
    "CONTINUOUS",
    "DEFAULT_SPEC",
    "OPPONENT",
    "FrontierSpec",
    "Opponent",
    "choose",
    "frontier_figure",
    "load_frontier",
    "load_spec",
    "run_frontier",
    "save_frontier",
    "summarise",
]

DEFAULT_SPEC = runs_dir() / "paper" / "frontier.toml"  # package data
OPPONENT = "CTC-best"  # the fair opponent's name in sweeps, tables and the report
CONTINUOUS = "FCM-CTC-continuous"  # placed on the frontier beside the proposed controller
QUINTIC = "quintic"  # the regime of the claims study as its file says
EFFORT = ("torque_peak_Nm", "torque_variation_Nm")
PERFORMANCE = (
    "rise_time_s",
    "settling_time_s",
    "overshoot_pct",
    "steady_state_error_rad",
    "iae_rad_s",
)


@dataclass(frozen=True)
class Grid:
    """One regime's family: CTC on ``wn`` x ``zeta``; clipped CTC on ``clipped_wn`` x
    ``clipped_zeta``."""

    wn: tuple[float, ...]
    zeta: tuple[float, ...]
    clipped_wn: tuple[float, ...]
    clipped_zeta: tuple[float, ...]


@dataclass(frozen=True)
class FrontierSpec:
    """``runs/paper/frontier.toml``: the manifest whose claims study sets the regimes and
    the plants' distribution, the training plants (``plants`` drawn with ``seed``), and
    each regime's grid (``quintic`` and the names of the manifest's raw-step variants)."""

    source: str
    manifest: Path
    plants: int
    seed: int
    grids: tuple[tuple[str, Grid], ...]

    def grid(self, regime: str) -> Grid:
        return dict(self.grids)[regime]

    def digest(self) -> str:
        """What decides the frontier: the grids, the training plants, and every regime's
        sweep data (plants, references, gains, sensor, FCM-CTC and its rule base's bytes)."""
        parts: list[Any] = [self.plants, self.seed, [(r, asdict(g)) for r, g in self.grids]]
        for regime, _ in self.grids:
            plan = training_plan(self, regime)
            parts.append([plan.base, [asdict(p) for p in plan.parameters], plan.controllers])
            parts.append(_rule_base_bytes(plan))
        blob = json.dumps(parts, sort_keys=True, default=str)
        return hashlib.sha256(blob.encode()).hexdigest()


def _rule_base_bytes(plan: Any) -> list[str]:
    """SHA-256 of the rule-base files the plan's fuzzy controllers read."""
    from twolink.simulation.config import resolve_rule_base

    out = []
    for _, entry in plan.controllers:
        if "rule_base" in entry:
            path = resolve_rule_base(entry["rule_base"], Path(plan.file).parent)
            out.append(hashlib.sha256(Path(path).read_bytes()).hexdigest())
    return out


def _numbers(t: TomlTable, key: str) -> tuple[float, ...]:
    value = t.raw(key, [])
    if not isinstance(value, list) or not all(
        isinstance(v, int | float) and not isinstance(v, bool) and v > 0 for v in value
    ):
        t.fail(key, f"must be a list of numbers > 0, got {value!r}")
    return tuple(float(v) for v in value)


def load_spec(path: str | Path = DEFAULT_SPEC) -> FrontierSpec:
    """Read and check a frontier file (errors name the file and key)."""
    from twolink.studies.reproduction.manifest import load_manifest

    path = Path(path)
    data = read_toml(path)
    expect_kind(data, path, "frontier")
    top = TomlTable(data, "", str(path))
    manifest_path = path.parent / top.string("manifest", "reproduce.toml")
    plants = top.integer("plants", 20)
    if plants < 1:
        top.fail("plants", f"must be >= 1, got {plants}")
    seed = top.integer("seed", 1)
    manifest = load_manifest(manifest_path)
    if manifest.claims_study is None:
        top.fail("manifest", f"{manifest_path} has no claims_study")
    claims_seed = read_toml(manifest.claims_study).get("seed", 0)
    if seed == claims_seed:
        top.fail(
            "seed", f"must differ from the claims study's ({claims_seed}): its plants are held out"
        )
    known = [QUINTIC, *(v.name for v in manifest.variants if v.raw_steps)]
    regimes = top.table("regimes")
    grids = []
    for name in known:
        g = regimes.table(name)
        grid = Grid(*(_numbers(g, k) for k in ("wn", "zeta", "clipped_wn", "clipped_zeta")))
        if not grid.wn or not grid.zeta:
            g.fail("wn", "the CTC grid needs at least one ωn and one ζ")
        g.done()
        grids.append((name, grid))
    regimes.done()
    top.done()
    return FrontierSpec(str(path), manifest_path, plants, seed, tuple(grids))


def _variant(spec: FrontierSpec, regime: str) -> Any:
    from twolink.studies.reproduction.manifest import load_manifest

    if regime == QUINTIC:
        return None
    return next(v for v in load_manifest(spec.manifest).variants if v.name == regime)


def training_plan(spec: FrontierSpec, regime: str, controllers: dict | None = None) -> Any:
    """The claims sweep of ``regime`` on the training plants, with ``controllers`` (default:
    the proposed controller and its continuous variant)."""
    from twolink.studies.judgments.claims_plans import regime_plan
    from twolink.studies.reproduction.manifest import load_manifest

    manifest = load_manifest(spec.manifest)
    full = regime_plan(manifest, _variant(spec, regime))
    keep = dict(full.controllers)
    if controllers is None:
        controllers = {n: keep[n] for n in (manifest.proposed, CONTINUOUS) if n in keep}
    more = {
        "samples": spec.plants,
        "seed": spec.seed,
        "chunk_size": max(1, -(-spec.plants // 4)),
        "controllers": {"replace": True, **controllers},
    }
    return regime_plan(manifest, _variant(spec, regime), more)


def _name(family: str, wn: float, zeta: float) -> str:
    return f"{family}_wn{wn:g}_z{zeta:g}"


def _run(plan: Any, pool: Any) -> pd.DataFrame:
    from twolink.sweep.execution import _chunk_frame, run_chunk

    chunks = range(plan.n_chunks)
    if pool is None:
        results = [run_chunk(plan, c) for c in chunks]
    else:
        results = [f.result() for f in [pool.submit(run_chunk, plan, c) for c in chunks]]
    return _chunk_frame(plan, [row for r in results for row in r.rows])


def summarise(results: pd.DataFrame) -> pd.DataFrame:
    """Per controller of a sweep's results: the medians over its plants of the effort and
    performance metrics per joint, the index (median of IAE₁ + IAE₂), and the plants whose
    run failed."""
    rows = []
    for name, g in results.groupby("controller", sort=False):
        ok = g[g["status"] == "ok"]
        row: dict[str, Any] = {"controller": name, "failed": int(len(g) - len(ok))}
        for j in (1, 2):
            for key in (*EFFORT, *PERFORMANCE):
                row[f"{key}{j}"] = float(np.nanmedian(ok[f"joint{j}_{key}"])) if len(ok) else np.nan
        iae = ok["joint1_iae_rad_s"] + ok["joint2_iae_rad_s"]
        row["index"] = float(np.median(iae)) if len(ok) else np.nan
        rows.append(row)
    return pd.DataFrame(rows)


def run_frontier(spec: FrontierSpec, pool: Any = None) -> pd.DataFrame:
    """Every regime's family, FCM-CTC and its continuous variant on the training plants:
    one row per (regime, loop) with its family, gains, torque limit, effort, performance,
    effort ratio to FCM-CTC's (the largest of the four), whether it is within the budget
    and on the Pareto frontier (no other loop has both a lower effort ratio and a lower
    index)."""
    from twolink.studies.reproduction.manifest import load_manifest

    manifest = load_manifest(spec.manifest)
    tables = []
    for regime, grid in spec.grids:
        plan = training_plan(spec, regime)
        limit = plan.nominal_scenario().controller.torque_limit
        loops: dict[str, dict[str, Any]] = {}
        labels: dict[str, dict[str, Any]] = {}
        for wn in grid.wn:
            for z in grid.zeta:
                name = _name("CTC", wn, z)
                loops[name] = {"kind": "ctc", "kp": wn * wn, "kd": 2 * z * wn}
                labels[name] = {
                    "family": "CTC",
                    "wn": wn,
                    "zeta": z,
                    "limit1": limit[0],
                    "limit2": limit[1],
                }
        first = _run(training_plan(spec, regime, {**dict(plan.controllers), **loops}), pool)
        fuzzy = summarise(first[first["controller"] == manifest.proposed]).iloc[0]
        clip = [min(float(fuzzy[f"torque_peak_Nm{j}"]), limit[j - 1]) for j in (1, 2)]
        clipped: dict[str, dict[str, Any]] = {}
        for wn in grid.clipped_wn:
            for z in grid.clipped_zeta:
                name = _name("CTC-clipped", wn, z)
                clipped[name] = {
                    "kind": "ctc",
                    "kp": wn * wn,
                    "kd": 2 * z * wn,
                    "torque_limit": clip,
                }
                labels[name] = {
                    "family": "CTC clipped",
                    "wn": wn,
                    "zeta": z,
                    "limit1": clip[0],
                    "limit2": clip[1],
                }
        results = first
        if clipped:
            results = pd.concat([first, _run(training_plan(spec, regime, clipped), pool)])
        table = summarise(results)
        wn0 = float(np.sqrt(plan.nominal_scenario().controller.kp[0]))
        for name in dict(plan.controllers):
            labels[name] = {"family": name, "wn": wn0, "zeta": np.nan, "limit1": limit[0],
                            "limit2": limit[1]}  # fmt: skip
        table.insert(0, "regime", regime)
        for col in ("family", "wn", "zeta", "limit1", "limit2"):
            table.insert(2, col, [labels[n][col] for n in table["controller"]])
        budget = {f"{k}{j}": float(fuzzy[f"{k}{j}"]) for k in EFFORT for j in (1, 2)}
        ratios = np.stack([table[c] / v for c, v in budget.items()], axis=1)
        table["effort_ratio"] = ratios.max(axis=1)
        table["within"] = effort.within_budget(table, budget) & (table["failed"] == 0)
        table["pareto"] = _pareto(table["effort_ratio"].to_numpy(), table["index"].to_numpy())
        tables.append(table)
    return pd.concat(tables, ignore_index=True)


def _pareto(effort: np.ndarray, index: np.ndarray) -> np.ndarray:
    out = np.zeros(effort.size, dtype=bool)
    for i in range(effort.size):
        if not (np.isfinite(effort[i]) and np.isfinite(index[i])):
            continue
        dominated = (
            (effort <= effort[i])
            & (index <= index[i])
            & ((effort < effort[i]) | (index < index[i]))
        )
        out[i] = not dominated.any()
    return out


@dataclass(frozen=True)
class Opponent:
    """The fair opponent of one regime: the loop, its gains and torque limit, its index
    and effort ratio, and FCM-CTC's index."""

    regime: str
    loop: str
    family: str
    wn: float
    zeta: float
    torque_limit: tuple[float, float]
    index: float
    effort_ratio: float
    proposed_index: float

    def controller(self) -> dict[str, Any]:
        """The sweep's ``[controllers]`` entry."""
        return {
            "kind": "ctc",
            "kp": self.wn**2,
            "kd": 2 * self.zeta * self.wn,
            "torque_limit": list(self.torque_limit),
        }

    def describe(self) -> str:
        clip = (
            f", clipped at {self.torque_limit[0]:.1f} / {self.torque_limit[1]:.1f} N·m"
            if self.family == "CTC clipped"
            else ""
        )
        return f"CTC at ωn = {self.wn:g} rad/s, ζ = {self.zeta:g}{clip}"


def choose(table: pd.DataFrame, regime: str, proposed: str = "FCM-CTC") -> Opponent:
    """The rule (module docstring): of the linear loops within FCM-CTC's effort, the lowest
    index; ties to the lower effort ratio. Raises ValueError where none is within."""
    t = table[(table["regime"] == regime) & table["family"].isin(["CTC", "CTC clipped"])]
    t = t[t["within"]]
    if t.empty:
        raise ValueError(f"{regime}: no linear loop of the grid is within FCM-CTC's effort")
    best = t.sort_values(["index", "effort_ratio"], kind="stable").iloc[0]
    fuzzy = table[(table["regime"] == regime) & (table["controller"] == proposed)].iloc[0]
    return Opponent(
        regime=regime,
        loop=str(best["controller"]),
        family=str(best["family"]),
        wn=float(best["wn"]),
        zeta=float(best["zeta"]),
        torque_limit=(float(best["limit1"]), float(best["limit2"])),
        index=float(best["index"]),
        effort_ratio=float(best["effort_ratio"]),
        proposed_index=float(fuzzy["index"]),
    )


def table_path(spec: FrontierSpec) -> Path:
    """The shipped table beside the spec (``frontier.toml`` -> ``frontier.csv``, with
    ``frontier.json``: its digest and the opponents)."""
    return Path(spec.source).with_suffix(".csv")


def save_frontier(table: pd.DataFrame, spec: FrontierSpec, path: Path) -> Path:
    from twolink.foundation.io import atomic_write_json, atomic_write_text

    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, table.to_csv(index=False))
    opponents = {r: asdict(choose(table, r)) for r, _ in spec.grids}
    meta = {"spec": Path(spec.source).name, "digest": spec.digest(), "opponents": opponents}
    atomic_write_json(path.with_suffix(".json"), meta)
    return path


def load_frontier(
    spec: FrontierSpec, path: Path | None = None
) -> tuple[pd.DataFrame, dict[str, Opponent]] | None:
    """The saved table and opponents at ``path`` (default: the shipped one), or None where
    absent or stale (its digest is not the spec's now)."""
    path = table_path(spec) if path is None else path
    meta_path = path.with_suffix(".json")
    if not (path.is_file() and meta_path.is_file()):
        return None
    meta = json.loads(meta_path.read_text())
    if meta.get("digest") != spec.digest():
        return None
    opponents = {
        r: Opponent(**{**o, "torque_limit": tuple(o["torque_limit"])})
        for r, o in meta["opponents"].items()
    }
    return pd.read_csv(path), opponents


def opponents(
    spec: FrontierSpec, pool: Any = None
) -> tuple[pd.DataFrame, dict[str, Opponent], bool]:
    """The shipped frontier and its opponents where current, else run here (the flag says
    which: True where shipped)."""
    saved = load_frontier(spec)
    if saved is not None:
        return *saved, True
    table = run_frontier(spec, pool)
    return table, {r: choose(table, r) for r, _ in spec.grids}, False


def frontier_axes(ax, title: str) -> None:
    """A frontier panel's axes: effort ratio against the index, both logarithmic, the
    budget (ratio 1) dotted, and its legend."""
    ax.axvline(1.0, color="k", lw=0.8, ls=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set(
        xlabel="effort / FCM-CTC's (largest of peak |τ| and Σ|Δτ| per joint)",
        ylabel="IAE₁ + IAE₂, median over training plants [rad·s]",
        title=title,
    )
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="best")


def frontier_figure(table: pd.DataFrame, chosen: dict[str, Opponent], path: Path) -> Path:
    """Effort (the largest of the four effort ratios to FCM-CTC's) against the index, per
    regime: the CTC grid by ζ, the clipped family, FCM-CTC, its continuous variant, the
    Pareto frontier and the chosen opponent."""
    from twolink.figures.plots import plt, save_figure

    regimes = list(dict.fromkeys(table["regime"]))
    fig, axes = plt.subplots(1, len(regimes), figsize=(6.2 * len(regimes), 5.0), squeeze=False)
    for ax, regime in zip(axes[0], regimes, strict=True):
        t = table[table["regime"] == regime]
        ctc = t[t["family"] == "CTC"]
        sc = ax.scatter(
            ctc["effort_ratio"],
            ctc["index"],
            c=ctc["zeta"],
            cmap="viridis",
            s=22,
            label="CTC (ωn, ζ grid; colour: ζ)",
        )
        fig.colorbar(sc, ax=ax, label="ζ")
        clip = t[t["family"] == "CTC clipped"]
        ax.scatter(
            clip["effort_ratio"],
            clip["index"],
            marker="s",
            facecolors="none",
            edgecolors="tab:orange",
            s=36,
            label="CTC clipped at FCM-CTC's peaks",
        )
        front = t[t["pareto"] & t["family"].isin(["CTC", "CTC clipped"])].sort_values(
            "effort_ratio"
        )
        ax.plot(
            front["effort_ratio"],
            front["index"],
            color="0.4",
            lw=1,
            label="frontier (linear loops)",
        )
        for name, marker, colour in (("FCM-CTC", "*", "tab:red"), (CONTINUOUS, "D", "tab:blue")):
            row = t[t["controller"] == name]
            if not row.empty:
                ax.scatter(
                    row["effort_ratio"],
                    row["index"],
                    marker=marker,
                    s=140 if marker == "*" else 60,
                    color=colour,
                    zorder=5,
                    label=name,
                )
        if regime in chosen:
            o = chosen[regime]
            ax.scatter(
                [o.effort_ratio],
                [o.index],
                s=220,
                facecolors="none",
                edgecolors="k",
                lw=1.5,
                zorder=6,
                label=f"{OPPONENT}: {o.describe()}",
            )
        frontier_axes(ax, f"linear frontier: {regime}")
    fig.tight_layout()
    save_figure(fig, path)
    return path


def summary_lines(table: pd.DataFrame, chosen: dict[str, Opponent]) -> list[str]:
    """A markdown table per regime: FCM-CTC, its continuous variant, the opponent and the
    frontier's loops within a few times FCM-CTC's effort."""
    lines = []
    cols = ("effort", "τ1 peak", "τ2 peak", "Σ|Δτ|1", "Σ|Δτ|2", "Tr1", "Ts1", "Mp1 %", "ess1",
            "Tr2", "Ts2", "Mp2 %", "ess2", "IAE1+2")  # fmt: skip
    for regime, o in chosen.items():
        t = table[table["regime"] == regime]
        keep = t[
            (t["family"].isin(["FCM-CTC", CONTINUOUS])) | (t["controller"] == o.loop) | t["pareto"]
        ]
        head = "| loop | " + " | ".join(cols) + " |"
        lines += ["", f"{regime}: {OPPONENT} = {o.loop} ({o.describe()})", "", head]
        lines.append("|---" * (len(cols) + 1) + "|")
        for r in keep.sort_values("effort_ratio").itertuples():
            mark = (
                " **(opponent)**" if r.controller == o.loop else (" (frontier)" if r.pareto else "")
            )
            vals = [r.effort_ratio, r.torque_peak_Nm1, r.torque_peak_Nm2, r.torque_variation_Nm1,
                    r.torque_variation_Nm2, r.rise_time_s1, r.settling_time_s1, r.overshoot_pct1,
                    r.steady_state_error_rad1, r.rise_time_s2, r.settling_time_s2, r.overshoot_pct2,
                    r.steady_state_error_rad2, r.index]  # fmt: skip
            lines.append(f"| {r.controller}{mark} | " + " | ".join(f"{v:.3g}" for v in vals) + " |")
    return lines


def report_section(manifest: Any, out: Path, pool: Any = None) -> list[str]:
    """The reproduction's section on the frontier: the shipped table where current (else
    run here), written to ``out/frontier.csv`` and ``.json``, its figure
    ``out/figures/frontier.png`` (drawn on ``pool``), and the table of each regime."""
    spec = load_spec(manifest.path.parent / DEFAULT_SPEC.name)
    table, chosen, shipped = opponents(spec, pool)
    save_frontier(table, spec, out / "frontier.csv")
    figure = out / "figures" / "frontier.png"
    if pool is None:
        frontier_figure(table, chosen, figure)
    else:
        pool.submit(frontier_figure, table, chosen, figure).result()
    where = "shipped and current" if shipped else "rerun here: the shipped table was stale"
    return [
        "",
        "## The linear frontier and the fair opponent",
        "",
        f"CTC on a grid of ωn and ζ, and CTC clipped at FCM-CTC's peak torques, on {spec.plants}",
        f"training plants per regime (`{Path(spec.source).name}`, {where}; `frontier.csv`;",
        'docs/reproduction.md, "The linear frontier"). Effort: median peak |τ| and Σ|Δτ| per',
        "joint, as a ratio to FCM-CTC's (the largest of the four); performance: median",
        f"IAE₁ + IAE₂. {OPPONENT}, the fair opponent of the claims below, is the loop with the",
        "lowest index within FCM-CTC's effort. Medians over the training plants: Tr, Ts [s],",
        "Mp [%], ess [rad], IAE [rad·s], τ [N·m].",
        "",
        "![linear frontier](figures/frontier.png)",
        *summary_lines(table, chosen),
    ]
