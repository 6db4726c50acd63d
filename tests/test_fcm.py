"""Tests of Fuzzy C-Means against synthetic clusters and scikit-fuzzy's cmeans."""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest
import skfuzzy

from twolink.controllers.fcm import FCMResult, fcm, fcm_memberships

TRUE_CENTRES = np.array([[0.0, 0.0], [4.0, 4.0], [-4.0, 3.0], [3.0, -4.0]])
SIGMA = 0.5
PER_BLOB = 500


def blobs(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Gaussian blobs around TRUE_CENTRES; returns the points and each point's blob."""
    rng = np.random.default_rng(seed)
    x = np.vstack([c + SIGMA * rng.standard_normal((PER_BLOB, 2)) for c in TRUE_CENTRES])
    return x, np.repeat(np.arange(len(TRUE_CENTRES)), PER_BLOB)


def match(found: np.ndarray, expected: np.ndarray) -> np.ndarray:
    """Rows of ``found`` reordered to the permutation closest to ``expected``."""
    best = min(
        itertools.permutations(range(len(found))),
        key=lambda p: np.abs(found[list(p)] - expected).max(),
    )
    return found[list(best)]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_recovers_centres_of_gaussian_blobs(seed):
    x, blob = blobs(seed)
    res = fcm(x, 4, seed=seed)
    assert res.converged and res.n_iter < 300
    found = match(res.centers, TRUE_CENTRES)
    # Sampling error of a blob mean is SIGMA / sqrt(500) = 0.022 per coordinate: 0.1 is 4.5 of
    # those. Against each blob's own sample mean only FCM's pull towards the other blobs
    # remains: their points weigh u^2 ~ (0.5 / 5.6)^4 ~ 6e-5 each, a shift of order 1e-3.
    np.testing.assert_allclose(found, TRUE_CENTRES, atol=0.1, rtol=0)
    sample_means = np.array([x[blob == k].mean(axis=0) for k in range(4)])
    np.testing.assert_allclose(found, sample_means, atol=0.01, rtol=0)
    # Hard labels reproduce the blobs (up to the cluster permutation).
    perm = [int(np.argmin(np.abs(res.centers - c).sum(axis=1))) for c in TRUE_CENTRES]
    assert np.mean(res.labels == np.array(perm)[blob]) > 0.99
    # Memberships are a fuzzy partition and predict() reproduces them.
    np.testing.assert_allclose(res.memberships.sum(axis=1), 1.0, atol=1e-12, rtol=0)
    assert res.memberships.min() >= 0.0
    np.testing.assert_allclose(res.predict(x), res.memberships, atol=1e-12, rtol=0)
    # The objective J_m never increases (alternating optimisation).
    assert np.all(np.diff(res.objective) <= 1e-9 * res.objective[0])


@pytest.mark.parametrize("n_iter", [1, 2, 7, 25])
def test_equals_skfuzzy_cmeans_iteration_by_iteration(n_iter):
    x, _ = blobs(3)
    x = x[::5]
    u0 = fcm(x, 4, max_iter=1, seed=11).initial_memberships
    ours = fcm(x, 4, m=2.0, eps=0.0, max_iter=n_iter, init=u0)
    # skfuzzy: data (d, N), init (c, N); a negative error threshold never stops early.
    cntr, u, _, _, jm, p, _ = skfuzzy.cmeans(x.T, 4, 2.0, error=-1.0, maxiter=n_iter, init=u0.T)
    assert p == ours.n_iter == n_iter
    # skfuzzy floors memberships and distances at machine eps; nothing here is that small
    # for it to matter beyond rounding.
    np.testing.assert_allclose(ours.centers, cntr, atol=1e-12, rtol=0)
    np.testing.assert_allclose(ours.memberships, u.T, atol=1e-12, rtol=0)
    np.testing.assert_allclose(ours.objective, jm, rtol=1e-12, atol=0)


@pytest.mark.parametrize("m", [1.5, 2.0, 3.0])
def test_converges_to_skfuzzys_fixed_point(m):
    x, _ = blobs(4)
    x = x[::4]
    rng = np.random.default_rng(5)
    u0 = rng.random((x.shape[0], 4))
    u0 /= u0.sum(axis=1, keepdims=True)
    # Different stopping rules (max |dU| here, ||dU||_F there): both run to a tight eps.
    ours = fcm(x, 4, m=m, eps=1e-13, max_iter=2000, init=u0)
    cntr, u, *_ = skfuzzy.cmeans(x.T, 4, m, error=1e-13, maxiter=2000, init=u0.T)
    assert ours.converged
    np.testing.assert_allclose(ours.centers, cntr, atol=1e-9, rtol=0)
    np.testing.assert_allclose(ours.memberships, u.T, atol=1e-9, rtol=0)


def test_deterministic_for_a_seed_and_generator():
    x, _ = blobs(6)
    a = fcm(x, 4, seed=123)
    b = fcm(x, 4, seed=123)
    np.testing.assert_array_equal(a.initial_memberships, b.initial_memberships)
    np.testing.assert_array_equal(a.centers, b.centers)
    np.testing.assert_array_equal(a.memberships, b.memberships)
    np.testing.assert_array_equal(a.objective, b.objective)
    c = fcm(x, 4, rng=np.random.default_rng(123))
    np.testing.assert_array_equal(a.centers, c.centers)
    d = fcm(x, 4, seed=124)
    assert not np.array_equal(a.initial_memberships, d.initial_memberships)
    # A shared generator advances: two draws differ.
    rng = np.random.default_rng(9)
    e, f = fcm(x, 4, rng=rng), fcm(x, 4, rng=rng)
    assert not np.array_equal(e.initial_memberships, f.initial_memberships)
    # The random partition is a fuzzy partition.
    np.testing.assert_allclose(a.initial_memberships.sum(axis=1), 1.0, atol=1e-12, rtol=0)


def test_points_on_centres_get_full_membership_without_warnings():
    x = np.array([[-1.0], [0.0], [1.0], [9.0], [10.0], [11.0]])
    init = np.array([[1.0, 0.0]] * 3 + [[0.0, 1.0]] * 3)
    # Underflow to zero is harmless (and expected: tiny weights); the rest must not happen.
    with warnings.catch_warnings(), np.errstate(divide="raise", over="raise", invalid="raise"):
        warnings.simplefilter("error")
        res = fcm(x, 2, init=init, max_iter=1)
        np.testing.assert_array_equal(res.centers.ravel(), [0.0, 10.0])
        np.testing.assert_array_equal(res.memberships[[1, 4]], [[1.0, 0.0], [0.0, 1.0]])
        # The others: 1 / (1 + (d1 / d2)^2) with m = 2.
        assert res.memberships[0, 0] == pytest.approx(1.0 / (1.0 + (1.0 / 11.0) ** 2), abs=1e-15)
        np.testing.assert_array_equal(res.predict(np.array([[10.0], [0.0]])), [[0, 1], [1, 0]])
        # Two coincident centres share a point that sits on both.
        np.testing.assert_array_equal(
            fcm_memberships([[1.0, 2.0]], [[1.0, 2.0]] * 2, 2.0), [[0.5, 0.5]]
        )
        # All points identical: every distance vanishes, memberships stay uniform.
        same = fcm(np.ones((5, 2)), 3, seed=0)
        np.testing.assert_allclose(same.memberships, 1.0 / 3.0, atol=1e-15, rtol=0)
        np.testing.assert_allclose(same.centers, 1.0, atol=1e-15, rtol=0)
        # Tiny distances do not overflow the power either (m close to 1: exponent 200).
        near = fcm_memberships([[1e-150, 0.0], [5.0, 5.0]], [[0.0, 0.0], [5.0, 5.0 + 1e-14]], 1.01)
        np.testing.assert_array_equal(near, [[1.0, 0.0], [0.0, 1.0]])


def test_result_is_frozen_and_read_only():
    res = fcm(blobs(0)[0][::10], 4, seed=0)
    assert isinstance(res, FCMResult) and res.n_clusters == 4 and res.m == 2.0
    with pytest.raises(AttributeError):
        res.n_iter = 3
    with pytest.raises(ValueError):
        res.centers[0, 0] = 1.0
    assert res.memberships.shape == (200, 4) and res.centers.shape == (4, 2)
    assert res.objective.shape == (res.n_iter,)


def test_stops_on_eps_or_max_iter():
    x, _ = blobs(7)
    loose = fcm(x, 4, eps=1e-2, seed=1)
    tight = fcm(x, 4, eps=1e-10, seed=1)
    assert loose.converged and tight.converged and loose.n_iter < tight.n_iter
    capped = fcm(x, 4, eps=1e-10, max_iter=2, seed=1)
    assert capped.n_iter == 2 and not capped.converged
    # The criterion is the paper's: the largest membership change of the last step.
    prev = fcm(x, 4, eps=0.0, max_iter=loose.n_iter - 1, seed=1).memberships
    assert np.abs(loose.memberships - prev).max() < 1e-2


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"m": 1.0}, "fuzzifier"),
        ({"m": 0.5}, "fuzzifier"),
        ({"m": float("nan")}, "fuzzifier"),
        ({"n_clusters": 1}, ">= 2"),
        ({"n_clusters": 11}, "exceed"),
        ({"n_clusters": 2.5}, "integer"),
        ({"eps": -1.0}, "eps"),
        ({"max_iter": 0}, "max_iter"),
        ({"seed": None}, "exactly one"),
        ({"rng": np.random.default_rng(0)}, "exactly one"),
        ({"seed": None, "init": np.full((10, 3), 1 / 3)}, "shape"),
        ({"seed": None, "init": np.full((10, 2), 0.6)}, "sum to 1"),
        ({"seed": None, "init": np.tile([1.5, -0.5], (10, 1))}, "non-negative"),
        ({"seed": None, "init": np.tile([1.0, 0.0], (10, 1))}, "empty"),
        ({"x": np.zeros(10)}, "2-D"),
        ({"x": np.zeros((10, 2, 1))}, "2-D"),
        ({"x": np.zeros((0, 2))}, "at least one point"),
        ({"x": np.array([[np.nan, 0.0]] * 10)}, "NaN"),
        ({"weights": np.ones(9)}, "weights must have shape"),
        ({"weights": -np.ones(10)}, "non-negative"),
        ({"weights": np.zeros(10)}, "not all zero"),
        ({"weights": np.full(10, np.nan)}, "finite"),
    ],
)
def test_errors(kwargs, match):
    args = {"x": np.arange(20.0).reshape(10, 2), "n_clusters": 2, "seed": 0} | kwargs
    with pytest.raises(ValueError, match=match):
        fcm(**args)


