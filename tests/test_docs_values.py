"""The numbers the docs and README state about the shipped configuration are the ones the
shipped files produce: a doc that drifts from the runs fails here."""

from __future__ import annotations

import math
import re
from pathlib import Path

from twolink.simulation.config import load_scenario
from twolink.simulation.experiment import build_controller

REPO = Path(__file__).resolve().parents[1]


def _doc_value(text: str, row: str) -> float:
    """The first number of ``our value`` in the table row that starts ``| row |``."""
    match = re.search(rf"^\| {re.escape(row)} \| [^|]* \| ([-0-9.e+]+)", text, re.MULTILINE)
    assert match, f"docs/reproduction.md has no row {row!r}"
    return float(match.group(1))


def _printed(value: float, shown: float) -> bool:
    """``value`` rounds to ``shown`` at the digits ``shown`` was printed with."""
    digits = len(repr(shown).split(".")[1]) if "." in repr(shown) else 0
    return math.isclose(round(value, digits), shown, abs_tol=10 ** -(digits + 3))


def test_reproduction_doc_gives_the_shipped_gains_and_fuzzy_scaling():
    text = (REPO / "docs" / "reproduction.md").read_text()
    s = load_scenario(
        REPO / "runs" / "paper" / "theta1_step.toml",
        {"controller": {"kind": "fcm_ctc", "rule_base": "designed"}},
    )
    c = build_controller(s)
    shipped = {
        "Kp": s.controller.kp[0],
        "Kd": s.controller.kd[0],
        "span E": s.controller.fuzzy.span,
        "ke": c.ke,
        "kde": c.kde,
        "ku": c.ku,
    }
    for row, value in shipped.items():
        shown = _doc_value(text, row)
        assert _printed(float(value), shown), (row, value, shown)
    wn = math.sqrt(s.controller.kp[0])
    assert f"ωn = {wn:g} rad/s" in text


def test_the_readme_counts_the_reproductions_runs_from_its_manifest():
    """The reproduction's description's "210 runs (10 × 7 × 3)" (docs/reproduction.md,
    moved there from the README) is the shipped manifest's plan (it said 180 after a
    controller was added), and names every controller the runs have."""
    from twolink.studies.reproduction.manifest import load_manifest
    from twolink.studies.reproduction.reproduce import plan

    m = load_manifest()
    n = (len(m.experiments), len(m.controllers), len(m.variants))
    readme = " ".join((REPO / "docs" / "reproduction.md").read_text().split())
    assert f"{len(plan(m, None))} runs ({n[0]} × {n[1]} × {n[2]})" in readme
    assert f"({n[0]} experiments)" in readme
    assert "FCM-CTC-continuous" in readme and "four baselines" in readme
    assert len(m.controllers) == 3 + 4  # CTC, FCM-CTC, its variant and four baselines


def test_the_load_results_example_names_real_columns():
    """The docstring's example column is one a sweep table has (it raised KeyError)."""
    import re as _re

    from twolink.sweep import load_results
    from twolink.sweep.results import METRIC_COLUMNS

    used = _re.findall(r'\["(joint\d_\w+)"\]', load_results.__doc__ or "")
    assert used and all(c in METRIC_COLUMNS for c in used), used
