"""Tests of the Mamdani engine against scikit-fuzzy 0.5 and closed forms."""

from __future__ import annotations

import dataclasses
import functools
import tomllib
import warnings
from decimal import Decimal, localcontext

import numpy as np
import pytest
import skfuzzy
import skfuzzy.control.controlsystem as sk_controlsystem
from skfuzzy import control as ctrl
from skfuzzy.control.exceptions import EmptyMembershipError, NoTermMembershipsError

from twolink.controllers import fuzzy
from twolink.controllers.fuzzy import (
    LABELS_7,
    RULEBASE_DIR,
    FuzzyVariable,
    MamdaniEngine,
    MembershipFunction,
    Rule,
    RuleBase,
    default_fuzzy_pd,
    load_rule_base,
    paper_fuzzy_pd,
    pd_rule_table,
    save_rule_base,
    triangular_partition,
)
from twolink.controllers.fuzzy import engine as fuzzy_engine

pytestmark = pytest.mark.filterwarnings(
    # skfuzzy 0.5 calls np.maximum with a positional output argument.
    "ignore:Passing more than 2 positional arguments:DeprecationWarning"
)

TOL = 1e-9  # agreement with skfuzzy, absolute, on the normalised universe [-1, 1]
PATHS_TOL = 1e-12  # agreement between the engine's own evaluation paths

PAPER_RULES_OURS = (
    Rule("NB", "NS", "NB"),
    Rule("PS", "NB", "NS"),
    Rule("PS", "PS", "PM"),
    Rule("PB", "PB", "PB"),
    Rule("NS", "PB", "NM"),
)


# ----- helpers ------------------------------------------------------------------------


@functools.cache
def skfuzzy_system(engine: MamdaniEngine) -> ctrl.ControlSystem:
    """engine.to_skfuzzy(), built once per engine (skfuzzy takes ~0.5 s for 49 rules)."""
    return engine.to_skfuzzy()


def skfuzzy_scalar(engine: MamdaniEngine, e: np.ndarray, de: np.ndarray) -> np.ndarray:
    """skfuzzy's compute() per input pair (cache=False); NaN where skfuzzy raises."""
    sim = ctrl.ControlSystemSimulation(skfuzzy_system(engine), cache=False, lenient=False)
    out = np.full(len(e), np.nan)
    for n, (a, b) in enumerate(zip(e, de, strict=True)):
        sim.input["e"] = float(a)
        sim.input["de"] = float(b)
        try:
            sim.compute()
        except (EmptyMembershipError, NoTermMembershipsError):
            sim.reset()  # the failed run skipped skfuzzy's own clean-up
            continue
        out[n] = sim.output["u"]
    return out


def skfuzzy_array(engine: MamdaniEngine, e: np.ndarray, de: np.ndarray) -> np.ndarray:
    """skfuzzy's compute() on array inputs (one call; needs every output term used)."""
    sim = ctrl.ControlSystemSimulation(skfuzzy_system(engine), cache=False)
    sim.input["e"] = np.asarray(e, dtype=float)
    sim.input["de"] = np.asarray(de, dtype=float)
    sim.compute()
    return np.asarray(sim.output["u"], dtype=float)


