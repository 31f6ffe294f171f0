"""Contact impulses on nodes with prescribed velocity components (the boundary-conditions pass
runs before contact): a prescribed component is an infinite mass along its axis, so an impulse
changes a node's velocity only along its free axes and uses the matching effective mass
(impactsim.contact.impulse, used by nodeface.point_face_impulse and edgeedge._apply; rows)."""

import numpy as np
import pytest

from impactsim.contact import make_contact_passes
from impactsim.contact.edgeedge import edge_edge_detect
from impactsim.contact.nodeface import node_face_correct
from impactsim.contact.rows import row_partners, rows_round
from impactsim.mesh.structured import structured_box

from test_contact_nodeface import crossing_reference
from test_contact_passes import case_with, make_model, penetration, rot, step

EPS = 1e-6
TAU = 1e-6


def momentum(v, m):
    return (m[:, None] * v).sum(axis=0)


def random_node_face(rng):
    """Node 0 falling through a tilted face (nodes 1..3) within the step."""
    face = rng.normal(size=(3, 3)) * 1e-2
    face[:, 2] *= 0.1  # a face tilted a little from the x-y plane, as at a flyer's interface
    n = np.cross(face[1] - face[0], face[2] - face[0])
    n *= np.sign(n[2]) / np.linalg.norm(n)
    if np.cross(face[1] - face[0], face[2] - face[0])[2] < 0:
        face[[1, 2]] = face[[2, 1]]
    w = rng.dirichlet([3, 3, 3])
    p = w @ face + n * rng.uniform(1e-5, 1e-4)
    v_face = rng.normal(size=(3, 3)) * 10.0
    v_p = w @ v_face - n * rng.uniform(150, 300) + rng.normal(size=3) * 5
    return np.vstack([p, face]), np.vstack([v_p, v_face]), rng.uniform(0.5, 2.0, 4)


@pytest.mark.parametrize("held", ["xy", "mixed"])
def test_node_face_impulse_leaves_held_components_alone(held):
    rng = np.random.default_rng(1)
    done = 0
    for _ in range(40):
        x, v, m = random_node_face(rng)
        lock = np.ones((4, 3))
        if held == "xy":
            lock[:, :2] = 0.0  # uniaxial strain: every node held in x and y
        else:
            lock[rng.random((4, 3)) < 0.4] = 0.0
            lock[:, 2] = 1.0  # z stays free somewhere, so the pair can be held apart
        v[lock == 0.0] = 0.0  # what the boundary-conditions pass left
        ref = crossing_reference(x, v, TAU)
        if ref is None:
            continue
        _, w, n = ref
        v0 = v.copy()
        J = node_face_correct(0, 1, 2, 3, x, v, m, TAU, 0.0, 0.0, EPS, 1.0, lock)
        assert J > 0
        done += 1
        assert np.array_equal(v[lock == 0.0], v0[lock == 0.0])  # held: not changed at all
        dp = momentum(v, m) - momentum(v0, m)
        free = lock.min(axis=0) == 1.0  # axes free at all four nodes
        np.testing.assert_allclose(dp[free], 0.0, atol=1e-13 * J)
        # velocity change along the free axes only: dv_k = c_k J (lock_k * n) / m_k
        c = np.array([1.0, -w[0], -w[1], -w[2]])
        np.testing.assert_allclose(v - v0, (c / m)[:, None] * J * lock * n, atol=1e-9 * J)
        rel = (v[0] - w @ v[1:]) @ n  # the relative normal velocity reaches its target, 0
        assert abs(rel) <= 1e-10 * np.abs(v0).max()
    assert done > 20


