"""Monte Carlo sweeps: draws, executors, resumption after a kill, bad sweep files, failures."""

from __future__ import annotations

import csv
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from twolink import sweep as sw
from twolink.interface.cli import main as cli_main
from twolink.simulation import experiment
from twolink.simulation.config import ConfigError, load_scenario
from twolink.simulation.experiment import measure, run_scenario
from twolink.simulation.vocabulary import STEP_KEYS

REPO = Path(__file__).resolve().parents[1]
BASE = REPO / "runs" / "paper" / "base.toml"

# A small sweep: short runs, both controllers, every kind of distribution, flexible joints.
SMALL = f"""
name = "small"
scenario = "{BASE}"
samples = 8
seed = 7
chunk_size = 3

[overrides]
duration = 0.5

[reference.joint1]
kind = "step"
final = 1.0

[reference.joint2]
kind = "step"
final = 0.5

[parameters]
m1 = {{ dist = "uniform", low = 0.8, high = 1.2 }}
m2 = {{ dist = "normal", mean = 1.0, std = 0.1, low = 0.5 }}
l2 = {{ dist = "loguniform", low = 0.9, high = 1.1 }}
payload = {{ dist = "choice", values = [0.0, 0.1, 0.2], weights = [1, 1, 2] }}
k = {{ dist = "grid", values = [50.0, 5000.0] }}

[controllers.ctc]
kind = "ctc"

[controllers.fcm]
kind = "fcm_ctc"
rule_base = "paper"
"""


