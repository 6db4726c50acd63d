"""The [sensor] table: quantisation, delay and velocity estimates as specified, against
scipy.signal's own filter and its design's lag; controllers see the sensor, records the
truth; the batch engine equals the single-arm loop with sensors on."""

import math

import numpy as np
import pytest
import scipy.signal

from twolink.foundation.overrides import merge
from twolink.simulation.config import load_scenario
from twolink.simulation.experiment import build_controller, build_plant, run_scenario, run_scenarios
from twolink.simulation.sensor import Sensor, encoder_resolution
from twolink.simulation.stability import closed_loop_growth

DT = 1e-3
RES = encoder_resolution(17)
STEP = "runs/paper/theta1_step.toml"


def read_all(sensor, q, qd=None, noise=None):
    """Feed (N, 2) true angles (and rates) through a single-arm reader."""
    qd = np.zeros_like(q) if qd is None else qd
    reader = sensor.reader(DT, noise)
    out = [reader(k, tuple(q[k]), tuple(qd[k])) for k in range(len(q))]
    return np.array([o[0] for o in out]), np.array([o[1] for o in out])


def test_17_bit_encoder_resolution():
    assert RES == pytest.approx(4.79e-5, rel=1e-3)
    assert Sensor.encoder().describe().startswith("17-bit encoder (4.79e-05 rad)")


def test_angles_are_whole_counts_within_half_a_count():
    t = np.arange(0, 1, DT)
    q = np.stack([0.3 * t + 1e-7, -0.2 * np.sin(3 * t)], axis=1)
    seen, _ = read_all(Sensor(resolution_rad=RES), q)
    counts = seen / RES
    np.testing.assert_allclose(counts, np.round(counts), atol=1e-9)
    assert np.abs(seen - q).max() <= RES / 2 * (1 + 1e-9)
    assert np.abs(seen - q).max() > 0.4 * RES  # it does quantise


def test_delay_shifts_by_whole_samples_and_holds_the_first():
    t = np.arange(0, 0.2, DT)
    q = np.stack([t**2, np.cos(t)], axis=1)
    qd = np.stack([2 * t, -np.sin(t)], axis=1)
    seen, rate = read_all(Sensor(delay_samples=3), q, qd)
    np.testing.assert_array_equal(seen[3:], q[:-3])
    np.testing.assert_array_equal(rate[3:], qd[:-3])
    np.testing.assert_array_equal(seen[:3], np.repeat(q[:1], 3, axis=0))


def test_noise_is_added_to_the_angles_only():
    t = np.arange(0, 0.1, DT)
    q = np.stack([t, 2 * t], axis=1)
    noise = np.random.default_rng(0).normal(0, 1e-3, q.shape)
    seen, rate = read_all(Sensor(noise_std_rad=1e-3), q, np.ones_like(q), noise)
    np.testing.assert_array_equal(seen, q + noise)
    np.testing.assert_array_equal(rate, np.ones_like(q))


def test_differenced_velocity_is_the_backward_difference():
    t = np.arange(0, 0.5, DT)
    q = np.stack([0.7 * t, np.sin(5 * t)], axis=1)
    _, rate = read_all(Sensor(velocity="difference"), q)
    np.testing.assert_array_equal(rate[0], [0.0, 0.0])  # at rest before the first sample
    np.testing.assert_allclose(rate[1:], np.diff(q, axis=0) / DT, rtol=1e-12, atol=1e-12)


def test_filtered_velocity_is_scipys_butterworth_of_the_difference():
    sensor = Sensor(velocity="filtered", cutoff_hz=30.0)
    b, a = scipy.signal.butter(2, 30.0, fs=1 / DT)
    np.testing.assert_allclose(sensor.velocity_filter(DT)[0], b)
    np.testing.assert_allclose(sensor.velocity_filter(DT)[1], a)
    q = np.cumsum(np.random.default_rng(1).normal(0, 1e-3, (800, 2)), axis=0)
    _, rate = read_all(sensor, q)
    diff = np.vstack([np.zeros((1, 2)), np.diff(q, axis=0) / DT])
    np.testing.assert_allclose(rate, scipy.signal.lfilter(b, a, diff, axis=0), atol=1e-9)


