"""Honest metrics (issue 14, item 3): Tp only where there is a peak, Ts to the target beside
Ts to the final value, max |e| of every joint, and both joints in the report's tables.

Against python-control's step_info where it measures the same thing, and closed forms.
"""

from __future__ import annotations

import math
import re

import control
import numpy as np
import pytest

from twolink.simulation.config import merge, scenario_from_dict
from twolink.simulation.experiment import measure, run_scenario, run_scenarios
from twolink.simulation.metrics import error_measures, step_metrics
from twolink.simulation.vocabulary import METRICS, format_value, joint_values, metric

NEW_KEYS = ("settling_time_target_s", "max_error_rad")


def _underdamped(t: np.ndarray, zeta: float, wn: float) -> np.ndarray:
    """Closed-form unit step response of wn^2 / (s^2 + 2 zeta wn s + wn^2), zeta < 1."""
    wd = wn * math.sqrt(1.0 - zeta * zeta)
    phi = math.acos(zeta)
    return 1.0 - np.exp(-zeta * wn * t) * np.sin(wd * t + phi) / math.sqrt(1.0 - zeta * zeta)


# ----------------------------------------------------------------------------- Tp


@pytest.mark.parametrize(
    "sys",
    [
        control.tf([9.0], [1.0, 6.0, 9.0]),  # critically damped
        control.tf([5.0], [1.0, 6.0, 5.0]),  # overdamped
        control.tf([1.0], [1.0, 1.0]),  # first order
    ],
    ids=["critical", "overdamped", "first order"],
)
def test_a_monotone_response_has_no_peak_time_though_step_info_reports_one(sys) -> None:
    t = np.arange(0.0, 40.0, 0.01)
    y = np.asarray(control.step_response(sys, t).outputs, dtype=float)
    assert np.all(np.diff(y) >= -1e-12)  # monotone (up to rounding)
    info = control.step_info(y, t, yfinal=1.0)
    assert math.isfinite(info["PeakTime"])  # python-control always reports one
    m = step_metrics(t, y, target=1.0)
    assert math.isnan(m.peak_time)  # not the end of the run, nor where rounding put it
    # the other metrics still agree with step_info
    assert abs(m.rise_time - info["RiseTime"]) <= 0.01 * (1 + 1e-9)
    assert abs(m.settling_time - info["SettlingTime"]) <= 0.01 * (1 + 1e-9)
    assert m.overshoot == pytest.approx(0.0, abs=1e-12)
    assert info["Overshoot"] == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("zeta", [0.2, 0.4, 0.6])
def test_peak_time_with_overshoot_agrees_with_step_info_and_the_closed_form(zeta: float) -> None:
    wn, dt = 2.0, 1e-3
    t = np.arange(0.0, 40.0, dt)
    y = _underdamped(t, zeta, wn)
    info = control.step_info(y, t, yfinal=1.0)
    m = step_metrics(t, y, target=1.0)
    assert m.peak_time == info["PeakTime"]
    assert abs(m.peak_time - math.pi / (wn * math.sqrt(1.0 - zeta * zeta))) <= dt


def test_a_peak_is_a_turn_by_more_than_the_band() -> None:
    t = np.arange(6.0)
    # Rises to 1.05, ends at 1.0: turns by 5 % of the step, a peak at t = 3.
    assert step_metrics(t, np.array([0, 0.5, 0.9, 1.05, 1.01, 1.0]), 1.0).peak_time == 3.0
    # Rises to 1.015 and ends at 1.0: a turn inside the 2 % band is no peak...
    assert math.isnan(step_metrics(t, np.array([0, 0.5, 0.9, 1.015, 1.0, 1.0]), 1.0).peak_time)
    # ... unless the band is narrower.
    y = np.array([0, 0.5, 0.9, 1.015, 1.0, 1.0])
    assert step_metrics(t, y, 1.0, settling_threshold=0.01).peak_time == 3.0
    # A response short of its target that falls back has a peak (no overshoot, though).
    m = step_metrics(t, np.array([0, 0.4, 0.8, 0.9, 0.7, 0.6]), 1.0)
    assert m.peak_time == 3.0 and m.overshoot == 0.0
    # Downward steps the same: from 1 to -1, undershooting -1 by 10 % of |S| = 2.
    m = step_metrics(t, np.array([1.0, 0.0, -0.9, -1.2, -1.02, -1.0]), -1.0, y0=1.0)
    assert m.peak_time == 3.0


