"""MuJoCo's warnings go to the run's record, never to MUJOCO_LOG.TXT in the working folder
(issue 49: nothing written outside --out). Before, MuJoCo's own handler appended to that
file, and printed to stderr, at every unstable step."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
# Joints far too stiff for the time step (√(k/j) = 1e9 rad/s): RK4 blows up at once, and
# with 10 physics steps per control period MuJoCo meets the huge values before the loop.
UNSTABLE = f"""extends = "{REPO / "runs" / "paper" / "theta1_step.toml"}"
duration = 0.05
timestep = 0.0001
control_dt = 0.001

[plant.flexibility]
k = 1e9
j = 1e-9
"""
UNSTABLE_TEXT = "MuJoCo warned: Nan, Inf or huge value in QACC; the simulation is unstable"


def test_an_unstable_run_names_mujocos_warning_in_its_record_and_writes_no_log(tmp_path):
    (tmp_path / "unstable.toml").write_text(UNSTABLE)
    done = subprocess.run(
        [sys.executable, "-m", "twolink", "run", "unstable.toml", "--out", "out", "--no-trace"],
        cwd=tmp_path, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert done.returncode == 1, done.stderr  # diverged
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out", "unstable.toml"]
    assert "WARNING" not in done.stderr and "unstable" not in done.stderr
    metrics = json.loads((tmp_path / "out" / "metrics.json").read_text())
    assert metrics["status"] == "diverged"
    assert UNSTABLE_TEXT in metrics["warnings"]


def test_an_arm_of_a_batch_that_goes_unstable_carries_the_warning_alone(tmp_path):
    (tmp_path / "unstable.toml").write_text(UNSTABLE)
    code = (
        "from twolink.simulation.config import load_scenario\n"
        "from twolink.simulation.experiment import run_scenarios\n"
        f"calm = load_scenario({str(REPO / 'runs' / 'paper' / 'theta1_step.toml')!r}, "
        "{'duration': 0.05, 'timestep': 0.0001, 'plant': {'flexibility': {'k': 500.0}}})\n"
        "bad = load_scenario('unstable.toml')\n"
        "for t in run_scenarios([calm, bad, calm]): print(t.status, list(t.warnings))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0] == lines[2] == "ok []"
    assert lines[1].startswith("diverged") and UNSTABLE_TEXT in lines[1]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["unstable.toml"]
    assert "WARNING" not in done.stderr


@pytest.mark.slow  # ~15 s: the flexible map's 288 runs, measured
def test_a_runaway_linearisation_prints_no_numpy_warning(tmp_path):
    """The reproduction's flexible study with model error: the linearisation's search
    evaluates flexible-FL laws far from any rest state, where w² overflows. Before, numpy
    printed ~30 RuntimeWarnings into `twolink reproduce`'s output; the answer (no rest
    state, NaN σ) is the run's record."""
    code = (
        "from twolink.sweep.plan import load_sweep\n"
        "from twolink.sweep.chunks import run_chunk\n"
        f"plan = load_sweep({str(REPO / 'runs' / 'sweeps' / 'flexible_map.toml')!r}, "
        "{'overrides': {'plant': {'scale': {'m1': 1.2, 'm2': 1.2, 'g': 1.1, "
        "'k': 0.8333333333333334}}}})\n"
        "print(len(run_chunk(plan, 0).rows))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0 and done.stdout.strip() == "288", done.stderr
    assert "Warning" not in done.stderr, done.stderr[:2000]
