"""Fuzzy C-Means clustering (the paper's eqs 22-23, in their standard form).

Minimise the objective

    J_m(U, V) = sum_i sum_j u_ij^m ||x_i - v_j||^2,    sum_j u_ij = 1, m > 1,

by alternating the two optimality conditions

    v_j  = sum_i u_ij^m x_i / sum_i u_ij^m                          (centres)
    u_ij = 1 / sum_k (||x_i - v_j|| / ||x_i - v_k||)^(2 / (m - 1))  (memberships)

from a random initial partition, until max |U(k+1) - U(k)| < eps (the paper's
criterion). The paper's eq 23 mixes its indices; this is the textbook update
(Bezdek 1981) that it means.

Optional sample weights w_i >= 0 weigh each point's term of the objective,
J = sum_i w_i sum_j u_ij^m ||x_i - v_j||^2, so the centres become
v_j = sum_i w_i u_ij^m x_i / sum_i w_i u_ij^m and the membership update is unchanged
(a point's memberships do not depend on its own weight). An integer weight k is the
same as the point repeated k times.

A point that coincides with a centre (zero distance) belongs to that centre
fully (shared equally if several centres coincide there); the update never
divides by zero.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

__all__ = ["FCMResult", "fcm", "fcm_memberships"]


def _as_points(x: np.ndarray, what: str, dim: int | None = None) -> np.ndarray:
    arr = np.asarray(x, dtype=float)
    if arr.ndim != 2:
        raise ValueError(
            f"{what} must be a 2-D array of shape (n_points, n_features), got shape {arr.shape}"
            " (use x.reshape(-1, 1) for 1-D data)"
        )
    if arr.shape[0] < 1 or arr.shape[1] < 1:
        raise ValueError(f"{what} must have at least one point and one feature, got {arr.shape}")
    if dim is not None and arr.shape[1] != dim:
        raise ValueError(f"{what} has {arr.shape[1]} features, the centres have {dim}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{what} contains NaN or infinite values")
    return arr


def _check_m(m: float) -> float:
    if isinstance(m, bool) or not isinstance(m, numbers.Real):
        raise ValueError(f"fuzzifier m must be a real number > 1, got {m!r}")
    m = float(m)
    if not (math.isfinite(m) and m > 1.0):
        raise ValueError(f"fuzzifier m must be a finite number > 1, got {m!r}")
    return m


def fcm_memberships(x: np.ndarray, centers: np.ndarray, m: float) -> np.ndarray:
    """Memberships of points in clusters with given centres (the U update).

    Parameters
    ----------
    x : array_like, shape (N, d)
        Points.
    centers : array_like, shape (c, d)
        Cluster centres.
    m : float
        Fuzzifier, > 1.

    Returns
    -------
    numpy.ndarray, shape (N, c)
        Rows sum to 1. A point at zero distance from a centre gets membership 1
        there (split equally between coincident centres) and 0 elsewhere.
    """
    m = _check_m(m)
    centers = _as_points(centers, "centers")
    x = _as_points(x, "x", dim=centers.shape[1])
    dist = np.sqrt(((x[:, None, :] - centers[None, :, :]) ** 2).sum(axis=-1))
    return _memberships_from_distances(dist, m)


def _memberships_from_distances(dist: np.ndarray, m: float) -> np.ndarray:
    # u_ij = (d_min / d_ij)^p / sum_k (d_min / d_ik)^p with p = 2 / (m - 1): the ratios lie
    # in [0, 1], so the power cannot overflow, and the nearest centre has weight 1, so the
    # sum is >= 1. A zero distance gives ratio 1 there and 0 / d = 0 at the other centres.
    nearest = dist.min(axis=1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(dist > 0.0, nearest / dist, 1.0)
    weight = ratio ** (2.0 / (m - 1.0))
    return weight / weight.sum(axis=1, keepdims=True)


def _centres(
    x: np.ndarray, u: np.ndarray, m: float, previous: np.ndarray | None, weights: np.ndarray
) -> np.ndarray:
    w = weights[:, None] * u**m
    mass = w.sum(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        centers = (w.T @ x) / mass[:, None]
    empty = mass <= 0.0
    if empty.any():
        if previous is None:
            raise ValueError(f"initial partition leaves cluster(s) {np.flatnonzero(empty)} empty")
        # Every member's weight underflowed to zero: keep the cluster where it was.
        centers[empty] = previous[empty]
    return centers


@dataclass(frozen=True, eq=False)
class FCMResult:
    """Outcome of ``fcm``; arrays are read-only.

    Attributes
    ----------
    centers : numpy.ndarray, shape (c, d)
        Cluster centres v_j.
    memberships : numpy.ndarray, shape (N, c)
        Memberships u_ij of the data points with respect to ``centers`` (rows sum to 1):
        the last update, so ``predict(x) == memberships`` for the training data.
    initial_memberships : numpy.ndarray, shape (N, c)
        The starting partition U(0).
    objective : numpy.ndarray, shape (n_iter,)
        J_m(U(k), V(k)) at each iteration k = 0 .. n_iter - 1, V(k) the centres of U(k)
        (with sample weights: the weighted objective).
    n_iter : int
        Iterations run.
    converged : bool
        Whether max |U(k+1) - U(k)| < eps was reached within ``max_iter``.
    m : float
        The fuzzifier used.
    """

    centers: np.ndarray
    memberships: np.ndarray
    initial_memberships: np.ndarray
    objective: np.ndarray
    n_iter: int
    converged: bool
    m: float

    def __post_init__(self) -> None:
        for name in ("centers", "memberships", "initial_memberships", "objective"):
            arr = np.array(getattr(self, name), dtype=float)
            arr.flags.writeable = False
            object.__setattr__(self, name, arr)

    @property
    def n_clusters(self) -> int:
        """Number of clusters c."""
        return self.centers.shape[0]

    @property
    def labels(self) -> np.ndarray:
        """Hard assignment: index of the largest membership of each point, shape (N,)."""
        return np.argmax(self.memberships, axis=1)

    def predict(self, x_new: np.ndarray) -> np.ndarray:
        """Memberships of new points in the fitted clusters, shape (M, c).

        Parameters
        ----------
        x_new : array_like, shape (M, d)
            Points with the training data's number of features.
        """
        return fcm_memberships(x_new, self.centers, self.m)


def fcm(
    x: np.ndarray,
    n_clusters: int,
    m: float = 2.0,
    eps: float = 1e-5,
    max_iter: int = 300,
    *,
    seed: int | None = None,
    rng: np.random.Generator | None = None,
    init: np.ndarray | None = None,
    weights: np.ndarray | None = None,
) -> FCMResult:
    """Fuzzy C-Means clustering.

    Parameters
    ----------
    x : array_like, shape (N, d)
        Data points, one per row (e.g. the (e, de) phase-plane trajectory, d = 2).
    n_clusters : int
        Number of clusters c, 2 <= c <= N.
    m : float, default 2.0
        Fuzzifier, > 1 (m -> 1 gives hard k-means, large m uniform memberships).
    eps : float, default 1e-5
        Stop when max |U(k+1) - U(k)| < eps (``eps = 0`` runs ``max_iter`` iterations).
    max_iter : int, default 300
        Iteration limit; ``converged`` says whether eps was reached.
    seed : int, optional
        Seed of the ``numpy.random.Generator`` that draws the initial partition.
    rng : numpy.random.Generator, optional
        Generator that draws the initial partition (it is advanced).
    init : array_like, shape (N, c), optional
        Initial partition U(0): non-negative, rows summing to 1. Give exactly one
        of ``seed``, ``rng`` and ``init``.
    weights : array_like, shape (N,), optional
        Sample weights w_i >= 0, not all zero (default: all 1): the weighted objective
        sum_i w_i sum_j u_ij^m ||x_i - v_j||^2. Integer weights equal repeated points.

    Returns
    -------
    FCMResult

    Raises
    ------
    ValueError
        For m <= 1, c < 2 or c > N, malformed x, init or weights, eps < 0,
        max_iter < 1, or not exactly one source of the initial partition.
    """
    x = _as_points(x, "x")
    c, m = _check_fcm_options(x.shape[0], n_clusters, m, eps, max_iter)
    w = _check_weights(weights, x.shape[0])
    u = _initial_partition(x.shape[0], c, seed, rng, init)
    u0 = u.copy()

    objective = []
    centers = None
    converged = False
    n_iter = 0
    while n_iter < max_iter:
        centers = _centres(x, u, m, centers, w)
        sq = ((x[:, None, :] - centers[None, :, :]) ** 2).sum(axis=-1)
        objective.append(float((w[:, None] * (u**m) * sq).sum()))
        u_next = _memberships_from_distances(np.sqrt(sq), m)
        change = float(np.max(np.abs(u_next - u)))
        u = u_next
        n_iter += 1
        if change < eps:
            converged = True
            break
    return FCMResult(
        centers=centers,
        memberships=u,
        initial_memberships=u0,
        objective=np.array(objective),
        n_iter=n_iter,
        converged=converged,
        m=m,
    )


def _check_fcm_options(n_points: int, n_clusters, m, eps, max_iter) -> tuple[int, float]:
    """The number of clusters and the fuzzifier, checked with eps and max_iter."""
    if isinstance(n_clusters, bool) or not isinstance(n_clusters, numbers.Integral):
        raise ValueError(f"n_clusters must be an integer, got {n_clusters!r}")
    c = int(n_clusters)
    if c < 2:
        raise ValueError(f"n_clusters must be >= 2, got {c}")
    if c > n_points:
        raise ValueError(f"n_clusters ({c}) cannot exceed the number of points ({n_points})")
    m = _check_m(m)
    if not (isinstance(eps, numbers.Real) and math.isfinite(eps) and eps >= 0):
        raise ValueError(f"eps must be a finite number >= 0, got {eps!r}")
    if isinstance(max_iter, bool) or not isinstance(max_iter, numbers.Integral) or max_iter < 1:
        raise ValueError(f"max_iter must be an integer >= 1, got {max_iter!r}")
    return c, m


def _check_weights(weights, n_points: int) -> np.ndarray:
    """The sample weights (all 1 when not given), checked."""
    if weights is None:
        return np.ones(n_points)
    w = np.asarray(weights, dtype=float)
    if w.shape != (n_points,):
        raise ValueError(f"weights must have shape (N,) = {(n_points,)}, got {w.shape}")
    if not np.all(np.isfinite(w)) or np.any(w < 0) or not w.sum() > 0:
        raise ValueError("weights must be finite, non-negative and not all zero")
    return w


def _initial_partition(n_points: int, c: int, seed, rng, init) -> np.ndarray:
    """U(0): ``init`` checked, or drawn from ``seed`` or ``rng`` (exactly one of the three)."""
    sources = [name for name, v in (("seed", seed), ("rng", rng), ("init", init)) if v is not None]
    if len(sources) != 1:
        raise ValueError(
            "give exactly one of seed, rng or init for the initial partition, got "
            + (", ".join(sources) if sources else "none")
        )
    if init is not None:
        u = np.array(init, dtype=float)
        if u.shape != (n_points, c):
            raise ValueError(f"init must have shape (N, c) = {(n_points, c)}, got {u.shape}")
        if not np.all(np.isfinite(u)) or np.any(u < 0):
            raise ValueError("init must be finite and non-negative")
        if not np.allclose(u.sum(axis=1), 1.0, rtol=0, atol=1e-9):
            raise ValueError("init rows must sum to 1")
        return u / u.sum(axis=1, keepdims=True)
    if rng is None:
        rng = np.random.default_rng(seed)
    elif not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    u = rng.random((n_points, c))
    return u / u.sum(axis=1, keepdims=True)
