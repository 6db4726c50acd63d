"""The compiled fuzzy kernels (controllers/fuzzy/kernels.py) equal the engines'
pure-Python paths to the bit, on inputs that cover every cell, the box's edges and
beyond it, the peaks themselves and no-fire points; and without numba the engines fall
back to their numpy paths."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from twolink.controllers.fuzzy import kernels
from twolink.controllers.fuzzy.continuous import ContinuousEngine
from twolink.controllers.fuzzy.table import FuzzyTable
from twolink.controllers.fuzzy.tables import default_fuzzy_pd, paper_fuzzy_pd
from twolink.simulation.config import load_scenario
from twolink.simulation.experiment import build_controller

pytestmark = pytest.mark.skipif(not kernels.available(), reason="numba is not installed")


def inputs(engine, n=4000, seed=0):
    rng = np.random.default_rng(seed)
    peaks_e = np.array(engine.e.universe)[[0, -1]]
    e = rng.uniform(-1.3, 1.3, n)
    de = rng.uniform(-1.3, 1.3, n)
    e[: n // 8] = rng.choice(np.linspace(-1.0, 1.0, 13), n // 8)  # on peaks and grid points
    de[n // 8 : n // 4] = 0.0
    e[-3:] = [peaks_e[0], peaks_e[1], -0.0]
    return e, de


def engines():
    designed = build_controller(load_scenario("runs/theta1_step_fcm.toml")).engine
    return {"designed": designed, "paper": paper_fuzzy_pd(), "default": default_fuzzy_pd()}


@pytest.mark.parametrize("name", ["designed", "paper", "default"])
def test_mamdani_kernel_equals_the_pure_python_path_to_the_bit(name):
    engine = engines()[name]
    e, de = inputs(engine)
    got = engine.evaluate_compiled(e, de)
    want = np.array(engine.evaluate_floats(e.tolist(), de.tolist()))
    assert np.array_equal(got, want)
    assert (want == engine.no_fire_output).any() or name != "designed"


@pytest.mark.parametrize("kind", ["table", "continuous"])
def test_table_and_continuous_kernels_equal_their_pure_python_paths(kind):
    exact = engines()["designed"]
    engine = FuzzyTable(exact, 41) if kind == "table" else ContinuousEngine(exact)
    e, de = inputs(exact, seed=1)
    got = engine.evaluate_compiled(e.reshape(-1, 2), de.reshape(-1, 2))
    want = np.array(engine.evaluate_floats(e.tolist(), de.tolist())).reshape(-1, 2)
    assert np.array_equal(got, want)


@pytest.mark.parametrize("kind", ["exact", "table", "continuous"])
def test_nan_is_refused_on_the_compiled_path(kind):
    exact = engines()["designed"]
    engine = {"exact": exact, "table": FuzzyTable(exact), "continuous": ContinuousEngine(exact)}
    e = np.zeros(200)
    e[7] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        engine[kind].evaluate_compiled(e, np.zeros(200))


def test_without_numba_the_numpy_paths_agree(monkeypatch):
    engine = engines()["designed"]
    e, de = inputs(engine, seed=2)
    compiled = {
        kind: eng.evaluate_compiled(e, de)
        for kind, eng in (
            ("exact", engine),
            ("table", FuzzyTable(engine, 41)),
            ("continuous", ContinuousEngine(engine)),
        )
    }
    monkeypatch.setattr(kernels, "available", lambda: False)
    np.testing.assert_allclose(
        engine.evaluate_compiled(e, de), compiled["exact"], rtol=0, atol=1e-12
    )
    assert np.array_equal(FuzzyTable(engine, 41).evaluate_compiled(e, de), compiled["table"])
    assert np.array_equal(ContinuousEngine(engine).evaluate_compiled(e, de), compiled["continuous"])


def test_building_a_table_or_a_design_does_not_import_numba():
    import subprocess
    import sys

    code = (
        "import sys; from twolink.controllers.fuzzy.table import FuzzyTable, table_bound; "
        "from twolink.controllers.fuzzy.tables import paper_fuzzy_pd; "
        "t = FuzzyTable(paper_fuzzy_pd()); table_bound(t, refine=1); "
        "print('numba' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_a_fork_servers_warm_kernels_are_the_ones_the_batch_laws_call():
    # The pools' preload (kernels_loaded) loads each kernel for the argument types the
    # engines pass: a batch of every fuzzy law afterwards compiles no second version.
    import subprocess
    import sys

    code = (
        "from twolink.controllers.fuzzy import kernels, kernels_loaded; "
        "import bench_batch as b; b.ARM_STEPS = 800; "
        "before = {k: len(f.signatures) for k, f in kernels._compiled().items()}; "
        "[b.batch_step_us(8, n) for n in ('FCM-CTC', 'FCM-CTC table', 'FCM-CTC continuous')]; "
        "after = {k: len(f.signatures) for k, f in kernels._compiled().items()}; "
        "print(before, after)"
    )
    bench = Path(__file__).resolve().parents[1] / "benchmarks"
    env = {**os.environ, "PYTHONPATH": str(bench)}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env
    )
    before, after = out.stdout.strip().split("} {")
    assert before + "}" == "{" + after == "{'mamdani': 1, 'table': 1, 'continuous': 1}"
