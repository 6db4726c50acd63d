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


def test_a_ctc_i_gain_vector_runs_as_the_integral_law_it_names():
    """The regime's own CTC-I gains as a gain vector (ωn, ζ, ρ per joint) run the same arms
    as the sweep's CTC-I (Ki = ρ Kp Kd: the base's 0.25 ωn³ is ρ = 0.125 at ζ = 1)."""
    spec = search.load_spec(overrides={"plants": 2, "regimes": ["raw"]})
    stp = search.setup(spec, "raw")
    config = ops.configured(stp, {"kind": "ctc_integral"}).controller
    x = ops.SPANS["CTC-I"][1](config)
    assert x[[2, 5]] == pytest.approx([0.125, 0.125])
    entry = LAWS["CTC-I"].entry(x, config.torque_limit)
    assert entry["ki"] == pytest.approx(list(config.ki))
    mine = ops.evaluate_loops(stp, [entry])
    theirs = ops.evaluate_loops(stp, [{"kind": "ctc_integral"}])
    np.testing.assert_allclose(mine, theirs, rtol=1e-12)
    # and not CTC's: the integral acts
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