@pytest.mark.parametrize("cutoff", [20.0, 50.0, 100.0])
def test_filtered_velocity_lags_a_constant_acceleration_by_its_design(cutoff):
    # For q = a t²/2 the estimate settles to a (t − τ) with τ = dt/2 (the backward
    # difference's centre) + the filter's group delay at DC (scipy.signal.group_delay);
    # for a 2nd-order Butterworth that is close to √2 / (2π fc).
    acc = 2.0
    t = np.arange(0, 1.0, DT)
    q = np.stack([acc * t**2 / 2, -acc * t**2 / 2], axis=1)
    _, rate = read_all(Sensor(velocity="filtered", cutoff_hz=cutoff), q)
    b, a = Sensor(cutoff_hz=cutoff).velocity_filter(DT)
    _, gd = scipy.signal.group_delay((b, a), w=[1e-6])
    lag = DT / 2 + gd[0] * DT
    error = acc * t[-1] - rate[-1, 0]
    assert error == pytest.approx(acc * lag, rel=1e-6)
    assert rate[-1, 1] == pytest.approx(-rate[-1, 0], rel=1e-12)
    assert lag == pytest.approx(DT / 2 + math.sqrt(2) / (2 * math.pi * cutoff), rel=0.05)


def test_filtered_velocity_attenuates_quantisation_noise():
    # A slow ramp seen through the encoder: the differenced rate jumps between 0 and one
    # count per period (0.048 rad/s); the 50 Hz filter brings its spread down > 5x.
    t = np.arange(0, 2, DT)
    q = np.stack([0.013 * t, 0.007 * t], axis=1)
    _, raw = read_all(Sensor(resolution_rad=RES, velocity="difference"), q)
    _, filtered = read_all(Sensor(resolution_rad=RES, velocity="filtered"), q)
    assert raw[500:].std() > 5 * filtered[500:].std()
    np.testing.assert_allclose(filtered[500:].mean(axis=0), [0.013, 0.007], rtol=0.02)


def scenario(sensor, **more):
    data = {"duration": 2.0, "sensor": sensor}
    return load_scenario(STEP, merge(data, more))


SENSORS = [
    {"resolution_rad": RES, "velocity": "filtered"},
    {"resolution_rad": RES, "velocity": "difference", "delay_samples": 2, "noise_std_rad": 1e-4},
    {"velocity": "filtered", "cutoff_hz": 20.0, "delay_samples": 1},
]


def test_records_hold_the_true_state_and_controllers_the_sensors():
    coarse = scenario({"resolution_rad": 0.01})
    traj = run_scenario(coarse)
    counts = traj.q[1:, 0] / 0.01
    assert np.abs(counts - np.round(counts)).max() > 0.1  # the truth, not whole counts
    ideal = run_scenario(scenario({}))
    assert not np.array_equal(traj.tau, ideal.tau)  # ...while the law saw whole counts


def test_a_sensor_run_is_deterministic_for_its_seed():
    s = scenario(SENSORS[1], seed=4)
    assert run_scenario(s).equals(run_scenario(s))
    assert not run_scenario(s).equals(run_scenario(scenario(SENSORS[1], seed=5)))


def test_exact_velocity_noise_only_is_the_old_noise_path():
    # [sensor] noise_std_rad alone must give what [plant] noise_std gave: angles + noise.
    s = scenario({"noise_std_rad": 1e-3}, seed=2)
    plant, controller = build_plant(s), build_controller(s)
    from twolink.simulation.experiment import measurement_noise
    from twolink.simulation.sim import simulate

    old = simulate(plant, controller, s.duration, noise=measurement_noise(s))
    assert run_scenario(s).equals(old)


@pytest.mark.parametrize("sensor", SENSORS, ids=["encoder filtered", "noisy delayed", "filter"])
def test_batch_equals_single_arm_with_sensors_on(sensor):
    scenarios = [
        scenario(sensor, controller={"kind": kind, "rule_base": "designed"}, seed=i)
        for i, kind in enumerate(["ctc", "fcm_ctc", "ctc_integral", "pd_gravity"])
    ]
    for s, batch in zip(scenarios, run_scenarios(scenarios), strict=True):
        assert batch.equals(run_scenario(s))


@pytest.mark.parametrize("kind", ["motor_pd", "composite", "flexible_fl"])
def test_batch_equals_single_arm_with_sensors_on_flexible_joints(kind):
    base = {
        "plant": {"flexibility": {"k": [1e4, 1e4], "j": [0.4, 0.08], "d": [2.5, 1.1]}},
        "reference": {
            "joint1": {"kind": "septic", "final": 1.0, "duration": 1.0},
            "joint2": {"kind": "septic", "final": 0.5, "duration": 1.0},
        },
        "controller": {"kind": kind, "kp": 25.0, "kd": 10.0},
    }
    scenarios = [scenario(sensor, **base) for sensor in SENSORS[:2]]
    scenarios.append(scenario(SENSORS[0], **merge(base, {"controller": {"kind": "ctc"}})))
    for s, batch in zip(scenarios, run_scenarios(scenarios), strict=True):
        single = run_scenario(s)
        assert single.ok
        assert batch.equals(single)


