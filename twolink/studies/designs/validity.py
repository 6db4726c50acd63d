"""Cluster validity of the FCM design (c = 2..10) and the full 7x7 surface against the
reduced one (docs/fuzzy.md, "Cluster validity" and "Full against reduced").

The design keeps c = 5 (runs/paper/design.toml); these numbers are reported beside it,
they do not choose it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from twolink.controllers.fcm import fcm

__all__ = [
    "ValidityRow",
    "partition_coefficient",
    "partition_entropy",
    "surface_difference",
    "validity_sweep",
    "xie_beni",
]

CLUSTER_RANGE = tuple(range(2, 11))
VALIDITY_SAMPLES = 2000  # design samples clustered per c (every k-th): keeps the sweep < 1 s


def _w(u: np.ndarray, weights: np.ndarray | None) -> np.ndarray:
    return np.ones(len(u)) if weights is None else np.asarray(weights, dtype=float)


def partition_coefficient(u: np.ndarray, weights: np.ndarray | None = None) -> float:
    """PC = Σ_i w_i Σ_j u_ij² / Σ_i w_i (u: (N, c)); 1/c (fuzziest) .. 1 (crisp)."""
    w = _w(u, weights)
    return float(w @ (u * u).sum(axis=1) / w.sum())


def partition_entropy(u: np.ndarray, weights: np.ndarray | None = None) -> float:
    """PE = −Σ_i w_i Σ_j u_ij ln u_ij / Σ_i w_i; 0 (crisp) .. ln c."""
    w = _w(u, weights)
    with np.errstate(divide="ignore", invalid="ignore"):
        h = -np.where(u > 0, u * np.log(u), 0.0).sum(axis=1)
    return float(w @ h / w.sum())


def xie_beni(
    x: np.ndarray,
    u: np.ndarray,
    centers: np.ndarray,
    m: float = 2.0,
    weights: np.ndarray | None = None,
) -> float:
    """XB = Σ_i w_i Σ_j u_ij^m ‖x_i − v_j‖² / (Σ_i w_i · min_{j≠k} ‖v_j − v_k‖²): compactness
    over separation, smaller is better."""
    w = _w(u, weights)
    d2 = ((x[:, None, :] - centers[None, :, :]) ** 2).sum(axis=2)
    compact = float(w @ (u**m * d2).sum(axis=1))
    sep = ((centers[:, None, :] - centers[None, :, :]) ** 2).sum(axis=2)
    sep = sep[~np.eye(len(centers), dtype=bool)].min()
    return compact / (w.sum() * sep)


@dataclass(frozen=True)
class ValidityRow:
    clusters: int
    pc: float
    pe: float
    xb: float


def validity_sweep(
    points: np.ndarray,
    weights: np.ndarray | None = None,
    clusters: Sequence[int] = CLUSTER_RANGE,
    m: float = 2.0,
    seed: int = 0,
    samples: int = VALIDITY_SAMPLES,
) -> tuple[ValidityRow, ...]:
    """Weighted FCM (the design's settings) for each c, on every k-th sample so that at
    most ``samples`` remain, and its PC, PE and XB (weighted as the design weighs)."""
    step = max(1, -(-len(points) // samples))
    x = np.asarray(points)[::step]
    w = None if weights is None else np.asarray(weights)[::step]
    rows = []
    for c in clusters:
        res = fcm(x, c, m=m, eps=1e-5, max_iter=500, seed=seed, weights=w)
        u = res.memberships
        rows.append(
            ValidityRow(
                c,
                partition_coefficient(u, w),
                partition_entropy(u, w),
                xie_beni(x, u, res.centers, m, w),
            )
        )
    return tuple(rows)


def surface_difference(full: Any, reduced: Any, points: np.ndarray, n: int = 121) -> dict:
    """max and mean |u_full − u_reduced| over an n x n grid of the input box and over
    ``points`` (the closed-loop phase-plane samples, normalised)."""
    g = np.linspace(-1.0, 1.0, n)
    e, de = np.meshgrid(g, g)
    box = np.abs(full.evaluate_batch(e, de) - reduced.evaluate_batch(e, de))
    p = np.asarray(points)
    visited = np.abs(
        full.evaluate_batch(p[:, 0], p[:, 1]) - reduced.evaluate_batch(p[:, 0], p[:, 1])
    )
    return {
        "box_max": float(box.max()),
        "box_mean": float(box.mean()),
        "visited_max": float(visited.max()),
        "visited_mean": float(visited.mean()),
        "visited_n": int(len(p)),
    }


def validity_figure(rows: Sequence[ValidityRow], chosen: int):
    """PC, PE and XB against c, the design's c marked."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    from twolink.figures.plots import fixed_layout

    fig = fixed_layout(Figure(figsize=(9, 3)), left=0.06, right=0.98, top=0.9, bottom=0.16)
    fig.subplots_adjust(wspace=0.3)
    c = [r.clusters for r in rows]
    for ax, key, title in zip(
        fig.subplots(1, 3),
        ("pc", "pe", "xb"),
        ("partition coefficient (max)", "partition entropy (min)", "Xie-Beni (min)"),
        strict=True,
    ):
        ax.plot(c, [getattr(r, key) for r in rows], "o-")
        ax.axvline(chosen, color="0.6", ls="--", label=f"design c = {chosen}")
        ax.set_xlabel("clusters c")
        ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8)
    return fig


