"""Scenarios with [arm.links], the closed loop on bending links and the tip's measures."""

from __future__ import annotations

import math

import numpy as np
import pytest

from twolink.arm.params import ArmParams
from twolink.simulation.config import ConfigError, scenario_from_dict
from twolink.simulation.experiment import build_controller, build_plant, run_scenario
from twolink.simulation.links_sim import LinkRun, plant_links, run_links, tip_metrics
from twolink.simulation.sim import Trajectory, simulate


def _data(**links):
    return {
        "duration": 1.0,
        "arm": {"g": 0.0, "links": {"ei": 1e4, "segments": 4, **links}},
        "controller": {"kind": "ctc"},
        "reference": {
            "joint1": {"kind": "quintic", "final": 0.5, "duration": 0.8},
            "joint2": {"kind": "quintic", "final": -0.3, "duration": 0.8},
        },
    }


def test_arm_links_are_read_and_written_back():
    s = scenario_from_dict(_data(hub_inertia=[0.4, 0.08], tip_mass=0.2, damping_ratio=0.02))
    b1, b2 = s.links.links
    assert (b1.ei, b1.rho_a, b1.length, b1.hub_inertia, b1.tip_mass) == (1e4, 1.0, 1.0, 0.4, 0.2)
    assert (b2.hub_inertia, b2.damping_ratio, s.links.segments) == (0.08, 0.02, 4)
    again = scenario_from_dict(s.to_dict())
    assert again.links == s.links
    # The plant's links are on the plant's rods: a heavier link 2 is a heavier beam.
    heavier = scenario_from_dict(_data() | {"plant": {"scale": {"m2": 1.5}}})
    assert plant_links(heavier).link2.rho_a == 1.5 and heavier.links.link2.rho_a == 1.0
    assert "links" not in scenario_from_dict(_data() | {"arm": {}}).to_dict()["arm"]


@pytest.mark.parametrize(
    "change, key",
    [
        ({"ei": -1.0}, "arm.links.ei"),
        ({"segments": 0}, "arm.links.segments"),
        ({"tip_mass": [0.1, -0.1]}, "arm.links.tip_mass"),
        ({"stiffness": 3.0}, "arm.links.stiffness"),
    ],
)
def test_bad_links_are_one_line_errors_that_name_the_key(change, key):
    with pytest.raises(ConfigError, match=key.replace(".", r"\.")) as info:
        scenario_from_dict(_data(**change), "x.toml")
    assert "\n" not in str(info.value)


def test_bending_links_refuse_what_their_loop_does_not_model():
    for extra, key in (
        ({"plant": {"flexibility": {}}}, "plant.flexibility"),
        ({"sensor": {"noise_std_rad": 1e-3}}, "sensor"),
    ):
        with pytest.raises(ConfigError, match=key):
            scenario_from_dict(_data() | extra)


def test_stiff_links_under_ctc_follow_the_rigid_arm():
    """E I = 1e4 N m² (first mode 56 Hz), no hubs or tip masses: the paper's CTC with the
    rigid model moves the hubs as on the rigid arm, to within 1 mrad. The tip bends by
    about a millimetre: link 2's inertia (6.8 N, 2 N m at 4.5 rad/s²) on link 1 gives a
    quasi-static 0.9 mm at the tip."""
    s = scenario_from_dict(_data())
    run = run_links(s, build_controller(s))
    rigid = simulate(build_plant(s), build_controller(s), s.duration, s.control_dt)
    assert run.trajectory.ok
    assert np.abs(run.trajectory.q - rigid.q).max() < 1e-3
    assert np.abs(run.trajectory.q - rigid.q).max() > 1e-7  # but they do differ
    bend = np.linalg.norm(run.tip - run.rigid_tip(s.arm), axis=1).max()
    assert 5e-4 < bend < 2e-3
    assert np.array_equal(run_scenario(s).q, run.trajectory.q)  # `twolink run` takes this path


def _synthetic(deflection: np.ndarray, t: np.ndarray) -> LinkRun:
    """A run whose hubs sit at 0 (the rigid tip at (2, 0)) and whose tip is off by
    ``deflection`` along y."""
    n = len(t)
    zeros = np.zeros((n, 2))
    traj = Trajectory(t, zeros, zeros, zeros, zeros, zeros, zeros, np.empty((0, 2)))
    tip = np.stack([np.full(n, 2.0), deflection], -1)
    return LinkRun(traj, tip, np.zeros((n, 2, 1)))