def paper_support_points(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Points inside the antecedent supports of the paper's rules (so a rule fires)."""
    peaks = np.linspace(-1.0, 1.0, 7)
    idx = rng.integers(0, len(PAPER_RULES_OURS), n)
    pe = peaks[[LABELS_7.index(PAPER_RULES_OURS[i].e) for i in idx]]
    pd = peaks[[LABELS_7.index(PAPER_RULES_OURS[i].de) for i in idx]]
    w = 1.0 / 3.0
    e = np.clip(pe + rng.uniform(-w, w, n), -1.0, 1.0)
    de = np.clip(pd + rng.uniform(-w, w, n), -1.0, 1.0)
    return e, de


def exact_bisector(x: np.ndarray, y: np.ndarray) -> float:
    """Bisector of the piecewise-linear function through (x, y), in 60-digit decimals."""
    with localcontext() as ctx:
        ctx.prec = 60
        xs = [Decimal(float(v)) for v in x]
        ys = [Decimal(float(v)) for v in y]
        areas = [(xs[i + 1] - xs[i]) * (ys[i] + ys[i + 1]) / 2 for i in range(len(xs) - 1)]
        half = sum(areas) / 2
        before = Decimal(0)
        for i, area in enumerate(areas):
            if area > 0 and before + area >= half:
                need = half - before
                slope = (ys[i + 1] - ys[i]) / (xs[i + 1] - xs[i])
                t = 2 * need / (ys[i] + (ys[i] * ys[i] + 2 * slope * need).sqrt())
                return float(xs[i] + t)
            before += area
    raise AssertionError("no area")


@pytest.fixture
def record_skfuzzy_defuzz(monkeypatch):
    """Record the (upsampled universe, aggregated output) that skfuzzy defuzzifies."""
    seen: list[tuple[np.ndarray, np.ndarray]] = []
    original = sk_controlsystem.defuzz

    def recorder(x, mfx, mode):
        seen.append((np.array(x, dtype=float), np.array(mfx, dtype=float)))
        return original(x, mfx, mode)

    monkeypatch.setattr(sk_controlsystem, "defuzz", recorder)
    return seen


@pytest.fixture(scope="module")
def pd7() -> MamdaniEngine:
    return default_fuzzy_pd()


@pytest.fixture(scope="module")
def paper() -> MamdaniEngine:
    return paper_fuzzy_pd()


# ----- rule-base data -----------------------------------------------------------------


def test_default_rule_file_is_the_diagonal_pd_table():
    rb = load_rule_base(RULEBASE_DIR / "default_7x7.toml")
    assert rb.mirror_inputs is False
    assert len(rb.rules) == 49
    assert {(r.e, r.de) for r in rb.rules} == {(a, b) for a in LABELS_7 for b in LABELS_7}
    for r in rb.rules:
        i, j = LABELS_7.index(r.e), LABELS_7.index(r.de)
        assert LABELS_7.index(r.u) == min(max(i + j - 3, 0), 6)
    assert rb.rules == pd_rule_table()
    assert default_fuzzy_pd().rules == rb.rules


def test_paper_table1_file_is_verbatim_and_loads_mirrored():
    path = RULEBASE_DIR / "paper_table1.toml"
    with path.open("rb") as fh:
        raw = tomllib.load(fh)
    assert raw["mirror_inputs"] is True
    # The paper's Table 1 as printed (input1 = e, input2 = de -> output).
    assert [(r["e"], r["de"], r["u"]) for r in raw["rule"]] == [
        ("PB", "PS", "NB"),
        ("NS", "PB", "NS"),
        ("NS", "NS", "PM"),
        ("NB", "NB", "PB"),
        ("PS", "NB", "NM"),
    ]
    rb = load_rule_base(path)
    assert rb.mirror_inputs is True
    assert rb.rules == PAPER_RULES_OURS
    assert "source" in rb.metadata
    assert paper_fuzzy_pd().rules == PAPER_RULES_OURS


def test_paper_rules_in_our_convention_read_as_pd_except_rule_5():
    # u ~ e + de: sign of the output label vs sign of the antecedent sum.
    value = {label: i - 3 for i, label in enumerate(LABELS_7)}
    agree = [np.sign(value[r.u]) == np.sign(value[r.e] + value[r.de]) for r in PAPER_RULES_OURS]
    assert agree == [True, True, True, True, False]


def test_rule_base_round_trip(tmp_path):
    rules = pd_rule_table()[::5]
    metadata = {
        "design": {
            "method": "fcm",
            "n_clusters": np.int64(5),
            "m": 2.0,
            "eps": 1e-5,
            "converged": True,
            "note": 'quotes " and \\ and unicode \u03b8 \U0001f600 and\nnewline \x7f \t',
            "centres": np.array([[0.1, -0.2], [0.3, 0.4]]),
            "odd key.with dot": [1, 2, 3],
            "evidence": {"hits": [3, 0, 7], "label": "NB"},
        },
        "about": {"empty_list": [], "nested": [{"a": 1}, {"b": "x"}]},
    }
    out = save_rule_base(tmp_path / "sub" / "designed.toml", rules, metadata=metadata)
    assert out.exists()
    assert [p.name for p in out.parent.iterdir()] == ["designed.toml"]  # no temp file left
    rb = load_rule_base(out)
    assert rb.rules == rules
    assert rb.mirror_inputs is False
    design = rb.metadata["design"]
    assert design["n_clusters"] == 5 and design["m"] == 2.0 and design["eps"] == 1e-5
    assert design["converged"] is True
    assert design["note"] == metadata["design"]["note"]
    assert design["centres"] == ((0.1, -0.2), (0.3, 0.4))
    assert design["odd key.with dot"] == (1, 2, 3)
    assert design["evidence"]["hits"] == (3, 0, 7)
    assert rb.metadata["about"]["nested"][1]["b"] == "x"
    with pytest.raises(TypeError):
        rb.metadata["design"]["m"] = 3.0  # exposed read-only
    # A RuleBase saves with its own metadata and flag, mirrored on disk when asked.
    mirrored = save_rule_base(tmp_path / "m.toml", RuleBase(PAPER_RULES_OURS, mirror_inputs=True))
    with mirrored.open("rb") as fh:
        assert tomllib.load(fh)["rule"][0] == {"e": "PB", "de": "PS", "u": "NB"}
    assert load_rule_base(mirrored).rules == PAPER_RULES_OURS
    again = save_rule_base(tmp_path / "again.toml", rb)
    assert load_rule_base(again) == rb


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ('mirror_input = true\n[[rule]]\ne = "Z"\nde = "Z"\nu = "Z"\n', "mirror_input"),
        ('mirror_inputs = "yes"\n[[rule]]\ne = "Z"\nde = "Z"\nu = "Z"\n', "mirror_inputs"),
        ("[about]\nname = 'x'\n", r"\[\[rule\]\]"),
        ('[[rule]]\ne = "Z"\nde = "Z"\n', "missing"),
        ('[[rule]]\ne = "Z"\nde = "Z"\nu = "Z"\nw = 1\n', "unknown"),
        ('[[rule]]\ne = "Z"\nde = 1\nu = "Z"\n', "'de'"),
        ('mirror_inputs = true\n[[rule]]\ne = "XX"\nde = "Z"\nu = "Z"\n', "XX"),
        ("[[rule]\n", "TOML"),
    ],
)
def test_rule_base_loader_errors_name_file_and_key(tmp_path, text, match):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ValueError, match=match) as info:
        load_rule_base(path)
    assert "bad.toml" in str(info.value)


