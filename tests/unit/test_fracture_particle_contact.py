"""Particle-face contact (ALGORITHMS.md 4.1 with the node-face algebra of 3.1): which side of a
face a particle meets it from, crossing within one step, momentum; the particle broad phase's
selection of faces; the particle sums."""

import numpy as np
import pytest

from impactsim.fracture.particle_cells import EVERY_CELL, ParticleCells
from impactsim.fracture.particles import (Particles, faces_near, particle_boxes,
                                          particle_face_sweep)

R = 1e-4  # [m] particle radius
TAU = 1e-8  # [s]


def _scene(z0, vz):
    """One face (0, 1, 2) in the plane z = 0, outward normal +z, nodes of 1e-8 kg at rest; one
    particle of 1e-8 kg above its centroid at height z0, velocity vz."""
    x = np.array([[0.0, 0.0, 0.0], [1e-3, 0.0, 0.0], [0.0, 1e-3, 0.0]])
    v = np.zeros((3, 3))
    mass = np.full(3, 1e-8)
    faces = np.array([[0, 1, 2]], dtype=np.int32)
    px = np.array([[1e-3 / 3, 1e-3 / 3, z0]])
    pv = np.array([[0.0, 0.0, vz]])
    pm, pr = np.array([1e-8]), np.array([R])
    return x, v, mass, faces, px, pv, pm, pr


def _sweep(x, v, mass, faces, px, pv, pm, pr):
    pairs = np.array([[0, 0]], dtype=np.int64)
    force = np.zeros_like(x)
    return particle_face_sweep(pairs, px, pv, pm, pr, faces, x, v, mass, force, 0.0, TAU, 1e-6)


def test_overlapping_particle_in_front_of_the_face_is_stopped():
    s = _scene(0.5 * R, -100.0)
    x, v, mass, faces, px, pv, pm, pr = s
    p0 = pm @ pv + mass @ v
    applied, work = _sweep(*s)
    assert applied == 1 and work < 0.0
    # equal normal velocities: the particle and the face point move together
    assert pv[0, 2] == pytest.approx(v.mean(axis=0)[2], rel=1e-12)
    assert np.allclose(pm @ pv + mass @ v, p0, rtol=0, atol=1e-20)


def test_particle_behind_the_face_plane_is_left_alone():
    """A centre behind the plane (here within one radius of it, moving on) is inside the body
    or past the face: the face must not act on it. Counting such pairs let one particle press on
    the opposite faces of a thin cell at once and crush it."""
    s = _scene(-0.5 * R, -100.0)
    x, v, mass, faces, px, pv, pm, pr = s
    applied, _ = _sweep(*s)
    assert applied == 0
    assert pv[0, 2] == -100.0 and np.all(v == 0.0)


def test_fast_particle_crossing_within_one_step_is_caught():
    """In front at the start, far behind at the end of the step: it must not tunnel."""
    s = _scene(2.0 * R, -1e5)  # moves 1 mm in the step
    x, v, mass, faces, px, pv, pm, pr = s
    applied, _ = _sweep(*s)
    assert applied == 1
    gap_end = (px[0, 2] + TAU * pv[0, 2]) - (TAU * v.mean(axis=0)[2]) - R
    assert gap_end >= -1e-12


def test_face_with_a_massless_node_takes_no_impulse():
    s = _scene(0.5 * R, -100.0)
    s[2][1] = 0.0  # node 1 orphaned by erosion
    applied, work = _sweep(*s)
    assert applied == 0 and work == 0.0
    assert s[5][0, 2] == -100.0 and np.all(s[1] == 0.0)


def _overlapping(lo, hi, plo, phi):
    """Whether each box (lo, hi) overlaps one of the boxes (plo, phi) (closed intervals)."""
    return np.any(np.all((lo[:, None, :] <= phi[None, :, :]) & (plo[None, :, :] <= hi[:, None, :]),
                         axis=2), axis=1)


