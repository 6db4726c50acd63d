"""Closed loop: CTC against closed-form error dynamics, determinism, divergence, configs."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from twolink.arm import dynamics
from twolink.arm.params import ArmParams
from twolink.arm.plant import Plant
from twolink.controllers.ctc import ComputedTorque
from twolink.foundation.references import ArmReference, Ramp, Step
from twolink.interface.cli import main
from twolink.simulation.config import ConfigError, load_scenario
from twolink.simulation.experiment import build_controller, measure, run_scenario
from twolink.simulation.sim import Trajectory, simulate
from twolink.studies.reproduction.run_folder import write_run

RUNS = Path(__file__).resolve().parents[1] / "runs"
KP, KD = 4.0, 2.4


def closed_form_error(t, e0):
    """e'' + KD e' + KP e = 0 from e(0) = e0, e'(0) = 0 (underdamped)."""
    wn = math.sqrt(KP)
    zeta = KD / (2 * wn)
    wd = wn * math.sqrt(1 - zeta**2)
    return e0 * np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t))


def ctc_step_error(dt, steps=(1.0, 0.5)):
    p = ArmParams(m1=1.3, m2=0.8, l1=0.9, l2=0.7)
    ctc = ComputedTorque(
        p,
        ArmReference(Step(0.0, steps[0]), Step(0.0, steps[1])),
        kp=KP,
        kd=KD,
        torque_limit=math.inf,
    )
    traj = simulate(Plant.build(p, timestep=dt), ctc, 6.0, control_dt=dt)
    expected = np.stack([closed_form_error(traj.t, s) for s in steps], axis=1)
    return np.abs(traj.e - expected).max(axis=0)


def test_perfect_model_ctc_follows_the_closed_form_error_dynamics():
    # Zero-order hold makes the sampled loop deviate from e'' + Kd e' + Kp e = 0 by
    # O(dt): the torque is held while M(q), H(q, qd) move within the period. We claim
    # |e_sim - e_closed_form| <= 2 dt (|step1| + |step2|) rad, and first-order convergence.
    steps = (1.0, 0.5)
    errors = {dt: ctc_step_error(dt, steps) for dt in (1e-3, 5e-4, 2.5e-4)}
    for dt, err in errors.items():
        assert err.max() <= 2 * dt * sum(steps), (dt, err)
    for coarse, fine in ((1e-3, 5e-4), (5e-4, 2.5e-4)):
        ratio = errors[coarse].max() / errors[fine].max()
        assert 1.8 < ratio < 2.2, ratio


def test_wrong_gravity_model_gives_the_predicted_steady_state_error():
    # At rest on a step, M^(q) Kp e = G(q) - G^(q): solve for e (implicitly in q).
    plant_p = ArmParams(m1=1.2, m2=0.9)
    model_p = ArmParams(m1=1.2, m2=0.9, g=9.81 * 0.8)
    target = np.array([0.8, -0.4])
    ref = ArmReference(Step(0.0, target[0]), Step(0.0, target[1]))
    traj = simulate(
        Plant.build(plant_p),
        ComputedTorque(model_p, ref, kp=KP, kd=KD, torque_limit=math.inf),
        25.0,
    )
    e = np.zeros(2)
    for _ in range(100):  # fixed point: converges fast as e is small
        q = target - e
        mismatch = dynamics.gravity(plant_p, q) - dynamics.gravity(model_p, q)
        e = np.linalg.solve(dynamics.mass_matrix(model_p, q) * KP, mismatch)
    assert np.abs(e).min() > 0.05  # a real, visible error
    np.testing.assert_allclose(traj.e[-1], e, rtol=0, atol=1e-6)


def test_ramp_is_tracked_with_feedforward_and_zero_final_error():
    p = ArmParams()
    ref = ArmReference(Ramp(0.0, 1.0, 2.0), Ramp(0.0, -0.5, 3.0))
    traj = simulate(
        Plant.build(p), ComputedTorque(p, ref, kp=4.0, kd=2.4, torque_limit=math.inf), 10.0
    )
    # From rest the error starts at zero, the ramp's corners kick it, then it decays.
    assert np.abs(traj.e[-1]).max() < 1e-4
    assert np.abs(traj.e).max() < 0.3


def test_same_config_and_seed_give_bit_identical_trajectories(tmp_path):
    path = tmp_path / "noisy.toml"
    path.write_text(
        f'extends = "{RUNS / "theta1_step.toml"}"\nduration = 2.0\n[sensor]\nnoise_std_rad = 1e-3\n'
    )
    s = load_scenario(path)
    a, b = run_scenario(s), run_scenario(load_scenario(path))
    assert a.equals(b)
    other = load_scenario(path, {"seed": 1})
    assert not run_scenario(other).equals(a)


def test_trajectory_round_trips_through_npz(tmp_path):
    s = load_scenario(RUNS / "theta1_step.toml", {"duration": 1.0})
    traj = run_scenario(s)
    traj.save(tmp_path / "t.npz")
    back = Trajectory.load(tmp_path / "t.npz")
    assert back.equals(traj) and back.status == "ok"
    assert traj.t[-1] == pytest.approx(1.0) and len(traj.t) == 1001


def test_divergence_stops_the_run_and_keeps_what_was_computed():
    p = ArmParams()
    ref = ArmReference(Step(0.0, 1.0), Step(0.0, 0.0))
    # A controller whose model thinks the arm is 100x lighter and gains are huge: blows up.
    ctc = ComputedTorque(ArmParams(m1=0.01, m2=0.01), ref, kp=1e6, kd=0.0, torque_limit=math.inf)
    traj = simulate(Plant.build(p), ctc, 5.0)
    assert traj.status == "diverged" and "out of bounds" in traj.message
    assert 0 < len(traj.t) < 5001
    assert np.all(np.isfinite(traj.q))


def test_nan_torque_is_reported_not_propagated():
    class NanController(ComputedTorque):
        def __call__(self, t, q, qd):
            return (math.nan, 0.0) if t >= 0.5 else super().__call__(t, q, qd)

    p = ArmParams()
    traj = simulate(Plant.build(p), NanController(p, ArmReference(Step(0, 1), Step(0, 0))), 2.0)
    assert traj.status == "diverged" and "torque" in traj.message
    # The run ends at the sample where the controller asked for NaN: that request is kept
    # (as data), never applied, so the state there is still the finite one measured.
    assert traj.t[-1] == pytest.approx(0.5) and traj.t[-2] == pytest.approx(0.499)
    assert math.isnan(traj.tau[-1, 0]) and np.isfinite(traj.tau[:-1]).all()
    assert np.isfinite(traj.q).all()


def test_a_run_that_diverges_at_once_keeps_its_one_sample(tmp_path):
    # kp = 1e11 asks for ~1e11 N m at t = 0 (issue 13: was "t is empty", a traceback; 1e300,
    # the case of old, is now bad input: numbers are bounded to 1e12 in size).
    path = tmp_path / "kp.toml"
    text = f'extends = "{RUNS / "theta1_step.toml"}"\n[controller]\nkp = 1e11\n'
    path.write_text(text + "torque_limit = inf\n")  # an actuator limit would bound it
    result = CliRunner().invoke(main, ["run", str(path), "--out", str(tmp_path / "o")])
    assert result.exit_code == 1, result.output
    assert "torque out of bounds at t=0.0000 s" in result.output
    traj = Trajectory.load(tmp_path / "o" / "trajectory.npz")
    assert len(traj.t) == 1 and traj.status == "diverged" and traj.tau[0, 0] > 1e10
    metrics = json.loads((tmp_path / "o" / "metrics.json").read_text())
    assert metrics["status"] == metrics["outcome"] == "diverged"
    # a state out of bounds from the start: the one state is kept, no torque was asked
    path.write_text(f'extends = "{RUNS / "theta1_step.toml"}"\n[initial]\nq = [1000.0, 0.0]\n')
    result = CliRunner().invoke(main, ["run", str(path), "--out", str(tmp_path / "p")])
    assert result.exit_code == 1 and "state out of bounds at t=0.0000 s" in result.output
    traj = Trajectory.load(tmp_path / "p" / "trajectory.npz")
    assert traj.q.tolist() == [[1000.0, 0.0]] and np.isnan(traj.tau).all()


def test_zero_order_hold_at_a_slower_control_rate():
    s = load_scenario(RUNS / "theta1_step.toml", {"control_dt": 0.004, "duration": 4.0})
    traj = run_scenario(s)
    assert len(traj.t) == 1001 and traj.ok
    with pytest.raises(ConfigError, match="control_dt"):
        load_scenario(RUNS / "theta1_step.toml", {"control_dt": 0.0015})


def test_resolved_config_reloads_to_the_same_scenario(tmp_path):
    s = load_scenario(
        RUNS / "theta1_step.toml",
        {"plant": {"scale": {"m2": 1.3}, "flexibility": {"k": [300, 400]}}, "duration": 0.5},
    )
    traj = run_scenario(s)
    out = write_run(tmp_path / "run", s, traj, measure(s, traj), plots=False, trace=False)
    again = load_scenario(out / "config.toml")
    assert again.to_dict() == s.to_dict()


def test_twolink_run_writes_one_folder(tmp_path):
    result = CliRunner().invoke(
        main, ["run", str(RUNS / "theta1_step.toml"), "--out", str(tmp_path / "out")]
    )
    assert result.exit_code == 0, result.output
    names = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert names == [
        ".twolink-owner.json",  # what twolink wrote here (docs/reliability.md)
        ".twolink.lock",
        "angles.png",
        "config.toml",
        "errors.png",
        "metrics.json",
        "seal.json",
        "torques.png",
        "trace.rrd",
        "trajectory.npz",
    ]
    # one line per metric key (the keys of metrics.json), undefined values as "—"
    from twolink.simulation.vocabulary import METRICS

    for m in METRICS:
        assert m.key in result.output
    assert "nan" not in result.output and "—" in result.output  # θ2 holds: no step metrics


def test_twolink_run_exits_1_when_the_run_diverges(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(
        f'extends = "{RUNS / "theta1_step.toml"}"\nduration = 3.0\n'
        "[arm]\nm1 = 0.01\nm2 = 0.01\n[controller]\nkp = 1e6\nkd = 0.0\n"
    )
    result = CliRunner().invoke(
        main, ["run", str(path), "--out", str(tmp_path / "o"), "--no-plots"]
    )
    assert result.exit_code == 1
    assert "diverged" in result.output
    assert Trajectory.load(tmp_path / "o" / "trajectory.npz").status == "diverged"


@pytest.mark.parametrize(
    ("body", "needle"),
    [
        ("[controller]\nkpp = 3.0\n", "controller.kpp: unknown key"),
        ("[arm]\nm1 = -1.0\n", "arm.m1: must be > 0, got -1.0"),
        ("[controller]\nkp = nan\n", "controller.kp: must be finite, got nan"),
        ('[controller]\nkind = "pid"\n', "controller.kind: must be one of"),
        ('duration = "long"\n', "duration: must be a number"),
        ('[reference.joint1]\nkind = "step"\nfinal = 1.0\nslope = 2\n', "reference.joint1"),
        ("[plant.scale]\nm3 = 2.0\n", "plant.scale.m3: unknown key"),
        ("[plant]\nflexibility = { k = [0, 1] }\n", "plant.flexibility.k: must be > 0"),
    ],
)
def test_bad_configs_name_file_and_key_and_exit_2(tmp_path, body, needle):
    path = tmp_path / "bad.toml"
    path.write_text(f'extends = "{RUNS / "theta1_step.toml"}"\n' + body)
    with pytest.raises(ConfigError) as info:
        load_scenario(path)
    assert str(info.value).startswith(f"{path}: ") and needle in str(info.value)
    result = CliRunner().invoke(main, ["run", str(path), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2
    assert needle in result.output and "Traceback" not in result.output
    assert not (tmp_path / "o").exists()


def test_missing_file_and_broken_toml_exit_2(tmp_path):
    result = CliRunner().invoke(main, ["run", str(tmp_path / "nope.toml")])
    assert result.exit_code == 2 and "no such file" in result.output
    (tmp_path / "broken.toml").write_text("duration = = 3\n")
    result = CliRunner().invoke(main, ["run", str(tmp_path / "broken.toml")])
    assert result.exit_code == 2 and "not valid TOML" in result.output


def test_build_controller_gives_ctc_with_the_nominal_model():
    s = load_scenario(RUNS / "theta1_step.toml", {"plant": {"scale": {"m1": 2.0}}})
    c = build_controller(s)
    assert isinstance(c, ComputedTorque) and c.model == s.arm
    assert s.plant_params.m1 == 2 * s.arm.m1


def test_every_shipped_scenario_file_loads_and_builds():
    # study files, not scenarios
    special = {
        *("reproduce.toml", "design.toml", "gains.toml", "calibrate.toml", "calibrated.toml"),
        *("frontier.toml", "search.toml"),
    }
    files = [
        p
        for p in RUNS.rglob("*.toml")
        if p.name not in special and not {"sweeps", "search"} & set(p.parts)  # rule bases there
    ]
    assert len(files) >= 11
    for path in files:
        build_controller(load_scenario(path))


def test_fcm_ctc_reads_a_rule_base_file_next_to_the_scenario(tmp_path):
    from twolink.controllers.fuzzy import Rule, save_rule_base

    rules = [Rule("PB", "Z", "PB"), Rule("NB", "Z", "NB")]
    save_rule_base(tmp_path / "mine.toml", rules)
    path = tmp_path / "s.toml"
    path.write_text(
        f'extends = "{RUNS / "theta1_step.toml"}"\n'
        '[controller]\nkind = "fcm_ctc"\nrule_base = "mine.toml"\n'
    )
    assert build_controller(load_scenario(path)).engine.rules == tuple(rules)
    # a broken rule base is bad input: exit 2 with the file named
    (tmp_path / "mine.toml").write_text('[[rule]]\ne = "PB"\nde = "Z"\nu = "HUGE"\n')
    result = CliRunner().invoke(main, ["run", str(path), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2
    assert "HUGE" in result.output and "Traceback" not in result.output


def test_a_rerun_replaces_the_folder_as_a_whole(tmp_path):
    out = tmp_path / "run"
    args = ["run", str(RUNS / "theta1_step.toml"), "--out", str(out), "--set", "duration=0.3"]
    assert CliRunner().invoke(main, args).exit_code == 0
    assert (out / "angles.png").is_file() and (out / "trace.rrd").is_file()
    result = CliRunner().invoke(main, [*args, "--no-plots", "--no-trace"])
    assert result.exit_code == 0, result.output
    # no plot or recording of the earlier run beside the new data
    assert sorted(p.name for p in out.iterdir()) == [
        ".twolink-owner.json",
        ".twolink.lock",
        "config.toml",
        "metrics.json",
        "seal.json",
        "trajectory.npz",
    ]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporaries left
    # a file twolink did not write is never deleted: the rerun is refused instead
    (out / "stray.txt").write_text("from before")
    result = CliRunner().invoke(main, [*args, "--no-plots", "--no-trace"])
    assert result.exit_code == 2 and "stray.txt" in result.output
    assert (out / "stray.txt").read_text() == "from before"