def test_engine_rejects_unknown_labels_and_empty_rules(pd7):
    with pytest.raises(ValueError, match="QQ"):
        pd7.with_rules([("QQ", "Z", "Z")])
    with pytest.raises(ValueError, match="empty"):
        pd7.with_rules([])
    with pytest.raises(ValueError, match="and_method"):
        dataclasses.replace(pd7, and_method="max")
    with pytest.raises(ValueError, match="defuzz"):
        dataclasses.replace(pd7, defuzz="lom")


# ----- structure ----------------------------------------------------------------------


def test_engine_is_immutable_and_with_rules_returns_a_new_engine(pd7):
    with pytest.raises(dataclasses.FrozenInstanceError):
        pd7.no_fire_output = 1.0
    with pytest.raises(ValueError):
        pd7.u.table[0, 0] = 0.5  # read-only arrays
    other = pd7.with_rules(PAPER_RULES_OURS)
    assert other.rules == PAPER_RULES_OURS and len(pd7.rules) == 49
    assert other == paper_fuzzy_pd()
    assert hash(other) == hash(paper_fuzzy_pd())


def test_to_skfuzzy_structure(pd7, paper):
    system = skfuzzy_system(pd7)
    assert isinstance(system, ctrl.ControlSystem)
    assert sorted(a.label for a in system.antecedents) == ["de", "e"]
    (cons,) = list(system.consequents)
    assert cons.label == "u" and cons.defuzzify_method == "centroid"
    assert list(cons.terms) == list(LABELS_7)
    np.testing.assert_array_equal(cons["PS"].mf, pd7.u.table[4])
    (ant_e,) = [a for a in system.antecedents if a.label == "e"]
    np.testing.assert_array_equal(ant_e.universe, pd7.e.grid)
    assert len(list(system.rules)) == 49
    (cons,) = list(dataclasses.replace(paper, defuzz="bisector").to_skfuzzy().consequents)
    assert cons.defuzzify_method == "bisector"