def test_tip_metrics_on_a_known_decaying_vibration():
    t = np.arange(0, 5.0, 1e-3)
    amplitude = 0.01 * np.exp(-t)  # within 1 mm once e^-t < 0.1: t = ln 10
    run = _synthetic(amplitude * np.cos(2 * np.pi * 5 * t), t)
    m = tip_metrics(run, ArmParams(), rest_time=1.0, band=1e-3)
    assert m.tip_error == pytest.approx(0.01)
    assert m.residual_vibration == pytest.approx(0.01 * math.exp(-1.0), rel=1e-3)
    assert math.log(10) - 0.1 < m.vibration_settling_time <= math.log(10)
    # The first sample from which every swing stays in the band, and none before it.
    tail = t >= t[-1] - 0.5
    swing = np.abs(run.tip[:, 1] - run.tip[tail, 1].mean())
    i = int(np.searchsorted(t, m.vibration_settling_time))
    assert np.all(swing[i:] <= 1e-3) and swing[i - 1] > 1e-3
    assert m.final_tip_error == pytest.approx(abs(run.tip[-1, 1]))
    # Still swinging past the band at the end: not settled.
    still = tip_metrics(_synthetic(0.01 * np.cos(2 * np.pi * 5 * t), t), ArmParams(), 1.0)
    assert math.isnan(still.vibration_settling_time)


def test_recording_draws_the_bent_links(tmp_path):
    """The 3D view's strip ``arm/bent`` holds, per kept sample, the hubs, hinges and tip
    as MuJoCo placed them, in the paper's plane (x, y) drawn as (x, z)."""
    from rerun.chunk import RrdReader

    from twolink.tracing import write_recording

    s = scenario_from_dict(_data() | {"duration": 0.3})
    run = run_links(s, build_controller(s))
    assert run.points.shape == (len(run.trajectory.t), 2 * 4 + 3, 2)
    assert np.allclose(run.points[:, -1], run.tip)  # its last point is the tip
    assert np.allclose(run.points[:, 0], 0.0)  # its first the base
    path = write_recording(
        tmp_path / "r.rrd", [("", run.trajectory, s.arm, {"bent": run.points})], every=50
    )
    strips = []
    for chunk in RrdReader(path).store().stream():
        if chunk.entity_path.strip("/") == "arm/bent" and not chunk.is_static:
            batch = chunk.to_record_batch()
            name = next(n for n in batch.schema.names if n.endswith(":strips"))
            strips += batch.column(name).to_pylist()
    kept = np.arange(0, len(run.trajectory.t), 50)
    assert len(strips) == len(kept)
    first = np.array(strips[-1][0])
    expected = run.points[kept[-1]]
    assert np.allclose(first[:, [0, 2]], expected, atol=1e-6) and np.allclose(first[:, 1], 0)
    with pytest.raises(ValueError, match="bent"):
        write_recording(tmp_path / "x.rrd", [("", run.trajectory, s.arm, {"bent": run.points[1:]})])


@pytest.mark.slow
def test_shipped_soft_links_bend_as_the_docs_say():
    """docs/flexible_links.md: the screenshot's moment, 0.34 m of bending at 0.198 s."""
    from twolink.simulation.config import load_scenario

    s = load_scenario("flexible_links/ctc_soft")
    assert s.links.link1.ei == 100.0 and s.links.segments == 8
    run = run_links(s, build_controller(s))
    bend = np.linalg.norm(run.tip - run.rigid_tip(s.arm), axis=1)
    assert run.trajectory.t[bend.argmax()] == pytest.approx(0.198)
    assert bend.max() == pytest.approx(0.344, abs=5e-4)


def _bent_strips(path) -> list:
    from rerun.chunk import RrdReader

    strips = []
    for chunk in RrdReader(path).store().stream():
        if chunk.entity_path.strip("/").endswith("arm/bent") and not chunk.is_static:
            batch = chunk.to_record_batch()
            name = next(n for n in batch.schema.names if n.endswith(":strips"))
            strips += batch.column(name).to_pylist()
    return strips


