"""Cluster validity indices (twolink/studies/designs/validity.py) against scikit-fuzzy and closed
forms."""

from __future__ import annotations

import numpy as np
import pytest
import skfuzzy

from twolink.controllers.fcm import fcm
from twolink.controllers.fuzzy import default_fuzzy_pd
from twolink.studies.designs.validity import (
    partition_coefficient,
    partition_entropy,
    surface_difference,
    validity_sweep,
    xie_beni,
)


def blobs(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    centres = np.array([[-0.6, -0.5], [0.5, -0.4], [0.0, 0.6]])
    return np.concatenate([c + 0.08 * rng.standard_normal((60, 2)) for c in centres])


def test_partition_coefficient_equals_skfuzzys_fpc():
    x = blobs(0)
    u0 = fcm(x, 3, max_iter=1, seed=3).initial_memberships
    cntr, u, _, _, _, _, fpc = skfuzzy.cmeans(x.T, 3, 2.0, error=1e-12, maxiter=1000, init=u0.T)
    assert partition_coefficient(u.T) == pytest.approx(fpc, abs=1e-12)
    ours = fcm(x, 3, eps=1e-13, max_iter=2000, init=u0)
    np.testing.assert_allclose(ours.centers, cntr, atol=1e-9, rtol=0)  # same fixed point
    assert partition_coefficient(ours.memberships) == pytest.approx(fpc, abs=1e-9)


def test_indices_closed_forms_and_weights():
    c = 4
    uniform = np.full((10, c), 1 / c)
    assert partition_coefficient(uniform) == pytest.approx(1 / c)
    assert partition_entropy(uniform) == pytest.approx(np.log(c))
    crisp = np.eye(c)[np.arange(10) % c]
    assert partition_coefficient(crisp) == 1.0 and partition_entropy(crisp) == 0.0
    # Integer weights equal repeated points.
    x = blobs(1)
    res = fcm(x, 3, seed=0)
    w = np.arange(len(x)) % 3
    rep = np.repeat(np.arange(len(x)), w)
    u = res.memberships
    assert partition_coefficient(u, w) == pytest.approx(partition_coefficient(u[rep]))
    assert xie_beni(x, u, res.centers, 2.0, w) == pytest.approx(
        xie_beni(x[rep], u[rep], res.centers)
    )


def test_sweep_prefers_the_true_number_of_blobs():
    rows = validity_sweep(blobs(2), clusters=range(2, 7))
    assert min(rows, key=lambda r: r.xb).clusters == 3
    assert [r.clusters for r in rows] == [2, 3, 4, 5, 6]


def test_surface_difference_of_an_engine_with_itself_is_zero():
    e = default_fuzzy_pd()
    d = surface_difference(e, e, np.zeros((3, 2)), n=11)
    assert d["box_max"] == d["visited_max"] == 0.0


def test_design_figure_writes_the_validity_figure_beside_it(tmp_path):
    """`twolink design --figure PATH` also writes PATH's <stem>_validity.png: PC, PE and XB
    for c = 2..10 with the design's c marked (the figure the report's design section
    shows); here on a stand-in design result."""
    from types import SimpleNamespace

    from twolink.interface.cli_fuzzy import validity_figure_path, write_validity_figure

    path = validity_figure_path(tmp_path / "phase.png")
    assert path == tmp_path / "phase_validity.png"
    x = blobs(4)
    result = SimpleNamespace(
        points=x, weights=np.ones(len(x)), clustering=SimpleNamespace(n_clusters=3)
    )
    rows = write_validity_figure(result, path)
    assert [r.clusters for r in rows] == list(range(2, 11))
    assert path.stat().st_size > 10_000
