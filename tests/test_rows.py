"""Every row its plant's (issue 49): a sweep's row depends on its own drawn plant, never
on the other arms of its batch, so the executor, the number of workers and the parts a
chunk is split into change no bit of the table."""

from __future__ import annotations

import hashlib
import sys
from pathlib import Path

import numpy as np
import pytest

from twolink import sweep as sw
from twolink.simulation.batch import BatchPlant, batch_model
from twolink.simulation.config import load_scenario
from twolink.simulation.experiment import _arm
from twolink.sweep.chunks import run_chunk_part

REPO = Path(__file__).resolve().parents[1]
ROBUSTNESS = REPO / "runs" / "sweeps" / "robustness.toml"  # the lab's 17-bit encoder


def rows_equal(a, b) -> None:
    """Rows equal cell for cell, NaN for NaN, floats bit for bit."""
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        assert len(x) == len(y)
        for u, v in zip(x, y, strict=True):
            if isinstance(u, float):
                assert np.array_equal(u, v, equal_nan=True), (x[:2], u, v)
            else:
                assert u == v


def short_plan(samples: int, chunk_size: int, duration: float = 1.5):
    return sw.load_sweep(
        ROBUSTNESS,
        {"samples": samples, "chunk_size": chunk_size, "overrides": {"duration": duration}},
    )


def test_a_chunk_computed_in_parts_gives_the_rows_of_the_whole_chunk():
    """What 1, 2 and 3 workers do with a sweep of fewer chunks than workers: each part is
    its own batch. Before, each part's model took the largest g of its own arms, and the
    encoder's quantiser turned the rounding into other counts (26 columns moved)."""
    plan = short_plan(9, 9)
    whole = sw.run_chunk(plan, 0).rows
    for cuts in ((0, 4, 9), (0, 3, 6, 9)):
        parts = []
        for start, stop in zip(cuts, cuts[1:], strict=False):
            parts += run_chunk_part(plan, 0, start, stop)[0].rows
        rows_equal(parts, whole)


def test_the_chunk_size_changes_no_row():
    """The model's gravity is the sweep's (from its g distribution's ends), not a batch's."""
    small = short_plan(6, 2, duration=0.8)
    large = short_plan(6, 6, duration=0.8)
    rows = [r for c in range(small.n_chunks) for r in sw.run_chunk(small, c).rows]
    rows_equal(rows, sw.run_chunk(large, 0).rows)


def test_the_sweeps_model_gravity_comes_from_its_definition():
    plan = short_plan(3, 3)
    g = plan.nominal_scenario().arm.g
    assert plan.model_gravity() == g * 1.1  # robustness: normal g truncated at [0.9, 1.1]
    for i in range(200):  # no draw exceeds it, and it does not depend on N
        assert abs(plan.draw(i)[0]["g"] * g) <= plan.model_gravity()
    assert short_plan(200, 100).model_gravity() == plan.model_gravity()
    nominal = sw.load_sweep(REPO / "runs" / "sweeps" / "flexible_map.toml")
    assert nominal.model_gravity() == nominal.nominal_scenario().plant_params.g
    import dataclasses

    open_normal = dataclasses.replace(
        plan,
        parameters=tuple(
            dataclasses.replace(p, low=None, high=None) if p.name == "g" else p
            for p in plan.parameters
        ),
    )
    assert open_normal.model_gravity() == pytest.approx(g * (1 + 10 * 0.02), rel=1e-15)


def test_a_batch_model_at_a_fixed_gravity_tilts_an_arm_the_same_in_any_batch():
    s = load_scenario(REPO / "runs" / "paper" / "base.toml")
    light = _arm(s)  # the nominal arm
    heavy = type(light)(light.params.scaled(g=1.05), light.flexibility, light.payload)
    alone = BatchPlant([light], 1e-3, model_g=s.arm.g * 1.1)
    beside = BatchPlant([heavy, light], 1e-3, model_g=s.arm.g * 1.1)
    q = beside.model.body("arm1_link1").quat
    assert np.array_equal(alone.model.body("arm0_link1").quat, q)
    assert not np.array_equal(q, [1, 0, 0, 0])  # tilted: its g is below the model's
    with pytest.raises(ValueError, match="cannot exceed"):
        batch_model([heavy], 1e-3, model_g=s.arm.g)


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.slow
def test_the_lab_sensor_sweep_is_byte_identical_on_1_2_3_workers_and_in_process(tmp_path):
    import subprocess

    digests = {}
    for label, args in (
        ("inprocess", ["--executor", "inprocess", "--workers", "1"]),
        ("w1", ["--workers", "1"]),
        ("w2", ["--workers", "2"]),
        ("w3", ["--workers", "3"]),
    ):
        out = tmp_path / label
        subprocess.run(
            [sys.executable, "-m", "twolink", "sweep", str(ROBUSTNESS), "-n", "16", "--out",
             str(out), "--no-plots", "--no-progress", *args],
            check=True, capture_output=True, timeout=600,
        )  # fmt: skip
        digests[label] = _sha256(out / "results.parquet")
    assert len(set(digests.values())) == 1, digests


@pytest.mark.slow
def test_compare_gives_the_same_rows_on_1_and_2_workers(tmp_path):
    import twolink

    short = {"duration": 1.5}
    one = twolink.compare("theta1_step", "CTC", "FCM-CTC", 6, workers=1, overrides=short)
    two = twolink.compare("theta1_step", "CTC", "FCM-CTC", 6, workers=2, overrides=short)
    rows_equal(list(one.results.itertuples(index=False)), list(two.results.itertuples(index=False)))


def test_the_mjx_engine_builds_an_arm_under_the_same_gravity_and_tilt():
    """MJX's arms are single-arm models; with the sweep's gravity each is tilted exactly
    as the CPU engine tilts it beside others (no JAX needed to build them)."""
    from twolink.simulation.mjx_engine import arm_model

    plan = short_plan(3, 3)
    s = load_scenario(REPO / "runs" / "paper" / "base.toml")
    arm = _arm(s)
    light = type(arm)(arm.params.scaled(g=0.93), arm.flexibility, arm.payload)
    g = plan.model_gravity()
    alone = arm_model(light, 1e-3, g)
    batch = BatchPlant([arm, light], 1e-3, model_g=g).model
    assert np.array_equal(alone.opt.gravity, batch.opt.gravity)
    assert np.array_equal(alone.body("arm0_link1").quat, batch.body("arm1_link1").quat)
    assert np.array_equal(arm_model(light, 1e-3).opt.gravity, [0, 0, -light.params.g])
