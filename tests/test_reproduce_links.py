"""The reproduction's variant whose links bend: its runs keep the tip's measures (in
the rows, metrics.json and on resume), and the report's section counts the pair at the
tip by the tip's tolerances (docs/reproduction.md, "Flexible links")."""

from __future__ import annotations

import json
import math

import pytest

from twolink.studies.judgments.link_claims import TIP_TOLERANCES
from twolink.studies.reproduction.manifest import load_manifest
from twolink.studies.reproduction.report_sections import links_section
from twolink.studies.reproduction.reproduce import _execute, finished_row, plan

TIP = tuple(TIP_TOLERANCES)


def test_the_shipped_manifest_runs_every_experiment_on_bending_links():
    manifest = load_manifest()
    links = [v for v in manifest.variants if "links" in v.overrides.get("arm", {})]
    assert [v.name for v in links] == ["links"]
    specs = [sp for sp in plan(manifest, None) if sp.variant.name == "links"]
    assert len(specs) == len(manifest.experiments) * len(manifest.controllers)


def test_a_links_run_keeps_its_tip_measures_in_the_row_the_folder_and_on_resume(tmp_path):
    manifest = load_manifest()
    specs = [
        sp
        for sp in plan(manifest, None, overrides={"duration": 3.0})
        if sp.variant.name == "links" and sp.experiment.key == "table2"
        and sp.controller in ("CTC", "PD-G")
    ]  # fmt: skip
    rows = _execute(specs, tmp_path, trace=False)
    for spec, row in zip(specs, rows, strict=True):
        assert all(math.isfinite(row[k]) for k in TIP[:3]), row
        saved = json.loads((tmp_path / spec.folder / "metrics.json").read_text())["tip"]
        assert saved == {k: row[k] for k in TIP} | {k: v for k, v in saved.items() if k not in TIP}
        from twolink.simulation.config import load_scenario

        again = finished_row(spec, load_scenario(spec.experiment.scenario, spec.overrides),
                             tmp_path, trace=False)  # fmt: skip
        assert again is not None and {k: again[k] for k in TIP} == {k: row[k] for k in TIP}
    ctc, pd = rows
    assert pd["tip_error_m"] > ctc["tip_error_m"] + 0.01  # PD-G lags: the tip is further off
    # Under gravity the tip ends below the rigid tip by its sag (more than 1 cm here);
    # the residual vibration is taken about that sag, so it is far smaller
    assert ctc["final_tip_error_m"] > 0.01 > 5 * ctc["residual_vibration_m"]


def test_a_tip_that_never_settled_reads_nan_again_on_resume(tmp_path):
    """metrics.json writes NaN as null; the resumed row must read NaN, as the fresh one."""
    from twolink.simulation.config import load_scenario

    (spec,) = [
        sp
        for sp in plan(load_manifest(), None)
        if sp.folder == "links/table2/fuzzy-PD"  # its tip still swings at the end
    ]
    (row,) = _execute([spec], tmp_path, trace=False)
    assert math.isnan(row["vibration_settling_time_s"])
    scenario = load_scenario(spec.experiment.scenario, spec.overrides)
    again = finished_row(spec, scenario, tmp_path, trace=False)
    assert json.dumps(again) == json.dumps(row)


def _rows(values: dict[str, tuple[float, float]]) -> list[dict]:
    """Rows of one bending-link experiment: each tip measure's (CTC, FCM-CTC) values."""
    out = []
    for k, controller in enumerate(("CTC", "FCM-CTC")):
        row = {"variant": "links", "experiment": "table2", "controller": controller}
        row.update({m: v[k] for m, v in values.items()})
        out.append(row)
    return out


@pytest.mark.parametrize(
    "shift_mm, word",
    [(0.4, "within 0.5 mm in 1"), (0.6, "worse in 1"), (-0.6, "better in 1")],
)
def test_the_links_section_counts_a_tip_error_beyond_half_a_millimetre_only(shift_mm, word):
    manifest = load_manifest()
    base = {"tip_error_m": 0.03, "final_tip_error_m": 0.01, "residual_vibration_m": 1e-3,
            "vibration_settling_time_s": 2.0}  # fmt: skip
    values = {m: (v, v) for m, v in base.items()}
    values["tip_error_m"] = (0.03, 0.03 + shift_mm * 1e-3)
    text = "\n".join(links_section(_rows(values), manifest))
    assert f"tip error {word}" in text.replace("better in 0, ", "").replace("worse in 0, ", "")
    assert "| table2 | 30 | " in text  # in mm
    assert "(of 1 experiments)" in text


def test_a_tip_that_never_settled_counts_against_its_law_and_shows_a_dash():
    """As in the link claims (link_claims.REACHED): a settling never reached is worse."""
    manifest = load_manifest()
    values = {m: (0.01, 0.01) for m in TIP}
    values["vibration_settling_time_s"] = (2.0, math.nan)
    text = "\n".join(links_section(_rows(values), manifest))
    assert "tip settling better in 0, worse in 1, within 0.01 s in 0" in text
    assert "| 2 | — |" in text
    values["vibration_settling_time_s"] = (math.nan, math.nan)
    text = "\n".join(links_section(_rows(values), manifest))
    assert "tip settling better in 0, worse in 0, within 0.01 s in 0" in text


def test_no_section_without_bending_links():
    rows = [
        {"variant": "rigid", "experiment": "table2", "controller": c} for c in ("CTC", "FCM-CTC")
    ]
    assert links_section(rows, load_manifest()) == []


def test_the_section_shows_the_shipped_claims_on_drawn_plants():
    import pandas as pd

    from twolink.studies.judgments.link_claims import shipped_paths, table_lines

    values = {m: (0.01, 0.01) for m in TIP}
    text = links_section(_rows(values), load_manifest())
    shipped = table_lines(pd.read_csv(shipped_paths()[0]))
    assert "### The claims on drawn plants (shipped)" in text
    start = text.index(shipped[0])
    assert text[start : start + len(shipped)] == shipped
    assert any(line.startswith("| two-time-scale + ZV | residual vibration |") for line in shipped)
