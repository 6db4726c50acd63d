"""`twolink reproduce`: report vs saved trajectories, tables, recordings, determinism."""

import json
import math
import os
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pytest

from twolink.config import load_scenario
from twolink.manifest import METRIC_FIELDS, load_manifest
from twolink.metrics import step_metrics
from twolink.reproduce import reproduce
from twolink.sim import Trajectory


@pytest.fixture(scope="module")
def reproduction(tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduce")
    return reproduce(out=out, workers=2, progress=False)


def test_every_paper_table_is_in_the_report_beside_the_papers_values(reproduction):
    report = (reproduction.out / "report.md").read_text()
    manifest = load_manifest()
    for table in range(2, 9):
        assert f"### Table {table}:" in report
    # Table 2's CTC row carries the paper's numbers next to ours
    row = next(
        line for line in report.splitlines() if line.startswith("| CTC |") and "/ 5.89 |" in line
    )
    assert "/ 0.655 |" in row and "/ 0.21 |" in row
    assert len(reproduction.rows) == (
        len(manifest.experiments) * len(manifest.controllers) * len(manifest.variants)
    )
    assert (reproduction.out / "figures" / "design_phase_plane.png").stat().st_size > 10_000
    # beyond the paper: the flexible-joint stiffness study, table and figure
    assert "## Beyond the paper: flexible joints from stiff to soft" in report
    assert (reproduction.out / "figures" / "flexible_study.png").is_file()


def test_report_metrics_equal_step_metrics_of_the_saved_trajectories(reproduction):
    rows = json.loads((reproduction.out / "metrics.json").read_text())
    for row in rows:
        folder = reproduction.out / row["variant"] / row["experiment"] / row["controller"]
        traj = Trajectory.load(folder / "trajectory.npz")
        scenario = load_scenario(folder / "config.toml")
        j = row["joint"] - 1
        m = step_metrics(traj.t, traj.q[:, j], scenario.reference.final[j], y0=scenario.q0[j])
        for key, name in METRIC_FIELDS.items():
            expected = getattr(m, name)
            if math.isnan(expected):
                assert row[key] is None, (row, key)
            else:
                assert row[key] == expected, (row, key)
        per_run = json.loads((folder / "metrics.json").read_text())
        assert per_run[f"joint{row['joint']}"]["overshoot"] == row["Mp"]


def _rerun(*args):
    env = {**os.environ, "RERUN_CONFIG_DIR": "/tmp/twolink-rerun-config"}
    return subprocess.run(
        [sys.executable, "-m", "rerun", *args], capture_output=True, text=True, env=env, timeout=120
    )


def test_recordings_pass_rerun_rrd_verify(reproduction):
    files = [
        reproduction.out / "reproduction.rrd",
        reproduction.out / "rigid" / "table2" / "FCM" / "trace.rrd",
    ]
    for f in files:
        assert f.stat().st_size > 100_000
        result = _rerun("rrd", "verify", str(f))
        assert result.returncode == 0, result.stdout + result.stderr


def test_second_run_reuses_the_design_and_gives_identical_metrics(reproduction):
    again = reproduce(out=reproduction.out, workers=2, trace=False, progress=False)
    assert not again.designed
    # JSON text, so that NaN (undefined metrics) compares equal to NaN
    assert json.dumps(again.rows) == json.dumps(reproduction.rows)


def _files(folder: Path) -> dict[str, int]:
    return {str(p.relative_to(folder)): p.stat().st_size for p in folder.rglob("*") if p.is_file()}


@pytest.mark.slow
def test_interrupted_reproduction_leaves_whole_files_and_reruns_to_completion(
    tmp_path, reproduction
):
    out = tmp_path / "r"
    cmd = [sys.executable, "-m", "twolink.cli", "reproduce", "--out", str(out)]
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True
    )
    deadline = time.monotonic() + 120
    while len(list(out.rglob("trajectory.npz"))) < 6 and time.monotonic() < deadline:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C reaches the whole process group
    proc.communicate(timeout=120)
    assert proc.returncode != 0
    assert not [p for p in out.rglob("*") if p.name.endswith(".tmp")]
    for npz in out.rglob("trajectory.npz"):
        Trajectory.load(npz)  # whole, readable
    for toml_file in out.rglob("*.toml"):
        tomllib.loads(toml_file.read_text())
    subprocess.run(cmd + ["--no-trace"], check=True, capture_output=True, timeout=300)
    rows = json.loads((out / "metrics.json").read_text())
    expected = json.loads((reproduction.out / "metrics.json").read_text())
    assert rows == expected
