"""The gain study (twolink.studies.designs.gains): its rule, its physics against closed forms, and
that the
shipped table and the gains in use are what the study and its rule give."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd
import pytest

from twolink.arm.dynamics import gravity, mass_matrix
from twolink.arm.params import ArmParams
from twolink.simulation.config import ConfigError, load_scenario
from twolink.studies.designs import gains
from twolink.sweep import load_sweep

SMALL = {"plants": 3, "natural_frequencies": [2.0, 15.0], "damping_ratios": [1.0]}


@pytest.fixture(scope="module")
def small():
    study = gains.load_gain_study(overrides=SMALL)
    return study, gains.run_gain_study(study)


def test_small_study_has_every_run(small):
    study, results = small
    assert len(results) == gains.n_runs(study) == 2 * 2 * 2 * (3 + 2)
    assert set(results.reference) == {"step", "quintic"}
    assert (results.status == "ok").all()


def test_step_demand_is_the_closed_form_ctc_torque_at_t0(small):
    """At t = 0 the arm is at rest and horizontal: CTC asks M̂(0) Kp e0 + Ĝ(0), its peak."""
    _, results = small
    plan = load_sweep(gains.DEFAULT_STUDY.parent / "../sweeps/robustness.toml")
    e0 = np.array([plan.base["reference"][j]["final"] for j in ("joint1", "joint2")])
    arm = ArmParams()
    q0 = np.zeros(2)
    for wn in (2.0, 15.0):
        row = results[
            (results.controller == "CTC")
            & (results.wn == wn)
            & (results.reference == "step")
            & (results.plant == "nominal")
            & ~results.limited
        ].iloc[0]
        expected = mass_matrix(arm, q0) @ (wn**2 * e0) + gravity(arm, q0)
        assert row.torque_peak1 == pytest.approx(abs(expected[0]), rel=1e-9)
        assert row.torque_peak2 >= abs(expected[1]) * (1 - 1e-9)


def test_limited_runs_never_exceed_the_limit_and_saturate_on_stiff_steps(small):
    study, results = small
    limited = results[results.limited]
    assert (limited.torque_peak1 <= study.torque_limit[0] * (1 + 1e-12)).all()
    assert (limited.torque_peak2 <= study.torque_limit[1] * (1 + 1e-12)).all()
    stiff_step = limited[(limited.wn == 15.0) & (limited.reference == "step")]
    assert (stiff_step.saturated1 > 0).all()
    smooth = limited[limited.reference == "quintic"]
    assert (smooth.saturated1 == 0).all() and (smooth.saturated2 == 0).all()


def test_error_under_mismatch_falls_with_stiffness(small):
    """CTC's final error under a gravity mismatch solves M̂ Kp e = G − Ĝ: ~1/ωn²."""
    study, results = small
    table = gains.gain_table(results, study.quantile)
    ctc = table[(table.controller == "CTC") & (table.reference == "quintic")].set_index("wn")
    assert ctc.error_median[15.0] < ctc.error_median[2.0] / 20
    ctc_i = table[(table.controller == "CTC-I") & (table.reference == "quintic")].set_index("wn")
    # Integral action removes the constant mismatch, down to what the study's sensor can
    # see: one count of its 17-bit encoder (4.8e-5 rad; with the true state it is < 1e-6).
    assert ctc_i.error_q[15.0] < study.sensor["resolution_rad"]
    assert ctc_i.error_q[15.0] < ctc.error_q[15.0] / 1000


def _table(rows):
    keys = ("controller", "zeta", "wn", "reference", "error_q", "demand1", "demand2")
    table = pd.DataFrame([dict(zip(keys, r[:7], strict=True)) for r in rows])
    table["step1"] = [r[7] if len(r) > 7 else 0.01 for r in rows]  # N m per period
    table["step2"] = 0.001
    return table


