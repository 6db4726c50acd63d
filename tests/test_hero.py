"""The README's figure (twolink.studies.reproduction.hero): the experiment where the pair differ
most."""

from types import SimpleNamespace

import numpy as np

from twolink.simulation.sim import Trajectory
from twolink.studies.reproduction.hero import hero, pair_gap


def trajectory(q1: np.ndarray, n: int | None = None) -> Trajectory:
    n = len(q1) if n is None else n
    t = np.arange(n) * 1e-3
    q = np.zeros((n, 2))
    q[:, 0] = q1[:n]
    z = np.zeros((n, 2))
    return Trajectory(t, q, z, z, z, z, z, np.empty((0, 2)))


def specs_and_runs(gaps: dict[tuple[str, str], float]):
    """Per (variant, experiment): FCM-CTC at 0, CTC at the gap, PD-G far off (not the pair)."""
    specs, runs = [], {}
    variants, experiments = {}, {}
    for (v, e), gap in gaps.items():
        variant = variants.setdefault(v, SimpleNamespace(name=v, title=f"{v} arm"))
        exp = experiments.setdefault(
            e, SimpleNamespace(key=e, label=f"Table {e}", title=f"{e} step", joint=1)
        )
        for name, offset in (("FCM-CTC", 0.0), ("CTC", gap), ("PD-G", 5.0)):
            folder = f"{v}/{e}/{name}"
            specs.append(SimpleNamespace(variant=variant, experiment=exp, controller=name,
                                         folder=folder))  # fmt: skip
            runs[folder] = trajectory(np.full(100, offset))
    return specs, runs


def test_it_picks_the_largest_pair_difference_not_a_baselines():
    specs, runs = specs_and_runs({("rigid", "2"): 3e-17, ("raw", "2"): 0.05, ("raw", "3"): 0.1})
    shown = hero(specs, runs, ("FCM-CTC", "CTC"))
    assert shown is not None
    folders, joint, title = shown
    assert folders == {n: f"raw/3/{n}" for n in ("FCM-CTC", "CTC", "PD-G")}
    assert joint == 1
    assert title == (
        "Where FCM-CTC and CTC differ most: largest |Δθ1| 0.1 rad\nTable 3: 3 step\n(raw arm)"
    )


def test_ties_go_to_the_first_and_a_missing_pair_to_none():
    specs, runs = specs_and_runs({("rigid", "2"): 0.0, ("rigid", "3"): 0.0})
    assert hero(specs, runs, ("FCM-CTC", "CTC"))[0]["CTC"] == "rigid/2/CTC"
    assert hero(specs, runs, ("FCM-CTC", "CTC-matched")) is None


def test_the_gap_is_over_the_samples_both_runs_have():
    a = trajectory(np.zeros(100))
    b = trajectory(np.r_[np.full(50, 0.01), np.full(50, np.nan)])
    assert pair_gap(a, b, 1) == 0.01
    assert pair_gap(a, trajectory(np.ones(100), 1), 1) == 1.0
    assert pair_gap(a, trajectory(np.full(10, np.nan)), 1) == 0.0