def test_partition_membership_is_the_closed_form_triangle_and_skfuzzy_automf():
    var = triangular_partition(n_points=61)
    grid = var.grid
    # skfuzzy's automf builds the same 7 triangles.
    auto = ctrl.Antecedent(grid.copy(), "x")
    auto.automf(names=list(LABELS_7))
    for k, label in enumerate(LABELS_7):
        np.testing.assert_allclose(var.table[k], auto[label].mf, atol=1e-12, rtol=0)
    rng = np.random.default_rng(11)
    x = rng.uniform(-1.0, 1.0, 2000)
    peaks = np.linspace(-1.0, 1.0, 7)
    closed = np.maximum(0.0, 1.0 - np.abs(x[:, None] - peaks[None, :]) * 3.0)
    np.testing.assert_allclose(var.membership(x), closed, atol=1e-12, rtol=0)
    # The memberships of a partition sum to one.
    np.testing.assert_allclose(var.membership(x).sum(axis=1), 1.0, atol=1e-12, rtol=0)


def test_membership_functions_are_skfuzzys():
    x = np.linspace(-2, 2, 101)
    np.testing.assert_array_equal(
        MembershipFunction("tri", (-1, 0, 0.5))(x), skfuzzy.trimf(x, [-1, 0, 0.5])
    )
    np.testing.assert_array_equal(
        MembershipFunction("trap", (-1, -0.5, 0, 1))(x), skfuzzy.trapmf(x, [-1, -0.5, 0, 1])
    )
    np.testing.assert_array_equal(
        MembershipFunction("gauss", (0.2, 0.3))(x), skfuzzy.gaussmf(x, 0.2, 0.3)
    )
    with pytest.raises(ValueError):
        MembershipFunction("tri", (0, -1, 1))
    with pytest.raises(ValueError):
        MembershipFunction("gauss", (0, 0))
    with pytest.raises(ValueError):
        MembershipFunction("bell", (0, 1, 2))
    with pytest.raises(ValueError, match="multiple"):
        triangular_partition(n_points=60)


# ----- equality with skfuzzy ----------------------------------------------------------


def test_7x7_equals_skfuzzy_on_random_inputs(pd7):
    assert pd7.fast_path
    rng = np.random.default_rng(20240601)
    e = rng.uniform(-1.3, 1.3, 1500)  # some outside the universe: both engines clip
    de = rng.uniform(-1.3, 1.3, 1500)
    ref = skfuzzy_array(pd7, e, de)
    # Spot-check that skfuzzy's array mode is its scalar mode.
    np.testing.assert_allclose(skfuzzy_scalar(pd7, e[:5], de[:5]), ref[:5], atol=0, rtol=0)
    assert e.size > fuzzy_engine._SMALL_N  # the batch (numpy) path
    np.testing.assert_allclose(pd7(e, de), ref, atol=TOL, rtol=0)
    # The control loop's call: both joints at once, the small-N (pure Python) path.
    pairs = np.array([pd7(e[i : i + 2], de[i : i + 2]) for i in range(0, 1500, 2)]).ravel()
    np.testing.assert_allclose(pairs, ref, atol=TOL, rtol=0)


def test_paper_base_equals_skfuzzy_and_no_fire_where_skfuzzy_raises(paper):
    rng = np.random.default_rng(7)
    e_in, de_in = paper_support_points(rng, 500)
    e = np.concatenate([rng.uniform(-1.3, 1.3, 500), e_in])
    de = np.concatenate([rng.uniform(-1.3, 1.3, 500), de_in])
    ref = skfuzzy_scalar(paper, e, de)
    fired = ~np.isnan(ref)
    assert fired.sum() >= 500 and (~fired).sum() >= 250
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        batch = paper(e, de)
        pairs = np.array([paper(e[i : i + 2], de[i : i + 2]) for i in range(0, e.size, 2)])
    for out in (batch, pairs.ravel()):
        np.testing.assert_allclose(out[fired], ref[fired], atol=TOL, rtol=0)
        assert np.all(out[~fired] == 0.0)
    # Where skfuzzy raises, no rule fires at all.
    assert np.all(paper.firing(e[~fired], de[~fired]) == 0.0)
    assert np.all(paper.firing(e[fired], de[fired]).max(axis=1) > 0.0)


def test_no_fire_output_is_configurable(paper):
    eng = dataclasses.replace(paper, no_fire_output=0.25)
    e, de = np.array([0.0, 0.5, -0.9]), np.array([0.0, -0.1, 0.9])  # no paper rule covers these
    assert np.all(paper.firing(e, de) == 0.0)
    np.testing.assert_array_equal(eng(e, de), 0.25)
    np.testing.assert_array_equal(eng(np.tile(e, 40), np.tile(de, 40)), 0.25)  # batch path
    assert float(eng(0.0, 0.0)) == 0.25
    assert float(paper(0.0, 0.0)) == 0.0