def test_rule_picks_the_smallest_qualifying_wn():
    study = gains.load_gain_study()
    table = _table(
        [
            ("CTC", 1.0, 5.0, "quintic", 0.2, 20.0, 5.0),  # error too large
            ("CTC", 1.0, 8.0, "quintic", 0.04, 80.0, 5.0),  # demand over the limit
            ("CTC", 1.0, 9.0, "quintic", 0.04, 20.0, 5.0, 0.61),  # torque steps > 1 % of 60
            ("CTC", 1.0, 10.0, "quintic", 0.04, 20.0, 5.0, 0.59),  # the one
            ("CTC", 1.0, 12.0, "quintic", 0.01, 20.0, 5.0),
            ("CTC", 1.0, 6.0, "step", 0.01, 20.0, 5.0),  # steps do not count
            ("CTC", 0.7, 6.0, "quintic", 0.01, 20.0, 5.0),  # nor ζ ≠ 1
        ]
    )
    choice = gains.choose(table, study)
    assert (choice.wn, choice.zeta) == (10.0, 1.0)
    assert choice.ki == pytest.approx(study.integral_ratio * 1000.0)
    with pytest.raises(ValueError, match="no ωn"):
        gains.choose(table[table.wn < 9], study)


def test_the_rule_states_its_sensor_and_its_joints_and_warns_on_realistic_ones():
    # The shipped choice (ωn 15) is unstable on realistic joints: the choice says so, with
    # the largest ωn of the grid that is stable there, and points to the flexible laws.
    study = gains.load_gain_study()
    assert gains.sensor_text(study).startswith("17-bit encoder (4.79e-05 rad), filtered")
    _, choice = gains.load_study(study)
    assert choice.realistic_growth > 0
    assert (
        "unstable" in choice.stiffness_note() and "flexible-joint laws" in choice.stiffness_note()
    )
    growth = gains.realistic_growth(study, (choice.realistic_stable_up_to, 5.0))
    assert growth[choice.realistic_stable_up_to] < 0 < growth[5.0]
    stable = gains.Choice(1.0, 1.0, 0.25, "", realistic_growth=-0.5)
    assert "stable (σ = -0.5" in stable.stiffness_note()
    assert "unstable" not in stable.stiffness_note()


def test_shipped_table_is_current_and_the_base_uses_its_choice():
    study = gains.load_gain_study()
    saved = gains.load_study(study)
    assert saved is not None, "runs/paper/gains.csv is stale: run `twolink gains --install`"
    table, choice = saved
    chosen = gains.choose(table, study)
    # σ is an eigenvalue of a finite-difference Jacobian: its last digits (1e-13 relative)
    # follow the BLAS build, so it is compared to 1e-9; every other field exactly.
    assert math.isclose(chosen.realistic_growth, choice.realistic_growth, rel_tol=1e-9)
    assert dataclasses.replace(chosen, realistic_growth=choice.realistic_growth) == choice
    base = load_scenario(gains.DEFAULT_STUDY.parent / "base.toml")
    assert base.controller.kp == (choice.wn**2,) * 2
    assert base.controller.kd == (2 * choice.zeta * choice.wn,) * 2
    assert base.controller.ki == (choice.ki,) * 2
    assert base.controller.torque_limit == study.torque_limit
    # Hurwitz margin of the integral CTC: Ki < Kd Kp.
    assert choice.ki < base.controller.kd[0] * base.controller.kp[0]


def test_digest_ignores_the_base_gains_but_not_the_move(tmp_path):
    study = gains.load_gain_study()
    assert study.digest() == gains.load_gain_study(overrides={}).digest()
    other = gains.load_gain_study(overrides={"move_time": 3.0})
    assert other.digest() != study.digest()


@pytest.mark.parametrize(
    ("override", "key"),
    [
        ({"torque_limit": [60.0, -1.0]}, "torque_limit"),
        ({"natural_frequencies": []}, "natural_frequencies"),
        ({"natural_frequencies": [1.0, math.inf]}, "natural_frequencies"),
        ({"damping_ratios": "one"}, "damping_ratios"),
        ({"quantile": 1.5}, "quantile"),
        ({"plants": 0}, "plants"),
        ({"sweep": "nowhere.toml"}, "sweep"),
        ({"colour": "red"}, "colour"),
    ],
)
def test_bad_study_file_names_the_key(override, key):
    with pytest.raises(ConfigError, match=f"gains.toml: {key}"):
        gains.load_gain_study(overrides=override)


