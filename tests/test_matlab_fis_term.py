"""A MATLAB FIS as the fuzzy term of a controller and of the lookup table; what cannot
work is refused in one line naming the file; twolink's own export measured against the
exact evaluation (docs/fuzzy.md, "Any MATLAB FIS")."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from twolink import ArmParams, ArmReference, FuzzyComputedTorque, Step
from twolink.controllers.fuzzy.engine import MamdaniEngine
from twolink.controllers.fuzzy.fis.engine_files import to_fis
from twolink.controllers.fuzzy.fis.matlab import FisTerm, parse_matlab_fis, read_fis
from twolink.controllers.fuzzy.table import FuzzyTable, table_bound
from twolink.simulation.config import ConfigError, load_scenario
from twolink.simulation.experiment import build_controller, run_scenario, trace_extras

REPO = Path(__file__).resolve().parents[1]
DATA = Path(__file__).parent / "data" / "fis"
STEP = REPO / "runs/paper/theta1_step.toml"


def scenario(tmp_path, fis: Path, **fuzzy) -> Path:
    extra = "".join(f"{k} = {v!r}\n".replace("'", '"') for k, v in fuzzy.items())
    f = tmp_path / "s.toml"
    f.write_text(
        f'extends = "{STEP}"\nduration = 0.3\n[controller]\nkind = "fcm_ctc"\n'
        f'rule_base = "{fis}"\n[controller.fuzzy]\n{extra}'
    )
    return f


def test_a_two_input_fis_is_the_fuzzy_term_of_a_scenario_and_its_table(tmp_path):
    fis = read_fis(DATA / "mam21.fis")  # angle, velocity -> force: gbellmf everywhere
    c = build_controller(load_scenario(scenario(tmp_path, DATA / "mam21.fis")))
    assert isinstance(c, FuzzyComputedTorque) and isinstance(c.engine, FisTerm)
    # the term is the file's system on normalised inputs: F(5 e, 5 de) / 5, clipped
    rng = np.random.default_rng(0)
    e, de = rng.uniform(-1.5, 1.5, 200), rng.uniform(-1.5, 1.5, 200)
    want = fis.evaluate(np.clip(np.stack([5 * e, 5 * de], 1), -5, 5))[:, 0] / 5
    assert np.max(np.abs(c.engine(e, de) - want)) < 1e-15
    assert c.engine.evaluate_floats([0.3, -0.2], [0.1, 0.4]) == pytest.approx(
        c.engine(np.array([0.3, -0.2]), np.array([0.1, 0.4])).tolist(), abs=1e-15
    )
    assert c.engine.scaling == (0.2, 0.2, 5.0)
    # with those as the scenario's scaling the correction is the file's own law, F(e, de)
    own = build_controller(load_scenario(scenario(tmp_path, DATA / "mam21.fis", ke=0.2,
                                                  kde=0.2, ku=5.0)))  # fmt: skip
    x = np.stack([rng.uniform(-5, 5, 50), rng.uniform(-5, 5, 50)], 1)
    law = own.ku * own.engine(own.ke * x[:, 0], own.kde * x[:, 1])
    assert np.max(np.abs(law - fis.evaluate(x)[:, 0])) < 1e-12
    traj = run_scenario(load_scenario(scenario(tmp_path, DATA / "mam21.fis")))
    assert np.isfinite(traj.q).all() and np.isfinite(traj.tau).all()
    labels = trace_extras(c, traj)["fired_rules"]  # what a recording shows
    assert (
        set(np.unique(labels).tolist()) <= {*c.engine.rules, "none"}
        and "small,small→negBig" in c.engine.rules
    )
    # the lookup table of the same term: exact at its nodes, close between them
    t = build_controller(load_scenario(scenario(tmp_path, DATA / "mam21.fis", engine="table",
                                                table_points=41)))  # fmt: skip
    assert isinstance(t.engine, FuzzyTable) and t.engine.exact is c.engine  # one cached term
    nodes = t.engine.e_nodes[::8]
    E, D = np.meshgrid(nodes, nodes, indexing="ij")
    assert np.max(np.abs(t.engine(E, D) - c.engine(E, D))) < 1e-15
    x = rng.uniform(-1, 1, (2, 400))
    assert np.max(np.abs(t.engine(*x) - c.engine(*x))) < 0.01
    # the library's constructor takes the file too
    fcm = FuzzyComputedTorque.fcm(ArmParams(), ArmReference(Step(final=0.05), Step(final=0.0)),
                                  rule_base=str(DATA / "mam21.fis"))  # fmt: skip
    assert isinstance(fcm.engine, FisTerm)


def test_the_rules_of_a_term_read_as_text():
    assert read_fis(DATA / "tipper.fis").term().rules == (
        "poor|rancid→cheap",
        "good,*→average",
        "excellent|delicious→generous",
    )
    text = read_fis(DATA / "allmf_min_max.fis").term().rules
    assert len(text) == 12 and text[3] == "gauss2,¬dsig→gauss2 (0.9)"
    assert text[11] == "gauss,dsig→¬gauss (0.4)"


def test_a_sugeno_fis_is_a_fuzzy_term_too(tmp_path):
    c = build_controller(load_scenario(scenario(tmp_path, DATA / "juggler.fis")))
    assert c.engine.scaling[2] == 1.0  # the output range [0 0]: not scaled
    x = np.array([[0.5, 0.2]])
    want = read_fis(DATA / "juggler.fis").evaluate(x * [4, 3.1415926])[0, 0]
    assert c.engine(0.5, 0.2) == pytest.approx(want, abs=1e-15)


@pytest.mark.parametrize(
    ("name", "fuzzy", "words"),
    [
        ("mam22.fis", {}, "a fuzzy term takes 2 inputs (error, rate) and 1 output; this "
                          "system has 2 inputs and 2 outputs"),
        ("tipper1.fis", {}, "this system has 1 inputs and 1 outputs"),
        ("mam21.fis", {"inference": "continuous"}, "continuous inference re-infers"),
    ],
)  # fmt: skip
def test_what_cannot_work_is_refused_in_one_line_naming_the_file(tmp_path, name, fuzzy, words):
    with pytest.raises(ConfigError) as err:
        load_scenario(scenario(tmp_path, DATA / name, **fuzzy))
    message = str(err.value)
    assert words in message and str(DATA / name) in message
    assert message.count(name) == 1 and "\n" not in message.strip()


def test_twolinks_own_export_keeps_the_project_engine_and_agrees_with_the_exact_evaluation():
    """docs/fuzzy.md: where a rule fires in both, the paper's table agrees to 1e-14 rad/s²
    and the designed rule base to 1.8e-2 rad/s² (skfuzzy's sampled centroid)."""
    measured = {}
    for rb in ("paper", "designed"):
        s = load_scenario(REPO / "runs/paper/base.toml",
                          {"controller": {"kind": "fcm_ctc", "rule_base": rb}})  # fmt: skip
        c = build_controller(s)
        assert isinstance(c.engine, MamdaniEngine)
        fis = parse_matlab_fis(to_fis(c.engine, rb, (c.ke, c.kde, c.ku)), f"{rb}.fis")
        (e_lo, e_hi), (d_lo, d_hi) = fis.inputs[0].range, fis.inputs[1].range
        rng = np.random.default_rng(1)
        x = np.stack([rng.uniform(e_lo, e_hi, 4000), rng.uniform(d_lo, d_hi, 4000)], 1)
        exact = fis.evaluate(x)[:, 0]
        ours = c.ku * c.engine(c.ke * x[:, 0], c.kde * x[:, 1])
        both = (fis.firing(x).sum(1) > 1e-12) & (
            c.engine.firing(c.ke * x[:, 0], c.kde * x[:, 1]).sum(-1) > 1e-12
        )
        assert both.sum() > 500
        measured[rb] = np.abs(exact - ours)[both].max()
    assert measured["paper"] < 1e-13
    assert 5e-3 < measured["designed"] < 2e-2


def test_coverage_of_a_matlab_fis(tmp_path):
    from click.testing import CliRunner

    from twolink.interface.cli import main

    gap = tmp_path / "gap.fis"
    gap.write_text(
        "[System]\nType='mamdani'\nNumInputs=2\nNumOutputs=1\n"
        "[Input1]\nName='e'\nRange=[-5 5]\nNumMFs=2\n"
        "MF1='N':'trimf',[-5 -3 -1]\nMF2='P':'trimf',[1 3 5]\n"
        "[Input2]\nName='de'\nRange=[-5 5]\nNumMFs=1\nMF1='any':'trapmf',[-6 -5 5 6]\n"
        "[Output1]\nName='u'\nRange=[-1 1]\nNumMFs=2\n"
        "MF1='N':'trimf',[-1 -0.5 0]\nMF2='P':'trimf',[0 0.5 1]\n"
        "[Rules]\n1 1, 1 (1) : 1\n2 1, 2 (1) : 1\n"
    )
    result = CliRunner().invoke(main, ["coverage", str(gap), "--grid", "101"])
    assert result.exit_code == 1, result.output
    # e in [-1, 1] of [-5, 5] fires nothing, and the ends e = ±5 (a triangle's foot):
    # 21 + 2 of 101 grid columns
    assert "no rule fires (total firing <= 0) on 22.77 % of the input box" in result.output
    assert "jumps are not listed" in result.output
    result = CliRunner().invoke(main, ["coverage", str(DATA / "mam21.fis")])
    assert result.exit_code == 0 and " 0.00 % of the input box" in result.output
    result = CliRunner().invoke(main, ["coverage", str(DATA / "mam22.fis")])
    assert result.exit_code == 2
    assert result.output.count("mam22.fis") == 1 and "2 outputs" in result.output


@pytest.mark.parametrize(
    ("name", "defuzz"),
    [("mam21.fis", None), ("tipper.fis", None), ("tank.fis", None), ("juggler.fis", None),
     ("juggler.fis", "wtsum"), ("allmf_probor_bisector.fis", None)],
)  # fmt: skip
def test_the_table_of_a_fis_term_holds_its_proven_bound(name, defuzz):
    """Every cell's largest error, on a grid 6 times finer (nodes and edges included),
    within that cell's bound (controllers/fuzzy/fis/bound.py)."""
    text = (DATA / name).read_text()
    if defuzz:
        text = text.replace("'wtaver'", f"'{defuzz}'")
    term = parse_matlab_fis(text, name).term()
    points, k = 11, 6
    table = FuzzyTable(term, points)
    bound = table_bound(table)
    fe = np.linspace(table.e_lo, table.e_hi, (points - 1) * k + 1)
    fd = np.linspace(table.d_lo, table.d_hi, (points - 1) * k + 1)
    E, D = np.meshgrid(fe, fd, indexing="ij")
    err = np.abs(table(E, D) - term(E, D))
    n = points - 1
    cells = err[: n * k, : n * k].reshape(n, k, n, k).max(axis=(1, 3))
    cells = np.maximum(cells, err[k::k, : n * k].reshape(n, n, k).max(axis=2))  # far edges
    cells = np.maximum(cells, err[: n * k, k::k].reshape(n, k, n).max(axis=1))
    assert (cells <= bound.cell_bound).all()
    assert bound.bound < 60 * cells.max()  # loose (a range, not a slope), not vacuous


def test_no_table_bound_for_a_maximum_based_defuzzifier():
    text = (DATA / "tipper.fis").read_text().replace("'centroid'", "'mom'")
    table = FuzzyTable(parse_matlab_fis(text, "tipper_mom.fis").term(), 5)
    with pytest.raises(ValueError, match=r"tipper_mom.fis: .* mom \(maximum-based"):
        table_bound(table)


@pytest.mark.parametrize(
    "name",
    ["tipper.fis", "tank.fis", "tank2.fis", "mam21.fis", "line_control.fis", "dual_sensor.fis"],
)
def test_the_public_files_refused_before_are_fuzzy_terms_now(tmp_path, name):
    c = build_controller(load_scenario(scenario(tmp_path, DATA / name)))
    assert isinstance(c.engine, FisTerm)
    assert np.isfinite(c.engine.evaluate_floats([0.2, -0.4], [0.1, 0.3])).all()


def test_the_batch_engine_runs_a_fis_term_as_the_single_path_does(tmp_path):
    from twolink.simulation.experiment import run_scenarios

    s = load_scenario(scenario(tmp_path, DATA / "tipper.fis"))
    single = run_scenario(s)
    for traj in run_scenarios([s, s]):  # one engine object: one batch law for both
        assert np.max(np.abs(traj.q - single.q)) < 1e-12