def test_product_and_equals_skfuzzy(pd7, paper):
    rng = np.random.default_rng(3)
    prod7 = dataclasses.replace(pd7, and_method="product")
    e, de = rng.uniform(-1.2, 1.2, 1000), rng.uniform(-1.2, 1.2, 1000)
    ref = skfuzzy_array(prod7, e, de)
    np.testing.assert_allclose(prod7(e, de), ref, atol=TOL, rtol=0)
    np.testing.assert_allclose(
        [float(prod7(a, b)) for a, b in zip(e[:200], de[:200], strict=True)],
        ref[:200],
        atol=TOL,
        rtol=0,
    )
    prod_paper = dataclasses.replace(paper, and_method="product")
    e, de = paper_support_points(rng, 100)
    ref = skfuzzy_scalar(prod_paper, e, de)
    assert np.isfinite(ref).all()
    np.testing.assert_allclose(prod_paper(e, de), ref, atol=TOL, rtol=0)


def test_general_path_gauss_trap_equals_skfuzzy():
    universe = tuple(np.linspace(-1.0, 1.0, 81).tolist())
    centres = np.linspace(-1.0, 1.0, 7).tolist()
    e = FuzzyVariable(
        universe, LABELS_7, tuple(MembershipFunction("gauss", (c, 0.18)) for c in centres)
    )
    de = FuzzyVariable(
        universe,
        LABELS_7,
        tuple(MembershipFunction("trap", (c - 0.3, c - 0.1, c + 0.1, c + 0.3)) for c in centres),
    )
    u = FuzzyVariable(
        universe, LABELS_7, tuple(MembershipFunction("tri", (c - 0.4, c, c + 0.4)) for c in centres)
    )
    eng = MamdaniEngine(e, de, u, pd_rule_table())
    assert not eng.fast_path
    rng = np.random.default_rng(5)
    x, y = rng.uniform(-1.2, 1.2, 500), rng.uniform(-1.2, 1.2, 500)
    ref = skfuzzy_array(eng, x, y)
    np.testing.assert_allclose(eng(x, y), ref, atol=TOL, rtol=0)
    np.testing.assert_allclose(eng(x[:2], y[:2]), ref[:2], atol=TOL, rtol=0)


def test_fast_centroid_equals_general_grid_path(pd7, paper):
    # The closed form and skfuzzy's upsampled grid, on the same clip levels.
    rng = np.random.default_rng(9)
    for eng in (pd7, paper, default_fuzzy_pd(n_points=7), default_fuzzy_pd(n_points=13)):
        e, de = rng.uniform(-1, 1, 3000), rng.uniform(-1, 1, 3000)
        cuts = eng._cuts(eng._firing_flat(e, de))
        cuts = cuts[cuts.max(axis=1) > 0]
        np.testing.assert_allclose(
            eng._centroid_partition(cuts), eng._grid_defuzz(cuts), atol=PATHS_TOL, rtol=0
        )
        # Random clip levels too, including exact 0, 0.5 and 1 (kinks on grid points).
        levels = rng.choice([0.0, 0.5, 1.0, 0.25], size=(500, 7))
        levels = np.where(rng.random((500, 7)) < 0.5, rng.random((500, 7)), levels)
        levels[:, 3] = np.maximum(levels[:, 3], 0.1)
        np.testing.assert_allclose(
            eng._centroid_partition(levels), eng._grid_defuzz(levels), atol=PATHS_TOL, rtol=0
        )


def test_coarse_universe_equals_skfuzzy():
    # Universe = the 7 peaks only: every chord skfuzzy draws spans a whole interval.
    eng = default_fuzzy_pd(n_points=7)
    assert eng.fast_path
    rng = np.random.default_rng(21)
    e, de = rng.uniform(-1, 1, 300), rng.uniform(-1, 1, 300)
    ref = skfuzzy_array(eng, e, de)
    np.testing.assert_allclose(eng(e, de), ref, atol=TOL, rtol=0)
    small = [float(eng(a, b)) for a, b in zip(e, de, strict=True)]
    np.testing.assert_allclose(small, ref, atol=TOL, rtol=0)


