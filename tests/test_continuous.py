"""The relay diagnosed and cured: where a rule base's surface jumps
(controllers/fuzzy/coverage.py, ``surface_jumps``), and the continuous inference of the
same rules (controllers/fuzzy/continuous.py), against an independent product-sum,
centre-of-sets computation with scikit-fuzzy's membership functions."""

from __future__ import annotations

import numpy as np
import pytest
import skfuzzy

from twolink.controllers.fuzzy import default_fuzzy_pd
from twolink.controllers.fuzzy.continuous import ContinuousEngine, lipschitz_bound
from twolink.controllers.fuzzy.coverage import surface_jumps
from twolink.controllers.fuzzy.engine import MamdaniEngine
from twolink.controllers.fuzzy.fis.engine_files import read_rule_base
from twolink.simulation.config import ConfigError, load_scenario, resolve_rule_base
from twolink.simulation.experiment import build_controller

RULE_BASES = ("designed", "paper", "default")


def engine_of(name: str):
    return default_fuzzy_pd().with_rules(read_rule_base(resolve_rule_base(name)))


def reference(engine, e: float, de: float) -> float:
    """Product-sum, centre of sets, every rule-less label cell a rule with output 0: with
    skfuzzy's interp_membership and defuzz, over all 49 cells, divided by the total
    strength (not assumed to be 1)."""
    e = min(max(e, engine.e.grid[0]), engine.e.grid[-1])
    de = min(max(de, engine.de.grid[0]), engine.de.grid[-1])
    mu = [skfuzzy.interp_membership(engine.e.grid, row, e) for row in engine.e.table]
    nu = [skfuzzy.interp_membership(engine.de.grid, row, de) for row in engine.de.table]
    centre = {
        label: skfuzzy.defuzz(engine.u.grid, row, "centroid")
        for label, row in zip(engine.u.labels, engine.u.table, strict=True)
    }
    outputs = {(r.e, r.de): centre[r.u] for r in engine.rules}
    num = den = 0.0
    for i, le in enumerate(engine.e.labels):
        for j, ld in enumerate(engine.de.labels):
            w = mu[i] * nu[j]
            num += w * outputs.get((le, ld), 0.0)
            den += w
    return num / den


