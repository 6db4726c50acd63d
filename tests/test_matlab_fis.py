"""twolink.read_fis: every Toolbox .fis in tests/data/fis/ (README.md there names where
each comes from) against an independent evaluator written here, scalar and from the
Toolbox's documented formulas: the exact mode against adaptive quadrature (scipy's quad,
1e-13) and closed-form level sets, the sampled mode against the Toolbox's C arithmetic
(fis.c) transcribed as a plain loop, both within 1e-9 on a grid of inputs; the membership
functions and the sampled mean of maximum against scikit-fuzzy."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import skfuzzy
from scipy import integrate, optimize

import twolink
from twolink.controllers.fuzzy.fis.matlab import parse_matlab_fis, read_fis

DATA = Path(__file__).parent / "data" / "fis"
FILES = sorted(p.name for p in DATA.glob("*.fis"))
TOL = 1e-9


# ----------------------------------------------------------------------------- reference


def ref_mf(kind: str, p, x: float) -> float:
    """The Toolbox's membership functions as its documentation writes them."""
    if kind == "trimf":
        a, b, c = p
        left = 1.0 if x >= b else ((x - a) / (b - a) if x > a else 0.0)
        right = 1.0 if x <= b else ((c - x) / (c - b) if x < c else 0.0)
        return max(min(left, right), 0.0)
    if kind == "trapmf":
        a, b, c, d = p
        left = 1.0 if x >= b else ((x - a) / (b - a) if x > a else 0.0)
        right = 1.0 if x <= c else ((d - x) / (d - c) if x < d else 0.0)
        return max(min(left, right), 0.0)
    if kind == "gaussmf":
        return math.exp(-((x - p[1]) ** 2) / (2 * p[0] ** 2))
    if kind == "gauss2mf":
        f1 = 1.0 if x >= p[1] else math.exp(-((x - p[1]) ** 2) / (2 * p[0] ** 2))
        f2 = 1.0 if x <= p[3] else math.exp(-((x - p[3]) ** 2) / (2 * p[2] ** 2))
        return f1 * f2
    if kind == "gbellmf":
        return 1.0 / (1.0 + abs((x - p[2]) / p[0]) ** (2 * p[1]))

    def sig(a, c):
        z = -a * (x - c)
        return 0.0 if z > 700 else 1.0 / (1.0 + math.exp(z))

    if kind == "sigmf":
        return sig(p[0], p[1])
    if kind == "dsigmf":
        return abs(sig(p[0], p[1]) - sig(p[2], p[3]))
    if kind == "psigmf":
        return sig(p[0], p[1]) * sig(p[2], p[3])

    def s_shape(a, b):
        if x <= a:
            return 0.0
        if x >= b:
            return 1.0
        t = (x - a) / (b - a)
        return 2 * t * t if x <= (a + b) / 2 else 1 - 2 * (1 - t) ** 2

    if kind == "smf":
        return s_shape(p[0], p[1])
    if kind == "zmf":
        return 1.0 - s_shape(p[0], p[1])
    if kind == "pimf":
        return s_shape(p[0], p[1]) * (1.0 - s_shape(p[2], p[3]))
    raise AssertionError(kind)


