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


# ------------------------------------------------ the numbers docs/reproduction.md quotes


def _shown(value: float, text: str) -> bool:
    """``value`` prints as ``text`` at the decimals ``text`` was written with."""
    text = text.strip().strip("*")
    decimals = len(text.split(".")[1]) if "." in text else 0
    return abs(value - float(text)) <= 0.5 * 10**-decimals + 1e-12


def _numbers(cell: str) -> list[str]:
    return re.findall(r"-?\d+(?:\.\d+)?", cell)


def _table(text: str, header: str) -> list[dict[str, str]]:
    """The rows of the markdown table whose header line starts ``| header``."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(f"| {header}"))
    names = [c.strip() for c in re.split(r"(?<!\\)\|", lines[start])[1:-1]]
    rows = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]]
        rows.append(dict(zip(names, cells, strict=True)))
    return rows


def _agree(values: list[float], cell: str) -> bool:
    shown = _numbers(cell)
    return len(shown) == len(values) and all(map(_shown, values, shown))


REPRODUCTION = (REPO / "docs" / "reproduction.md").read_text()


def test_the_frontier_table_is_the_shipped_frontier():
    """Every row of "The linear frontier" table is its row of runs/paper/frontier.csv, and
    the rows marked CTC-best are frontier.json's choice."""
    import json

    import pandas as pd

    front = pd.read_csv(REPO / "runs" / "paper" / "frontier.csv")
    chosen = json.loads((REPO / "runs" / "paper" / "frontier.json").read_text())["opponents"]
    rows = _table(REPRODUCTION, "regime | loop | effort ratio")
    assert len(rows) == 8
    for row in rows:
        loop = row["loop"]
        regime = front[front.regime == row["regime"]]
        if loop.startswith("FCM-CTC"):
            match = regime[regime.controller == loop]
        else:
            wn, zeta = (float(v) for v in re.findall(r"[ωζ]\S* = ([\d.]+)", loop))
            family = "CTC clipped" if "clipped" in loop else "CTC"
            match = regime[(regime.family == family) & (regime.wn == wn) & (regime.zeta == zeta)]
        assert len(match) == 1, loop
        r = match.iloc[0]
        if "CTC-best" in loop:
            assert r.controller == chosen[row["regime"]]["loop"], loop
        if "clipped" in loop:
            assert _agree([r.limit1, r.limit2], loop.split("clipped at")[1]), loop
        cells = {
            "effort ratio": [r.effort_ratio],
            "peak τ₁ / τ₂": [r.torque_peak_Nm1, r.torque_peak_Nm2],
            "Σ\\|Δτ\\|₁ / ₂": [r.torque_variation_Nm1, r.torque_variation_Nm2],
            "Tr₁": [r.rise_time_s1],
            "Ts₁": [r.settling_time_s1],
            "Mp₂ %": [r.overshoot_pct2],
            "ess₁ / ess₂": [r.steady_state_error_rad1, r.steady_state_error_rad2],
            "IAE₁ + IAE₂": [r["index"]],
        }
        for name, values in cells.items():
            assert _agree(values, row[name]), (loop, name, values, row[name])


def test_the_per_joint_opponent_table_is_the_shipped_search():
    """The per-joint CTC-best table is runs/paper/frontier_per_joint.json: the chosen loop
    and its effort and index beside FCM-CTC's, on the training and the judged plants."""
    import json

    shipped = json.loads((REPO / "runs" / "paper" / "frontier_per_joint.json").read_text())
    rows = _table(REPRODUCTION, "regime | CTC-best (per joint)")
    assert {row["regime"] for row in rows} == {"quintic", "raw"}
    for row in rows:
        o = shipped["opponents"][row["regime"]]
        loop = row["CTC-best (per joint)"]
        wn = re.search(r"ωn ([\d.]+) / ([\d.]+)", loop).groups()
        zeta = re.search(r"ζ ([\d.]+) / ([\d.]+)", loop).groups()
        assert all(map(_shown, [*o["wn"], *o["zeta"]], [*wn, *zeta])), loop
        assert ("clipped" in loop) == (o["family"] == "CTC clipped"), loop
        train, fcm_train = o["train"], o["train_fcm"]
        judged, fcm_judged = o["judged"], o["judged_fcm"]
        cells = {
            "training Σ\\|Δτ\\|₁ / ₂ (FCM-CTC)": [*train[2:4], *fcm_train[2:4]],
            "judged peak τ₁ / τ₂ (FCM-CTC)": [*judged[0:2], *fcm_judged[0:2]],
            "judged Σ\\|Δτ\\|₁ / ₂ (FCM-CTC)": [*judged[2:4], *fcm_judged[2:4]],
            "index training / judged (FCM-CTC)": [train[4], judged[4], fcm_train[4], fcm_judged[4]],
        }
        for name, values in cells.items():
            assert _agree(values, row[name]), (row["regime"], name, values, row[name])