def write(tmp_path: Path, text: str, name: str = "sweep.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def columns_equal(a: pd.DataFrame, b: pd.DataFrame, attrs: bool = True) -> None:
    assert list(a.columns) == list(b.columns)
    assert a.attrs == b.attrs or not attrs
    for name in a.columns:
        x, y = a[name].to_numpy(), b[name].to_numpy()
        if x.dtype.kind in "fi":
            assert np.array_equal(x, y, equal_nan=True), name
        else:
            assert list(x) == list(y), name


def chunk_bytes(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((out / "chunks").glob("chunk_*.parquet"))}


def sweep_command(args: list[str]):
    return CliRunner().invoke(cli_main, ["sweep", *args])


def log_chunks(out: Path) -> list[int]:
    return [int(line.split()[0]) for line in (out / "computed.log").read_text().splitlines()]


# ----------------------------------------------------------------------------- draws


def test_each_sample_draws_from_its_own_seeded_generator(tmp_path):
    plan = sw.load_sweep(write(tmp_path, SMALL))
    assert plan.parameter_names == ("k", "l2", "m1", "m2", "payload")
    for i in range(plan.samples):
        values, noise_seed = plan.draw(i)
        # The same draws, by hand: grid from the index, the rest in name order.
        rng = np.random.default_rng([7, i])
        expected = {"k": (50.0, 5000.0)[i % 2]}
        expected["l2"] = math.exp(rng.uniform(math.log(0.9), math.log(1.1)))
        expected["m1"] = rng.uniform(0.8, 1.2)
        while True:
            m2 = rng.normal(1.0, 0.1)
            if m2 >= 0.5:
                break
        expected["m2"] = m2
        expected["payload"] = (0.0, 0.1, 0.2)[rng.choice(3, p=[0.25, 0.25, 0.5])]
        assert values == pytest.approx(expected, rel=0, abs=0)
        assert noise_seed == int(rng.integers(0, 2**31))
    # Independent of N and of which samples are computed.
    bigger = sw.load_sweep(write(tmp_path, SMALL), {"samples": 1000})
    assert bigger.draw(5) == plan.draw(5)
    assert bigger.draw(999)[0] != plan.draw(5)[0]


def test_grid_is_the_full_product_cycled(tmp_path):
    text = SMALL.replace(
        'm1 = { dist = "uniform", low = 0.8, high = 1.2 }',
        'm1 = { dist = "grid", values = [0.9, 1.0, 1.1] }',
    )
    plan = sw.load_sweep(write(tmp_path, text), {"samples": 12})
    points = [(plan.draw(i)[0]["k"], plan.draw(i)[0]["m1"]) for i in range(12)]
    product = [(k, m) for m in (0.9, 1.0, 1.1) for k in (50.0, 5000.0)]
    assert points == product + product


def test_a_row_equals_a_direct_run_of_its_drawn_scenario(tmp_path):
    """The sweep's plumbing (shared plant, reused controllers) changes nothing."""
    plan = sw.load_sweep(write(tmp_path, SMALL))
    result = sw.run_chunk(plan, 1)  # samples 3, 4, 5: not the first of its chunk
    row = dict(zip(plan.columns, result.rows[5], strict=True))  # sample 5, fcm
    assert (row["sample"], row["controller"]) == (5, "fcm")
    v = plan.draw(5)[0]
    s = load_scenario(
        BASE,
        {
            "duration": 0.5,
            "reference": {
                "joint1": {"kind": "step", "final": 1.0},
                "joint2": {"kind": "step", "final": 0.5},
            },
            "plant": {
                "scale": {"m1": v["m1"], "m2": v["m2"], "l2": v["l2"]},
                "payload": v["payload"],
                "flexibility": {"k": v["k"]},
            },
            "controller": {"kind": "fcm_ctc", "rule_base": "paper"},
        },
    )
    m = measure(s, run_scenario(s))
    assert row["status"] == m.status == "ok"
    got, want = [], []
    for j in (1, 2):
        got += [row[f"joint{j}_{key}"] for key in (*STEP_KEYS, "iae_rad_s", "torque_peak_Nm")]
        step = m.step[j - 1]
        want += [step.peak_time, step.delay_time, step.rise_time, step.settling_time]
        want += [step.overshoot, step.steady_state_error]  # percent, as in the table
        want += [m.errors.iae[j - 1], m.torque.peak[j - 1]]
    assert np.isfinite(want).sum() >= 10
    assert np.array_equal(got, want, equal_nan=True)  # bit for bit


# ----------------------------------------------------------------------------- executors


def test_inprocess_process_and_dask_give_identical_results(tmp_path):
    # dask is a test dependency: this runs (never skips) wherever the tests run
    plan = sw.load_sweep(write(tmp_path, SMALL))
    outs = {}
    for kind in ("inprocess", "process", "dask"):
        outcome = sw.run_sweep(plan, tmp_path / kind, executor=kind, workers=2, plots=False)
        assert outcome.computed and not outcome.reused
        outs[kind] = outcome
    assert outs["process"].workers == outs["dask"].workers == 2
    ref = outs["inprocess"]
    assert len(ref.results) == plan.samples * 2
    assert set(ref.results["status"]) == {"ok"}
    for kind in ("process", "dask"):
        columns_equal(ref.results, outs[kind].results)
        assert chunk_bytes(tmp_path / kind) == chunk_bytes(tmp_path / "inprocess")
        assert (tmp_path / kind / "summary.csv").read_bytes() == (
            tmp_path / "inprocess" / "summary.csv"
        ).read_bytes()
    # The process pool really ran in other processes.
    pids = {line.split("pid=")[1].split()[0] for line in (tmp_path / "process" / "computed.log")
            .read_text().splitlines()}  # fmt: skip
    assert str(os.getpid()) not in pids


def test_dask_on_a_running_scheduler(tmp_path):
    from dask import distributed

    plan = sw.load_sweep(write(tmp_path, SMALL), {"samples": 4})
    ref = sw.run_sweep(plan, tmp_path / "ref", executor="inprocess", plots=False)
    with distributed.LocalCluster(
        n_workers=2, processes=False, threads_per_worker=1, dashboard_address=None
    ) as cluster:
        outcome = sw.run_sweep(
            plan, tmp_path / "dask", scheduler=cluster.scheduler_address, plots=False
        )
    columns_equal(ref.results, outcome.results)


# ----------------------------------------------------------------------------- resumption

# Enough work (~3 s on one core) that the signal lands well before the end even on a
# loaded machine; chunks of one sample, so there are many of them.
KILL = f"""
scenario = "{BASE}"
samples = 80
seed = 3
chunk_size = 1

[overrides]
duration = 2.0

[reference.joint1]
kind = "step"
final = 1.0

[parameters]
m2 = {{ dist = "uniform", low = 0.5, high = 1.5 }}

[controllers.ctc]
kind = "ctc"

[controllers.stiff]
kind = "ctc"
kp = 25.0
kd = 10.0
"""


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory) -> Path:
    """The kill test's sweep, run in one go."""
    tmp = tmp_path_factory.mktemp("uninterrupted")
    plan = sw.load_sweep(write(tmp, KILL))
    sw.run_sweep(plan, tmp / "out", executor="process", workers=2, plots=False)
    return tmp / "out"