def test_broad_phase_keeps_exactly_the_faces_near_the_particles():
    rng = np.random.default_rng(3)
    n, nf = 50, 400
    px = rng.uniform(0.0, 1e-2, (n, 3))
    pv = rng.normal(0.0, 100.0, (n, 3))
    pr = rng.uniform(1e-5, 2e-4, n)
    corner = rng.uniform(-1e-2, 2e-2, (nf, 1, 3))
    x = (corner + rng.uniform(0.0, 1e-3, (nf, 3, 3))).reshape(-1, 3)  # small triangles
    v = rng.normal(0.0, 100.0, x.shape)
    faces = np.arange(3 * nf, dtype=np.int32).reshape(nf, 3)
    body = rng.integers(0, 2, nf).astype(np.int32)
    plo, phi, cloud = np.empty((n, 3)), np.empty((n, 3)), np.empty((2, 3))
    r_max = particle_boxes(px, pv, pr, n, TAU, 1e-7, plo, phi, cloud)
    assert r_max == pr.max()
    assert np.array_equal(cloud, [plo.min(axis=0), phi.max(axis=0)])
    flo, fhi = np.empty((nf, 3)), np.empty((nf, 3))
    sel, sel_body, bounds = np.empty((nf, 3), np.int32), np.empty(nf, np.int32), cloud.copy()
    mass = rng.uniform(1e-9, 2e-9, x.shape[0])
    table = np.full((x.shape[0], 8), np.nan)
    k = faces_near(x, v, mass, TAU, faces, body, nf, 1e-7, cloud, *EVERY_CELL, flo, fhi, sel,
                   sel_body, bounds, table)
    ends = np.stack([x[faces], x[faces] + TAU * v[faces]], axis=1).reshape(nf, 6, 3)
    lo, hi = ends.min(axis=1) - 1e-7, ends.max(axis=1) + 1e-7
    near = np.flatnonzero(np.all((lo <= cloud[1]) & (hi >= cloud[0]), axis=1))
    assert 0 < k == near.size < nf
    assert np.array_equal(sel[:k], faces[near]) and np.array_equal(sel_body[:k], body[near])
    assert np.allclose(flo[:k], lo[near]) and np.allclose(fhi[:k], hi[near])
    assert np.allclose(bounds, [np.minimum(cloud[0], lo[near].min(axis=0)),
                                np.maximum(cloud[1], hi[near].max(axis=0))])
    # the sweep's table holds the selected faces' nodes (position, velocity, mass), no other
    nodes = np.unique(faces[near])
    assert np.array_equal(table[nodes, :3], x[nodes]) and np.array_equal(table[nodes, 3:6],
                                                                          v[nodes])
    assert np.array_equal(table[nodes, 6], mass[nodes])
    assert np.isnan(np.delete(table, nodes, axis=0)[:, :7]).all()
    # with the cells the particle boxes touch (cells of a tenth of the faces' size): fewer
    # faces, in order, and every one whose box overlaps a particle's among them
    cells = ParticleCells()
    cells.mark_boxes(plo, phi, n, cloud, 1e-4)
    bounds = cloud.copy()
    k2 = faces_near(x, v, mass, TAU, faces, body, nf, 1e-7, cloud, *cells.args(), flo, fhi, sel,
                    sel_body, bounds, table)
    kept = sel[:k2, 0] // 3  # the faces' indices (their nodes are 3 f, 3 f + 1, 3 f + 2)
    assert np.all(np.diff(kept) > 0) and np.isin(kept, near).all()
    assert np.array_equal(sel[:k2], faces[kept]) and np.array_equal(sel_body[:k2], body[kept])
    touching = near[_overlapping(lo[near], hi[near], plo, phi)]
    assert 0 < touching.size <= k2 < k
    assert np.isin(touching, kept).all()


def test_particle_sums():
    pa = Particles(4)
    pa.reserve(40)
    rng = np.random.default_rng(4)
    pa.n = 40
    pa.m[:40] = rng.uniform(1e-9, 1e-8, 40)
    pa.v[:40] = rng.normal(0.0, 1e3, (40, 3))
    pa.energy[:40] = rng.uniform(0.0, 1e-3, 40)
    m, ke, ie, p = pa.sums()
    assert m == pytest.approx(pa.m[:40].sum(), rel=1e-14)
    assert ke == pytest.approx(0.5 * np.sum(pa.m[:40, None] * pa.v[:40] ** 2), rel=1e-14)
    assert ie == pytest.approx(pa.energy[:40].sum(), rel=1e-14)
    assert np.allclose(p, pa.m[:40] @ pa.v[:40], rtol=1e-14, atol=0)