def test_bisector_is_exact_on_skfuzzys_own_aggregated_output(pd7, paper, record_skfuzzy_defuzz):
    # skfuzzy's bisector solves its quadratic as (sqrt(...) - y1) / slope, which loses all
    # digits when a segment's ends differ by one rounding; so the reference is the exact
    # bisector of the very piecewise-linear output that skfuzzy builds.
    rng = np.random.default_rng(17)
    bis7 = dataclasses.replace(pd7, defuzz="bisector")
    e, de = rng.uniform(-1.2, 1.2, 600), rng.uniform(-1.2, 1.2, 600)
    skfuzzy_array(bis7, e, de)
    assert len(record_skfuzzy_defuzz) == 600
    ref = np.array([exact_bisector(x, y) for x, y in record_skfuzzy_defuzz])
    np.testing.assert_allclose(bis7(e, de), ref, atol=TOL, rtol=0)

    record_skfuzzy_defuzz.clear()
    bis_paper = dataclasses.replace(paper, defuzz="bisector")
    e, de = paper_support_points(rng, 100)
    assert np.isfinite(skfuzzy_scalar(bis_paper, e, de)).all()
    ref = np.array([exact_bisector(x, y) for x, y in record_skfuzzy_defuzz])
    np.testing.assert_allclose(bis_paper(e, de), ref, atol=TOL, rtol=0)


def test_mean_of_maximum_closed_forms(pd7, paper):
    mom7 = dataclasses.replace(pd7, defuzz="mom")
    mom_paper = dataclasses.replace(paper, defuzz="mom")
    third = 1.0 / 3.0
    # Only (Z, Z -> Z) fires, fully: the maximum is the single point at Z's peak.
    assert float(mom7(0.0, 0.0)) == pytest.approx(0.0, abs=1e-15)
    # (PB, PB -> PB) fires at c = 1 - 3 (1 - e) for de = 1: plateau [1 - (1 - c) / 3, 1].
    e = 1.0 - 0.1
    c = 1.0 - 3.0 * 0.1
    assert float(mom_paper(e, 1.0)) == pytest.approx(1.0 - (1.0 - c) * third / 2, abs=1e-12)
    # (PS, PS -> PM) with both memberships 0.6: symmetric plateau around PM's peak.
    x = third + 0.4 * third
    assert float(mom_paper(x, x)) == pytest.approx(2 * third, abs=1e-12)
    # Ties between output terms: on [-3, 3] sampled at the peaks, memberships at e = 0.5
    # are exactly 0.5, so (Z, Z -> Z) and (PS, Z -> PS) tie at 0.5 and their plateaus
    # [-0.5, 0.5] and [0.5, 1.5] join: the mean of maximum is their common centre.
    var = triangular_partition(LABELS_7, -3.0, 3.0, n_points=7)
    tie = MamdaniEngine(var, var, var, pd_rule_table(), defuzz="mom")
    assert float(tie(0.5, 0.0)) == 0.5
    # Off the tie, PS (clip 0.6) wins alone: its plateau [0.6, 1.4] is centred on its peak.
    assert float(tie(0.6, 0.0)) == pytest.approx(1.0, abs=1e-12)
    # Disjoint plateaus at one level: the mean is over their union, by length.
    split = tie.with_rules([("Z", "Z", "NB"), ("Z", "Z", "PB")])
    assert float(split(0.5, 0.0)) == pytest.approx(0.0, abs=1e-12)  # [-3, -2.5], [2.5, 3]
    split = tie.with_rules([("Z", "Z", "NB"), ("Z", "Z", "PB"), ("Z", "Z", "PS")])
    # plus [0.5, 1.5]: (-2.75 * 0.5 + 1.0 * 1.0 + 2.75 * 0.5) / 2
    assert float(split(0.5, 0.0)) == pytest.approx(0.5, abs=1e-12)
    # No rule fires: the no-fire value.
    assert float(mom_paper(0.0, 0.0)) == 0.0


def test_mean_of_maximum_matches_dense_evaluation(pd7):
    mom7 = dataclasses.replace(pd7, defuzz="mom")
    rng = np.random.default_rng(23)
    e, de = rng.uniform(-1, 1, 200), rng.uniform(-1, 1, 200)
    cuts = pd7._cuts(pd7.firing(e, de))
    dense = np.linspace(-1.0, 1.0, 200_001)  # step 1e-5
    peaks = np.linspace(-1.0, 1.0, 7)
    tents = np.maximum(0.0, 1.0 - np.abs(dense[None, :] - peaks[:, None]) * 3.0)
    expected = []
    for row in cuts:
        agg = np.max(np.minimum(row[:, None], tents), axis=0)
        expected.append(dense[agg >= agg.max() - 1e-12].mean())
    # Discretising the plateau ends costs at most one dense step each.
    np.testing.assert_allclose(mom7(e, de), expected, atol=2e-5, rtol=0)


