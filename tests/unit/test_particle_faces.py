"""The faces near the particles on the threads (fracture/particle_faces.py) are ``faces_near``'s:
the same faces in the same order, bodies, boxes and bounds, bit for bit, on 1 and 2 threads, on
a surface of several chunks with faces far from the cloud in every chunk; the table packed for
all nodes holds every node's position, velocity and mass; and the particle pass gives the same
with the faces found either way."""

import numba
import numpy as np
import pytest

from impactsim.fracture import particle_faces as PF
from impactsim.fracture.particle_cells import EVERY_CELL, ParticleCells
from impactsim.fracture.particles import NODE_COLS, faces_near, particle_boxes
from tests.unit.test_fracture_particle_contact import _particles_over_a_plate

TAU = 1e-8


def _surface(seed=3):
    rng = np.random.default_rng(seed)
    n, nf = 60, 3 * PF.FACE_CHUNK + 17
    px = rng.uniform(0.0, 1e-2, (n, 3))
    pv = rng.normal(0.0, 100.0, (n, 3))
    pr = rng.uniform(1e-5, 2e-4, n)
    corner = rng.uniform(-1e-2, 2e-2, (nf, 1, 3))
    x = (corner + rng.uniform(0.0, 1e-3, (nf, 3, 3))).reshape(-1, 3)
    v = rng.normal(0.0, 100.0, x.shape)
    faces = rng.permutation(3 * nf).astype(np.int32).reshape(nf, 3)  # nodes scattered
    body = rng.integers(0, 3, nf).astype(np.int32)
    mass = rng.uniform(1e-9, 2e-9, x.shape[0])
    plo, phi, cloud = np.empty((n, 3)), np.empty((n, 3)), np.empty((2, 3))
    particle_boxes(px, pv, pr, n, TAU, 1e-7, plo, phi, cloud)
    return x, v, mass, faces, body, cloud, plo, phi


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("marked", ["every cell", "the particles' cells"])
def test_threaded_faces_near_is_faces_near(threads, marked):
    if threads > numba.config.NUMBA_NUM_THREADS:
        pytest.skip(f"NUMBA_NUM_THREADS={numba.config.NUMBA_NUM_THREADS}")
    x, v, mass, faces, body, cloud, plo, phi = _surface()
    nf = faces.shape[0]
    cells = EVERY_CELL
    if marked != "every cell":
        occ = ParticleCells()
        occ.mark_boxes(plo, phi, plo.shape[0], cloud, 1e-3)
        cells = occ.args()
    out = {}
    before = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        for side in ("serial", "threads"):
            flo, fhi = np.full((nf, 3), np.nan), np.full((nf, 3), np.nan)
            sel, sel_body = np.full((nf, 3), -1, np.int32), np.full(nf, -1, np.int32)
            bounds = cloud.copy()
            table = np.full((x.shape[0], NODE_COLS), np.nan)
            if side == "serial":
                k = faces_near(x, v, mass, TAU, faces, body, nf, 1e-7, cloud, *cells, flo, fhi,
                               sel, sel_body, bounds, table)
            else:
                n_chunk = -(-nf // PF.FACE_CHUNK)
                PF.pack_all_nodes(x, v, mass, table)
                k = PF.faces_near_threads(
                    x, v, TAU, faces, body, nf, 1e-7, cloud, *cells, flo, fhi, sel, sel_body,
                    bounds,
                    np.empty((nf, 3)), np.empty((nf, 3)), np.empty(nf, np.uint8),
                    np.empty(n_chunk, np.int64), np.empty((n_chunk, 2, 3)))
            out[side] = (k, flo[:k], fhi[:k], sel[:k], sel_body[:k], bounds, table)
    finally:
        numba.set_num_threads(before)
    k, flo, fhi, sel, sel_body, bounds, table = out["serial"]
    k2, flo2, fhi2, sel2, sel_body2, bounds2, table2 = out["threads"]
    assert 0 < k == k2 < nf - 100  # far faces left out, near ones in every chunk
    chunks = np.isin(faces, sel).all(axis=1).nonzero()[0] // PF.FACE_CHUNK
    assert set(chunks.tolist()) == {0, 1, 2, 3}
    if marked != "every cell":  # the faces (large triangles) that touch no particle's cell left out
        every = faces_near(x, v, mass, TAU, faces, body, nf, 1e-7, cloud, *EVERY_CELL,
                           np.empty((nf, 3)), np.empty((nf, 3)), np.empty((nf, 3), np.int32),
                           np.empty(nf, np.int32), cloud.copy(), np.empty_like(table))
        assert k < every
    for a, b in ((flo, flo2), (fhi, fhi2), (bounds, bounds2)):
        assert np.array_equal(a.view(np.int64), b.view(np.int64))
    assert np.array_equal(sel, sel2) and np.array_equal(sel_body, sel_body2)
    nodes = np.unique(sel)
    assert np.array_equal(table2[nodes, :7], table[nodes, :7])  # what the sweep reads
    assert np.array_equal(table2[:, :3], x) and np.array_equal(table2[:, 3:6], v)
    assert np.array_equal(table2[:, 6], mass)


def test_the_particle_pass_with_the_faces_found_on_the_threads(monkeypatch):
    dt = 2e-9
    results = []
    threads = numba.get_num_threads()
    try:
        for least, n_threads in ((10**12, 1), (0, threads)):
            monkeypatch.setattr(PF, "THREADED_FACES", least)
            numba.set_num_threads(n_threads)
            model, ppass = _particles_over_a_plate(1500, False)
            model.energy_terms["contact_dissipated"] = 0.0
            ppass.run(model, dt)
            results.append((model.v.copy(), ppass.s.particles.v[:1500].copy(),
                            model.energy_terms["contact_dissipated"], ppass.impacts,
                            PF.threaded_faces_wanted(1)))
    finally:
        numba.set_num_threads(threads)
    (v0, pv0, w0, hits0, on0), (v1, pv1, w1, hits1, on1) = results
    assert hits0 > 50 and not on0 and on1 == (threads > 1)
    np.testing.assert_array_equal(v1, v0)
    np.testing.assert_array_equal(pv1, pv0)
    assert (w1, hits1) == (w0, hits0)
