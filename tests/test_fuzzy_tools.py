"""Rule coverage and the lookup-table mode (controllers/fuzzy/coverage.py, table.py)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from click.testing import CliRunner

from controllers.fuzzy import RULEBASE_DIR, default_fuzzy_pd, load_rule_base, paper_fuzzy_pd
from controllers.fuzzy.coverage import coverage
from controllers.fuzzy.table import FuzzyTable, table_bound


def test_paper_coverage_equals_skfuzzys_no_rule_fired_fraction():
    from skfuzzy import control as ctrl

    engine = paper_fuzzy_pd()
    cov = coverage(engine)
    assert cov.exact and cov.uncovered_fraction == pytest.approx(25 / 36, abs=1e-12)
    # Cell midpoints of an 18 x 18 grid: every peak line (k/3) is a cell boundary, so each
    # midpoint lies inside one label cell; skfuzzy leaves "u" unset where no rule fires.
    x = -1.0 + (np.arange(18) + 0.5) * (2.0 / 18)
    sim = ctrl.ControlSystemSimulation(engine.to_skfuzzy(), cache=False)
    none = 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for e in x:
            for de in x:
                sim.input["e"], sim.input["de"] = float(e), float(de)
                try:
                    sim.compute()
                    none += "u" not in sim.output
                except ValueError:
                    none += 1
    sk_fraction = none / x.size**2
    assert abs(cov.uncovered_fraction - sk_fraction) <= 0.01
    ours = engine.firing(*np.meshgrid(x, x)).sum(axis=-1) == 0
    assert ours.sum() == none


def test_coverage_of_the_three_rule_bases_and_regions():
    full = coverage(default_fuzzy_pd())
    assert full.complete and full.uncovered_fraction == 0.0
    designed = default_fuzzy_pd().with_rules(load_rule_base(RULEBASE_DIR / "designed.toml"))
    cov = coverage(designed)
    assert cov.uncovered_fraction == pytest.approx(22 / 36, abs=1e-12)
    assert sum(r.area for r in cov.regions) == pytest.approx(4 * cov.uncovered_fraction)
    # Every region's interior fires nothing; the grid share converges to the area share.
    for r in cov.regions:
        e = np.linspace(*r.e_range, 9)[1:-1]
        de = np.linspace(*r.de_range, 9)[1:-1]
        assert designed.firing(*np.meshgrid(e, de)).sum() == 0
    assert abs(coverage(designed, grid=401).grid_fraction - cov.uncovered_fraction) < 0.01
    # A threshold counts weakly fired points too (grid measure).
    weak = coverage(paper_fuzzy_pd(), threshold=0.5, grid=61)
    assert not weak.exact and weak.uncovered_fraction > coverage(paper_fuzzy_pd()).grid_fraction


def test_coverage_cli_exit_codes():
    from twolink.cli import main

    runner = CliRunner()
    assert runner.invoke(main, ["coverage", "paper", "--grid", "41"]).exit_code == 1
    assert runner.invoke(main, ["coverage", "default", "--grid", "41"]).exit_code == 0
    assert runner.invoke(main, ["coverage", "no/such.toml"]).exit_code == 2
    assert runner.invoke(main, ["coverage", "paper", "--grid", "1"]).exit_code == 2


def test_table_within_its_bound_and_matches_the_engine_at_nodes():
    engine = default_fuzzy_pd()
    table = FuzzyTable(engine, 61)
    b = table_bound(table, refine=4)
    assert b.jump_cells == 0
    g = np.linspace(-1.0, 1.0, 601)  # dense: 10 points per table cell
    e, de = np.meshgrid(g, g)
    err = np.abs(table(e, de) - engine.evaluate_batch(e, de))
    assert err.max() <= b.bound
    nodes = np.meshgrid(table.e_nodes, table.de_nodes, indexing="ij")
    np.testing.assert_allclose(table(*nodes), table.values, atol=1e-15, rtol=0)
    pairs = np.random.default_rng(1).uniform(-1.3, 1.3, (50, 2))
    np.testing.assert_allclose(
        table.evaluate_floats(pairs[:, 0], pairs[:, 1]),
        table(pairs[:, 0], pairs[:, 1]),
        atol=1e-15,
        rtol=0,
    )
    with pytest.raises(ValueError, match="NaN"):
        table(np.nan, 0.0)
    with pytest.raises(ValueError):
        FuzzyTable(engine, 1)
    assert table.rules == engine.rules


def test_closed_loop_with_table_agrees_with_exact_engine():
    from twolink.config import load_scenario
    from twolink.experiment import build_controller, measure, run_scenario

    f = "runs/paper/design/heldout_theta1_up.toml"
    for kind, tol in (("fuzzy_ctc", 1e-5), ("fcm_ctc", 1e-3)):
        ctrl = {"kind": kind, "rule_base": "designed"}
        exact = load_scenario(f, {"controller": ctrl})
        tab = load_scenario(f, {"controller": {**ctrl, "fuzzy": {"engine": "table"}}})
        assert isinstance(build_controller(tab).engine, FuzzyTable)
        a, b = run_scenario(exact), run_scenario(tab)
        assert np.abs(a.q - b.q).max() <= tol  # rad
        ma, mb = measure(exact, a), measure(tab, b)
        sa, sb = ma.step[0], mb.step[0]
        assert abs(sa.overshoot - sb.overshoot) <= 0.01
        assert abs(sa.settling_time - sb.settling_time) <= 0.01