# ----- behaviour ----------------------------------------------------------------------


def test_inputs_are_clipped_to_the_universe(pd7, paper):
    for eng in (pd7, paper):
        for e, de, ce, cde in [(5.0, -7.0, 1.0, -1.0), (-1e9, 0.2, -1.0, 0.2), (np.inf, 1.5, 1, 1)]:
            assert float(eng(e, de)) == float(eng(ce, cde))
            np.testing.assert_array_equal(eng.firing(e, de), eng.firing(ce, cde))
        big = np.array([3.0, -3.0] * 50)
        np.testing.assert_array_equal(eng(big, -big), eng(np.sign(big), -np.sign(big)))
    assert float(pd7(10.0, 10.0)) == pytest.approx(float(pd7(1.0, 1.0)), abs=0)


def test_nan_input_is_an_error(pd7):
    with pytest.raises(ValueError, match="NaN"):
        pd7(np.nan, 0.0)
    with pytest.raises(ValueError, match="NaN"):
        pd7(np.full(100, np.nan), 0.0)
    with pytest.raises(ValueError, match="NaN"):
        pd7.firing(0.0, np.nan)


def test_firing_strengths(pd7, paper):
    rng = np.random.default_rng(31)
    e, de = rng.uniform(-1.2, 1.2, 500), rng.uniform(-1.2, 1.2, 500)
    ce, cde = np.clip(e, -1, 1), np.clip(de, -1, 1)
    for and_method, op in (("min", np.fmin), ("product", np.multiply)):
        eng = dataclasses.replace(pd7, and_method=and_method)
        expected = np.stack(
            [
                op(
                    skfuzzy.interp_membership(eng.e.grid, eng.e.table[eng.e.index(r.e)], ce),
                    skfuzzy.interp_membership(eng.de.grid, eng.de.table[eng.de.index(r.de)], cde),
                )
                for r in eng.rules
            ],
            axis=-1,
        )
        np.testing.assert_allclose(eng.firing(e, de), expected, atol=1e-15, rtol=0)
    # At the origin only (Z, Z -> Z) fires, fully.
    f = pd7.firing(0.0, 0.0)
    assert f.shape == (49,)
    assert np.flatnonzero(f).tolist() == [pd7.rules.index(Rule("Z", "Z", "Z"))]
    assert f.max() == 1.0
    # Midway between Z and PS in e: two rules at 0.5.
    f = pd7.firing(1.0 / 6.0, 0.0)
    fired = {pd7.rules[i]: f[i] for i in np.flatnonzero(f)}
    assert fired.keys() == {Rule("Z", "Z", "Z"), Rule("PS", "Z", "PS")}
    assert all(v == pytest.approx(0.5, abs=1e-15) for v in fired.values())
    # The paper's rules never fire together (their antecedents do not overlap).
    e, de = paper_support_points(rng, 2000)
    assert ((paper.firing(e, de) > 0).sum(axis=1) <= 1).all()


def test_broadcasting_and_shapes(pd7):
    e = np.linspace(-1, 1, 3)[:, None]
    de = np.linspace(-1, 1, 4)
    out = pd7(e, de)
    assert out.shape == (3, 4) and out.dtype == np.float64
    for i in range(3):
        for j in range(4):
            assert out[i, j] == pytest.approx(float(pd7(e[i, 0], de[j])), abs=PATHS_TOL)
    assert pd7.firing(e, de).shape == (3, 4, 49)
    assert np.shape(pd7(0.1, 0.2)) == ()
    assert pd7([0.1, 0.2], 0.3).shape == (2,)
    assert pd7(np.zeros((0,)), np.zeros((0,))).shape == (0,)
    big = np.full((5, 40), 0.3)
    assert pd7(big, -0.1).shape == (5, 40)
    # The small-N and the batch paths agree on the same pairs.
    rng = np.random.default_rng(41)
    x, y = rng.uniform(-1, 1, 2000), rng.uniform(-1, 1, 2000)
    small = np.concatenate([pd7(x[i : i + 2], y[i : i + 2]) for i in range(0, 2000, 2)])
    np.testing.assert_allclose(small, pd7(x, y), atol=PATHS_TOL, rtol=0)


