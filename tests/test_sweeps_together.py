"""Several sweeps on one executor at once (``run_sweeps``: the regime map's two regimes):
each sweep's folder, chunks and table are those it gets alone."""

from __future__ import annotations

import pytest
from test_sweep import SMALL, chunk_bytes, columns_equal, write

from twolink import sweep as sw
from twolink.foundation.executors import open_executor

# The same sweep with other draws and raw steps of another size: a second, different sweep.
OTHER = SMALL.replace("seed = 7", "seed = 11").replace("final = 0.5", "final = -0.3")


def two_plans(tmp_path) -> list[sw.SweepPlan]:
    return [sw.load_sweep(write(tmp_path, t, f"{n}.toml")) for n, t in (("a", SMALL), ("b", OTHER))]


def alone(tmp_path, text: str, name: str) -> sw.SweepOutcome:
    plan = sw.load_sweep(write(tmp_path, text, f"{name}.toml"))
    return sw.run_sweep(plan, tmp_path / "alone" / name, executor="inprocess", plots=False)


@pytest.mark.parametrize("workers", [2, 8])  # 8: fewer chunks (6) than workers: in parts
def test_sweeps_run_together_equal_each_sweep_run_alone(tmp_path, workers):
    plans = two_plans(tmp_path)
    outs = [tmp_path / "together" / n for n in ("a", "b")]
    with open_executor("process", workers) as pool:
        together = sw.run_sweeps(list(zip(plans, outs, strict=True)), pool=pool, plots=False)
    assert [o.out for o in together] == outs
    for outcome, (name, text) in zip(together, (("a", SMALL), ("b", OTHER)), strict=True):
        ref = alone(tmp_path, text, name)
        assert sorted(outcome.computed) == sorted(ref.computed) and outcome.workers == workers
        columns_equal(ref.results, outcome.results)
        assert chunk_bytes(outcome.out) == chunk_bytes(ref.out)
        assert (outcome.out / "summary.csv").read_bytes() == (ref.out / "summary.csv").read_bytes()
    a, b = (o.results for o in together)
    assert not a["joint2_max_error_rad"].equals(b["joint2_max_error_rad"])  # two sweeps


def test_a_finished_sweep_beside_a_missing_one_computes_only_the_missing(tmp_path):
    plans = two_plans(tmp_path)
    outs = [tmp_path / n for n in ("a", "b")]
    sw.run_sweep(plans[0], outs[0], executor="inprocess", plots=False)
    first, second = sw.run_sweeps(
        list(zip(plans, outs, strict=True)), executor="inprocess", plots=False
    )
    assert first.computed == () and first.reused == (0, 1, 2)
    assert second.computed == (0, 1, 2) and second.reused == ()


def test_two_sweeps_into_one_folder_are_refused_before_anything_is_written(tmp_path):
    plan = sw.load_sweep(write(tmp_path, SMALL))
    with pytest.raises(ValueError, match="two sweeps into one folder"):
        sw.run_sweeps([(plan, tmp_path / "out"), (plan, tmp_path / "x" / ".." / "out")])
    assert not (tmp_path / "out").exists()