def interrupt_once(cmd: list[str], out: Path, signum: int) -> subprocess.CompletedProcess:
    """Start the sweep, send ``signum`` once 3 chunks exist; return how it ended."""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while len(list((out / "chunks").glob("chunk_*.parquet"))) < 3:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "no chunks written"
        time.sleep(0.01)
    os.kill(proc.pid, signum)
    stdout, stderr = proc.communicate(timeout=60)
    return subprocess.CompletedProcess(cmd, proc.returncode, stdout, stderr)


@pytest.mark.parametrize(
    ("signum", "executor"),
    [
        # the in-process variant is slow (38 s); SIGTERM on the pool stays in the default suite
        pytest.param(signal.SIGINT, "inprocess", marks=pytest.mark.slow),
        (signal.SIGTERM, "process"),
    ],
)
def test_killed_sweep_resumes_without_recomputing(tmp_path, signum, executor, uninterrupted):
    path = write(tmp_path, KILL)
    for attempt in range(3):
        out = tmp_path / f"out{attempt}"
        cmd = [sys.executable, "-m", "twolink", "sweep", str(path), "--out", str(out)]
        cmd += ["--executor", executor, "--workers", "2", "--no-plots", "--no-progress"]
        ended = interrupt_once(cmd, out, signum)
        # On a starved machine the whole sweep can finish before the signal lands; that
        # run tests nothing, so start over (the signal handling itself is asserted below).
        if not (ended.returncode == 0 and "0 reused" in ended.stdout):
            break
    assert ended.returncode == 128 + signum, (ended.stdout, ended.stderr)
    assert "run the same command again" in ended.stderr
    assert signal.Signals(signum).name in ended.stderr

    plan = sw.load_sweep(path)
    kept = chunk_bytes(out)
    kept_ids = sorted(int(name[6:11]) for name in kept)
    assert 3 <= len(kept) < plan.n_chunks, "the sweep should have been stopped halfway"
    assert sorted(log_chunks(out)) == kept_ids  # every chunk file is logged, and only those
    assert not (out / "results.csv").exists() and not (out / "results.parquet").exists()
    stamps = {p.name: p.stat().st_mtime_ns for p in (out / "chunks").glob("chunk_*.parquet")}

    rerun = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert rerun.returncode == 0, rerun.stderr
    assert f"{plan.n_chunks - len(kept)} chunks computed, {len(kept)} reused" in rerun.stdout
    log = log_chunks(out)
    assert sorted(log) == list(range(plan.n_chunks))  # each chunk computed exactly once
    for name, data in kept.items():
        assert (out / "chunks" / name).read_bytes() == data
        assert (out / "chunks" / name).stat().st_mtime_ns == stamps[name]

    columns_equal(sw.load_results(uninterrupted), sw.load_results(out))
    assert chunk_bytes(out) == chunk_bytes(uninterrupted)


def test_rerun_of_a_finished_sweep_computes_nothing_and_more_samples_extend_it(tmp_path):
    path = write(tmp_path, SMALL)
    plan = sw.load_sweep(path, {"samples": 4})
    first = sw.run_sweep(plan, tmp_path / "out", executor="inprocess", plots=False)
    assert first.computed == (0, 1) and first.reused == ()
    again = sw.run_sweep(plan, tmp_path / "out", executor="inprocess", plots=False)
    assert again.computed == () and again.reused == (0, 1)
    columns_equal(first.results, again.results)
    # Sample 3 sits alone in chunk 1 at N = 4: that chunk is redone, chunk 0 is kept.
    more = sw.load_sweep(path, {"samples": 8})
    grown = sw.run_sweep(more, tmp_path / "out", executor="inprocess", plots=False)
    assert grown.computed == (1, 2) and grown.reused == (0,)
    whole = sw.run_sweep(more, tmp_path / "whole", executor="inprocess", plots=False)
    columns_equal(whole.results, grown.results)


def test_a_changed_sweep_file_into_the_same_folder_is_refused(tmp_path):
    path = write(tmp_path, SMALL.replace("samples = 8", "samples = 3"))
    out = tmp_path / "out"
    args = [str(path), "--out", str(out), "--executor", "inprocess", "--no-plots"]
    assert sweep_command(args).exit_code == 0
    path.write_text(path.read_text().replace("seed = 7", "seed = 8"))
    result = sweep_command(args)
    assert result.exit_code == 2
    assert "holds results of a different sweep" in result.output
    assert "--fresh" in result.output
    result = sweep_command([*args, "--fresh"])
    assert result.exit_code == 0, result.output
    assert "1 chunks computed, 0 reused" in result.output


