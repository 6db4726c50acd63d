"""The flexible-link claims (twolink/studies/judgments/link_claims.py): the plants are the
sweep's draws, each verdict word reads what the paired differences say, and the shipped
files (runs/flexible_links/claims*.csv) are the study's output, which the docs' tables show."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from clone_guard import REPO

from twolink.studies.judgments import link_claims as lc
from twolink.studies.judgments.claims_words import EQUAL, SPLIT, WORSE

CLAIMS, RUNS, RECORD = lc.shipped_paths()


@pytest.fixture(scope="module")
def shipped_runs() -> pd.DataFrame:
    return lc.load_runs(RUNS)


def _row(claims, law, at, metric, where="all"):
    hit = claims[
        (claims["where"] == where)
        & (claims["law"] == law)
        & (claims["at"] == at)
        & (claims["metric"] == metric)
    ]
    assert len(hit) == 1
    return hit.iloc[0]


def _with_law(runs: pd.DataFrame, name: str, change) -> pd.DataFrame:
    """The runs with one more law: CTC's rows, named ``name``, changed by ``change``."""
    copy = runs[runs["controller"] == lc.BASELINE].copy()
    copy["controller"] = name
    change(copy)
    return pd.concat([runs, copy], ignore_index=True)


def test_the_plants_are_the_sweeps_draws(shipped_runs):
    """The study's plants are plan.draw(i) of runs/sweeps/flexible_links.toml: its E I times
    ei_scale, its payload; the laws keep the nominal links; the shipped runs are those
    plants, every law on each."""
    from twolink.simulation.links_sim import plant_links

    plan, drawn = lc.plant_scenarios(3)
    assert plan.file.endswith("runs/sweeps/flexible_links.toml")
    for i, (values, s) in enumerate(drawn):
        assert values == plan.draw(i)[0]
        assert plant_links(s).link1.ei == pytest.approx(1e3 * values["ei_scale"])
        assert s.plant.payload == values["payload"]
        assert s.links.link1.ei == 1e3 and s.controller.kp == (225.0, 225.0)
    record = json.loads(RECORD.read_text())
    n = record["plants"]
    assert n == plan.samples == 100 and len(shipped_runs) == n * len(lc.LAWS)
    for name in lc.LAWS:
        mine = shipped_runs[shipped_runs["controller"] == name].sort_values("sample")
        assert list(mine["sample"]) == list(range(n))
        for i in (0, 37, n - 1):
            drawn_values = plan.draw(i)[0]
            row = mine.iloc[i]
            assert (row["ei_scale"], row["payload"]) == (
                drawn_values["ei_scale"],
                drawn_values["payload"],
            )
    draws = np.array([plan.draw(i)[0]["ei_scale"] for i in range(n)])
    assert 0.5 <= draws.min() < 0.6 and 1.4 < draws.max() <= 1.5  # the rule: uniform 0.5-1.5


def test_the_shaper_is_tuned_to_the_nominal_loops_slow_mode():
    """docs/flexible_links.md's linearisation: with ks = 0.01 s the loop's slow pair is
    3.01 Hz (ζ 0.89) and 3.15 Hz (ζ 0.34); the shaper takes the less damped one."""
    plan, _ = lc.plant_scenarios(1)
    f, z = lc.shaper_mode(plan.nominal_scenario())
    assert (f, z) == pytest.approx((3.148, 0.337), abs=2e-3)
    assert json.loads(RECORD.read_text())["shaper"]["frequency_hz"] == pytest.approx(f, rel=1e-9)


