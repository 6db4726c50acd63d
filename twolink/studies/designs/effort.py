"""The effort rule, its one home (docs/reproduction.md, "The linear opponent by search, per
joint"): a loop, a searched fuzzy table or a tuned law is within FCM-CTC's effort where
each of its medians of peak |τ| and Σ|Δτ| per joint stays within FCM-CTC's plus the
metric's practical tolerance, on the plants where it is judged (:func:`within_budget`). A
tuned opponent must be within on the training plants and on the judged plants, each
against FCM-CTC's own effort on that set (:func:`admissible`). The linear frontier, the
per-joint search, the tuned laws and the fuzzy table search's flags all read it here."""

from __future__ import annotations

from typing import Any

import numpy as np

# The effort: peak |τ| and Σ|Δτ|, the metrics the claims judge against the fair opponent
EFFORT_KEYS = ("torque_peak_Nm", "torque_variation_Nm")
# per joint, within_budget's column order: peak |τ|₁, peak |τ|₂, Σ|Δτ|₁, Σ|Δτ|₂
EFFORT_METRICS = tuple((m, j) for m in EFFORT_KEYS for j in (1, 2))


EFFORT_COLUMNS = tuple(f"{m}{j}" for m, j in EFFORT_METRICS)  # a summary table's names


def tolerances() -> np.ndarray:
    """The claims' practical tolerance of each effort value, in :data:`EFFORT_METRICS`'
    order (0.5 N·m on a peak, 1 N·m on a Σ|Δτ|)."""
    from twolink.studies.judgments.claims import TOLERANCES

    return np.array([TOLERANCES[m] for m, _ in EFFORT_METRICS])


def within_budget(values: Any, budget: Any, tolerance: np.ndarray | None = None) -> np.ndarray:
    """Per row of ``values`` (n, 4: peak |τ|₁, peak |τ|₂, Σ|Δτ|₁, Σ|Δτ|₂, or a table with
    :data:`EFFORT_COLUMNS`): each at most the ``budget`` (4 values, or a mapping of those
    columns) plus its tolerance (default :func:`tolerances`). A NaN, a failed run, is never
    within."""
    if hasattr(values, "columns"):
        values = values[list(EFFORT_COLUMNS)]
    if isinstance(budget, dict):
        budget = [budget[c] for c in EFFORT_COLUMNS]
    tol = tolerances() if tolerance is None else np.asarray(tolerance, dtype=float)
    v = np.atleast_2d(np.asarray(values, dtype=float))
    ok = v <= np.asarray(budget, dtype=float) + tol
    return ok.all(axis=1) & np.isfinite(v).all(axis=1)


def admissible(
    train: Any,
    judged: Any,
    budget_train: Any,
    budget_judged: Any,
    tolerance: np.ndarray | None = None,
) -> np.ndarray:
    """The tuned opponents' rule: within FCM-CTC's effort on both plant sets, each against
    FCM-CTC's own effort on that set (``train`` against ``budget_train``, ``judged``
    against ``budget_judged``)."""
    return within_budget(train, budget_train, tolerance) & within_budget(
        judged, budget_judged, tolerance
    )


def effort_flags(held: Any, proposed: str = "FCM-CTC") -> Any:
    """The effort rule on a held-out table (``search/heldout.csv``: paired_claims rows per
    regime and controller): per regime and searched controller, its four effort medians on
    the judged plants beside FCM-CTC's there, and ``within`` (each at most FCM-CTC's plus
    the tolerance). One row per (regime, controller)."""
    import pandas as pd

    rows = []
    for (regime, name), g in held.groupby(["regime", "controller"], sort=False):
        if name == proposed:
            continue
        base = held[(held["regime"] == regime) & (held["controller"] == proposed)]

        def medians(t: Any) -> np.ndarray:
            return np.array(
                [
                    float(t[(t["metric"] == m) & (t["joint"] == j)]["proposed_median"].iloc[0])
                    for m, j in EFFORT_METRICS
                ]
            )

        mine, budget = medians(g), medians(base)
        rows.append(
            {
                "regime": regime,
                "controller": name,
                **{f"{m}{j}": v for (m, j), v in zip(EFFORT_METRICS, mine, strict=True)},
                **{
                    f"{proposed} {m}{j}": v
                    for (m, j), v in zip(EFFORT_METRICS, budget, strict=True)
                },
                "within": bool(within_budget(mine, budget)[0]),
            }
        )
    return pd.DataFrame(rows)


def effort_lines(held: Any) -> list[str]:
    """The effort rule on the judged plants (docs/reproduction.md, "The linear opponent by
    search"): each best table's Σ|Δτ| per joint beside FCM-CTC's, and whether it is within
    FCM-CTC's effort there; one over it is not an answer at equal effort."""
    lines = ["Effort on the claims' plants (medians; Σ|Δτ| [N·m] per joint, FCM-CTC's beside):", ""]
    for r in effort_flags(held).to_dict("records"):
        word = "within FCM-CTC's effort" if r["within"] else "OVER FCM-CTC's effort: not crowned"
        lines.append(
            f"- {r['regime']} {r['controller']}: {r['torque_variation_Nm1']:.1f} / "
            f"{r['torque_variation_Nm2']:.1f} against {r['FCM-CTC torque_variation_Nm1']:.1f} / "
            f"{r['FCM-CTC torque_variation_Nm2']:.1f}: {word}"
        )
    return [*lines, ""]
