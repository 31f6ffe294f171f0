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


def test_threaded_faces_near_gives_the_serial_rows():
    """faces_near over the threads (chunks moved together in order) writes the rows, boxes and
    bounds of the serial filter."""
    from impactsim.fracture.particles import NEAR_CHUNK, faces_near, faces_near_chunked

    rng = np.random.default_rng(5)
    n_node, n_face = 6000, 3 * NEAR_CHUNK + 123
    x = rng.uniform(0.0, 10.0, (n_node, 3))
    v = rng.normal(0.0, 50.0, (n_node, 3))
    faces = rng.integers(0, n_node, (n_face, 3)).astype(np.int32)
    body = rng.integers(0, 3, n_face).astype(np.int32)
    cloud = np.array([[2.0, 1.0, 3.0], [6.0, 5.0, 8.0]])

    def out():
        return (np.full((n_face, 3), np.nan), np.full((n_face, 3), np.nan),
                np.full((n_face, 3), -1, np.int32), np.full(n_face, -1, np.int32),
                cloud.copy())

    a, b = out(), out()
    ka = faces_near(x, v, 1e-3, faces, body, n_face, 0.01, cloud, *a)
    n_chunk = -(-n_face // NEAR_CHUNK)
    for threads in sorted({1, 2}):
        b = out()
        kb = faces_near_chunked(x, v, 1e-3, faces, body, n_face, 0.01, cloud, *b,
                                np.zeros(n_chunk, np.int64), np.empty((n_chunk, 2, 3)), threads,
                                np.zeros(1, np.int64))
        assert kb == ka and 0 < ka < n_face
        for u, w in zip(a[:4], b[:4]):
            np.testing.assert_array_equal(u[:ka], w[:ka])
        np.testing.assert_array_equal(a[4], b[4])