def test_twolink_run_writes_the_tip_metrics_and_draws_the_bent_links(tmp_path):
    """`twolink run` on bending links: metrics.json's ``tip`` holds the tip's measures by
    their keys (those of the API, in metres and seconds) and the recording draws the bent
    strip; a rigid run has neither."""
    import json

    from click.testing import CliRunner

    from twolink.foundation.io import to_toml
    from twolink.interface.cli import main
    from twolink.simulation.experiment import TRACE_EVERY
    from twolink.simulation.links_sim import scenario_tip_metrics
    from twolink.simulation.vocabulary import TIP_METRICS

    data = _data(ei=300.0, hub_inertia=[0.4, 0.08], tip_mass=[0.5, 0.1]) | {"duration": 1.5}
    (tmp_path / "s.toml").write_text(to_toml(data))
    rigid = {k: v for k, v in data.items() if k != "arm"} | {"arm": {"g": 0.0}}
    (tmp_path / "r.toml").write_text(to_toml(rigid))
    printed = {}
    for name in ("s", "r"):
        args = ["run", str(tmp_path / f"{name}.toml"), "--out", str(tmp_path / name), "--no-plots"]
        result = CliRunner().invoke(main, args)
        assert result.exit_code in (0, 1), result.output
        printed[name] = result.output
    written = json.loads((tmp_path / "s" / "metrics.json").read_text())
    s = scenario_from_dict(data)
    run = run_links(s, build_controller(s))
    expected = scenario_tip_metrics(s, run)
    # by hand: the deflection from the reference's end (0.8 s) on, off the plant's rods
    after = run.trajectory.t >= 0.8
    deflection = np.linalg.norm(run.tip - run.rigid_tip(s.plant_params), axis=1)
    assert expected.residual_vibration == pytest.approx(deflection[after].max(), rel=1e-12)
    assert set(written["tip"]) == {m.key for m in TIP_METRICS}
    assert written["tip"]["residual_vibration_m"] == pytest.approx(expected.residual_vibration)
    assert written["tip"]["tip_error_m"] == pytest.approx(expected.tip_error)
    assert 1e-4 < expected.residual_vibration < expected.tip_error  # a move that bends
    mm = f"{1e3 * expected.residual_vibration:.4g} mm"
    assert "residual_vibration_m" in printed["s"] and mm in printed["s"]
    assert "residual_vibration_m" not in printed["r"]
    strips = _bent_strips(tmp_path / "s" / "trace.rrd")
    assert len(strips) == len(range(0, round(s.duration / s.control_dt) + 1, TRACE_EVERY))
    assert "tip" not in json.loads((tmp_path / "r" / "metrics.json").read_text())
    assert _bent_strips(tmp_path / "r" / "trace.rrd") == []


def test_plant_scale_ei_stiffens_the_simulated_links_not_the_model():
    """[plant.scale] ei: the plant's E I times the factor (a sweep draws it as ei_scale);
    the scenario's [arm.links] (the laws' model) keeps its own; a rigid arm refuses it."""
    s = scenario_from_dict(_data(ei=[1e3, 500.0]) | {"plant": {"scale": {"ei": 0.5}}})
    assert [b.ei for b in plant_links(s).links] == [500.0, 250.0]
    assert [b.ei for b in s.links.links] == [1e3, 500.0]
    assert plant_links(scenario_from_dict(_data(ei=1e3))).link1.ei == 1e3
    rigid = _data()
    del rigid["arm"]["links"]
    with pytest.raises(ConfigError, match=r"plant\.scale\.ei"):
        scenario_from_dict(rigid | {"plant": {"scale": {"ei": 0.5}}})
    with pytest.raises(ConfigError, match=r"plant\.scale"):
        scenario_from_dict(_data() | {"plant": {"scale": {"ei": -1.0}}})


