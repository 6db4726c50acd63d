"""The README's figure (twolink.studies.reproduction.hero): the experiment where the pair differ
most."""

from types import SimpleNamespace

import numpy as np
import pytest

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


def moved(final: float, target: float = 1.0, n: int = 100) -> Trajectory:
    """A joint-1 move from 0 to ``target`` whose response ends at ``final``."""
    t = np.arange(n) * 1e-3
    q, ref = np.zeros((n, 2)), np.zeros((n, 2))
    q[:, 0] = np.linspace(0, final, n)
    ref[:, 0] = np.linspace(0, target, n)
    z = np.zeros((n, 2))
    return Trajectory(t, q, z, ref, z, z, z, np.empty((0, 2)))


def test_the_title_says_when_both_end_short_of_the_target_and_only_then():
    """Issue 46: the README's figure showed both 0.42 rad short of 1 rad without a word.
    "short" would be wrong where one reaches the target (within 2 % of the move) or
    overshoots it, and the reason where the plant is the model."""
    from twolink.studies.reproduction.hero import shortfall, shortfall_line

    assert shortfall(moved(0.58), 1) == pytest.approx(0.42)
    assert shortfall(moved(0.99), 1) == 0.0  # within 2 % of the move: on target
    assert shortfall(moved(1.1), 1) < 0  # past it
    assert shortfall(moved(-0.58, -1.0), 1) == pytest.approx(0.42)  # a move down, short
    step = moved(0.58)
    step.q_ref[:, 0] = 1.0  # a raw step: the reference is at its target from t = 0
    assert shortfall(step, 1) == pytest.approx(0.42)
    both = {"FCM-CTC": moved(0.58), "CTC": moved(0.6)}
    line = shortfall_line(both, 1, uncertain=True)
    assert line == (
        "\nboth end short of 1 rad: FCM-CTC 0.42 and CTC 0.4 rad (model error, no integral action)"
    )
    assert "model error" not in shortfall_line(both, 1, uncertain=False)
    assert shortfall_line({"FCM-CTC": moved(0.58), "CTC": moved(1.0)}, 1, True) == ""
    assert shortfall_line({"FCM-CTC": moved(1.2), "CTC": moved(1.3)}, 1, True) == ""