# ----------------------------------------------------------------------------- Ts to the target


@pytest.mark.parametrize("gain", [1.0, 0.995, 0.99, 1.01])
def test_settling_time_to_the_target_closed_form_first_order(gain: float) -> None:
    """y = A (1 - exp(-t/τ)) rises monotonically to A (0.98 < A < 1.02): it stays within
    2 % of the target 1 once y > 0.98, i.e. A e^(-t/τ) < A - 0.98, so Ts→θd =
    τ ln(A / (A - 0.98)); within 2 % of its own final value A once A e^(-t/τ) < 0.02, so
    Ts = τ ln(A / 0.02)."""
    tau, dt = 0.5, 1e-4
    t = np.arange(0.0, 30.0 * tau, dt)
    y = gain * (1.0 - np.exp(-t / tau))
    to_target = step_metrics(t, y, 1.0, final_value=1.0).settling_time
    to_final = step_metrics(t, y, 1.0).settling_time
    assert abs(to_target - tau * math.log(gain / (gain - 0.98))) <= dt
    assert abs(to_final - tau * math.log(gain / 0.02)) <= dt
    if gain < 1.0:
        assert to_target > to_final  # short of the target: later into its band


def test_settling_time_to_the_target_agrees_with_step_info_given_that_final_value() -> None:
    zeta, wn, dt = 0.3, 2.0, 1e-3
    t = np.arange(0.0, 30.0, dt)
    for gain in (1.0, 0.99, 1.005):  # ends at, short of, past its target
        y = gain * _underdamped(t, zeta, wn)
        info = control.step_info(y, t, yfinal=1.0, SettlingTimeThreshold=0.02)
        ours = step_metrics(t, y, 1.0, final_value=1.0).settling_time
        assert abs(ours - info["SettlingTime"]) <= dt * (1 + 1e-9), gain


def test_a_response_that_settles_off_target_has_ts_but_no_ts_to_the_target() -> None:
    t = np.linspace(0.0, 10.0, 1001)
    y = 0.9 * (1.0 - np.exp(-3.0 * t))  # settles 10 % short
    assert math.isfinite(step_metrics(t, y, 1.0).settling_time)
    assert math.isnan(step_metrics(t, y, 1.0, final_value=1.0).settling_time)


# ----------------------------------------------------------------------------- max |e|


def test_max_error_closed_form_per_joint() -> None:
    """e1 = exp(-t) sin t peaks at t = π/4 at exp(-π/4)/√2; e2 = -2 exp(-2t) is largest at
    t = 0 (|e2| = 2); a ramp followed by a first-order lag (v τ (1 - e^(-t/τ)) until the
    ramp ends at T, then decaying) lags most at T."""
    dt = 1e-4
    t = np.arange(0.0, 10.0, dt)
    v, tau, ramp_end = 0.5, 0.3, 2.0
    lag = np.where(
        t < ramp_end,
        v * tau * (1.0 - np.exp(-t / tau)),
        v * tau * (1.0 - np.exp(-ramp_end / tau)) * np.exp(-(t - ramp_end) / tau),
    )
    e = np.stack([np.exp(-t) * np.sin(t), -2.0 * np.exp(-2.0 * t), lag], axis=1)
    m = error_measures(t, e)
    expected = (
        math.exp(-math.pi / 4) / math.sqrt(2.0),
        2.0,
        v * tau * (1.0 - math.exp(-ramp_end / tau)),
    )
    # The sampled maximum misses a smooth one by at most |e''| (dt/2)^2 / 2 < 1e-8.
    np.testing.assert_allclose(m.max_abs, expected, rtol=0, atol=1e-7)
    assert error_measures(t, e[:, 1]).max_abs == 2.0  # one signal: a float
    bad = e[:, 0].copy()
    bad[100] = np.nan
    assert math.isnan(error_measures(t, bad).max_abs)