@pytest.mark.parametrize("name", RULE_BASES)
def test_the_continuous_inference_is_product_sum_centre_of_sets(name):
    engine = engine_of(name)
    cont = ContinuousEngine(engine)
    rng = np.random.default_rng(7)
    e, de = rng.uniform(-1.3, 1.3, (2, 300))  # some outside the box: clipped
    want = np.array([reference(engine, a, b) for a, b in zip(e, de, strict=True)])
    np.testing.assert_allclose(cont(e, de), want, rtol=0, atol=1e-12)
    np.testing.assert_allclose(cont.evaluate_floats(e[:8], de[:8]), want[:8], rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", RULE_BASES)
def test_at_a_rule_fired_alone_both_inferences_give_its_consequent(name):
    # at the peaks of a rule's two labels only that rule fires, fully: Mamdani's centroid
    # is its consequent's centroid, and so is the continuous output
    engine = engine_of(name)
    cont = ContinuousEngine(engine)
    peaks_e = dict(zip(engine.e.labels, cont.e_peaks, strict=True))
    peaks_de = dict(zip(engine.de.labels, cont.de_peaks, strict=True))
    e = np.array([peaks_e[r.e] for r in engine.rules])
    de = np.array([peaks_de[r.de] for r in engine.rules])
    np.testing.assert_allclose(cont(e, de), engine(e, de), rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", RULE_BASES)
def test_the_lipschitz_bound_holds_and_is_attained(name):
    cont = ContinuousEngine(engine_of(name))
    le, lde = lipschitz_bound(cont)
    rng = np.random.default_rng(1)
    a, b = rng.uniform(-1.1, 1.1, (2, 2, 20000))
    b = a + rng.normal(0, 0.05, a.shape)  # near pairs: where a jump would show
    change = np.abs(cont(*a) - cont(*b))
    allowed = le * np.abs(a[0] - b[0]) + lde * np.abs(a[1] - b[1])
    assert np.all(change <= allowed + 1e-12)
    # attained: along the steepest edge of the table the slope is the bound
    i, j = np.unravel_index(np.argmax(np.abs(np.diff(cont.values, axis=0))), (6, 7))
    x0, x1, y = cont.e_peaks[i], cont.e_peaks[i + 1], cont.de_peaks[j]
    slope = abs(cont(x1, y) - cont(x0, y)) / (x1 - x0)
    assert slope == pytest.approx(le, rel=1e-12)


def test_the_paper_inference_jumps_and_the_continuous_one_does_not():
    # The designed rules: across de = 0 the output jumps by a whole consequent (1/3 of
    # the normalised range, x ku = 15.1 rad/s^2 at the shipped scaling: 5.0 rad/s^2)
    designed = engine_of("designed")
    jumps = [j for j in surface_jumps(designed) if j.is_jump]
    assert jumps and max(j.size_finer for j in jumps) == pytest.approx(1 / 3, abs=1e-3)
    assert any(j.de_labels in (("NS", "Z"), ("Z", "PS")) for j in jumps)
    eps = 1e-9
    pm = 2 / 3  # the PM peak: (PM, NS -> PS) alone fires for de < 0, however weakly
    assert designed(pm, 0.0) == 0.0 and designed(pm, -eps) == pytest.approx(1 / 3)
    for name in RULE_BASES:
        cont = ContinuousEngine(engine_of(name))
        assert not [j for j in surface_jumps(cont) if j.is_jump], name
        assert abs(cont(pm, -eps) - cont(pm, 0.0)) < 1e-6  # continuous where it jumped
    # the paper's Table 1 jumps by up to 0.835 (its NB and PB centroids)
    paper = surface_jumps(engine_of("paper"))
    assert paper[0].is_jump and paper[0].size_finer == pytest.approx(0.835, abs=2e-3)


def test_a_steep_continuous_slope_is_not_called_a_jump():
    # a slope halves its per-cell change as the grid is refined; only jumps keep theirs
    cont = ContinuousEngine(engine_of("default"))
    top = surface_jumps(cont, grid=51)[0]
    assert not top.is_jump and top.size_finer == pytest.approx(top.size / 2, rel=0.05)


def test_a_scenario_selects_the_continuous_inference():
    over = {
        "controller": {
            "kind": "fcm_ctc",
            "rule_base": "designed",
            "fuzzy": {"inference": "continuous"},
        }
    }
    scenario = load_scenario("runs/paper/base.toml", over)
    controller = build_controller(scenario)
    assert isinstance(controller.engine, ContinuousEngine)
    mamdani = dict(over["controller"], fuzzy={})
    paper = build_controller(load_scenario("runs/paper/base.toml", {"controller": mamdani}))
    assert isinstance(paper.engine, MamdaniEngine)
    bad = dict(over["controller"], fuzzy={"inference": "sugeno"})
    with pytest.raises(ConfigError, match="inference"):
        load_scenario("runs/paper/base.toml", {"controller": bad})


def test_coverage_lists_the_jumps():
    from click.testing import CliRunner

    from twolink.interface.cli import main

    designed = CliRunner().invoke(main, ["coverage", "designed"])
    assert "its output jumps" in designed.output and "in 8 of 36 label cells" in designed.output
    assert "jump 0.333 (grid 0.333): e in [PS, PM], de in [NS, Z]" in designed.output
    full = CliRunner().invoke(main, ["coverage", "default"])
    assert full.exit_code == 0 and "in 0 of 36 label cells" in full.output


@pytest.mark.slow
def test_the_relay_oscillates_where_the_continuous_inference_does_not(tmp_path):
    # The robustness sweep's 200 plants, run 20 s: the paper's FCM-CTC ends in a sustained
    # oscillation (> 1 mrad) on 27 plants where CTC has none, up to 6.5 mrad; the
    # continuous inference of the same rules on none (docs/fuzzy.md, "The relay"). With the
    # true state, so that no encoder count blurs "none".
    from twolink import sweep

    overrides = {
        "overrides": {"duration": 20.0, "sensor": {"replace": True}},
        "controllers": {
            "replace": True,
            "CTC": {"kind": "ctc"},
            "FCM-CTC": {"kind": "fcm_ctc", "rule_base": "designed"},
            "FCM-CTC-continuous": {
                "kind": "fcm_ctc",
                "rule_base": "designed",
                "fuzzy": {"inference": "continuous"},
            },
        },
    }
    plan = sweep.load_sweep("runs/sweeps/robustness.toml", overrides)
    results = sweep.run_sweep(plan, tmp_path / "s", plots=False, progress=False).results
    osc = results.pivot(index="sample", columns="controller", values="joint1_oscillation_rad")
    osc = np.maximum(
        osc, results.pivot(index="sample", columns="controller", values="joint2_oscillation_rad")
    )
    assert len(osc) == 200 and (osc["CTC"] < 1e-6).all()
    relay = osc["FCM-CTC"] > 1e-3
    assert relay.sum() == 27 and osc["FCM-CTC"].max() == pytest.approx(6.5e-3, abs=1e-4)
    assert (osc["FCM-CTC-continuous"] < 1e-6).all()
