"""twolink as a library: the README's quick start runs as written; the public API."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np

import twolink

REPO = Path(__file__).resolve().parents[1]


def readme_quick_start() -> str:
    readme = (REPO / "README.md").read_text()
    section = readme.split("## Use it as a library", 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_the_readme_quick_start_runs_and_says_what_the_closed_form_says(tmp_path):
    code = readme_quick_start()
    assert len(code.strip().splitlines()) <= 12  # "about ten lines"
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0, result.stderr
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
    assert df.index.name == "t_s" and np.array_equal(df.index.to_numpy(), traj.t)
    assert np.array_equal(df["theta1_rad"].to_numpy(), traj.q[:, 0])
    assert np.array_equal(df["e2_rad"].to_numpy(), traj.e[:, 1])
    assert np.array_equal(df["tau1_Nm"].to_numpy(), traj.tau[:, 0])
    assert all("_" in c for c in df.columns)  # every column carries its unit
    fig = traj.plot("θ1 step")
    assert len(fig.axes) == 2 and fig.axes[0].get_lines()[1].get_ydata().tolist() == list(
        traj.q[:, 0]
    )