# ----------------------------------------------------------------------------- runs

# Self-contained scenarios (not the shipped runs/, whose gains and references may change):
# the paper's arm, θ1 ramps to 1 rad over 2 s (or steps), θ2 held at 0.
RAMP = {"kind": "ramp", "initial": 0.0, "final": 1.0, "duration": 2.0}
STEP = {"kind": "step", "initial": 0.0, "final": 1.0}
QUINTIC = {"kind": "quintic", "initial": 0.0, "final": 1.0, "duration": 2.0}
HELD = {"kind": "step", "initial": 0.0, "final": 0.0}


def _scenario(joint1=RAMP, **overrides):
    data = {
        "name": "honest",
        "duration": 4.0,
        "arm": {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 9.81},
        "controller": {"kind": "ctc", "kp": 25.0, "kd": 10.0, "torque_limit": math.inf},
        "reference": {"joint1": joint1, "joint2": HELD},
    }
    return scenario_from_dict(merge(data, overrides))


def test_measure_reports_ts_to_the_target_and_every_joints_max_error() -> None:
    s = _scenario()
    traj = run_scenario(s)
    m = measure(s, traj)
    j1, j2 = joint_values(m, 1), joint_values(m, 2)
    target, y0 = s.reference.final[0], s.q0[0]
    assert j1["settling_time_target_s"] == (
        step_metrics(traj.t, traj.q[:, 0], target, y0, final_value=target).settling_time
    )
    assert j1["max_error_rad"] == float(np.max(np.abs(traj.e[:, 0])))
    # The held joint: no step metrics, but its largest deviation and final error.
    assert math.isnan(j2["peak_time_s"]) and math.isnan(j2["settling_time_target_s"])
    assert j2["max_error_rad"] == float(np.max(np.abs(traj.e[:, 1]))) > 0.0
    assert j2["max_error_rad"] >= j2["final_error_rad"]


def test_a_sagging_arm_settles_but_never_reaches_its_target() -> None:
    """Soft gains under 30 % more gravity than the model: Ts is finite (it stopped
    somewhere), Ts to the target is NaN (it never got within 2 % of it)."""
    s = _scenario(
        duration=10.0,
        controller={"kp": 4.0, "kd": 4.0},
        plant={"scale": {"g": 1.3}},
    )
    m = joint_values(measure(s, run_scenario(s)), 1)
    assert m["final_error_rad"] > 0.02
    assert math.isfinite(m["settling_time_s"])
    assert math.isnan(m["settling_time_target_s"])


def test_the_batch_path_gives_the_single_arm_paths_new_metrics() -> None:
    scenarios = [
        _scenario(),
        _scenario(plant={"scale": {"g": 1.2, "m2": 1.1}}),
        _scenario(controller={"kind": "fuzzy_ctc"}),
    ]
    for s, batch in zip(scenarios, run_scenarios(scenarios), strict=True):
        single = measure(s, run_scenario(s))
        batched = measure(s, batch)
        for j in (1, 2):
            a, b = joint_values(single, j), joint_values(batched, j)
            for key in NEW_KEYS:
                assert (math.isnan(a[key]) and math.isnan(b[key])) or abs(
                    a[key] - b[key]
                ) <= 1e-9, (j, key)
            assert math.isfinite(a["max_error_rad"])


def test_the_new_keys_are_in_the_vocabulary_and_not_among_the_papers_symbols() -> None:
    from twolink.studies.reproduction.manifest import PAPER_SYMBOLS
    from twolink.sweep import METRIC_COLUMNS

    keys = [m.key for m in METRICS]
    for key in NEW_KEYS:
        assert key in keys
        assert f"joint1_{key}" in METRIC_COLUMNS and f"joint2_{key}" in METRIC_COLUMNS
    assert PAPER_SYMBOLS == ("Tp", "Td", "Tr", "Ts", "Mp", "ess")


# ----------------------------------------------------------------------------- report


