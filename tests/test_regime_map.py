"""The regime map (twolink regimes): a small grid end to end, and its summary's rule."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
from click.testing import CliRunner

from twolink.interface.cli import main
from twolink.studies.judgments.regimes import DEFAULT_STUDY, summary

SMALL = {
    "samples = 3000": "samples = 40",
    "chunk_size = 150": "chunk_size = 40",
    "duration = 4.0": "duration = 2.5",
    "values = [2.0, 4.0, 5.0, 10.0, 15.0]": "values = [4.0, 15.0]",
    "values = [1.0, 1.2, 1.5]": "values = [1.5]",
    '"../paper/base.toml"': f'"{DEFAULT_STUDY.parent.parent / "paper" / "base.toml"}"',
}


def test_a_small_regime_map_end_to_end(tmp_path):
    text = DEFAULT_STUDY.read_text()
    for old, new in SMALL.items():
        assert old in text, old
        text = text.replace(old, new)
    study = tmp_path / "regimes.toml"
    study.write_text(text)
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["regimes", str(study), "--out", str(out), "--workers", "1"])
    assert result.exit_code == 0, result.output
    for name in ("regimes.csv", "regimes_summary.csv", "regimes.md", "regimes.png"):
        assert (out / name).is_file(), name
    summ = pd.read_csv(out / "regimes_summary.csv")
    # 2 regimes x 4 cells x 2 proposed (FCM-CTC, its continuous inference) x 2
    # opponents, 10 plants each
    assert len(summ) == 32 and set(summ["plants"]) == {10}
    assert set(summ["proposed"]) == {"FCM-CTC", "FCM-CTC-continuous"}
    quintic = summ[(summ["regime"] == "quintic") & (summ["wn"] == 15.0)]
    # at the shipped bandwidth, no mismatch beyond the masses': the term acts little
    assert (quintic["fuzzy_active_share"] < 0.5).all()
    raw = summ[summ["regime"] == "raw steps"]
    assert (raw["fuzzy_active_share"] > 0).all()  # the paper's raw steps: it acts
    assert "| ωn [rad/s] |" in (out / "regimes.md").read_text()


def test_the_effect_of_a_cell_is_what_its_verdicts_say():
    def table(verdicts):
        return pd.DataFrame(
            {
                "regime": "quintic", "wn": 4.0, "mass": 1.0, "payload": 0.0,
                "proposed": "FCM-CTC", "opponent": "CTC", "fuzzy_active_share": 0.1,
                "n": 100,
                "joint": 1, "metric": "iae_rad_s", "verdict": verdicts,
            }
        )  # fmt: skip

    cases = {
        ("better", "equivalent"): "helps",
        ("worse", "inconclusive"): "hurts",
        ("better", "worse"): "mixed",
        ("equivalent", "inconclusive"): "no difference shown",
    }
    for verdicts, effect in cases.items():
        assert summary(table(list(verdicts)))["effect"].iloc[0] == effect
    assert Path(DEFAULT_STUDY).is_file()


def test_a_share_without_a_verdict_is_listed_apart_from_the_verdicts():
    t = pd.DataFrame(
        {
            "regime": "quintic", "wn": 4.0, "mass": 1.0, "payload": 0.0,
            "proposed": "FCM-CTC", "opponent": "CTC", "fuzzy_active_share": 0.1,
            "n": 100, "plants": 100, "joint": [2, 1], "metric": ["oscillation_rad", "iae_rad_s"],
            "verdict": ["equivalent", "worse"], "better": 0, "worse": [29, 60],
            "unreached_better": 0, "unreached_worse": 0,
            "share_better_shown": False, "share_worse_shown": True,
        }
    )  # fmt: skip
    row = summary(t).iloc[0]
    assert row["worse_share"] == "θ2 osc 29/100" and row["worse"] == "θ1 IAE"
    assert row["better_share"] == "" and row["effect"] == "hurts"


def test_a_friction_axis_splits_the_cells_and_shows_in_the_table():
    """Two friction levels of one cell otherwise: two cells, each its own effect."""
    from twolink.studies.judgments.regimes import FRICTION_AXIS, markdown

    t = pd.DataFrame(
        {
            "regime": "quintic", "wn": 15.0, "mass": 1.0, "payload": 0.0,
            FRICTION_AXIS: [0.0, 0.0, 0.1, 0.1],
            "proposed": "FCM-CTC", "opponent": "CTC", "fuzzy_active_share": 0.1,
            "n": 100, "joint": [1, 2, 1, 2], "metric": "iae_rad_s",
            "verdict": ["equivalent", "equivalent", "worse", "equivalent"],
        }
    )  # fmt: skip
    summ = summary(t)
    assert list(summ[FRICTION_AXIS]) == [0.0, 0.1]
    assert list(summ["effect"]) == ["no difference shown", "hurts"]
    text = "\n".join(markdown(summ))
    assert "| F_c [% of G] |" in text and "| 15 | 1 | 0 | 10 | 10.0 % | 100 | hurts |" in text
