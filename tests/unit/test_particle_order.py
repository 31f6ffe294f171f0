"""The particles' queries in cell order (fracture/particle_order.py) give the pairs of the query
in particle order, the same pairs in the same order, step after step as particles move and new
ones are made."""

import numpy as np

from impactsim.contact.broadphase import SpatialHash, grid_for
from impactsim.fracture.particle_order import SpatialOrder


def _faces(rng, n):
    c = rng.uniform(0.0, 10.0, (n, 3))
    size = rng.uniform(0.1, 1.5, (n, 3))
    return c - 0.5 * size, c + 0.5 * size


def test_cell_order_queries_give_the_pairs_in_particle_order():
    rng = np.random.default_rng(3)
    flo, fhi = _faces(rng, 3000)
    ent = np.arange(3000).reshape(-1, 1)
    body = np.zeros(3000, np.int32)
    order = SpatialOrder()
    x = rng.uniform(0.0, 10.0, (500, 3))
    plain, ordered = SpatialHash(), SpatialHash()
    checked = 0
    for step in range(6):
        x = np.concatenate([x + rng.normal(0.0, 0.05, x.shape),
                            rng.uniform(0.0, 10.0, (200, 3))])  # moved, and new particles
        r = rng.uniform(0.05, 0.4, x.shape[0])[:, None]
        lo, hi = x - r, x + r
        n = x.shape[0]
        ids = np.arange(n).reshape(-1, 1)
        no_body = np.full(n, -1, np.int32)
        origin, cell = grid_for([(flo, fhi), (lo, hi)], 0.8)
        plain.build(flo, fhi, origin, cell)
        ordered.build(flo, fhi, origin, cell)
        want = plain.query(lo, hi, ids, no_body, ent, body, False, False).copy()
        got = order.pairs(ordered, lo, hi, ids, no_body, ent, body, origin, cell)
        np.testing.assert_array_equal(got, want)
        # the queries really ran in another order than the particles'
        assert not np.array_equal(order.order, np.arange(n))
        checked += want.shape[0]
    assert checked > 5000


def test_order_is_sorted_by_cell_and_a_permutation():
    rng = np.random.default_rng(4)
    lo = rng.uniform(0.0, 5.0, (1000, 3))
    order = SpatialOrder().update(lo, np.zeros(3), 0.5)
    assert np.array_equal(np.sort(order), np.arange(1000))
    c = np.floor(lo[order] / 0.5).astype(np.int64)
    key = (c[:, 0] << 40) | (c[:, 1] << 20) | c[:, 2]
    assert (np.diff(key) >= 0).all()