def _cells(line: str) -> list[str]:
    """A markdown table row's cells ("\\|" is a literal "|", not a separator)."""
    return [c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]]


@pytest.fixture(scope="module")
def report_rows():
    """Rows as the reproduction makes them (``reproduce._row``) for a step, a ramp and a
    quintic experiment of θ1 (θ2 held), two controllers each, with paper values for one."""
    from pathlib import Path

    from twolink.studies.reproduction.manifest import Experiment, Variant
    from twolink.studies.reproduction.reproduce import RunSpec, _row

    paper = {"CTC": {"Tp": 5.89, "Ts": 12.3, "Mp": 0.655}}
    exps = {
        "table2": Experiment("step", Path("step.toml"), 1, table=2, paper=paper),
        "table3": Experiment("ramp", Path("ramp.toml"), 1, table=3, paper=paper),
        "figure6": Experiment("quintic", Path("quintic.toml"), 1, figure=6),
    }
    references = {"table2": STEP, "table3": RAMP, "figure6": QUINTIC}
    variant = Variant("rigid", "rigid arm", {})
    controllers = {"CTC": {"kind": "ctc"}, "CTC-I": {"kind": "ctc_integral", "ki": 20.0}}
    rows = []
    for key, exp in exps.items():
        for name, ctrl in controllers.items():
            over = {"duration": 3.0, "controller": ctrl}
            s = _scenario(references[key], **over)
            traj = run_scenario(s)
            spec = RunSpec(exp, variant, name, over)
            rows.append(_row(spec, s, traj.status, measure(s, traj)))
    return variant, exps, list(controllers), rows


def test_every_experiment_table_shows_the_held_joint(report_rows) -> None:
    from twolink.studies.reproduction.report import CLAIMED_BETTER, experiment_table

    variant, exps, controllers, rows = report_rows
    for key, kind in (("table2", "step"), ("table3", "ramp"), ("figure6", "quintic")):
        ramp = kind != "step"  # a ramp or quintic move: its tracking error too
        exp = exps[key]
        lines = experiment_table(rows, exp, variant.name, controllers).splitlines()
        head = _cells(lines[0])
        held = f"θ{3 - exp.joint} held: "
        expected_tail = [
            "osc [rad]",
            *(["max\\|e\\| [rad]", "IAE [rad·s]"] if ramp else []),
            held + "max\\|e\\| [rad]",
            held + "e(T) [rad]",
            "outcome",
        ]
        assert head[0] == "controller"
        assert head[1 : 1 + len(CLAIMED_BETTER)] == [
            f"{metric(k).label} ours / paper" for k in CLAIMED_BETTER
        ]
        assert head[1 + len(CLAIMED_BETTER) :] == expected_tail
        assert all(len(_cells(line)) == len(head) for line in lines[1:])
        for line, ctrl in zip(lines[2:], controllers, strict=True):
            row = next(r for r in rows if (r["experiment"], r["controller"]) == (key, ctrl))
            cells = dict(zip(head, _cells(line), strict=True))
            assert row["reference"] == kind
            assert row["other_reference"] == "held"
            assert cells[held + "max\\|e\\| [rad]"] == format_value(row["other_max_error_rad"])
            assert cells[held + "e(T) [rad]"] == format_value(row["other_final_error_rad"])
            assert cells["outcome"] == row["outcome"]
            if ramp:
                assert cells["max\\|e\\| [rad]"] == format_value(row["max_error_rad"])
                assert cells["IAE [rad·s]"] == format_value(row["iae_rad_s"])
            # the paper's values stay beside ours
            tp = cells[f"{metric('peak_time_s').label} ours / paper"]
            assert tp.endswith(f"/ {format_value(exp.paper_value(ctrl, 'peak_time_s'))}")


def test_rows_carry_the_other_joints_values(report_rows) -> None:
    *_, rows = report_rows
    for row in rows:
        assert row["joint"] == 1
        assert row["other_max_error_rad"] >= row["other_final_error_rad"] >= 0.0
        assert math.isfinite(row["max_error_rad"])
