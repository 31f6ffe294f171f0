"""The faces near the particle cloud picked over the threads (fracture/particles.py,
``faces_near_chunked``): the rows, boxes and bounds of the serial filter."""

import numpy as np


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
