"""The step log (twolink/simulation/steplog.py): the arm-steps the engines count, and the
digest that finds a run computed twice, against numbers worked out by hand."""

from __future__ import annotations

import json

from twolink.foundation.steplog import ENV
from twolink.simulation.config import load_scenario, merge
from twolink.simulation.experiment import run_scenario, run_scenarios

BASE = "runs/paper/theta1_step.toml"


def scenario(**overrides):
    return load_scenario(BASE, merge({"duration": 0.2}, overrides))


def lines(folder):
    paths = sorted(folder.glob("*.jsonl"))
    return [json.loads(x) for p in paths for x in p.read_text().splitlines()]


def test_off_by_default_nothing_is_written(tmp_path, monkeypatch):
    monkeypatch.delenv(ENV, raising=False)
    monkeypatch.chdir(tmp_path)
    run_scenarios([scenario()])
    assert list(tmp_path.iterdir()) == []


def test_a_batch_counts_its_physics_steps_times_its_arms(tmp_path, monkeypatch):
    monkeypatch.setenv(ENV, str(tmp_path))
    a, b = scenario(), scenario(duration=0.1)  # b's run ends halfway, frozen after
    run_scenarios([a, a, b])
    (line,) = lines(tmp_path)
    periods = round(a.duration / a.control_dt)  # 200 control periods
    substeps = round(a.control_dt / a.timestep)
    assert line["engine"] == "batch" and line["arms"] == 3
    assert line["physics_steps"] == periods * substeps
    assert line["arm_steps"] == 3 * periods * substeps
    assert line["useful_arm_steps"] == (2 * periods + periods // 2) * substeps
    # the two equal arms share a digest; the shorter run's differs
    assert line["digests"][0] == line["digests"][1] != line["digests"][2]
    assert "twolink.simulation.experiment.run_scenarios" in line["callers"]


def test_the_same_run_has_the_same_digest_alone_and_in_a_batch(tmp_path, monkeypatch):
    monkeypatch.setenv(ENV, str(tmp_path))
    s = scenario()
    run_scenario(s)
    run_scenarios([s, scenario(**{"plant": {"payload": 0.3}})])
    single, batch = sorted(lines(tmp_path), key=lambda r: r["arms"])
    assert single["engine"] == "single" and single["arms"] == 1
    assert single["physics_steps"] == batch["physics_steps"]
    assert single["digests"][0] == batch["digests"][0] != batch["digests"][1]


def test_a_batch_of_bending_links_counts_its_physics_steps_times_its_arms(tmp_path, monkeypatch):
    """The link batch (links_sim.simulate_links_batch) logs as the rigid one, engine
    "links": its physics steps are the control periods times the substeps it needs."""
    from twolink.simulation.links_sim import links_timestep

    monkeypatch.setenv(ENV, str(tmp_path))
    links = {"arm": {"links": {"ei": 800.0, "segments": 4, "hub_inertia": 0.05}}}
    a = scenario(**links)
    run_scenarios([a, scenario(**links, plant={"payload": 0.2})])
    (line,) = lines(tmp_path)
    periods = round(a.duration / a.control_dt)
    substeps = round(a.control_dt / links_timestep(a))
    assert substeps > 1  # the stiff hinges need a finer step than the rigid arm's
    assert line["engine"] == "links" and line["arms"] == 2
    assert line["physics_steps"] == periods * substeps
    assert line["arm_steps"] == line["useful_arm_steps"] == 2 * periods * substeps
    assert line["digests"][0] != line["digests"][1]