def test_scenarios_with_different_sensors_share_a_call_not_a_batch():
    a, b = scenario(SENSORS[0]), scenario({})
    ra, rb = run_scenarios([a, b])
    assert ra.equals(run_scenario(a)) and rb.equals(run_scenario(b))


def test_linear_stability_is_not_claimed_behind_a_sensor_with_dynamics():
    # The linearisation is of the true state; a filter or delay adds states it lacks.
    ideal, filtered = scenario({}), scenario(SENSORS[0])
    growth = closed_loop_growth(ideal, build_plant(ideal), build_controller(ideal))
    assert growth < 0
    assert math.isnan(
        closed_loop_growth(filtered, build_plant(filtered), build_controller(filtered))
    )


def test_sensor_in_the_written_config_only_when_not_ideal():
    assert "sensor" not in scenario({}).to_dict()
    assert scenario(SENSORS[0]).to_dict()["sensor"]["velocity"] == "filtered"


def test_joint_scale_is_the_plants_model_error():
    s = load_scenario(
        STEP,
        {
            "plant": {
                "flexibility": {"k": [1e4, 2e3], "j": [0.4, 0.08], "d": [1.0, 1.0]},
                "scale": {"k": 1 / 1.2, "j": 1.1, "m1": 1.2},
            },
            "controller": {"kind": "composite"},
        },
    )
    assert s.plant_joints.k == pytest.approx((1e4 / 1.2, 2e3 / 1.2))
    assert s.plant_joints.j == pytest.approx((0.44, 0.088))
    assert s.plant_joints.d == (1.0, 1.0)
    assert s.plant_params.m1 == pytest.approx(1.2)
    plant = build_plant(s)
    stiffness = [plant.model.tendon_stiffness[plant.model.tendon(f"spring{k}").id] for k in (1, 2)]
    assert stiffness == pytest.approx([1e4 / 1.2, 2e3 / 1.2])
    assert build_controller(s).joints.k == (1e4, 2e3)  # the model keeps the nominal joints


def test_with_a_model_error_the_loop_is_linearised_where_it_rests_not_at_the_target():
    # CTC at ωn 2 on realistic joints with masses ×1.2, g ×1.1 and joints 1/1.2 as stiff
    # rests about a radian off the target; the map is linearised there (found by Newton
    # from the run's end), and the run agrees: it is calm, at that state.
    wn = 2.0
    s = load_scenario(
        STEP,
        {
            "duration": 20.0,
            "plant": {
                "flexibility": {"k": [1e4, 1e4], "j": [0.4, 0.08], "d": [2.53, 1.13]},
                "scale": {"m1": 1.2, "m2": 1.2, "g": 1.1, "k": 1 / 1.2},
            },
            "controller": {"kind": "ctc", "kp": wn * wn, "kd": 2 * wn},
            "reference": {
                "joint1": {"kind": "septic", "final": 1.0, "duration": 1.5},
                "joint2": {"kind": "septic", "final": 0.5, "duration": 1.5},
            },
        },
    )
    traj = run_scenario(s)
    assert np.abs(traj.e[-1]).max() > 0.5  # far from the target...
    assert np.abs(traj.q[-1] - traj.q[-1000]).max() < 1e-9  # ...and at rest there
    near = (traj.q[-1], traj.motor_q[-1])
    growth = closed_loop_growth(s, build_plant(s), build_controller(s), near=near)
    assert -5 < growth < 0
    # With no hint, Newton from the target does not reach that rest state: no claim.
    assert math.isnan(closed_loop_growth(s, build_plant(s), build_controller(s)))


def test_sweep_parameters_k_scale_and_j_scale_are_the_joints_model_error(tmp_path):
    from twolink.simulation.config import scenario_from_dict
    from twolink.sweep import load_sweep

    plan = load_sweep(
        "runs/sweeps/flexible_map.toml",
        {
            "samples": 2,
            "parameters": {
                "replace": True,
                "k": {"dist": "grid", "values": [1e4]},
                "k_scale": {"dist": "grid", "values": [0.5, 1 / 1.2]},
                "j_scale": {"dist": "grid", "values": [1.1]},
            },
        },
    )
    scales = []
    for i in range(2):
        values, seed = plan.draw(i)
        s = scenario_from_dict(plan.sample_data(values, seed), plan.file)
        assert s.plant.flexibility.k == (1e4, 1e4)  # the model: the drawn joints
        scales.append(s.plant_joints.k[0] / 1e4)
        assert s.plant_joints.j == pytest.approx((0.44, 0.088))
    assert scales == pytest.approx([0.5, 1 / 1.2])