class Ref:
    """One input at a time, every operation spelled out."""

    def __init__(self, fis):
        self.f = fis

    def firing(self, x) -> list[float]:
        f, out = self.f, []
        for rule in f.rules:
            vals = []
            for var, idx, xi in zip(f.inputs, rule.antecedent, x, strict=True):
                if idx == 0:
                    vals.append(1.0 if rule.connection == 1 else 0.0)
                    continue
                mf = var.mfs[abs(idx) - 1]
                mu = ref_mf(mf.kind, mf.params, xi)
                vals.append(mu if idx > 0 else 1.0 - mu)
            v = vals[0]
            for b in vals[1:]:
                if rule.connection == 1:
                    v = min(v, b) if f.and_method == "min" else v * b
                else:
                    v = max(v, b) if f.or_method == "max" else v + b - v * b
            out.append(v * rule.weight)
        return out

    def mu(self, m: int, w, y: float) -> float:
        f, var, total = self.f, self.f.outputs[m], None
        for rule, wr in zip(f.rules, w, strict=True):
            k = rule.consequent[m]
            if k == 0:
                continue
            mf = var.mfs[abs(k) - 1]
            v = ref_mf(mf.kind, mf.params, y)
            v = v if k > 0 else 1.0 - v
            g = min(wr, v) if f.imp_method == "min" else wr * v
            if total is None:
                total = g
            elif f.agg_method == "max":
                total = max(total, g)
            elif f.agg_method == "sum":
                total = total + g
            else:
                total = total + g - total * g
        return 0.0 if total is None else total

    def breaks(self, m: int, w) -> list[float]:
        """Every kink of mu: the functions' breakpoints, and the clip crossings and
        changes of the largest rule found on a 1201-point scan and solved by brentq."""
        var = self.f.outputs[m]
        lo, hi = var.range
        pts = {lo, hi}
        for mf in var.mfs:
            pts.update(c for c, _ in mf.features())
        ys = np.linspace(lo, hi, 1201)
        rules = [(r, w[i]) for i, r in enumerate(self.f.rules) if r.consequent[m]]

        def val(r, wr, y):
            k = r.consequent[m]
            mf = var.mfs[abs(k) - 1]
            v = ref_mf(mf.kind, mf.params, y)
            v = v if k > 0 else 1 - v
            return v, (min(wr, v) if self.f.imp_method == "min" else wr * v)

        funcs = [lambda y, r=r, wr=wr: val(r, wr, y)[0] - wr for r, wr in rules]
        if self.f.agg_method == "max":
            for i in range(len(rules)):
                for j in range(i + 1, len(rules)):
                    funcs.append(lambda y, a=rules[i], b=rules[j]: val(*a, y)[1] - val(*b, y)[1])
        for func in funcs:
            v = np.array([func(y) for y in ys])
            for i in np.nonzero(np.sign(v[:-1]) * np.sign(v[1:]) < 0)[0]:
                pts.add(optimize.brentq(func, ys[i], ys[i + 1], xtol=1e-15, rtol=1e-15))
        return sorted(p for p in pts if lo <= p <= hi)

    def integral(self, m, w, g, a, b, pts) -> float:
        inner = [p for p in pts if a < p < b]
        cuts = [a, *inner, b]
        return sum(
            integrate.quad(g, u, v, epsabs=1e-14, epsrel=1e-13, limit=200)[0]
            for u, v in zip(cuts[:-1], cuts[1:], strict=True)
            if v > u
        )

    def exact(self, x) -> list[float]:
        f, w, out = self.f, self.firing(x), []
        for m, var in enumerate(f.outputs):
            out.append(self._exact_output(m, var, w, x))
        return out

    def _exact_output(self, m, var, w, x) -> float:
        f = self.f
        lo, hi = var.range
        if sum(w) == 0:
            return 0.5 * (lo + hi)
        if f.type == "sugeno":
            num = 0.0
            for rule, wr in zip(f.rules, w, strict=True):
                k = rule.consequent[m]
                if k:
                    mf = var.mfs[k - 1]
                    z = (
                        mf.params[0]
                        if mf.kind == "constant"
                        else (
                            sum(c * xi for c, xi in zip(mf.params, x, strict=False)) + mf.params[-1]
                        )
                    )
                    num += wr * z
            return num / sum(w) if f.defuzz_method == "wtaver" else num
        pts = self.breaks(m, w)
        mu = lambda y: self.mu(m, w, y)  # noqa: E731
        area = self.integral(m, w, mu, lo, hi, pts)
        if area == 0:
            return 0.5 * (lo + hi)
        if f.defuzz_method == "centroid":
            return self.integral(m, w, lambda y: y * mu(y), lo, hi, pts) / area
        if f.defuzz_method == "bisector":
            return optimize.brentq(
                lambda t: self.integral(m, w, mu, lo, t, pts) - area / 2, lo, hi, xtol=1e-13
            )
        raise AssertionError("mom/som/lom: see closed_form_max")


