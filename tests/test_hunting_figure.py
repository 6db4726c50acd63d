"""The lab arm's hunting figure (twolink/figures/hunting.py): its title says CTC-I hunts
and CTC stops short; the runs it draws must show both."""

from __future__ import annotations

import numpy as np

from twolink.figures.hunting import hunting_figure, hunting_runs
from twolink.simulation.metrics import oscillation_amplitude


def _stuck_errors(run, joint: int, after: float) -> np.ndarray:
    """Joint ``joint``'s error each time it came to rest (|q̇| fell below 1 mrad/s) after
    ``after`` seconds."""
    moving = np.abs(run.qd[:, joint - 1]) > 1e-3
    e = run.q_ref[:, joint - 1] - run.q[:, joint - 1]
    stops = np.flatnonzero(np.diff(moving.astype(int)) == -1) + 1
    return e[stops[run.t[stops] > after]]


def test_ctc_i_hunts_and_ctc_stops_short_on_the_figures_plant(tmp_path):
    runs = hunting_runs()
    hunt, clean = runs["CTC-I"], runs["CTC"]
    # CTC-I: the joint sticks on alternate sides of the target, again and again
    late = _stuck_errors(hunt, 2, after=5.0)
    assert len(late) >= 3 and np.all(np.sign(late[1:]) != np.sign(late[:-1]))
    assert oscillation_amplitude(hunt.t, hunt.q_ref - hunt.q)[1] > 5e-3  # rad
    # CTC: it stops short by its dead band, once, and stays (no slip after t = 2 s; MuJoCo's
    # dry friction is a stiff constraint, not a lock: it creeps by 0.14 mrad in 18 s)
    e = clean.q_ref - clean.q
    held = e[clean.t > 2.0]
    assert np.all(np.abs(held - held[-1]) < 2e-4) and np.all(np.abs(held[-1]) > 5e-3)
    assert oscillation_amplitude(clean.t, e) == (0.0, 0.0)
    fig = hunting_figure(runs)
    assert "CTC-I hunts" in fig._suptitle.get_text()