def test_node_face_without_free_axis_along_the_normal_gives_nothing():
    # a face in the x-y plane and every node held in z: the constraints take all of it
    x = np.array([[0.2, 0.2, 1e-5], [0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    v = np.array([[3.0, 0, -100.0], [0, 0, 0], [0, 0, 0], [0, 0, 0]])
    lock = np.ones((4, 3))
    lock[:, 2] = 0.0
    v0 = v.copy()
    assert node_face_correct(0, 1, 2, 3, x, v, np.ones(4), TAU, 0.3, 0.0, EPS, 1.0, lock) == 0.0
    assert np.array_equal(v, v0)


@pytest.mark.parametrize("mu", [0.0, 0.3])
def test_free_locks_give_the_plain_impulse(mu):
    rng = np.random.default_rng(2)
    for _ in range(20):
        x, v, m = random_node_face(rng)
        va, vb = v.copy(), v.copy()
        ja = node_face_correct(0, 1, 2, 3, x, va, m, TAU, mu, 0.0, EPS, 1.0)
        jb = node_face_correct(0, 1, 2, 3, x, vb, m, TAU, mu, 0.0, EPS, 1.0, np.ones((4, 3)))
        assert jb == pytest.approx(ja, rel=1e-12)
        np.testing.assert_allclose(vb, va, rtol=0, atol=1e-11 * np.abs(v).max())


def test_node_face_friction_with_held_components_stays_in_the_cone():
    rng = np.random.default_rng(3)
    for _ in range(20):
        x, v, m = random_node_face(rng)
        lock = np.ones((4, 3))
        lock[1:, 0] = 0.0  # the face's nodes held in x
        v[lock == 0.0] = 0.0
        v0 = v.copy()
        J = node_face_correct(0, 1, 2, 3, x, v, m, TAU, 0.3, 0.0, EPS, 1.0, lock)
        if not J > 0:
            continue
        assert np.array_equal(v[lock == 0.0], v0[lock == 0.0])
        dp = momentum(v, m) - momentum(v0, m)
        np.testing.assert_allclose(dp[1:], 0.0, atol=1e-12 * J)  # y and z free everywhere


def edge_setup(rng):
    """Edge [a, b] of body 1 above edge [e, f] of body 2, meeting at alpha = 0.7, beta = 0.5 in
    the step, the pair turned by a random rotation (so the normal is oblique)."""
    x = np.array([[-0.5, 0.0, 1e-4], [0.5, 0.0, 1e-4], [0.2, -0.5, 0.0], [0.2, 0.5, 0.0]])
    v = np.array([[0, 0, -200.0], [0, 0, -200.0], [0, 0, 0], [0, 0, 0]])
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    x = x @ q.T * 1e-2
    v = v @ q.T + rng.normal(size=(4, 3))
    return x, v, rng.uniform(0.5, 2.0, 4)


@pytest.mark.parametrize("held", ["xy", "mixed"])
def test_edge_edge_impulse_leaves_held_components_alone(held):
    rng = np.random.default_rng(4)
    done = 0
    for _ in range(30):
        x, v, m = edge_setup(rng)
        lock = np.ones((4, 3))
        if held == "xy":
            lock[:, :2] = 0.0
        else:
            lock[rng.random((4, 3)) < 0.4] = 0.0
            lock[:, 2] = 1.0
        v[lock == 0.0] = 0.0
        v0 = v.copy()
        geo = np.zeros((1, 7))
        J = edge_edge_detect(0, 1, 2, 3, x, v, m, 1e-4, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, geo, 0,
                             lock)
        if not J > 0:
            continue
        done += 1
        assert np.array_equal(v[lock == 0.0], v0[lock == 0.0])
        free = lock.min(axis=0) == 1.0
        dp = momentum(v, m) - momentum(v0, m)
        np.testing.assert_allclose(dp[free], 0.0, atol=1e-12 * J)
        # the constraint row of the crossing (alpha, beta, n, gap term 0): the approach of d on
        # [a, b] and c on [e, f] along n is closed, by nodes moving along lock * n only
        al, be, n = geo[0, 1], geo[0, 2], geo[0, 3:6]
        assert geo[0, 0] == J and geo[0, 6] == 0.0
        c = np.array([-(1 - al), -al, 1 - be, be])
        np.testing.assert_allclose(v - v0, (c / m)[:, None] * J * lock * n, atol=1e-9 * J)
        approach0 = -(c @ v0) @ n
        assert approach0 > 0
        assert abs((c @ v) @ n) <= 1e-10 * approach0
    assert done > 15


def test_mirror_rows_with_held_components_are_solved_together():
    # node 0 falls on node 1 along an oblique normal; both are held in x: the pair of mirror
    # rows has the coupling of the locked masses (C = D), one row's impulse, no x velocity
    n = np.array([0.6, 0.0, 0.8])
    v = np.zeros((6, 3))
    v[0, 2] = -1.0
    mass = np.ones(6)
    lock = np.ones((6, 3))
    lock[:, 0] = 0.0
    idx = np.array([[0, 1, 2, 3], [1, 0, 4, 5]], np.int64)
    coef = np.array([[1.0, -1.0, 0, 0], [1.0, -1.0, 0, 0]])
    nrm = np.array([n, -n])
    tgt = np.zeros(2)
    lam = np.zeros(2)
    diag = np.zeros(2)
    partner = np.zeros(2, np.int64)
    row_partners(idx, coef, nrm, mass, diag, partner, lock)
    assert list(partner) == [1, 0]
    np.testing.assert_allclose(diag, 2 * 0.64)
    stamp = np.zeros(6, np.int64)
    for k in range(2):
        rows_round(idx, coef, nrm, tgt, lam, diag, partner, v, mass, stamp, k + 1, lock)
    u = np.einsum("rk,rkd,rd->r", coef, v[idx], nrm)
    np.testing.assert_allclose(u, 0.0, atol=1e-15)
    assert np.all(v[:, 0] == 0.0)
    assert lam.sum() == pytest.approx(0.8 / 1.28)
    np.testing.assert_allclose(v[:2, 2], -0.5)
    np.testing.assert_allclose(momentum(v, mass)[1:], [0.0, -1.0])


def test_passes_on_a_uniaxial_scene_leave_held_components_and_conserve_free_momentum():
    # a rotated block falling on a plate, every node held in x and y (as the flyer plate):
    # the held components stay 0, z momentum is conserved, nothing penetrates
    a = structured_box((0.02, 0.02, 0.01), 0.004)
    b = structured_box((0.01, 0.01, 0.01), 0.003)
    b = (b[0] @ rot(2, 17).T + [0.001, 0.002, 0.0101], b[1])
    m = make_model([a, b], [(0, 0, 0), (0, 0, -300.0)])
    m.bc_nodes = np.arange(m.n_node, dtype=np.int32)
    m.bc_mask = np.tile([True, True, False], (m.n_node, 1))
    pz = m.mass @ m.v[:, 2]
    passes = make_contact_passes(case_with(passes=["node-face", "edge-edge"]), m)
    applied = 0
    for _ in range(4):
        step(m, passes, 1e-6)
        applied += sum(s["pairs"] for s in passes[0].ctx.last.values())
        assert np.all(m.v[:, :2] == 0.0)
        assert penetration(m) <= 1e-12
    assert applied > 0
    assert m.mass @ m.v[:, 2] == pytest.approx(pz, rel=1e-13)


def test_particle_face_impulse_leaves_held_face_components_alone():
    from impactsim.fracture.particles import particle_face_sweep
    x = np.array([[0, 0, 0], [1e-3, 0, 2e-5], [0, 1e-3, -1e-5]], float)  # a tilted face
    v = np.zeros((3, 3))
    mass = np.array([1e-6, 2e-6, 3e-6])
    lock = np.ones((3, 3))
    lock[:, :2] = 0.0
    px = np.array([[3e-4, 3e-4, 1.2e-4]])
    pv = np.array([[5.0, 0.0, -200.0]])
    pm = np.array([1e-6])
    faces = np.array([[0, 1, 2]], np.int32)
    pairs = np.array([[0, 0]], np.int64)
    p0 = pm @ pv + mass @ v
    applied, work = particle_face_sweep(pairs, px, pv, pm, np.array([1e-4]), faces, x, v, mass,
                                        np.zeros((3, 3)), 0.0, 1e-6, EPS, lock)
    assert applied == 1 and work < 0.0
    assert np.all(v[:, :2] == 0.0) and np.all(v[:, 2] < 0.0)
    assert (pm @ pv + mass @ v)[2] == pytest.approx(p0[2], rel=1e-13)