def test_predict_checks_shape():
    res = fcm(np.arange(20.0).reshape(10, 2), 2, seed=0)
    with pytest.raises(ValueError, match="features"):
        res.predict(np.zeros((3, 3)))
    assert res.predict(np.zeros((3, 2))).shape == (3, 2)


def test_integer_weights_equal_repeated_points():
    # Weighted FCM against its definition: a weight k is the point repeated k times (from
    # the same initial partition, repeated with it), iteration by iteration.
    x, _ = blobs(3)
    rng = np.random.default_rng(5)
    k = rng.integers(0, 4, size=len(x))
    k[0] = 1
    u0 = rng.random((len(x), 4))
    u0 /= u0.sum(axis=1, keepdims=True)
    for n_iter in (1, 7):
        weighted = fcm(x, 4, eps=0.0, max_iter=n_iter, init=u0, weights=k)
        repeated = fcm(
            np.repeat(x, k, axis=0), 4, eps=0.0, max_iter=n_iter, init=np.repeat(u0, k, 0)
        )
        np.testing.assert_allclose(weighted.centers, repeated.centers, rtol=0, atol=1e-12)
        np.testing.assert_allclose(weighted.objective, repeated.objective, rtol=1e-12)
        np.testing.assert_allclose(
            np.repeat(weighted.memberships, k, axis=0), repeated.memberships, atol=1e-12
        )


def test_unit_weights_change_nothing_and_zero_weights_drop_points():
    x, _ = blobs(4)
    plain = fcm(x, 4, seed=1)
    ones = fcm(x, 4, seed=1, weights=np.ones(len(x)))
    np.testing.assert_array_equal(plain.centers, ones.centers)
    np.testing.assert_array_equal(plain.objective, ones.objective)
    # far outliers with zero weight do not move the centres
    outliers = np.full((50, 2), 100.0)
    u0 = np.random.default_rng(2).random((len(x) + 50, 4))
    u0 /= u0.sum(axis=1, keepdims=True)
    with_outliers = fcm(
        np.vstack([x, outliers]),
        4,
        eps=0.0,
        max_iter=20,
        init=u0,
        weights=np.r_[np.ones(len(x)), np.zeros(50)],
    )
    without = fcm(
        x, 4, eps=0.0, max_iter=20, init=u0[: len(x)] / u0[: len(x)].sum(1, keepdims=True)
    )
    np.testing.assert_allclose(with_outliers.centers, without.centers, atol=1e-12)