def test_7x7_surface_is_odd_and_monotone_where_the_table_does_not_saturate(pd7):
    g = np.linspace(-1, 1, 301)
    surface = pd7(g[:, None], g[None, :])
    np.testing.assert_allclose(surface[::-1, ::-1], -surface, atol=1e-12, rtol=0)
    # Cells whose four rules all map to distinct, unclipped output terms: lower term
    # indices i, j with 3 <= i + j <= 7. There u is strictly increasing in e and in de.
    low = np.minimum(np.floor((g + 1.0) * 3.0 + 1e-9).astype(int), 5)
    band = (low[:, None] + low[None, :] >= 3) & (low[:, None] + low[None, :] <= 7)
    d_e = np.diff(surface, axis=0)[band[:-1] & band[1:]]
    d_de = np.diff(surface, axis=1)[band[:, :-1] & band[:, 1:]]
    assert d_e.size > 40_000 and d_de.size > 40_000
    assert d_e.min() > 0 and d_de.min() > 0
    # In the saturated corners several cells conclude NB (or PB) and the clip level of
    # that one shoulder term, max(1 - t, t), is not monotone: neither is u (docs/fuzzy.md).
    assert np.diff(surface, axis=0).min() < 0
    # Full NB: the centroid of the NB shoulder triangle on [-1, -2/3] is -1 + 1/9.
    assert float(pd7(-1.0, -1.0)) == pytest.approx(-8.0 / 9.0, abs=1e-12)
    assert surface.min() == pytest.approx(-8.0 / 9.0, abs=1e-12)
    assert float(pd7(0.0, 0.0)) == pytest.approx(0.0, abs=1e-15)
    # Sign convention: positive error (theta below target) gives a positive push.
    assert float(pd7(0.5, 0.0)) > 0 and float(pd7(0.0, 0.5)) > 0


@pytest.mark.parametrize("defuzz", ["centroid", "bisector"])
def test_float_path_of_the_control_loop_equals_the_array_path(defuzz):
    # centroid takes the closed-form pure-Python path, bisector the numpy one
    rng = np.random.default_rng(11)
    for engine in (default_fuzzy_pd(defuzz=defuzz), paper_fuzzy_pd(defuzz=defuzz)):
        for _ in range(500):
            e, de = rng.uniform(-1.3, 1.3, 2), rng.uniform(-1.3, 1.3, 2)
            out = engine.evaluate_floats(e.tolist(), de.tolist())
            assert all(isinstance(x, float) for x in out)
            assert out == engine(e, de).tolist()


def test_uncovered_fraction_equals_an_independent_skfuzzy_count():
    """The share of the input box where no rule of the paper's Table 1 fires, against a
    count from scikit-fuzzy's own interp_membership on the same grid."""
    engine = fuzzy.paper_fuzzy_pd()
    n = 61
    grid = np.linspace(-1.0, 1.0, n)
    universe = np.asarray(engine.e.universe)
    table = engine.e.table  # sampled memberships, one row per term
    mu = {
        lab: skfuzzy.interp_membership(universe, table[k], grid)
        for k, lab in enumerate(engine.e.labels)
    }
    fires = np.zeros((n, n), dtype=bool)
    for r in engine.rules:
        fires |= np.minimum.outer(mu[r.de], mu[r.e]) > 0
    assert fuzzy.uncovered_fraction(engine, n=n) == pytest.approx(1 - fires.mean(), abs=1e-12)
    assert fuzzy.uncovered_fraction(fuzzy.default_fuzzy_pd()) == 0.0  # the full 7x7 table


def test_a_rule_base_that_contradicts_itself_is_refused(tmp_path):
    path = tmp_path / "contradict.toml"
    rule = '[[rule]]\ne = "PS"\nde = "Z"\nu = "{}"\n'
    path.write_text(rule.format("PS") + rule.format("NB"))
    with pytest.raises(ValueError, match=r"rule\[1\]: contradicts rule\[0\]"):
        fuzzy.load_rule_base(path)
    path.write_text(rule.format("PS") + rule.format("PS"))  # a repeat is not a contradiction
    assert len(fuzzy.load_rule_base(path)) == 2