def _particles_over_a_plate(n, collisions):
    """A plate (2 x 2 x 0.5 mm, 0.25 mm cells) with n particles in a slab over and under it,
    moving at random towards it; the particle pass and its state."""
    from impactsim.case.schema import Failure, Fracture
    from impactsim.fracture import make_fracture_passes
    from tests.builders import box_model, material

    mat = material(name="m", failure=Failure(spall_strength=5e9))
    model, case = box_model(mat, size=(2e-3, 2e-3, 0.5e-3), h=0.25e-3)
    case.fracture = Fracture(particle_collisions=collisions)
    ppass = make_fracture_passes(case, model)[0]
    rng = np.random.default_rng(9)
    model.v[:] = rng.normal(0.0, 20.0, model.v.shape)
    pa = ppass.s.particles
    pa.reserve(n)
    side = rng.integers(0, 2, n) * 2 - 1
    pa.x[:n, :2] = rng.uniform(-1.1e-3, 1.1e-3, (n, 2))
    pa.x[:n, 2] = side * rng.uniform(0.25e-3, 0.35e-3, n)
    pa.v[:n] = rng.normal(0.0, 300.0, (n, 3))
    pa.v[:n, 2] -= side * 2000.0
    pa.m[:n] = rng.uniform(0.5e-11, 2e-11, n)
    pa.radius[:n] = rng.uniform(30e-6, 100e-6, n)
    pa.n = n
    return model, ppass


def _particles_in_corners(n, collisions):
    """``_particles_over_a_plate`` with the particles over the corner x, y < -0.6 mm and under
    the corner x, y > 0.6 mm of the 2 mm plate."""
    model, ppass = _particles_over_a_plate(n, collisions)
    pa = ppass.s.particles
    side = np.sign(pa.x[:n, 2])
    rng = np.random.default_rng(11)
    pa.x[:n, :2] = -side[:, None] * rng.uniform(0.6e-3, 1.1e-3, (n, 2))
    return model, ppass


def _brute_pairs(qlo, qhi, elo, ehi, same_set):
    over = np.all((qlo[:, None, :] <= ehi[None, :, :]) & (elo[None, :, :] <= qhi[:, None, :]),
                  axis=2)
    if same_set:
        over &= np.arange(len(elo))[None, :] > np.arange(len(qlo))[:, None]
    return np.argwhere(over).astype(np.int64)  # sorted by (query, entry)


@pytest.mark.parametrize("collisions, corner", [(False, False), (True, False), (False, True)])
def test_particle_pass_equals_the_sweeps_over_brute_force_pairs(monkeypatch, collisions, corner):
    """The particle pass (particle boxes, faces near them, spatial hash, sweeps, motion) gives,
    bit for bit, what the sweeps give over every pair of overlapping boxes in sorted order:
    the broad phase finds exactly those pairs, in Gauss-Seidel order, on one thread or two and
    with the query split in chunks. ``corner``: the particles over a corner of the plate and
    under the opposite one, so that the faces left out as touching no particle's cells
    (particle_cells.py) are most of those near the particles' bounding box."""
    import numba

    from impactsim.contact import broadphase
    from impactsim.fracture import passes as FPass
    from impactsim.fracture.particles import move_particles, particle_particle_sweep

    dt = 2e-9
    n = 1500
    scene = _particles_in_corners if corner else _particles_over_a_plate
    model, ppass = scene(n, collisions)
    s = ppass.s
    b = s.boundary
    # the reference: boxes as the pass makes them, every overlapping pair, the same sweeps
    ref_model, ref_pass = scene(n, collisions)
    rpa = ref_pass.s.particles
    pad = FPass.PAD * s.h_face
    plo, phi, cloud = np.empty((n, 3)), np.empty((n, 3)), np.empty((2, 3))
    particle_boxes(rpa.x, rpa.v, rpa.radius, n, dt, pad, plo, phi, cloud)
    flo, fhi = np.empty((b.n, 3)), np.empty((b.n, 3))
    sel, sel_body, bounds = np.empty((b.n, 3), np.int32), np.empty(b.n, np.int32), cloud.copy()
    k = faces_near(ref_model.x, ref_model.v, ref_model.mass, dt, b.faces, b.face_body, b.n, pad,
                   cloud, *EVERY_CELL, flo, fhi, sel, sel_body, bounds,
                   np.empty((ref_model.n_node, 8)))
    pairs = _brute_pairs(plo, phi, flo[:k], fhi[:k], False)
    applied, work = particle_face_sweep(pairs, rpa.x, rpa.v, rpa.m, rpa.radius, sel,
                                        ref_model.x, ref_model.v, ref_model.mass,
                                        ref_model.force, ref_model.dtv, dt, FPass.EPS_BARY)
    assert applied > 50 and pairs.shape[0] > 3 * applied
    if collisions:
        pp = _brute_pairs(plo, phi, plo, phi, True)
        hits, dke = particle_particle_sweep(pp, rpa.x, rpa.v, rpa.m, rpa.radius, dt)
        assert hits > 5
        work += dke
    move_particles(rpa.x, rpa.v, n, dt)
    monkeypatch.setattr(broadphase, "QUERY_CHUNK", 128)  # 12 chunks of particle queries
    threads = numba.get_num_threads()
    try:
        for n_threads in sorted({1, threads}):
            numba.set_num_threads(n_threads)
            m, p = scene(n, collisions)
            m.energy_terms["contact_dissipated"] = 0.0
            p.run(m, dt)
            assert p.impacts == applied
            hashed = p.hash.boxes.shape[0]  # the faces the pass hashed, of the k near the cloud
            assert hashed < k / 2 if corner else hashed > k / 2
            np.testing.assert_array_equal(p.s.particles.v[:n], rpa.v[:n])
            np.testing.assert_array_equal(p.s.particles.x[:n], rpa.x[:n])
            np.testing.assert_array_equal(m.v, ref_model.v)
            assert m.energy_terms["contact_dissipated"] == -work
    finally:
        numba.set_num_threads(threads)


