"""The MATLAB .fis readers under hostile input (issue 49): every error one line naming
the file, in both readers (:func:`read_fis`, any Toolbox system; :func:`read_engine` /
:func:`read_rule_base`, the project's engine); no non-finite range or parameter, no
fraction taken for an index or a count; a method no rule calls accepted, as the Toolbox
runs it. And each membership function against the Toolbox's documented formula, written
here independently, on inputs where its shape matters (dsigmf with f2 above f1, ...), so
that a changed formula fails a test."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from twolink.controllers.fuzzy.fis.engine_files import read_engine, read_rule_base, write_fis
from twolink.controllers.fuzzy.fis.matlab import FisMF, read_fis
from twolink.controllers.fuzzy.tables import paper_fuzzy_pd

DATA = Path(__file__).parent / "data" / "fis"
TOKENS = ("inf", "-inf", "nan", "1e400", "1.5", "x", "", "[", "]")


def _refusal(reader, path: Path) -> str | None:
    """The one-line error naming ``path``, or None where the file is read."""
    try:
        reader(path)
    except ValueError as exc:
        return str(exc)
    return None


@pytest.mark.parametrize("name", ["tipper.fis", "allmf_min_max.fis", "sugeno1.fis"])
def test_every_number_replaced_by_junk_is_one_line_naming_the_file(tmp_path, name):
    # each number of the file in turn replaced by each token: any other exception (a
    # ValueError of float(), "cannot convert float NaN to integer") or a message without
    # the file fails; on main 12 kinds of message did not name it
    text = (DATA / name).read_text()
    spans = [m.span() for m in re.finditer(r"-?\d+(\.\d+)?", text)]
    path = tmp_path / "mutated.fis"
    refused = 0
    for k, (a, b) in enumerate(spans[::3]):
        path.write_text(text[:a] + TOKENS[k % len(TOKENS)] + text[b:])
        for reader in (read_fis, read_engine):
            message = _refusal(reader, path)
            if message is not None:
                refused += 1
                assert str(path) in message and "\n" not in message, (reader, message)
    assert refused > len(spans[::3])  # the cases are refusals, not files that read


@pytest.mark.parametrize(
    "old, new, words",
    [
        ("Range=[0 10]", "Range=[-inf inf]", "the ends must be finite"),
        ("Range=[0 10]", "Range=[0 inf]", "the ends must be finite"),
        ("Range=[0 10]", "Range=[nan 10]", "low < high"),
        ("[1.5 0]", "[inf 0]", "parameters must be finite"),
        ("NumMFs=2", "NumMFs=1.5", "NumMFs: '1.5' is not a whole number"),
        ("NumInputs=2", "NumInputs=nan", "NumInputs: 'nan' is not a whole number"),
        ("1 1, 1 (1) : 2", "1.5 1, 1 (1) : 2", "membership index: '1.5' is not a whole"),
    ],
)
def test_non_finite_and_fractional_numbers_are_refused_naming_the_file(tmp_path, old, new, words):
    text = (DATA / "tipper.fis").read_text()
    assert old in text
    path = tmp_path / "bad.fis"
    path.write_text(text.replace(old, new, 1))
    message = _refusal(read_fis, path)
    assert message is not None and message.startswith(f"{path}: ") and words in message


def test_a_rule_base_fis_with_index_1_5_is_refused_not_read_as_1(tmp_path):
    good = write_fis(tmp_path / "paper.fis", paper_fuzzy_pd())
    assert len(read_rule_base(good).rules) == len(paper_fuzzy_pd().rules)
    text = good.read_text()
    rule = re.search(r"^(\d) (\d), (\d) \(1\) : 1$", text, re.M)
    bad = tmp_path / "bad.fis"
    bad.write_text(text.replace(rule.group(0), f"{rule.group(1)}.5 {rule.group(2)}, 1 (1) : 1"))
    with pytest.raises(ValueError, match=r"bad.fis: line \d+: membership index: '\d.5'"):
        read_rule_base(bad)


def test_a_method_no_rule_calls_is_accepted_and_refused_where_a_rule_calls_it(tmp_path):
    # tipper.fis: rules 1 and 3 are OR (connection 2), rule 2 AND
    text = (DATA / "tipper.fis").read_text().replace("OrMethod='max'", "OrMethod='sum'")
    assert "OrMethod='sum'" in text
    path = tmp_path / "or_sum.fis"
    path.write_text(text)
    message = _refusal(read_fis, path)
    assert (
        message == f"{path}: [System] OrMethod='sum': a custom function (read: ['max', 'probor'])"
    )
    all_and = re.sub(r": 2 *$", ": 1", text, flags=re.M)
    path.write_text(all_and)
    fis = read_fis(path)
    reference = re.sub(r": 2 *$", ": 1", (DATA / "tipper.fis").read_text(), flags=re.M)
    (tmp_path / "ref.fis").write_text(reference)
    x = np.array([[1.0, 2.0], [5.0, 5.0], [9.0, 8.0]])
    assert fis.or_method == "sum"
    np.testing.assert_array_equal(fis.evaluate(x), read_fis(tmp_path / "ref.fis").evaluate(x))
    path.write_text(all_and.replace("AndMethod='min'", "AndMethod='myand'"))
    assert "AndMethod='myand': a custom function" in _refusal(read_fis, path)


# ----------------------------------------------------------------------------- shapes


def _sig(a: float, c: float, x: float) -> float:
    z = -a * (x - c)
    return 0.0 if z > 700 else 1.0 / (1.0 + math.exp(z))


def _s(a: float, b: float, x: float) -> float:  # smf, as the Toolbox documents it
    if a >= b:
        return float(x >= (a + b) / 2)
    if x <= a:
        return 0.0
    if x <= (a + b) / 2:
        return 2 * ((x - a) / (b - a)) ** 2
    if x <= b:
        return 1 - 2 * ((x - b) / (b - a)) ** 2
    return 1.0


def _z(a: float, b: float, x: float) -> float:  # zmf
    if a >= b:
        return float(x <= (a + b) / 2)
    if x <= a:
        return 1.0
    if x <= (a + b) / 2:
        return 1 - 2 * ((x - a) / (b - a)) ** 2
    if x <= b:
        return 2 * ((x - b) / (b - a)) ** 2
    return 0.0


def _gauss(s: float, c: float, x: float) -> float:
    return math.exp(-((x - c) ** 2) / (2 * s * s))


# MATLAB's documentation of each function, one scalar x at a time
DOCUMENTED = {
    "dsigmf": lambda p, x: abs(_sig(p[0], p[1], x) - _sig(p[2], p[3], x)),
    "psigmf": lambda p, x: _sig(p[0], p[1], x) * _sig(p[2], p[3], x),
    "sigmf": lambda p, x: _sig(p[0], p[1], x),
    "pimf": lambda p, x: _s(p[0], p[1], x) * _z(p[2], p[3], x),
    "smf": lambda p, x: _s(p[0], p[1], x),
    "zmf": lambda p, x: _z(p[0], p[1], x),
    "gbellmf": lambda p, x: 1.0 / (1.0 + abs((x - p[2]) / p[0]) ** (2 * p[1])),
    "gaussmf": lambda p, x: _gauss(p[0], p[1], x),
    "gauss2mf": lambda p, x: (
        (1.0 if x >= p[1] else _gauss(p[0], p[1], x))
        * (1.0 if x <= p[3] else _gauss(p[2], p[3], x))
    ),
    "trimf": lambda p, x: max(min((x - p[0]) / (p[1] - p[0]), (p[2] - x) / (p[2] - p[1])), 0),
    "trapmf": lambda p, x: max(min((x - p[0]) / (p[1] - p[0]), 1, (p[3] - x) / (p[3] - p[2])), 0),
}

# the cases where the shape matters: the sign inside dsigmf's |.| (f2 above f1 on the
# left, below on the right, above everywhere), a falling psigmf, a pimf with a plateau,
# an odd and a fractional gbellmf slope, a gauss2mf whose halves overlap (c1 > c2: its
# top is below 1), a falling sigmf
CASES = [
    ("dsigmf", (5, 2, 5, 7)),
    ("dsigmf", (2, 6, 8, 4)),
    ("dsigmf", (5, 2, 5, -2)),
    ("dsigmf", (-3, 5, 2, 4)),
    ("psigmf", (2, 3, -5, 8)),
    ("psigmf", (-2, 6, 4, 1)),
    ("pimf", (1, 4, 5, 10)),
    ("pimf", (0, 2, 2, 9)),
    ("smf", (1, 8)),
    ("zmf", (2, 7)),
    ("gbellmf", (2, 3, 5)),
    ("gbellmf", (1.5, 0.75, 4)),
    ("gbellmf", (-2, 2.5, 6)),
    ("gaussmf", (1.5, 4)),
    ("gauss2mf", (1, 6, 2, 4)),
    ("gauss2mf", (0.5, 3, 1.5, 7)),
    ("sigmf", (-2, 5)),
    ("trimf", (1, 3, 9)),
    ("trapmf", (0, 2, 6, 10)),
]


@pytest.mark.parametrize("kind, params", CASES)
def test_each_membership_function_is_the_documented_formula_where_its_shape_matters(kind, params):
    x = np.linspace(-3.0, 13.0, 641)
    want = np.array([DOCUMENTED[kind](params, float(v)) for v in x])
    got = FisMF("m", kind, tuple(float(p) for p in params))(x)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert np.ptp(want) > 0.3  # the case has a shape: not flat on the grid


def test_the_dsigmf_cases_put_f2_above_f1():
    # what made the missing |.| invisible on main: no test had f2 > f1 anywhere
    x = np.linspace(-3.0, 13.0, 641)
    above = 0
    for kind, p in CASES:
        if kind == "dsigmf":
            f1 = np.array([_sig(p[0], p[1], v) for v in x])
            f2 = np.array([_sig(p[2], p[3], v) for v in x])
            above += (f2 - f1).max() > 0.3
    assert above == 3


# ----------------------------------------------------------------------------- bounds


def _many_rules(count: int) -> str:
    text = (DATA / "tipper.fis").read_text()
    head = text[: text.index("[Rules]")]
    return head + "[Rules]\n" + "1 1, 1 (1) : 1\n" * count


def test_more_rules_than_the_bound_are_refused_with_the_limit(tmp_path):
    from twolink.controllers.fuzzy.fis.matlab import MAX_RULES

    path = tmp_path / "many.fis"
    path.write_text(_many_rules(MAX_RULES + 1))
    message = _refusal(read_fis, path)
    assert message == (
        f"{path}: [Rules]: 10,001 rules > 10,000, the most whose exact evaluation of one "
        "input fits in 100 MiB (about 10 KiB a rule)"
    )
    path.write_text(_many_rules(MAX_RULES))
    assert len(read_fis(path).rules) == MAX_RULES


def test_the_exact_blocks_shrink_with_the_rules_to_stay_in_their_memory():
    from twolink.controllers.fuzzy.fis import exact

    assert exact.block_inputs(3) == 32
    assert exact.block_inputs(60_000) == 1  # on main: 32 inputs x 60,000 rules, ~19 GiB
    for rules in (3, 100, 400, 800, 5_000, 10_000):
        k = exact.block_inputs(rules)
        assert k == 32 or k * rules * exact.RULE_INPUT_BYTES <= exact.EXACT_BLOCK_BYTES


def test_evaluate_works_in_blocks_with_the_same_result_and_bounded_memory(monkeypatch):
    import tracemalloc

    from twolink.controllers.fuzzy.fis import matlab

    fis = read_fis(DATA / "tipper.fis")
    x = np.random.default_rng(0).uniform(0, 10, (200_000, 2))
    tracemalloc.start()
    whole = fis.evaluate(x, sampled=True)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    # the inputs (3.2 MB) and outputs are the caller's; one block's firing and aggregate
    # are under 64 MiB (on main: 200,000 x 101 samples x 8 bytes, several copies: ~0.6 GB)
    assert peak < 100 * 2**20, peak / 2**20
    exact = fis.evaluate(x[:40])  # in one block
    monkeypatch.setattr(matlab, "EVALUATE_BLOCK_BYTES", 32 * 200)  # blocks of ~1 input
    np.testing.assert_array_equal(fis.evaluate(x[:500], sampled=True), whole[:500])
    np.testing.assert_array_equal(fis.evaluate(x[:40]), exact)


def test_points_and_inputs_past_their_bounds_are_refused_with_the_limit():
    fis = read_fis(DATA / "tipper.fis")
    with pytest.raises(ValueError, match=r"tipper.fis: points: 1,000,001 > 1,000,000, the most"):
        fis.evaluate(np.zeros((1, 2)), sampled=True, points=1_000_001)
    huge = np.broadcast_to(np.zeros((1, 2)), (100_000_001, 2))  # a view: no memory
    with pytest.raises(ValueError, match=r"tipper.fis: 100,000,001 inputs > 100,000,000, the"):
        fis.evaluate(huge)