def test_a_sweep_draws_the_links_stiffness_and_payload(tmp_path):
    from twolink.foundation.io import to_toml
    from twolink.sweep.plan import load_sweep

    (tmp_path / "base.toml").write_text(to_toml(_data(ei=1e3)))
    (tmp_path / "links.toml").write_text(
        'name = "links"\nscenario = "base.toml"\nsamples = 3\nseed = 1\n'
        '[parameters]\nei_scale = { dist = "uniform", low = 0.5, high = 2.0 }\n'
        'payload = { dist = "uniform", low = 0.0, high = 0.3 }\n'
        '[controllers.CTC]\nkind = "ctc"\n'
    )
    plan = load_sweep(tmp_path / "links.toml")
    drawn = []
    for i in range(3):
        values, seed = plan.draw(i)
        s = scenario_from_dict(plan.sample_data(values, seed))
        assert plant_links(s).link1.ei == pytest.approx(1e3 * values["ei_scale"])
        assert s.plant.payload == pytest.approx(values["payload"])
        assert s.links.link1.ei == 1e3  # the laws' model keeps the nominal links
        drawn.append(values["ei_scale"])
    assert len(set(drawn)) == 3 and all(0.5 <= v <= 2.0 for v in drawn)


def _two_time_scale(**controller):
    data = _data(hub_inertia=[0.4, 0.08], tip_mass=[0.5, 0.1])
    data["controller"] = {"kind": "two_time_scale", **controller}
    return data


def test_a_scenarios_two_time_scale_law_is_the_librarys_on_its_nominal_links():
    """``kind = "two_time_scale"``: TwoTimeScaleControl on ``[arm.links]`` (not the
    plant's scaled links) with the scenario's gains and ``ks``; the run equals the
    library law's to the bit."""
    from twolink.arm.links import LinkPlant
    from twolink.controllers.flexible_links import TwoTimeScaleControl
    from twolink.simulation.links_sim import links_timestep, simulate_links

    data = _two_time_scale(ks=[0.02, 0.005], kp=100.0, kd=20.0)
    data["plant"] = {"scale": {"ei": 0.7}}
    s = scenario_from_dict(data)
    law = build_controller(s)
    assert isinstance(law, TwoTimeScaleControl) and law.model == s.links
    assert tuple(law.ks) == (0.02, 0.005)
    by_hand = TwoTimeScaleControl(s.links, s.reference, kp=100.0, kd=20.0, ks=(0.02, 0.005))
    plant = LinkPlant.build(plant_links(s), 0.0, timestep=links_timestep(s))
    alone = simulate_links(plant, by_hand, s.duration, s.control_dt)
    run = run_links(s, law)
    assert np.array_equal(run.trajectory.tau, alone.trajectory.tau)
    assert np.array_equal(run.tip, alone.tip)


def test_the_two_time_scale_law_needs_bending_links_and_a_gain_of_the_right_sign():
    rigid = _two_time_scale()
    del rigid["arm"]["links"]
    with pytest.raises(ConfigError, match=r"controller\.kind: .*needs \[arm\.links\]"):
        scenario_from_dict(rigid)
    with pytest.raises(ConfigError, match=r"controller\.ks: must be >= 0"):
        scenario_from_dict(_two_time_scale(ks=-0.01))
    # another kind neither reads nor writes ks: its resolved config (and digest) is unchanged
    assert "ks" not in scenario_from_dict(_data()).to_dict()["controller"]
    assert scenario_from_dict(_two_time_scale()).to_dict()["controller"]["ks"] == [0.01, 0.01]


def test_a_bending_links_run_is_not_linearised_as_a_rigid_arm():
    """The stability module models rigid links: a bending-link run's linear growth is
    NaN ("not linearised"), not the rigid arm's."""
    from twolink.simulation.experiment import measure

    s = scenario_from_dict(_two_time_scale())
    run = run_links(s, build_controller(s))
    assert all(math.isnan(g) for g in measure(s, run.trajectory).linear_growth)


def test_the_mjx_backend_refuses_bending_links_naming_the_cpu_backend():
    """MJX's step on the chain costs 116 to 92,212 times MuJoCo's (N = 1 to 3;
    benchmarks/bench_mjx_links.py): the backend refuses them, before importing JAX."""
    from twolink.simulation.experiment import iter_scenarios

    s = scenario_from_dict(_data())
    with pytest.raises(ValueError, match="run on the cpu backend, not mjx"):
        next(iter_scenarios([s], backend="mjx"))
