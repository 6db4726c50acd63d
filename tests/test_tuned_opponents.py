"""The laws tuned by CTC-best's rule (twolink.studies.designs.opponent_search.tune): on a
tiny problem the search's choice is the brute-force best of the loops it tried under the
effort rule; a family's gain vector runs as the law it names; the shipped tuned gains give
their shipped numbers and keep the rule, and repeat from their recorded seed (slow)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from twolink.studies.designs import effort, search
from twolink.studies.designs import opponent_search as ops
from twolink.studies.designs.searched_opponent import LAWS, TUNED, shipped_tuned


@pytest.fixture
def tiny(monkeypatch):
    """Raw steps, 2 training plants, 1 generation of 6 loops after the start, 3 judged
    plants (the claims' first 3, not its 200)."""
    spec = search.load_spec(overrides={"plants": 2, "regimes": ["raw"], "popsize": 1,
                                       "maxiter": 1})  # fmt: skip
    full = ops.judged_setup

    def few(spec, regime):
        stp = full(spec, regime)
        return search.Setup(stp.scenarios[:3], stp.fcm, stp.model_g, stp.plan)

    monkeypatch.setattr(ops, "judged_setup", few)
    return spec


def test_the_tuned_ctc_i_is_the_admissible_best_of_the_loops_tried(tiny):
    done = ops._search_and_judge(tiny, "raw", ("CTC-I",))
    loops = done["found"][0]["loops"]
    assert len(loops) == done["found"][0]["evaluations"] == 6 * 2  # popsize x 6 a generation
    # brute force: every loop tried, run where judged, the rule on both sets
    judged = ops.evaluate_loops(
        ops.judged_setup(tiny, "raw"),
        [LAWS["CTC-I"].entry(np.array(p["x"]), done["found"][0]["torque_limit"]) for p in loops],
    )
    train = np.array([p["values"][:4] for p in loops])
    ok = effort.admissible(train, judged[:, :4], done["found"][0]["budget"], done["judged_fcm"][:4])
    ok &= np.array([p["cost"] < search.OVER for p in loops])
    assert ok.any()
    best = min(np.flatnonzero(ok), key=lambda k: loops[k]["cost"])
    assert done["chosen"]["x"] == loops[best]["x"]
    np.testing.assert_allclose(done["chosen"]["judged"], judged[best], rtol=1e-12)
    found = ops.tune(tiny, "raw", "CTC-I")
    assert found["x"] == loops[best]["x"] and found["within"] is True
    assert found["params"] == ["ωn1", "ζ1", "ρ1", "ωn2", "ζ2", "ρ2"]


@pytest.mark.parametrize("family", [f for f in LAWS if f != "CTC clipped"])
def test_each_familys_start_is_the_law_at_the_regimes_own_gains(family):
    """A family's start (the regime's gains as its gain vector) runs the same arms as the
    sweep's law of that kind with its defaults: the vector means what its names say."""
    from twolink.simulation.experiment import build_controller

    spec = search.load_spec(overrides={"plants": 2, "regimes": ["quintic"]})
    stp = search.setup(spec, "quintic")
    kind = LAWS[family].kind
    default = build_controller(ops.configured(stp, {"kind": kind}))
    x = ops.SPANS[family][1](default)
    assert len(x) == len(LAWS[family].params) == len(ops.SPANS[family][0](
        ops.frontier_grid(spec, "quintic")))  # fmt: skip
    mine = ops.evaluate_loops(stp, [LAWS[family].entry(x, default.torque_limit)])
    theirs = ops.evaluate_loops(stp, [{"kind": kind}])
    np.testing.assert_allclose(mine, theirs, rtol=1e-9)
    if family == "CTC-I":  # Ki = ρ Kp Kd: the base's 0.25 ωn³ is ρ = 0.125 at ζ = 1
        assert x[[2, 5]] == pytest.approx([0.125, 0.125])
        assert not np.allclose(mine, ops.evaluate_loops(stp, [{"kind": "ctc"}]), rtol=1e-6)


def test_the_shipped_tuned_laws_give_their_numbers_and_keep_the_rule():
    spec = search.load_spec()
    meta = json.loads(ops.tuned_path(spec).read_text())
    assert meta["settings"] == json.loads(json.dumps(spec.settings()))
    shipped = shipped_tuned(ops.tuned_path(spec).parent)
    assert set(shipped) <= set(TUNED)
    for name, by_regime in shipped.items():
        for regime, o in by_regime.items():
            values = ops.evaluate_loops(search.setup(spec, regime), [o.controller()])
            np.testing.assert_allclose(values[0], o.train, rtol=1e-9)
            ok = effort.admissible([o.train[:4]], [o.judged[:4]], o.train_fcm[:4], o.judged_fcm[:4])
            assert ok[0] == o.within, (name, regime)


@pytest.mark.slow
@pytest.mark.parametrize("name", list(TUNED))
def test_the_shipped_tuned_gains_repeat_from_their_seed(name):
    spec = search.load_spec()
    shipped = json.loads(ops.tuned_path(spec).read_text())["opponents"][name]
    for regime, o in shipped.items():
        again = ops.tune(spec, regime, o["family"])
        assert again["x"] == o["x"], regime
        assert again["within"] == o["within"]


def _results(rows):
    """A sweep's results table: per (controller, IAE₁, Σ|Δτ|₁) three plants alike."""
    import pandas as pd

    from twolink.simulation.vocabulary import METRICS

    out = []
    for name, iae, var in rows:
        for sample in range(3):
            r = {"controller": name, "status": "ok", "sample": sample}
            for m in METRICS:
                for j in (1, 2):
                    r[f"joint{j}_{m.key}"] = 1.0
            r.update({"joint1_iae_rad_s": iae, "joint2_iae_rad_s": 0.01})
            r.update({"joint1_torque_variation_Nm": var, "joint2_torque_variation_Nm": 70.0})
            r.update({"joint1_torque_peak_Nm": 27.0, "joint2_torque_peak_Nm": 8.0})
            out.append(r)
    return pd.DataFrame(out)


def test_the_ranking_orders_by_index_and_says_who_is_over_the_effort():
    """Index = median IAE₁ + IAE₂ over the plants; ``within`` by the effort rule against
    FCM-CTC's effort on the same plants (234.5 + 1 N·m: 235.4 within, 236 not); the
    training columns are the shipped search's, for the searched and tuned only."""
    from twolink.studies.designs.searched_opponent import TunedOpponent
    from twolink.studies.judgments.claims_studies import ranking

    results = _results(
        [("FCM-CTC", 0.07, 234.5), ("CTC-best", 0.009, 235.4), ("CTC-I-best", 0.0, 236.0),
         ("CTC", 0.08, 200.0)]
    )  # fmt: skip
    law = TunedOpponent("CTC-I-best", "quintic", "CTC-I", (1,) * 6, (60.0, 15.0),
                        (1, 2, 3, 4, 0.5), (1, 2, 3, 4, 0.9), (0,) * 5, (0,) * 5, True)  # fmt: skip
    table = ranking(results, "FCM-CTC", None, object(), [law]).set_index("controller")
    assert list(table.index) == ["CTC-I-best", "CTC-best", "FCM-CTC", "CTC"]
    assert table["rank"].tolist() == [1, 2, 3, 4]
    assert table["index"].tolist() == pytest.approx([0.01, 0.019, 0.08, 0.09])
    assert table["within"].tolist() == [False, True, True, True]
    assert table.loc["CTC-I-best", "train_index"] == 0.5
    assert table.loc["CTC-I-best", "train_torque_variation_Nm2"] == 4
    assert np.isnan(table.loc["CTC", "train_index"]) and table.loc["CTC", "admitted"] is None
    assert set(table["regime"]) == {"quintic"} and set(table["plants"]) == {3}


@pytest.mark.parametrize("kind", ["adaptive_ctc", "ctc_dob", "ctc_integral"])
def test_a_law_with_a_state_runs_each_plant_as_if_alone(kind):
    """Two plants evaluated together give the medians of each plant run alone: no two arms
    share an adaptive estimate, an observer or an integral (the batch models' gravity the
    same for both: the sweep's)."""
    spec = search.load_spec(overrides={"plants": 2, "regimes": ["quintic"]})
    stp = search.setup(spec, "quintic")
    g = stp.model_g
    both = ops.evaluate_loops(stp, [{"kind": kind}])[0]
    alone = [
        ops.evaluate_loops(search.Setup((s,), stp.fcm, g, stp.plan), [{"kind": kind}])
        for s in stp.scenarios
    ]
    np.testing.assert_allclose(both, np.median(np.concatenate(alone), axis=0), rtol=1e-9)
