"""Rule coverage and the lookup-table mode (controllers/fuzzy/coverage.py, table.py)."""

from __future__ import annotations

import functools
import warnings

import numpy as np
import pytest
from click.testing import CliRunner

from twolink.controllers.fuzzy import RULEBASE_DIR, default_fuzzy_pd, load_rule_base, paper_fuzzy_pd
from twolink.controllers.fuzzy.coverage import coverage
from twolink.controllers.fuzzy.table import FuzzyTable, table_bound


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
    from twolink.interface.cli import main

    runner = CliRunner()
    assert runner.invoke(main, ["coverage", "paper", "--grid", "41"]).exit_code == 1
    assert runner.invoke(main, ["coverage", "default", "--grid", "41"]).exit_code == 0
    assert runner.invoke(main, ["coverage", "no/such.toml"]).exit_code == 2
    assert runner.invoke(main, ["coverage", "paper", "--grid", "1"]).exit_code == 2


def _per_cell_max(x: np.ndarray, r: int) -> np.ndarray:
    """Max of ``x`` (on a grid with r points per table cell, nodes included) over each
    closed table cell."""
    n = (x.shape[0] - 1) // r
    out = np.full((n, n), -np.inf)
    for a in range(r + 1):
        for b in range(r + 1):
            out = np.maximum(out, x[a : a + n * r : r, b : b + n * r : r])
    return out


def _dense(nodes: np.ndarray, r: int) -> np.ndarray:
    """r points per table cell (midpoints included for even r), the nodes bit for bit."""
    inner = nodes[:-1, None] + (np.arange(r) / r)[None, :] * np.diff(nodes)[:, None]
    return np.append(inner.ravel(), nodes[-1])


RULE_BASES = {
    "7x7": default_fuzzy_pd,
    "designed": lambda: default_fuzzy_pd().with_rules(
        load_rule_base(RULEBASE_DIR / "designed.toml")
    ),
    "Table 1": paper_fuzzy_pd,
}


@functools.cache
def _table_case(name: str, r: int = 6):
    """A rule base's 61-point table, its bound, and the exact surface on the dense grid."""
    engine = RULE_BASES[name]()
    table = FuzzyTable(engine, 61)
    g = _dense(table.e_nodes, r)
    e, de = np.meshgrid(g, g, indexing="ij")
    return engine, table, table_bound(table, refine=4), g, e, de, engine.evaluate_batch(e, de), r


@pytest.mark.parametrize("name", RULE_BASES)
def test_table_error_within_its_proven_bound_on_a_dense_grid(name):
    """(a) The measured error on a grid 6x finer than the table (cell midpoints included)
    stays within the proven bound of every cell, jump cells (no-fire boundary) included;
    the bound is not vacuous: within 15x of the worst measured error off the jumps."""
    _, table, b, _, e, de, u, r = _table_case(name)
    err = _per_cell_max(np.abs(table(e, de) - u), r)
    assert (err <= b.cell_bound).all()
    off = err[~b.jump].max()
    assert off <= b.bound <= 15 * off
    if name == "7x7":  # every point fires a rule: no jumps
        assert b.jump_cells == 0 and b.jump_bound == 0.0
    else:  # the gaps: the surface drops to the no-fire output, and the bound says so
        assert b.jump_cells > 0 and err[b.jump].max() > 0.3 and b.jump_bound >= 0.3


@pytest.mark.parametrize("name", RULE_BASES)
def test_table_cell_lipschitz_constants_hold_within_cells(name):
    """(b) No finite difference inside a cell exceeds that cell's proven Lipschitz
    constant (1e-12 for rounding); and the constants are attained to within 3x."""
    _, table, b, g, _, _, u, r = _table_case(name)
    step = np.diff(g)
    q_e = (np.abs(np.diff(u, axis=0)) - 1e-12) / step[:, None]
    q_d = (np.abs(np.diff(u, axis=1)) - 1e-12) / step[None, :]
    n = table.points - 1
    worst_e, worst_d = np.full((n, n), -np.inf), np.full((n, n), -np.inf)
    for a in range(r):  # differences along e (d) between points of one closed cell
        for c in range(r + 1):
            worst_e = np.maximum(worst_e, q_e[a : a + n * r : r, c : c + n * r : r])
            worst_d = np.maximum(worst_d, q_d[c : c + n * r : r, a : a + n * r : r])
    ok = ~b.jump
    assert (worst_e[ok] <= b.cell_lipschitz[0][ok]).all()
    assert (worst_d[ok] <= b.cell_lipschitz[1][ok]).all()
    if name == "7x7":
        assert max(b.lipschitz) <= 3 * max(worst_e.max(), worst_d.max())


def test_table_bound_201_points_and_product_and():
    """The default table (201 points): the bound shrinks with the step, still holds on
    the cell midpoints; the product AND has its own bound."""
    from dataclasses import replace

    for engine in (default_fuzzy_pd(), replace(default_fuzzy_pd(), and_method="product")):
        table = FuzzyTable(engine, 201)
        b = table_bound(table, refine=1)
        mid = 0.5 * (table.e_nodes[:-1] + table.e_nodes[1:])
        e, de = np.meshgrid(mid, mid, indexing="ij")
        err = np.abs(table(e, de) - engine.evaluate_batch(e, de))
        assert (err <= b.cell_bound).all()
        assert b.bound < table_bound(FuzzyTable(engine, 61), refine=1).bound / 2
    with pytest.raises(ValueError, match="refine"):
        table_bound(table, refine=0)
    with pytest.raises(ValueError, match="triangular"):
        table_bound(FuzzyTable(default_fuzzy_pd(defuzz="bisector"), 11))


def test_table_matches_the_engine_at_nodes():
    engine = default_fuzzy_pd()
    table = FuzzyTable(engine, 61)
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
    from twolink.simulation.config import load_scenario
    from twolink.simulation.experiment import build_controller, measure, run_scenario

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
        assert abs(sa.overshoot - sb.overshoot) <= 1.0  # percent of the step
        assert abs(sa.settling_time - sb.settling_time) <= 0.01
