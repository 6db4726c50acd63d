"""``twolink compare`` / ``twolink.compare``: two controllers on one scenario in one call."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from clone_guard import clone_files, written

import twolink
from twolink.interface.cli import main
from twolink.simulation.config import ConfigError
from twolink.studies.judgments.claims import paired_claims

SHORT = {"duration": 1.5}


def test_the_verdict_is_as_against_b_and_flips_when_they_swap(tmp_path, monkeypatch):
    """CTC (ωn = 15) rises far sooner than CTC-paper (ωn = 2, ζ = 0.6) on the raw step:
    'better' for CTC against CTC-paper, 'worse' the other way round. (10 plants: the
    margin test on 6 metrics with Holm's correction needs 9 plants all one way.)"""
    monkeypatch.chdir(tmp_path)
    before = clone_files()
    ab = twolink.compare("theta1_step", "CTC", "CTC-paper", 10, overrides=SHORT)
    ba = twolink.compare("theta1_step", "CTC-paper", "CTC", 10, overrides=SHORT)
    assert written(before) == [] and list(tmp_path.iterdir()) == []  # out=None: no file
    row = ab.claims.set_index("metric").loc["rise_time_s"]
    assert row["verdict"] == "better" and row["better"] == row["n"] >= 8
    assert ba.claims.set_index("metric").loc["rise_time_s", "verdict"] == "worse"
    # the table is paired_claims of the sweep's results, its medians the controllers'
    again = paired_claims(ab.results, "CTC", "CTC-paper", joints=(1,))
    assert list(again["verdict"]) == list(ab.claims["verdict"])
    rise = ab.results.pivot(index="sample", columns="controller", values="joint1_rise_time_s")
    paired = rise.dropna()  # the plants on which both rose
    assert row["proposed_median"] == pytest.approx(np.median(paired["CTC"]))
    assert row["baseline_median"] == pytest.approx(np.median(paired["CTC-paper"]))
    text = str(ab)
    assert text.startswith("CTC against CTC-paper on 10 plants, theta1_step")
    assert "better: CTC lower" in text and "met the spec:" in text
    # one moving joint: overlay and difference; CTC-paper never settles within 1.5 s, so
    # the transient they show is the whole run and no third panel repeats it
    assert len(ab.figure.axes) == 2 and ab.figure.axes[0].get_xlim()[1] == 1.5


def test_the_overlay_and_difference_are_the_plants_runs(tmp_path):
    result = twolink.compare(
        "theta1_step", "FCM-CTC", "CTC", 3, out=tmp_path / "cmp", overrides=SHORT
    )
    assert {p.name for p in (tmp_path / "cmp").iterdir()} >= {
        "claims.csv", "claims.md", "compare.png", "compare.rrd", "compare.toml", "sweep",
    }  # fmt: skip
    overlay, difference, whole = result.figure.axes  # both settle: the whole run below
    assert overlay.get_xlim() == difference.get_xlim() and overlay.get_xlim()[1] < 1.5
    assert whole.get_xlim()[1] >= 1.5
    # 3 plants, then the median, per controller, then the reference
    assert len(overlay.get_lines()) == 2 * (3 + 1) + 1
    medians = {line.get_label(): line.get_ydata() for line in overlay.get_lines()}
    fcm = medians["FCM-CTC: median of 3 plants"]
    ctc = medians["CTC: median of 3 plants"]
    difference_median = next(x for x in difference.get_lines() if x.get_label() == "median")
    n = len(difference_median.get_ydata())
    assert np.nanmax(np.abs(fcm[:n] - ctc[:n])) > 0  # the fuzzy term acts on raw steps
    # one recording: the two on the nominal plant, side by side
    from twolink.tracing.comparison import read_comparison

    recorded = read_comparison(tmp_path / "cmp" / "compare.rrd")
    assert {"joint1/angle/FCM-CTC", "joint1/angle/CTC", "joint1/angle/reference"} <= set(
        recorded.columns
    )
    # the sweep this ran is a file twolink sweep reads
    plan = twolink.sweep.load_sweep(tmp_path / "cmp" / "compare.toml")
    assert plan.samples == 3 and plan.controller_names == ("FCM-CTC", "CTC")
    assert plan.base["duration"] == 1.5
    # a second run into the same folder is the same command's: allowed
    twolink.compare("theta1_step", "FCM-CTC", "CTC", 3, out=tmp_path / "cmp", overrides=SHORT)


def test_bad_input_is_named_before_anything_runs(tmp_path):
    with pytest.raises(ConfigError, match="two different controllers"):
        twolink.compare("theta1_step", "CTC", "CTC")
    with pytest.raises(ConfigError, match=r"controller 'LQR': not a shipped controller \(CTC"):
        twolink.compare("theta1_step", "CTC", "LQR")
    runner = CliRunner()
    for args, says in (
        (["theta1_step", "CTC", "CTC"], "two different controllers"),
        (["theta1_stpe", "CTC", "FCM-CTC"], "did you mean theta1_step"),
        (["theta1_step", "CTC", "nope"], "not a shipped controller"),
        (["theta1_step", "CTC", "ctc_integral", "--set", "controller.kp=-1"], "controller.kp"),
    ):
        result = runner.invoke(main, ["compare", *args, "--out", str(tmp_path / "x")])
        assert result.exit_code == 2 and says in result.output, result.output
    assert not (tmp_path / "x").exists()
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("mine")
    result = runner.invoke(main, ["compare", "theta1_step", "CTC", "FCM-CTC", "-n", "2",
                                  "--set", "duration=0.5", "--out", str(mine)])  # fmt: skip
    assert result.exit_code == 2 and "notes.txt" in result.output, result.output


def test_the_paired_statistics_are_public():
    assert twolink.paired_claims is paired_claims
    assert twolink.Comparison.__name__ == "Comparison"