def validity_markdown(result: Any, rows: Sequence[ValidityRow] | None = None) -> list[str]:
    """The report's lines: validity indices per c (``rows``, or swept here), the design's
    c, and the full 7x7 surface against the reduced one."""
    if rows is None:
        rows = validity_sweep(result.points, result.weights)
    chosen = int(result.clustering.n_clusters)
    best = {
        "PC": max(rows, key=lambda r: r.pc).clusters,
        "PE": min(rows, key=lambda r: r.pe).clusters,
        "XB": min(rows, key=lambda r: r.xb).clusters,
    }
    diff = surface_difference(result.engine, result.engine.with_rules(result.rules), result.points)
    return [
        "",
        "Cluster validity (weighted FCM on the design data, m = 2, every k-th sample;",
        f"![validity](figures/design_validity.png)). The design keeps c = {chosen} (its",
        "Table 1 keeps 5 rules); the indices are reported, not used to choose c. Best c:",
        ", ".join(f"{k} {v}" for k, v in best.items()) + ".",
        "",
        "| c | PC | PE | XB |",
        "|---|---|---|---|",
        *(
            f"| {r.clusters}{' (design)' if r.clusters == chosen else ''} | {r.pc:.3f} "
            f"| {r.pe:.3f} | {r.xb:.3g} |"
            for r in rows
        ),
        "",
        "Full 7x7 against the designed reduction, |u_7x7 − u_designed| (normalised u):",
        f"over the input box (121 x 121) max {diff['box_max']:.3f}, mean "
        f"{diff['box_mean']:.3f}; over the {diff['visited_n']} closed-loop design samples max "
        f"{diff['visited_max']:.3f}, mean {diff['visited_mean']:.4f}.",
        "",
        *coverage_markdown(result),
    ]


def coverage_markdown(result: Any) -> list[str]:
    """Rule coverage (``twolink coverage``) of the paper's Table 1, the designed rule base
    and the 7x7: the share of the input box where no rule fires."""
    from twolink.controllers.fuzzy import paper_fuzzy_pd
    from twolink.controllers.fuzzy.coverage import coverage

    bases = {
        "paper's Table 1": paper_fuzzy_pd(),
        "designed": result.engine.with_rules(result.rules),
        "7x7 heuristic": result.engine,
    }
    cells = []
    for name, engine in bases.items():
        cov = coverage(engine, grid=41)
        cells.append(f"{name} {100 * cov.uncovered_fraction:.1f} % ({len(cov.regions)} regions)")
    return [
        "Rule coverage (`twolink coverage`): share of the input box where no rule fires",
        "(exact area; there the fuzzy term is 0 and CTC acts alone): " + "; ".join(cells) + ".",
    ]