# ----------------------------------------------------------------------------- bad files

BAD_CASES = {
    "uniform low > high": (
        'm1 = { dist = "uniform", low = 0.8, high = 1.2 }',
        'm1 = { dist = "uniform", low = 1.2, high = 0.8 }',
        "parameters.m1.high: must be >= low (1.2): the distribution is empty",
    ),
    "empty choice": (
        "values = [0.0, 0.1, 0.2], weights = [1, 1, 2]",
        "values = []",
        "parameters.payload.values: must be a non-empty list",
    ),
    "negative mass bound": (
        'm1 = { dist = "uniform", low = 0.8, high = 1.2 }',
        'm1 = { dist = "uniform", low = -0.1, high = 1.2 }',
        "parameters.m1.low: must be > 0 for parameter 'm1', got -0.1",
    ),
    "negative length bound": (
        'l2 = { dist = "loguniform", low = 0.9, high = 1.1 }',
        'l2 = { dist = "grid", values = [1.0, -1.0] }',
        "parameters.l2.values: must be > 0 for parameter 'l2', got -1.0",
    ),
    "negative stiffness": (
        'k = { dist = "grid", values = [50.0, 5000.0] }',
        'k = { dist = "uniform", low = -5.0, high = 50.0 }',
        "parameters.k.low: must be > 0 for parameter 'k', got -5.0",
    ),
    "normal mass without truncation": (
        "std = 0.1, low = 0.5 }",
        "std = 0.1 }",
        "parameters.m2.low: missing: a normal draw of 'm2' can be negative",
    ),
    "unknown executor": ("[controllers.ctc]", '[execution]\nexecutor = "mpi"\n\n[controllers.ctc]',
                         "execution.executor: must be one of"),  # fmt: skip
    "unknown top-level key": ("seed = 7", "seed = 7\nsample = 3", "sample: unknown key"),
    "unknown distribution key": ("low = 0.8, high", "lo = 0.8, high",
                                 "parameters.m1.lo: unknown key"),  # fmt: skip
    "unknown parameter": ("[parameters]", "[parameters]\nmass_ratio = 1.0",
                          "parameters.mass_ratio: unknown parameter"),  # fmt: skip
    "unknown distribution": ('dist = "uniform"', 'dist = "beta"',
                             "parameters.m1.dist: must be one of"),  # fmt: skip
    "n < 1": ("samples = 8", "samples = 0", "samples: must be an integer >= 1, got 0"),
    "no controllers": ('[controllers.ctc]\nkind = "ctc"\n\n[controllers.fcm]\nkind = "fcm_ctc"\n'
                       'rule_base = "paper"', "", "controllers: missing"),  # fmt: skip
    "bad controller gain": ('kind = "ctc"', 'kind = "ctc"\nkp = -1.0',
                            "controllers.ctc.kp: must be >= 0.0, got -1"),  # fmt: skip
    "bad override": ("duration = 0.5", "duration = -0.5", "overrides.duration: must be > 0"),
    "k and k1 together": ("[parameters]", '[parameters]\nk1 = { dist = "grid", values = [1.0] }',
                          "parameters.k1: conflicts with 'k'"),  # fmt: skip
    "missing base scenario": (f'scenario = "{BASE}"', 'scenario = "nope.toml"',
                              "nope.toml: no such file"),  # fmt: skip
}  # fmt: skip


