"""The fair linear opponent's rule (twolink/studies/designs/matching.py): the largest ωn scale at
which CTC's peak torque stays within the proposed controller's, on synthetic peaks with a
known answer (the shipped claims studies' matches: tests/test_reproduce.py)."""

from __future__ import annotations

import numpy as np
import pytest

from twolink.studies.designs.matching import SCALES, choose_scale

NO_LIMIT = np.array([np.inf, np.inf])


def quadratic(peak_at_1: tuple[float, float]) -> np.ndarray:
    # a raw step's peak torque grows as Kp = (s ωn)²: peak(s) = peak(1) s²
    # (SCALES[5] is 1.0)
    return np.outer(SCALES**2, peak_at_1)


def test_the_match_is_where_the_peak_crosses_the_proposed_controllers():
    grid = quadratic((40.0, 10.0))
    # joint 2 binds first here: 10 s² <= 11 up to s = 1.049, linear between 1.0 and 1.1
    scale, _ = choose_scale(np.array([48.4, 11.0]), grid[5], grid, NO_LIMIT)
    assert scale == pytest.approx(1.0 + 0.1 * (1 - 10 / 11) / (12.1 / 11 - 10 / 11), abs=1e-12)
    target = np.array([40.0 * 1.21, 20.0])  # joint 1 binds: s = 1.1 exactly
    scale, peak = choose_scale(target, grid[5], grid, NO_LIMIT)
    assert scale == pytest.approx(1.1, abs=1e-9)  # 1.1 is a grid point: no interpolation
    target = np.array([40.0 * 1.15**2, 100.0])
    scale, peak = choose_scale(target, grid[5], grid, NO_LIMIT)
    # between the grid points 1.1 and 1.2, linearly in the ratio: close to 1.15
    assert 1.1 < scale < 1.2 and scale == pytest.approx(1.15, abs=0.005)
    assert peak[0] == pytest.approx(target[0], rel=0.01)


def test_a_joint_at_its_limit_binds_nothing_and_no_extra_torque_means_scale_1():
    grid = np.minimum(quadratic((40.0, 10.0)), [100.0, 15.0])  # joint 2 saturates early
    target = np.array([40.0 * 1.3**2, 15.0])  # the proposed controller at joint 2's limit
    scale, _ = choose_scale(target, grid[5], grid, np.array([100.0, 15.0]))
    assert scale == pytest.approx(1.3, abs=1e-9)  # joint 1 alone decides
    # the proposed controller spends what the baseline does: the baseline is its match
    same = quadratic((24.0, 6.3))
    assert choose_scale(same[5], same[5], same, NO_LIMIT) == (1.0, pytest.approx(same[5]))
    flat = np.tile([24.0, 6.3], (SCALES.size, 1))  # smooth moves: feedforward sets the peak
    assert choose_scale(np.array([24.0, 6.3]), flat[5], flat, NO_LIMIT)[0] == 1.0


def test_a_failed_proposed_run_is_an_error_not_a_match():
    grid = quadratic((40.0, 10.0))
    with pytest.raises(ValueError, match="no torque to match"):
        choose_scale(np.array([np.nan, 10.0]), grid[5], grid, NO_LIMIT)