def test_the_sweeps_node_table_follows_the_impulses():
    """The sweep reads the face nodes from its table (packed by particles.faces_near): after a sweep
    with many impulses, every face node's row still holds its position, mass and current
    velocity (a later pair reads the velocity an earlier impulse left), and the sweep over the
    table gives what it gives on the arrays, node by node and particle by particle."""
    from impactsim.fracture import passes as FPass
    from impactsim.fracture.particles import NODE_COLS, particle_face_sweep_packed

    dt = 2e-9
    n = 1500
    model, ppass = _particles_over_a_plate(n, False)
    b = ppass.s.boundary
    pa = ppass.s.particles
    pad = FPass.PAD * ppass.s.h_face
    plo, phi, cloud = np.empty((n, 3)), np.empty((n, 3)), np.empty((2, 3))
    particle_boxes(pa.x, pa.v, pa.radius, n, dt, pad, plo, phi, cloud)
    flo, fhi = np.empty((b.n, 3)), np.empty((b.n, 3))
    sel, sel_body, bounds = np.empty((b.n, 3), np.int32), np.empty(b.n, np.int32), cloud.copy()
    table = np.full((model.n_node, NODE_COLS), np.nan)
    k = faces_near(model.x, model.v, model.mass, dt, b.faces, b.face_body, b.n, pad, cloud,
                   *EVERY_CELL, flo, fhi, sel, sel_body, bounds, table)
    pairs = _brute_pairs(plo, phi, flo[:k], fhi[:k], False)
    v0, pv0 = model.v.copy(), pa.v.copy()
    applied, work = particle_face_sweep_packed(pairs, pa.x, pa.v, pa.m, pa.radius, sel, table,
                                               model.v, model.mass, model.force, model.dtv, dt,
                                               FPass.EPS_BARY, np.ones((0, 3)))
    assert applied > 50
    nodes = np.unique(sel[:k])
    changed = np.flatnonzero(np.any(model.v != v0, axis=1))
    assert changed.size > 20 and np.isin(changed, nodes).all()
    np.testing.assert_array_equal(table[nodes, 3:6], model.v[nodes])
    np.testing.assert_array_equal(table[nodes, 0:3], model.x[nodes])
    np.testing.assert_array_equal(table[nodes, 6], model.mass[nodes])
    # the same sweep on the arrays themselves (particle_face_sweep packs a table of its own)
    v1, pv1 = v0.copy(), pv0.copy()
    again = particle_face_sweep(pairs, pa.x, pv1, pa.m, pa.radius, sel, model.x, v1, model.mass,
                                model.force, model.dtv, dt, FPass.EPS_BARY)
    assert again == (applied, work)
    np.testing.assert_array_equal(v1, model.v)
    np.testing.assert_array_equal(pv1, pa.v)