def test_figure_and_summary(small, tmp_path):
    study, results = small
    table = gains.gain_table(results, study.quantile)
    choice = gains.Choice(wn=15.0, zeta=1.0, ki=1.0, reason="test")
    path = gains.tradeoff_figure(table, study, choice, tmp_path / "g.png")
    assert path.stat().st_size > 10_000
    lines = gains.summary_lines(table, choice)
    assert any("**(chosen)**" in line for line in lines)


@pytest.mark.slow
def test_rerun_study_equals_the_shipped_table():
    study = gains.load_gain_study()
    table = gains.gain_table(gains.run_gain_study(study), study.quantile)
    shipped, _ = gains.load_study(study)
    pd.testing.assert_frame_equal(
        table.reset_index(drop=True), shipped, check_dtype=False, rtol=1e-9
    )


def test_cli_runs_a_small_study_and_refuses_bad_input(tmp_path):
    from click.testing import CliRunner

    from twolink.interface.cli import main

    runner = CliRunner()
    args = ["gains", "--out", str(tmp_path / "g"), "--workers", "1"]
    small = ["--set", "plants=2", "--set", "natural_frequencies=[15.0, 25.0]"]
    result = runner.invoke(main, [*args, *small, "--set", "damping_ratios=[1.0]"])
    assert result.exit_code == 0, result.output
    assert "kp = 225" in result.output
    for name in ("gains.csv", "gains.json", "gain_tradeoff.png"):
        assert (tmp_path / "g" / name).is_file()
    bad = runner.invoke(main, [*args, "--set", "quantile=2"])
    assert bad.exit_code == 2 and "quantile" in bad.output and "Traceback" not in bad.output
    refused = runner.invoke(main, [*args, *small, "--install"])
    assert refused.exit_code == 2 and "--set" in refused.output


def test_the_gain_study_runs_its_plants_at_the_sweeps_gravity(monkeypatch):
    """Every chunk runs at the sweep's model gravity (SweepPlan.model_gravity, the largest
    |g| the sweep can draw), not at the largest g of the plants drawn: a plant runs to the
    bit as the sweep runs it."""
    study = gains.load_gain_study(overrides={**SMALL, "plants": 2})
    seen = []
    monkeypatch.setattr(gains, "_run_chunk", lambda source, part, g: seen.append(g) or [])
    gains.run_gain_study(study)
    drawn = [
        gains.scenario_from_dict(d, study.source).plant_params.g for _, d in gains._plans(study)
    ]
    sweep_g = load_sweep(study.sweep, {"samples": study.plants}).model_gravity()
    assert seen and set(seen) == {sweep_g} and sweep_g > max(drawn)


def test_a_gain_run_does_not_depend_on_its_chunk():
    """One model gravity for every chunk (the sweep's): a run's row is the same whether it
    runs among all the study's plants or alone with a plant of smaller g (the chunk's own
    largest |g| would tilt it differently, and the lab's numbers with it)."""
    from twolink.simulation.config import scenario_from_dict

    study = gains.load_gain_study()
    items = list(gains._plans(study))
    g = [scenario_from_dict(d, study.source).plant_params.g for _, d in items]
    model_g = load_sweep(study.sweep, {"samples": study.plants}).model_gravity()
    low = [i for i in range(len(items)) if g[i] < 9.7][:2]  # a chunk without the largest g
    high = [i for i in range(len(items)) if g[i] == max(g)][:1]
    pick = [items[i] for i in low]
    alone = gains._run_chunk(study.source, pick, model_g)
    beside = gains._run_chunk(study.source, pick + [items[i] for i in high], model_g)[:2]
    assert len(alone) == 2
    for a, b in zip(alone, beside, strict=True):
        assert a.keys() == b.keys()
        for k in a:
            assert a[k] == b[k] or (a[k] != a[k] and b[k] != b[k]), k  # equal, NaN alike