def test_the_search_table_is_the_shipped_search():
    """The strongest fuzzy term's training table is runs/paper/search/search.json."""
    import json

    shipped = json.loads((REPO / "runs" / "paper" / "search" / "search.json").read_text())
    found = {(s["regime"], s["inference"]): s for s in shipped["searches"]}
    rows = _table(REPRODUCTION, "regime | inference | FCM-CTC | CTC (no rule)")
    assert len(rows) == len(found) == 4
    budget = None
    for row in rows:
        s = found[(row["regime"], row["inference"].lower())]
        assert _agree([s["designed"][4]], row["FCM-CTC"]), row
        assert _agree([s["empty"][4]], row["CTC (no rule)"]), row
        assert _agree([s["cost"]], row["best table"]), row
        effort = row["its effort: peak τ₁ / τ₂, Σ\\|Δτ\\|₁ / ₂ (budget)"]
        if "(same)" in effort:  # the budget is the row above's
            assert s["budget"] == budget, row
            effort = effort.replace("(same)", "")
            assert _agree(s["values"][:4], effort), row
        else:
            assert _agree(s["values"][:4] + s["budget"], effort), row
        budget = s["budget"]


def test_the_calibration_result_is_the_shipped_fit():
    """The calibration's result table and objectives are runs/paper/calibrated.toml's."""
    import tomllib

    fit = tomllib.loads((REPO / "runs" / "paper" / "calibrated.toml").read_text())
    p = fit["parameters"]
    rows = {row["parameter"]: row["fit"] for row in _table(REPRODUCTION, "parameter | fit")}
    expected = {
        "ωn1, ζ1": [p["wn1"], p["zeta1"]],
        "ωn2, ζ2": [p["wn2"], p["zeta2"]],
        "steps": [p["step1"], p["step2"]],
        "ramps": [p["ramp1"], p["ramp2"], p["ramp_time"]],
        "plant mass": [p["mass"]],
        "ke, kde, ku": [p["ke"], p["kde"], p["ku"]],
    }
    assert set(rows) == set(expected)
    for name, values in expected.items():
        assert _agree(values, rows[name]), (name, values, rows[name])
    ctc, fcm = re.search(
        r"\*\*([\d.]+) on the CTC rows and ([\d.]+) on the FCM-CTC rows\*\*", REPRODUCTION
    ).groups()
    assert _shown(fit["objective"]["CTC"], ctc) and _shown(fit["objective"]["FCM-CTC"], fcm)


def test_the_fuzzy_and_control_pages_give_the_shipped_scaling():
    """docs/fuzzy.md and docs/control.md quote the "auto" scaling of the shipped gains."""
    s = load_scenario(
        REPO / "runs" / "paper" / "theta1_step.toml",
        {"controller": {"kind": "fcm_ctc", "rule_base": "designed"}},
    )
    c = build_controller(s)
    fuzzy = (REPO / "docs" / "fuzzy.md").read_text()
    ke, kde, ku = re.search(
        r"At the shipped gains: ke = ([\d.]+) /rad, kde = ([\d.]+) s/rad, ku = ([\d.]+) rad/s²",
        fuzzy,
    ).groups()
    assert _shown(c.ke, ke) and _shown(c.kde, kde) and _shown(c.ku, ku)
    span = s.controller.fuzzy.span
    for page in ("fuzzy.md", "control.md"):
        shown = re.findall(
            r"([\d.]+) rad at the shipped ωn = 15", (REPO / "docs" / page).read_text()
        )
        shown += re.findall(r"span E \(([\d.]+) rad\)", (REPO / "docs" / page).read_text())
        assert shown and all(_shown(span, v) for v in shown), (page, shown)