def sampled_ref(fis, x, points=101) -> list[float]:
    """fis.c's evaluation, one input at a time (defuzzCentroid, defuzzBisector, ...)."""
    ref, out = Ref(fis), []
    w = ref.firing(x)
    for m, var in enumerate(fis.outputs):
        lo, hi = var.range
        if fis.type == "sugeno" or sum(w) == 0:
            out.append(ref._exact_output(m, var, w, x))
            continue
        step = (hi - lo) / (points - 1)
        mf = [ref.mu(m, w, lo + step * i) for i in range(points)]
        total = sum(mf)
        if total == 0:
            out.append((lo + hi) / 2)
            continue
        method = fis.defuzz_method
        if method == "centroid":
            out.append(sum(v * (lo + step * i) for i, v in enumerate(mf)) / total)
        elif method == "bisector":
            acc = 0.0
            first = 0
            for first, v in enumerate(mf):  # noqa: B007 - the index where it stops
                acc += v
                if acc >= total / 2:
                    break
            out.append(lo + step * first)
        else:
            top = max(mf)
            idx = [i for i, v in enumerate(mf) if v == top]
            if method == "mom":
                out.append(lo + step * sum(idx) / len(idx))
            else:
                pick = min if method == "som" else max
                best = pick(abs(lo + step * i) for i in idx)
                out.append(next(lo + step * i for i in idx if abs(lo + step * i) == best))
    return out


def closed_form_max(fis, x) -> list[float]:
    """mom / som / lom of piecewise-linear files under max aggregation: the set where mu
    is largest from the level sets of the triangles and trapezoids, in closed form."""
    ref, out = Ref(fis), []
    w = ref.firing(x)
    for m, var in enumerate(fis.outputs):
        lo, hi = var.range
        live = [
            (r.consequent[m], wr) for r, wr in zip(fis.rules, w, strict=True) if r.consequent[m]
        ]

        def level_set(k, level, var=var, lo=lo, hi=hi):  # {F_k >= level}, F: mf or 1 - mf
            mf = var.mfs[abs(k) - 1]
            p = mf.params if mf.kind == "trapmf" else (*mf.params[:2], *mf.params[1:])
            lev = level if k > 0 else 1 - level
            left = p[0] + lev * (p[1] - p[0])
            right = p[3] - lev * (p[3] - p[2])
            if k > 0:
                return [(max(left, lo), min(right, hi))] if left <= right else []
            return [(lo, min(left, hi)), (max(right, lo), hi)]

        def top(k):  # the largest F_k on the range
            return 1.0

        heights = [min(wr, top(k)) if fis.imp_method == "min" else wr * top(k) for k, wr in live]
        peak = max(heights, default=0.0)
        if sum(w) == 0 or peak == 0:
            out.append((lo + hi) / 2)
            continue
        sets = []
        for (k, _), h in zip(live, heights, strict=True):
            if h == peak:
                sets += level_set(k, peak if fis.imp_method == "min" else 1.0)
        sets = [(a, b) for a, b in sets if a <= b]
        merged = []
        for a, b in sorted(sets):
            if merged and a <= merged[-1][1]:
                merged[-1] = (merged[-1][0], max(merged[-1][1], b))
            else:
                merged.append((a, b))
        length = sum(b - a for a, b in merged)
        if fis.defuzz_method == "mom":
            if length > 0:
                out.append(sum((a + b) / 2 * (b - a) for a, b in merged) / length)
            else:
                pts = sorted({a for a, _ in merged})
                out.append(sum(pts) / len(pts))
            continue
        ends = [v for ab in merged for v in ab]
        if fis.defuzz_method == "som":
            if any(a <= 0 <= b for a, b in merged):
                out.append(0.0)
                continue
            best = min(abs(v) for v in ends)
        else:
            best = max(abs(v) for v in ends)
        out.append(min(v for v in ends if abs(abs(v) - best) <= 1e-12))
    return out