@pytest.mark.parametrize("case", sorted(BAD_CASES))
def test_invalid_sweep_files_exit_2_naming_file_and_key(tmp_path, case):
    old, new, message = BAD_CASES[case]
    assert old in SMALL
    path = write(tmp_path, SMALL.replace(old, new, 1))
    with pytest.raises(ConfigError) as err:
        sw.load_sweep(path)
    assert str(err.value).startswith(f"{path}: ")
    assert message in str(err.value)
    result = sweep_command([str(path), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2
    assert f"error: {path}: " in result.output and message in result.output
    assert not (tmp_path / "o").exists()


def test_bad_command_line_options_exit_2(tmp_path):
    path = write(tmp_path, SMALL)
    for args in (["--executor", "mpi"], ["--workers", "0"], ["--samples", "0"],
                 ["--executor", "process", "--scheduler", "tcp://127.0.0.1:1"]):  # fmt: skip
        result = sweep_command([str(path), "--out", str(tmp_path / "o"), *args])
        assert result.exit_code == 2, (args, result.output)
    assert not (tmp_path / "o").exists()


# ----------------------------------------------------------------------------- failures


def test_raising_and_diverging_samples_are_recorded_and_the_sweep_goes_on(tmp_path, monkeypatch):
    text = SMALL.replace(
        '[controllers.fcm]\nkind = "fcm_ctc"\nrule_base = "paper"',
        # ZOH at 1 kHz with natural frequency 3000 rad/s: the discrete loop is unstable.
        '[controllers.wild]\nkind = "ctc"\nkp = 1e7\nkd = 10.0\ntorque_limit = inf',
    )
    plan = sw.load_sweep(write(tmp_path, text))
    real = experiment._arm

    def arm(s):  # the arm of sample 4 cannot be built; the batch's others still run
        if abs(s.plant.scale["m1"] - plan.draw(4)[0]["m1"]) < 1e-15:
            raise RuntimeError("boom on sample 4")
        return real(s)

    monkeypatch.setattr(experiment, "_arm", arm)
    outcome = sw.run_sweep(plan, tmp_path / "out", executor="inprocess", plots=True)
    r = outcome.results
    assert len(r) == 2 * plan.samples and list(r["sample"]) == [
        i for i in range(plan.samples) for _ in range(2)
    ]
    status, message = r["status"].to_numpy(object), r["message"].to_numpy(object)
    failed = (r["sample"] == 4).to_numpy()
    assert set(status[failed]) == {"error"}
    assert all(m == "RuntimeError: boom on sample 4" for m in message[failed])
    assert np.isnan(r["joint1_overshoot_pct"][failed]).all()
    wild = (r["controller"] == "wild").to_numpy() & ~failed
    assert set(status[wild]) == {"diverged"}
    assert all("out of bounds" in m for m in message[wild])
    ctc = (r["controller"] == "ctc").to_numpy() & ~failed
    assert set(status[ctc]) == {"ok"} and set(message[ctc]) == {""}
    # 0.5 s is too short to settle: the runs complete but are off target, not successes
    outcomes = r["outcome"].to_numpy(object)
    assert set(outcomes[ctc]) == {"off target"} and set(outcomes[failed]) == {"error"}
    assert set(outcomes[wild]) == {"diverged"}
    assert outcome.summary["ctc"]["off_target"] == plan.samples - 1
    assert outcome.summary["ctc"]["success_rate"] == 0.0
    assert outcome.summary["wild"]["diverged"] == plan.samples - 1
    assert outcome.summary["wild"]["error"] == 1
    assert (tmp_path / "out" / "plots" / "metrics.png").stat().st_size > 0


# ----------------------------------------------------------------------------- outputs


def test_summary_matches_the_table_it_summarises(tmp_path):
    plan = sw.load_sweep(write(tmp_path, SMALL))
    outcome = sw.run_sweep(plan, tmp_path / "out", executor="inprocess", plots=False)
    with open(tmp_path / "out" / "summary.csv", newline="") as fh:
        summary = {row["controller"]: row for row in csv.DictReader(fh)}
    r = outcome.results
    for c in ("ctc", "fcm"):
        ok = r[(r["controller"] == c) & (r["status"] == "ok")]
        for j in (1, 2):
            x = ok[f"joint{j}_overshoot_pct"].to_numpy()
            assert float(summary[c][f"joint{j}_overshoot_pct_mean"]) == pytest.approx(x.mean())
            assert float(summary[c][f"joint{j}_overshoot_pct_p95"]) == pytest.approx(
                np.percentile(x, 95)
            )
        mine = r[r["controller"] == c]
        assert float(summary[c]["success_rate"]) == (mine["outcome"] == "met spec").mean()
        counts = [int(summary[c][k]) for k in ("met_spec", "off_target", "diverged", "error")]
        assert sum(counts) == int(summary[c]["runs"]) == plan.samples


SPEC = f"""
scenario = "{BASE}"
samples = 4
seed = 1
chunk_size = 2

[overrides]
duration = 3.0

[reference.joint1]
kind = "step"
final = 1.0

[parameters]
m2 = {{ dist = "uniform", low = 0.95, high = 1.05 }}

[controllers.stiff]        # ωn = 5 rad/s, ζ = 1: settles in ~1.2 s, ess ~ 4e-3 rad
kind = "ctc"
kp = 25.0
kd = 10.0

[controllers.weak]         # ωn = 0.7 rad/s: far from the target after 3 s
kind = "ctc"
kp = 0.5
kd = 1.4
"""


def test_runs_are_classified_against_the_spec_and_the_spec_is_the_files(tmp_path):
    path = write(tmp_path, SPEC)
    outcome = sw.run_sweep(sw.load_sweep(path), tmp_path / "out", executor="inprocess")
    r = outcome.results
    stiff, weak = r[r["controller"] == "stiff"], r[r["controller"] == "weak"]
    assert (stiff["joint1_final_error_rad"] < 0.02).all()
    assert set(stiff["outcome"]) == {"met spec"}
    assert (weak["joint1_final_error_rad"] > 0.1).all() and set(weak["outcome"]) == {"off target"}
    assert set(r["status"]) == {"ok"}  # neither diverged: "ok" alone is not success
    assert outcome.summary["stiff"]["met_spec"] == 4 and outcome.summary["weak"]["off_target"] == 4
    printed = sw.format_summary(outcome.summary)
    assert "weak: 0/4 met the spec (0.0 %), 4 off target, 0 diverged" in printed
    # A looser spec in the file reclassifies the same rows, without recomputing them.
    # (the band holds over the settling window: the tail's largest error decides). What
    # no band decides stays so: a weak law's held joint still dragged away at the end of
    # its 3 s (its loop stable at rest) has a growth the run cannot tell, "undecided".
    worst = float(r[["joint1_tail_error_rad", "joint2_tail_error_rad"]].max().max())
    path.write_text(SPEC + f"\n[success]\nfinal_error = {worst * 1.01}\n")
    loose = sw.run_sweep(sw.load_sweep(path), tmp_path / "out", executor="inprocess", plots=False)
    assert loose.computed == () and loose.reused == (0, 1)
    unknown = loose.results[["joint1_tail_growth", "joint2_tail_growth"]].isna().any(axis=1)
    assert (loose.results["outcome"] == np.where(unknown, "undecided", "met spec")).all()
    assert loose.results.attrs["success"]["final_error"] == pytest.approx(worst * 1.01)
    path.write_text(SPEC + "\n[success]\nfinal_error = -1.0\n")
    with pytest.raises(ConfigError, match="success.final_error: must be > 0"):
        sw.load_sweep(path)


def test_the_robustness_sweep_never_counts_a_run_off_target_as_a_success(tmp_path):
    plan = sw.load_sweep(REPO / "runs" / "sweeps" / "robustness.toml", {"samples": 4})
    outcome = sw.run_sweep(plan, tmp_path / "out", executor="inprocess", plots=False)
    r = outcome.results
    band = plan.success.final_error * plan.step
    off = (r[["joint1_final_error_rad", "joint2_final_error_rad"]] > band).any(axis=1)
    assert off.any()  # the shipped gains leave some arms sagging (issue-tracked)
    assert not (r.loc[off, "outcome"] == "met spec").any()
    for name, s in outcome.summary.items():
        assert s["met_spec"] + s["off_target"] + s["diverged"] + s["error"] == s["runs"] == 4
        assert s["met_spec"] <= int(
            ((r["controller"] == name) & ~off & (r["status"] == "ok")).sum()
        )
    first = sw.format_summary(outcome.summary).splitlines()[0]
    assert "met the spec" in first and "off target" in first and "diverged" in first


def test_table_is_parquet_and_reads_back_as_the_same_dataframe(tmp_path):
    plan = sw.load_sweep(write(tmp_path, SMALL), {"samples": 3})
    outcome = sw.run_sweep(plan, tmp_path / "a", executor="inprocess", plots=False)
    assert outcome.table == tmp_path / "a" / "results.parquet"
    assert not (tmp_path / "a" / "results.csv").exists()
    loaded = sw.load_results(tmp_path / "a")
    assert isinstance(loaded, pd.DataFrame)
    assert loaded.attrs == {
        "controllers": ["ctc", "fcm"],
        "parameters": ["k", "l2", "m1", "m2", "payload"],
        "joints": [1, 2],
        "success": {
            "final_error": 0.02,
            "max_overshoot_pct": 20.0,
            "max_tail_growth": 1.25,
            "step_rad": 1.0,
        },
    }
    columns = list(plan.columns)
    assert list(loaded.columns) == [*columns[:-1], "outcome", columns[-1]]
    assert loaded["sample"].dtype == np.int64
    columns_equal(outcome.results, loaded)
    # A plain pandas read gives the same frame, metadata included: no twolink needed.
    columns_equal(loaded, pd.read_parquet(tmp_path / "a" / "results.parquet"))
    chunks = pd.concat(
        [pd.read_parquet(p) for p in sorted((tmp_path / "a" / "chunks").glob("*.parquet"))],
        ignore_index=True,
    )
    # Each row equals its chunk's row, bit for bit; the outcome is added from the spec.
    columns_equal(loaded[list(chunks.columns)], chunks, attrs=False)
    assert list(chunks.columns) == list(plan.columns)


def test_shipped_sweep_files_load_and_run(tmp_path):
    for name in ("robustness", "flexible_map"):
        plan = sw.load_sweep(REPO / "runs" / "sweeps" / f"{name}.toml")
        names = dict(plan.controllers)
        assert names["CTC"] == {"kind": "ctc"}
        assert names["FCM-CTC"] == {"kind": "fcm_ctc", "rule_base": "designed"}
        assert plan.joints == (1, 2)
        short = sw.load_sweep(
            REPO / "runs" / "sweeps" / f"{name}.toml",
            {"samples": 1, "overrides": {"duration": 0.3}},
        )
        outcome = sw.run_sweep(short, tmp_path / name, executor="inprocess", plots=False)
        assert set(outcome.results["status"]) == {"ok"}
    flex = sw.load_sweep(REPO / "runs" / "sweeps" / "flexible_map.toml")
    grid = [flex.draw(i)[0] for i in range(flex.samples)]
    stiffness = sorted({g["k"] for g in grid}, reverse=True)
    assert [g["k"] for g in grid[: len(stiffness)]] == stiffness  # k varies fastest
    assert stiffness[0] / stiffness[-1] >= 1e4 and len(grid) == len(stiffness) * 6


def fake_results(k: list[float], ess: list[float], status: list[str]) -> pd.DataFrame:
    n = len(k)
    cols = {
        "sample": np.arange(n),
        "controller": ["a", "b"] * (n // 2),
        "k": np.array(k, dtype=float),
        **{f: np.full(n, 0.5) for f in sw.METRIC_COLUMNS},
        "status": status,
        "outcome": ["met spec" if x == "ok" else "diverged" for x in status],
        "message": [""] * n,
    }
    cols["joint1_steady_state_error_rad"] = np.array(ess, dtype=float)
    df = pd.DataFrame(cols)
    df.attrs.update(controllers=["a", "b"], parameters=["k"], joints=[1])
    return df


def test_flexible_study_table_bins_by_stiffness():
    k = [10.0, 10.0, 10.0, 10.0, 1.0, 1.0]
    ess = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6]
    status = ["ok", "ok", "ok", "diverged", "ok", "ok"]
    table = sw.flexible_study_table(fake_results(k, ess, status)).splitlines()
    head = "| stiffness [N·m/rad] | controller | runs | met spec | θ1 median ess [rad]"
    assert table[0].startswith(head)
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in table[2:]]
    # stiff to soft; a: ess 0.1, 0.3 at k=10 -> median 0.2; b: 0.2 ok, 0.4 diverged
    assert [r[:5] for r in rows] == [
        ["10", "a", "2", "100 %", "0.2"],
        ["10", "b", "2", "50 %", "0.2"],
        ["1", "a", "1", "100 %", "0.5"],
        ["1", "b", "1", "100 %", "0.6"],
    ]
    many = fake_results(list(np.geomspace(1, 1000, 40)), [0.1] * 40, ["ok"] * 40)
    binned = sw.flexible_study_table(many, bins=3).splitlines()[2:]
    assert len(binned) == 3 * 2 and binned[0].startswith("| 100 – 1000 | a | 7 |")


def test_flexible_study_figure_plots_every_controller():
    fig = sw.flexible_study_figure(
        fake_results([10.0, 10.0, 1.0, 1.0], [0.1, 0.2, 0.3, 0.4], ["ok"] * 4)
    )
    visible = [ax for ax in fig.axes if ax.get_visible()]
    assert len(visible) == 1 + 3  # success rate, ess, Mp, Ts of joint 1
    assert all(ax.get_xscale() == "log" for ax in visible)
    assert [t.get_text() for t in visible[0].get_legend().get_texts()] == ["a", "b"]


def test_dask_executor_without_dask_says_how_to_get_it(tmp_path, monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_dask(name, *args, **kwargs):
        if name == "dask" or name.startswith("dask."):
            raise ImportError("No module named 'dask'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_dask)
    path = write(tmp_path, SMALL.replace("samples = 8", "samples = 2"))
    result = sweep_command([str(path), "--out", str(tmp_path / "o"), "--executor", "dask"])
    assert result.exit_code == 2  # checked before any work: no bar, nothing written
    assert "pip install 'twolink[dask]'" in result.output
    assert "kept" not in result.output and not (tmp_path / "o").exists()


def test_corrupt_chunks_are_computed_again_and_a_corrupt_manifest_costs_nothing(tmp_path):
    # A file changed since twolink wrote it is not replaced (its owner record's SHA-256 no
    # longer matches: it may be the user's, docs/reliability.md): the rerun names it. Once
    # it is moved away, only what is missing is computed again.
    from twolink.foundation.io import ForeignOutput

    plan = sw.load_sweep(write(tmp_path, SMALL))
    out = tmp_path / "out"
    first = sw.run_sweep(plan, out, executor="inprocess", plots=False)
    chunks = sorted((out / "chunks").glob("chunk_*.parquet"))
    assert len(chunks) == plan.n_chunks == 3
    # an edited value (a valid Parquet file, other numbers) and a file cut short
    edited = pd.read_parquet(chunks[0])
    edited.loc[0, "joint1_overshoot_pct"] = 99.0
    edited.to_parquet(chunks[0], index=False)
    chunks[1].write_bytes(chunks[1].read_bytes()[:-40])
    with pytest.raises(ForeignOutput, match="chunk_00000.parquet .changed since twolink wrote"):
        sw.run_sweep(plan, out, executor="inprocess", plots=False)
    assert pd.read_parquet(chunks[0]).loc[0, "joint1_overshoot_pct"] == 99.0  # kept
    chunks[0].unlink()
    chunks[1].unlink()
    again = sw.run_sweep(plan, out, executor="inprocess", plots=False)
    assert again.computed == (0, 1) and again.reused == (2,)
    columns_equal(first.results, again.results)
    # a damaged manifest is refused the same way; moved away, every chunk's seal still
    # says it belongs to this sweep
    (out / "manifest.json").write_text('{"digest": ')
    with pytest.raises(ForeignOutput, match="manifest.json"):
        sw.run_sweep(plan, out, executor="inprocess", plots=False)
    (out / "manifest.json").unlink()
    third = sw.run_sweep(plan, out, executor="inprocess", plots=False)
    assert third.computed == () and third.reused == (0, 1, 2)
    columns_equal(first.results, third.results)
    # ... and names another sweep's chunks as such
    (out / "manifest.json").unlink()
    other = sw.load_sweep(write(tmp_path, SMALL.replace("seed = 7", "seed = 8"), "other.toml"))
    with pytest.raises(sw.SweepOutputError, match="holds results of a different sweep"):
        sw.run_sweep(other, out, executor="inprocess", plots=False)


def test_a_study_replaces_its_own_sweep_folder_when_its_sweep_file_changed(tmp_path):
    # The reproduction's claims_study/ (and the regime map's folders) are the study's own:
    # after the sweep file changes, a rerun replaces them instead of a traceback.
    from twolink import sweep

    over = {"samples": 2, "chunk_size": 2, "overrides": {"duration": 0.5}}
    first = sweep.load_sweep("runs/sweeps/robustness.toml", over)
    sweep.run_sweep(first, tmp_path / "s", executor="inprocess", plots=False)
    changed = sweep.load_sweep("runs/sweeps/robustness.toml", {**over, "seed": 1})
    with pytest.raises(sweep.SweepOutputError):
        sweep.run_sweep(changed, tmp_path / "s", executor="inprocess", plots=False)
    again = sweep.run_sweep(
        changed, tmp_path / "s", executor="inprocess", plots=False, replace_other=True
    )
    assert len(again.results) == 2 * len(changed.controller_names)
