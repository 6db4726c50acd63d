"""twolink as a library: the README's quick start runs as written; the public API."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
from clone_guard import clone_files, written

import twolink

REPO = Path(__file__).resolve().parents[1]


def readme_quick_start() -> str:
    readme = (REPO / "README.md").read_text()
    section = readme.split("## Use it as a library", 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_the_readme_quick_start_runs_and_says_what_the_closed_form_says(tmp_path):
    code = readme_quick_start()
    assert len(code.strip().splitlines()) <= 12  # "about ten lines"
    before = clone_files()
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0, result.stderr
    assert written(before) == []  # from any folder, writing only there
    # ωn = 5, ζ = 1 with an exact model: e(t) = (1 + ωn t) exp(-ωn t), whose 10-90 %
    # rise time is 0.672 s and 2 % settling time 1.167 s (solved numerically below).
    t = np.linspace(0, 3, 300_001)
    y = 1 - (1 + 5 * t) * np.exp(-5 * t)
    rise = t[np.argmax(y >= 0.9)] - t[np.argmax(y >= 0.1)]
    settle = t[np.nonzero(np.abs(1 - y) > 0.02)[0][-1]]
    assert f"rise {rise:.2f} s, settling {settle:.2f} s" in result.stdout, result.stdout
    assert (tmp_path / "theta1_step.png").stat().st_size > 10_000


def test_every_public_name_resolves_from_the_package():
    for name in twolink.__all__:
        assert getattr(twolink, name) is not None, name
    from twolink.controllers.ctc import ComputedTorque
    from twolink.simulation.sim import simulate

    assert twolink.ComputedTorque is ComputedTorque and twolink.simulate is simulate
    assert set(twolink.__all__) <= set(dir(twolink))


def test_import_twolink_loads_neither_mujoco_nor_matplotlib():
    code = "import sys, twolink; print('mujoco' in sys.modules, 'matplotlib' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.stdout.split() == ["False", "False"], out.stderr


def test_a_trajectory_converts_to_a_dataframe_and_plots_itself():
    arm = twolink.ArmParams()
    ref = twolink.ArmReference(twolink.Step(0.0, 1.0), twolink.Step(0.0, 0.0))
    traj = twolink.simulate(
        twolink.Plant.build(arm), twolink.ComputedTorque(arm, ref, kp=25.0, kd=10.0), 0.5
    )
    df = traj.to_dataframe()
    assert df.index.name == "time_s" and np.array_equal(df.index.to_numpy(), traj.t)
    assert np.array_equal(df["joint1_angle_rad"].to_numpy(), traj.q[:, 0])
    assert np.array_equal(df["joint2_error_rad"].to_numpy(), traj.e[:, 1])
    assert np.array_equal(df["joint1_torque_Nm"].to_numpy(), traj.tau[:, 0])
    assert all("_" in c for c in df.columns)  # every column carries its unit
    fig = twolink.run_figures(traj, "θ1 step")["angles"]  # figures live above the simulation
    assert len(fig.axes) == 2 and fig.axes[0].get_lines()[1].get_ydata().tolist() == list(
        traj.q[:, 0]
    )


def readme_one_call_block() -> str:
    page = (REPO / "docs" / "library.md").read_text()  # the README links it
    return re.search(r"```python\n(.*?)```", page, re.S).group(1)


def test_the_library_pages_one_call_block_runs_from_any_folder_and_writes_only_there(tmp_path):
    code = readme_one_call_block()  # as it stands: the sweep by its shipped name
    before = clone_files()
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stderr
    assert written(before) == []
    out = result.stdout
    assert "5 rules:\n  IF e is NM AND de is PS THEN u is NS" in out
    assert "mamdani Tp — s, Td 0.202 s" in out and "continuous Tp — s, Td 0.202 s" in out
    for name in ("CTC", "CTC-I", "FCM-CTC", "FCM-CTC-continuous", "PD-G"):
        assert re.search(rf"^{re.escape(name)}\s+0\.0\d+$", out, re.M), name
    assert (tmp_path / "fcm.png").stat().st_size > 10_000
    assert (tmp_path / "sweep_out" / "results.parquet").is_file()


def test_the_fcm_constructor_is_the_reproductions_fcm_ctc():
    from twolink.simulation.config import load_scenario
    from twolink.simulation.experiment import build_controller

    scenario = load_scenario(
        REPO / "runs/paper/base.toml", {"controller": {"kind": "fcm_ctc", "rule_base": "designed"}}
    )
    shipped = build_controller(scenario)
    ours = twolink.FuzzyComputedTorque.fcm(scenario.arm, scenario.reference, "designed")
    for name in ("kp", "kd", "torque_limit", "ke", "kde", "ku", "mode"):
        assert getattr(ours, name) == getattr(shipped, name), name
    assert ours.engine.rules == shipped.engine.rules
    rng = np.random.default_rng(3)
    for q, qd in rng.normal(0, 0.05, (20, 2, 2)):
        t = float(rng.uniform(0, 2))
        assert ours(t, q, qd) == shipped(t, q, qd)
    smooth = twolink.FuzzyComputedTorque.fcm(
        scenario.arm, scenario.reference, inference="continuous"
    )
    assert type(smooth.engine).__name__ == "ContinuousEngine"


def test_design_and_reproduce_are_one_call(tmp_path):
    designed = twolink.design_rule_base()
    assert designed.rules == twolink.load_rule_base("designed").rules  # the shipped design
    from twolink.studies.reproduction.reproduce import reproduce

    assert twolink.reproduce is reproduce  # run end to end by tests/test_reproduce.py


def test_metrics_print_as_tables():
    from twolink.simulation.config import load_scenario
    from twolink.simulation.experiment import measure, run_scenario

    s = load_scenario(REPO / "runs/paper/theta1_step.toml", {"duration": 2.0})
    m = measure(s, run_scenario(s))
    text = str(m)
    assert text.startswith("ok") and "joint1" in text and "joint2" in text
    assert "rise_time_s" in text and "nan" not in text  # undefined values print as "—"
    html = m._repr_html_()
    assert "<table" in html and "iae_rad_s" in html
    step = m.step[0]
    assert str(step).startswith("Tp ") and "Mp " in str(step) and " %" in str(step)