def test_a_law_against_itself_is_equal_and_a_known_shift_reads_as_that_size(shipped_runs):
    """CTC's own runs under another name: equal on every metric, shift 0. Worse by 2 mm at
    the tip and 20 ms in settling on every plant: worse, on all 100, by exactly that. A
    shift within the tolerance (0.3 mm, 5 ms) is no difference; half the plants 2 mm
    worse and half 2 mm better is split."""
    n = shipped_runs["sample"].nunique()
    runs = _with_law(shipped_runs, "itself", lambda r: None)

    def worse(r):
        r["residual_vibration_m"] += 2e-3
        r["vibration_settling_time_s"] += 0.02

    def small(r):
        r["residual_vibration_m"] += 3e-4
        r["vibration_settling_time_s"] += 0.005

    def both_ways(r):
        r["residual_vibration_m"] += np.where(r["sample"] % 2 == 0, 2e-3, -2e-3)

    runs = _with_law(runs, "worse", worse)
    runs = _with_law(runs, "small", small)
    runs = _with_law(runs, "both ways", both_ways)
    claims = lc.judge_links(runs, ["itself", "worse", "small", "both ways"])
    same = claims[claims["law"] == "itself"]
    assert set(same["verdict"]) == {EQUAL} and (same["estimate"] == 0).all()
    for metric, size in (("residual_vibration_m", 2e-3), ("vibration_settling_time_s", 0.02)):
        r = _row(claims, "worse", "tip", metric)
        assert r["verdict"] == WORSE and (r["worse"], r["plants"]) == (n, n)
        assert r["estimate"] == pytest.approx(size, rel=1e-9)
        assert r["ci_low"] == pytest.approx(size, rel=1e-9)
        assert _row(claims, "small", "tip", metric)["verdict"] == EQUAL
    assert (
        "worse by more than 0.5 mm on 100 of 100"
        in _row(claims, "worse", "tip", "residual_vibration_m")["reading"]
    )
    assert _row(claims, "worse", "tip", "tip_error_m")["verdict"] == EQUAL  # untouched
    split = _row(claims, "both ways", "tip", "residual_vibration_m")
    assert split["verdict"] == SPLIT and (split["better"], split["worse"]) == (n // 2, n // 2)


def test_a_tip_still_swinging_at_the_end_counts_against_its_law(shipped_runs):
    """A NaN settling time (the tip swings wider than 1 mm in the last 0.5 s) is a time
    never reached: it counts as worse, as claims.REACHED's times do."""

    def unsettled(r):
        r.loc[r["sample"] < 30, "vibration_settling_time_s"] = math.nan

    claims = lc.judge_links(_with_law(shipped_runs, "swings", unsettled), ["swings"])
    r = _row(claims, "swings", "tip", "vibration_settling_time_s")
    base = shipped_runs[shipped_runs["controller"] == lc.BASELINE]
    settled = int(base.loc[base["sample"] < 30, "vibration_settling_time_s"].notna().sum())
    assert r["unreached_worse"] == settled > 0 and r["unreached_better"] == 0


def test_the_halves_split_the_plants_by_ei_scale(shipped_runs):
    claims = pd.read_csv(CLAIMS)
    base = shipped_runs[shipped_runs["controller"] == lc.BASELINE]
    soft = int((base["ei_scale"] < 1).sum())
    assert 0 < soft < len(base)
    sizes = claims.groupby("where")["runs"].max().to_dict()
    assert sizes == {"all": len(base), "ei_scale < 1": soft, "ei_scale >= 1": len(base) - soft}
    assert set(claims["law"]) == set(lc.LAWS[1:]) and set(claims["opponent"]) == {"CTC"}
    assert len(claims) == len(lc.HALVES) * len(lc.LAWS[1:]) * len(lc.METRICS)
    fcm = shipped_runs[shipped_runs["controller"] == "FCM-CTC"]
    assert (fcm["fuzzy_active_share"] == 0).all()  # docs: its rule base never fires here


def test_the_shipped_verdicts_are_the_judgment_of_the_shipped_runs(tmp_path):
    """--reuse judges the shipped runs again: the same claims.csv, byte for byte."""
    assert lc.main(["--out", str(tmp_path), "--reuse"]) == 0
    assert (tmp_path / "claims.csv").read_bytes() == CLAIMS.read_bytes()
    assert (tmp_path / "claims_runs.csv").read_bytes() == RUNS.read_bytes()


def test_the_docs_show_the_shipped_tables():
    """docs/flexible_links.md, "Claims on drawn plants": every half's table, as
    table_lines prints it from the shipped verdicts."""
    docs = (REPO / "docs" / "flexible_links.md").read_text()
    claims = pd.read_csv(CLAIMS)
    for where in lc.HALVES:
        assert "\n".join(lc.table_lines(claims, where)[2:]) in docs, where


def test_each_law_runs_on_a_drawn_plant_and_fcm_ctc_is_ctc_there():
    """Two plants, a short run: every law on each; FCM-CTC's designed rule base fires on no
    sample (docs/fuzzy.md), so it runs as CTC; the shaped law's tip settles sooner."""
    result = lc.link_claims(2, duration=1.6)
    runs = result.runs
    assert len(runs) == 2 * len(lc.LAWS) and set(runs["status"]) == {"ok"}
    by = {name: runs[runs["controller"] == name].reset_index(drop=True) for name in lc.LAWS}
    assert (by["FCM-CTC"]["fuzzy_active_share"] == 0).all()
    assert by["CTC"]["fuzzy_active_share"].isna().all()
    for m in lc.METRICS:
        assert np.allclose(by["FCM-CTC"][m], by["CTC"][m], rtol=1e-9, equal_nan=True), m
    assert (by[lc.SHAPED]["residual_vibration_m"] < by["CTC"]["residual_vibration_m"]).all()
    assert (by[lc.SHAPED]["tip_error_m"] > by["CTC"]["tip_error_m"]).all()  # its lag


@pytest.mark.slow
def test_a_rerun_of_the_first_plants_equals_the_shipped_runs(shipped_runs):
    """The shipped runs are the study's: its first three plants again, to 1e-9."""
    rerun = lc.link_claims(3).runs
    first = shipped_runs[shipped_runs["sample"] < 3].reset_index(drop=True)
    pd.testing.assert_frame_equal(rerun[first.columns], first, check_dtype=False, rtol=1e-9)
