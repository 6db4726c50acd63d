"""The linear frontier (twolink.studies.designs.frontier): its rule, a small run of it on real
plants, and that the shipped frontier is current and wired into the claims studies as the
fair opponent, CTC-best."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from twolink.studies.designs import frontier
from twolink.studies.reproduction.manifest import DEFAULT_MANIFEST


def _table(rows):
    cols = ["regime", "controller", "family", "index", "effort_ratio", "within", "wn", "zeta"]
    t = pd.DataFrame(rows, columns=cols)
    t["limit1"], t["limit2"] = 60.0, 15.0
    return t


def test_the_rule_picks_the_lowest_index_within_the_budget_not_a_better_loop_beyond_it():
    t = _table(
        [
            ("raw", "FCM-CTC", "FCM-CTC", 2.3, 1.0, True, 3, np.nan),
            ("raw", "a", "CTC", 1.0, 1.3, False, 5, 1),  # best index, over the budget
            ("raw", "b", "CTC", 1.8, 0.99, True, 4, 1),
            ("raw", "c", "CTC clipped", 1.7, 1.0, True, 6, 1),  # the opponent
            ("raw", "d", "CTC", 1.7, 1.0, False, 6, 0.5),  # same index, a failed run
            ("quintic", "e", "CTC", 0.1, 0.5, True, 9, 1),  # another regime
        ]
    )
    o = frontier.choose(t, "raw")
    assert (o.loop, o.family, o.index, o.proposed_index) == ("c", "CTC clipped", 1.7, 2.3)
    # ties go to the lower effort
    t.loc[t.controller == "b", "index"] = 1.7
    assert frontier.choose(t, "raw").loop == "b"
    t["within"] = t["controller"].isin(["FCM-CTC"])
    with pytest.raises(ValueError, match="no linear loop"):
        frontier.choose(t, "raw")  # FCM-CTC itself is no linear loop


def test_pareto_keeps_only_loops_no_other_beats_on_both_axes():
    effort = np.array([1.0, 2.0, 0.5, 1.0, np.nan])
    index = np.array([1.0, 0.5, 2.0, 1.5, 0.1])
    assert frontier._pareto(effort, index).tolist() == [True, True, True, False, False]


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    path = tmp_path_factory.mktemp("frontier") / "frontier.toml"
    path.write_text(
        f'manifest = "{DEFAULT_MANIFEST}"\nplants = 2\nseed = 1\n'
        "[regimes.quintic]\nwn = [15.0]\nzeta = [1.0]\nclipped_wn = []\nclipped_zeta = []\n"
        "[regimes.raw]\nwn = [3.0]\nzeta = [1.0]\nclipped_wn = [6.0]\nclipped_zeta = [1.0]\n"
    )
    spec = frontier.load_spec(path)
    return spec, frontier.run_frontier(spec)


def test_a_small_frontier_measures_effort_against_fcm_ctcs(small):
    spec, table = small
    raw = table[table.regime == "raw"].set_index("controller")
    fcm = raw.loc["FCM-CTC"]
    assert fcm.effort_ratio == pytest.approx(1.0) and fcm.within
    # CTC at the regime's own gains is FCM-CTC without its fuzzy term: less torque
    ctc = raw.loc["CTC_wn3_z1"]
    assert ctc.torque_peak_Nm1 < fcm.torque_peak_Nm1 and ctc.within
    # the clipped loop is limited at FCM-CTC's median peak torques, so never above them
    clipped = raw.loc["CTC-clipped_wn6_z1"]
    assert clipped.limit1 == pytest.approx(min(fcm.torque_peak_Nm1, 60.0))
    assert clipped.torque_peak_Nm1 <= clipped.limit1 + 1e-9
    assert clipped.torque_peak_Nm2 <= clipped.limit2 + 1e-9
    # the effort ratio is the largest of the four ratios to FCM-CTC's
    ratios = [clipped[f"{k}{j}"] / fcm[f"{k}{j}"] for k in frontier.EFFORT for j in (1, 2)]
    assert clipped.effort_ratio == pytest.approx(max(ratios))
    # the training plants are not the claims' (seed 0): the spec refuses that seed
    assert spec.seed != 0


def test_the_frontier_refuses_the_claims_plants(tmp_path):
    path = tmp_path / "frontier.toml"
    path.write_text(
        f'manifest = "{DEFAULT_MANIFEST}"\nseed = 0\n[regimes.quintic]\nwn = [1.0]\nzeta = [1.0]\n'
        "[regimes.raw]\nwn = [1.0]\nzeta = [1.0]\n"
    )
    with pytest.raises(Exception, match="held out"):
        frontier.load_spec(path)


def test_shipped_frontier_is_current_and_its_opponents_follow_the_rule():
    spec = frontier.load_spec()
    saved = frontier.load_frontier(spec)
    assert saved is not None, "runs/paper/frontier.csv is stale: run `twolink frontier --install`"
    table, chosen = saved
    for regime, _ in spec.grids:
        assert frontier.choose(table, regime) == chosen[regime]
        o = chosen[regime]
        assert o.effort_ratio <= 1.0 + 0.02 and o.index < o.proposed_index


def test_the_claims_studies_judge_fcm_ctc_against_the_shipped_opponent():
    """The claims' CTC-best is the shipped per-joint search's loop (issue 48: the grid's one
    ωn and ζ for both joints is no longer the strongest linear opponent), and the sweep runs
    it with its own gains per joint and its torque limit."""
    from twolink.simulation.config import scenario_from_dict
    from twolink.studies.designs.opponent_search import shipped_opponents
    from twolink.studies.judgments.claims_studies import fair_opponent, regime_plan
    from twolink.studies.reproduction.manifest import load_manifest

    manifest = load_manifest()
    searched = shipped_opponents(manifest.path.parent)
    raw = next(v for v in manifest.variants if v.raw_steps)
    for variant, regime in ((None, frontier.QUINTIC), (raw, raw.name)):
        o = fair_opponent(manifest, variant)
        assert o == searched[regime]
        plan = regime_plan(manifest, variant, {"controllers": {frontier.OPPONENT: o.controller()}})
        s = scenario_from_dict(plan.controller_data(frontier.OPPONENT), plan.file)
        assert s.controller.kp == pytest.approx([w**2 for w in o.wn])
        kd = [2 * z * w for z, w in zip(o.zeta, o.wn, strict=True)]
        assert s.controller.kd == pytest.approx(kd)
        assert s.controller.torque_limit == pytest.approx(o.torque_limit)