def grid(fis, n: int) -> np.ndarray:
    axes = [np.linspace(*v.range, n + 2)[1:-1] for v in fis.inputs]
    return np.stack([a.ravel() for a in np.meshgrid(*axes, indexing="ij")], axis=1)


def sample(fis, n):
    pts = grid(fis, n if len(fis.inputs) < 3 else 3)
    return pts[:: max(1, len(pts) // 12)]  # about 12 inputs per file: quad is slow


# ----------------------------------------------------------------------------- tests


@pytest.mark.parametrize("name", FILES)
def test_every_file_equals_the_independent_evaluation_within_1e9(name):
    fis = read_fis(DATA / name)
    x = sample(fis, 6)
    exact = fis.evaluate(x)
    sampled = fis.evaluate(x, sampled=True)
    assert exact.shape == sampled.shape == (len(x), len(fis.outputs))
    for row, e, s in zip(x, exact, sampled, strict=True):
        assert np.max(np.abs(s - sampled_ref(fis, row))) < TOL
        want = (
            closed_form_max(fis, row)
            if fis.defuzz_method in ("mom", "som", "lom")
            else (Ref(fis).exact(row))
        )
        assert np.max(np.abs(e - want)) < TOL, (row, e, want)


def test_the_files_cover_every_operation():
    seen = set()
    for name in FILES:
        f = read_fis(DATA / name)
        seen |= {f.type, f"and {f.and_method}", f"or {f.or_method}", f"defuzz {f.defuzz_method}"}
        if f.type == "mamdani":
            seen |= {f"imp {f.imp_method}", f"agg {f.agg_method}"}
        seen |= {mf.kind for v in (*f.inputs, *f.outputs) for mf in v.mfs}
        for r in f.rules:
            seen |= {"AND" if r.connection == 1 else "OR"}
            seen |= {"NOT in" for i in r.antecedent if i < 0} | {
                "dont-care" for i in r.antecedent if i == 0
            }
            seen |= {"NOT out" for i in r.consequent if i < 0} | {
                "weight" for _ in [0] if r.weight < 1
            }
        if len(f.inputs) > 2 and len(f.outputs) > 1:
            seen.add("several")
    want = {
        "mamdani", "sugeno", "and min", "and prod", "or max", "or probor", "imp min", "imp prod",
        "agg max", "agg sum", "agg probor", "AND", "OR", "NOT in", "NOT out", "dont-care",
        "weight", "several", "constant", "linear", *(f"defuzz {d}" for d in (
            "centroid", "bisector", "mom", "som", "lom", "wtaver", "wtsum")),
        "trimf", "trapmf", "gaussmf", "gauss2mf", "gbellmf", "sigmf", "dsigmf", "psigmf",
        "pimf", "smf", "zmf",
    }  # fmt: skip
    assert want <= seen, want - seen


GAP = """[System]
Type='mamdani'
NumInputs=1
NumOutputs=1
[Input1]
Range=[0 5]
NumMFs=2
MF1='a':'trimf',[0 1 2]
MF2='b':'trimf',[3 4 5]
[Output1]
Range=[4 10]
NumMFs=2
MF1='lo':'trimf',[3 4 5]
MF2='hi':'trimf',[8 9 10]
[Rules]
1, 1 (1) : 1
2, 2 (1) : 1
"""


def test_the_toolbox_documented_values_and_the_no_fire_rule():
    tipper = read_fis(DATA / "tipper.fis")
    # MathWorks' evalfis documentation: tipper at service 2, food 1 gives 7.0169
    assert abs(tipper.evaluate([[2, 1]], sampled=True)[0, 0] - 7.0169) < 5e-5
    assert tipper.evaluate([[5, 5]])[0, 0] == pytest.approx(15.0, abs=1e-12)
    # exact against sampled: the Toolbox's 101 points move the tip by up to ~0.01 here
    x = grid(tipper, 20)
    diff = np.abs(tipper.evaluate(x) - tipper.evaluate(x, sampled=True))
    assert 1e-4 < diff.max() < 0.05
    # no rule fires: the middle of each output's range (the Toolbox's rule), both modes
    gap = parse_matlab_fis(GAP, "gap.fis")
    for sampled in (False, True):
        assert gap.evaluate([[2.5]], sampled=sampled)[0, 0] == 7.0
    # a consequent cut by the range: the centroid of its part inside, 4 + 1/3
    assert gap.evaluate([[1.0]])[0, 0] == pytest.approx(13 / 3, abs=1e-12)
    shower = read_fis(DATA / "shower.fis")
    assert shower.evaluate([[0.0, 0.0]]).shape == (1, 2)


def test_membership_functions_equal_scikit_fuzzy():
    y = np.linspace(-12, 12, 4801)
    fis = read_fis(DATA / "allmf_min_max.fis")
    ours = {mf.label: mf for mf in fis.outputs[0].mfs}
    theirs = {
        "tri": skfuzzy.trimf(y, [-10, -8, -5]),
        "trap": skfuzzy.trapmf(y, [-7, -5, -3, -1]),
        "gauss": skfuzzy.gaussmf(y, -2, 1.2),
        "gauss2": skfuzzy.gauss2mf(y, -0.5, 0.8, 0.5, 1),
        "bell": skfuzzy.gbellmf(y, 1.5, 4, 2),
        "sig": skfuzzy.sigmf(y, 8, 3),
        "dsig": np.abs(skfuzzy.dsigmf(y, 3, 4, 5, 4)),
        "psig": skfuzzy.psigmf(y, 4.5, 5, 7.5, -5),
        "pi": skfuzzy.pimf(y, 5, 6.5, 7, 9),
        "s": skfuzzy.smf(y, -1, 3),
        "z": skfuzzy.zmf(y, -9, -4),
    }
    for label, want in theirs.items():
        assert np.max(np.abs(ours[label](y) - want)) < 1e-12, label


def test_the_sampled_mean_of_maximum_equals_scikit_fuzzys_on_the_same_grid():
    from twolink.controllers.fuzzy.fis.exact import aggregate

    fis = read_fis(DATA / "linear_mom.fis")
    x = grid(fis, 9)
    w = fis.firing(x)
    ours = fis.evaluate(x, sampled=True)
    for m, var in enumerate(fis.outputs):
        y = np.linspace(*var.range, 101)
        cons = np.array([r.consequent[m] for r in fis.rules])
        mu = aggregate(fis, m, y[None, :], w, cons)
        for i in np.nonzero(w.sum(axis=1) > 0)[0]:
            assert abs(skfuzzy.defuzz(y, mu[i], "mom") - ours[i, m]) < 1e-12


def test_the_exact_centroid_equals_scikit_fuzzy_control_on_a_fine_universe():
    from skfuzzy import control as ctrl

    fis = read_fis(DATA / "tipper.fis")
    service = ctrl.Antecedent(np.linspace(0, 10, 2001), "service")
    food = ctrl.Antecedent(np.linspace(0, 10, 2001), "food")
    tip = ctrl.Consequent(np.linspace(0, 30, 3001), "tip")
    for var, sk in ((fis.inputs[0], service), (fis.inputs[1], food), (fis.outputs[0], tip)):
        for mf in var.mfs:
            sk[mf.label] = mf(sk.universe)
    rules = [
        ctrl.Rule(service["poor"] | food["rancid"], tip["cheap"]),
        ctrl.Rule(service["good"], tip["average"]),
        ctrl.Rule(service["excellent"] | food["delicious"], tip["generous"]),
    ]
    sim = ctrl.ControlSystemSimulation(ctrl.ControlSystem(rules), cache=False)
    x = grid(fis, 5)
    ours = fis.evaluate(x)[:, 0]
    for row, u in zip(x, ours, strict=True):
        sim.input["service"], sim.input["food"] = row
        sim.compute()
        assert abs(sim.output["tip"] - u) < 1e-5  # skfuzzy's interpolated inputs, 2001 points


def test_refusals_are_one_line_naming_the_file(tmp_path):
    text = (DATA / "tipper.fis").read_text()
    cases = {
        "AndMethod='min'": ("AndMethod='myand'", "AndMethod='myand': a custom function"),
        "'gaussmf',[1.5 0]": ("'mymf',[1.5 0]", "'mymf' is not a Toolbox membership function"),
        "'trimf',[0 5 10]": ("'trimf',[0 5]", "trimf takes 3 parameters"),
        "1 1, 1 (1) : 2": ("1 4, 1 (1) : 2", "index 4: food has 2 MFs"),
    }
    for old, (new, words) in cases.items():
        path = tmp_path / "bad.fis"
        path.write_text(text.replace(old, new))
        with pytest.raises(ValueError, match="bad.fis") as err:
            read_fis(path)
        assert words in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(ValueError, match=r"mam22.fis: a fuzzy term takes 2 inputs .* 2 outputs"):
        read_fis(DATA / "mam22.fis").term()
    assert twolink.read_fis is read_fis


def test_evaluate_takes_n_by_inputs():
    fis = parse_matlab_fis((DATA / "tipper1.fis").read_text(), "t.fis")
    assert fis.evaluate(np.array([1.0, 5.0, 9.0])).shape == (3, 1)
    with pytest.raises(ValueError, match="t.fis: evaluate takes"):
        fis.evaluate(np.ones((2, 3)))


def test_exact_and_sampled_differ_as_docs_fuzzy_md_says():
    def largest(name):
        fis = read_fis(DATA / name)
        axes = [np.linspace(*v.range, 21) for v in fis.inputs]
        x = np.stack([a.ravel() for a in np.meshgrid(*axes, indexing="ij")], axis=1)
        return np.abs(fis.evaluate(x) - fis.evaluate(x, sampled=True)).max()

    for name in ("tank.fis", "tank2.fis"):  # prod implication of symmetric triangles
        assert largest(name) < 1e-12
    assert 2e-4 < largest("shower.fis") < 4e-4
    assert 0.004 < largest("tipper.fis") < 0.006
    assert 0.04 < largest("mam21.fis") < 0.046


def test_inputs_are_not_clipped_to_their_ranges_as_in_the_toolbox():
    fis = read_fis(DATA / "tipper.fis")
    outside = np.array([[13.0, -2.0], [-4.0, 11.0]])
    got = fis.evaluate(outside)
    for row, g in zip(outside, got, strict=True):
        assert abs(g[0] - Ref(fis).exact(row)[0]) < TOL
    clipped = fis.evaluate(np.clip(outside, 0, 10))
    assert np.all(np.abs(got - clipped) > 1e-3)  # the gaussians are read where x is
    with pytest.raises(ValueError, match="tipper.fis: inputs contain NaN"):
        fis.evaluate([[np.nan, 1.0]])


@pytest.mark.slow
@pytest.mark.parametrize("name", FILES)
def test_every_file_on_its_whole_grid(name):
    """As the test above on every point of an 8 x 8 grid (4 x 4 x 4 for three inputs)."""
    fis = read_fis(DATA / name)
    x = grid(fis, 8 if len(fis.inputs) < 3 else 4)
    exact, sampled = fis.evaluate(x), fis.evaluate(x, sampled=True)
    maxlike = fis.defuzz_method in ("mom", "som", "lom")
    for row, e, s in zip(x, exact, sampled, strict=True):
        assert np.max(np.abs(s - sampled_ref(fis, row))) < TOL
        want = closed_form_max(fis, row) if maxlike else Ref(fis).exact(row)
        assert np.max(np.abs(e - want)) < TOL, (row, e, want)
