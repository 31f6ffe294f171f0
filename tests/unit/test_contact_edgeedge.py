"""Edge-edge pass ([D19], ALGORITHMS.md 3.2) on hand-built arrays."""

import numpy as np
import pytest

from impactsim.contact.edgeedge import edge_edge_correct, edge_edge_sweep, edge_normals

TAU = 1e-3
NO_NU = (0.0, 0.0, 0.0)


def crossing_setup(masses=(1.0, 3.0, 2.0, 5.0), v1=(0.0, 0.0, -100.0), v2=(0.0, 0.0, 0.0)):
    """Edge [a, b] of body 1 along x, 1 cm above edge [e, f] of body 2 along y, which it meets at
    alpha = 0.7, beta = 0.5 (nodes a, b, e, f = 0, 1, 2, 3)."""
    x = np.array([[-0.5, 0.0, 0.01], [0.5, 0.0, 0.01], [0.2, -0.5, 0.0], [0.2, 0.5, 0.0]])
    v = np.array([v1, v1, v2, v2], float)
    return x, v, np.array(masses, float)


def momentum(v, m):
    return (m[:, None] * v).sum(axis=0)


def test_crossing_edges_get_the_paper_correction():
    x, v, m = crossing_setup()
    v0 = v.copy()
    J = edge_edge_correct(0, 1, 2, 3, x, v, m, TAU, 0.0, 0.0, 1.0, *NO_NU)
    al, be = 0.7, 0.5
    n = np.array([0.0, 0.0, -1.0])  # from body 1 (above) toward body 2 before the crossing
    un = v0 @ n
    S = (1 - be) ** 2 / m[2] + be**2 / m[3] + (1 - al) ** 2 / m[0] + al**2 / m[1]
    Nc = ((1 - al) * un[0] + al * un[1] - (1 - be) * un[2] - be * un[3]) / (TAU * S)  # eq. 11
    assert J == pytest.approx(TAU * Nc, rel=1e-12)
    # eq. 12 with m_b in the last correction
    expected = v0.copy()
    expected[2] += TAU * (1 - be) * Nc / m[2] * n
    expected[3] += TAU * be * Nc / m[3] * n
    expected[0] -= TAU * (1 - al) * Nc / m[0] * n
    expected[1] -= TAU * al * Nc / m[1] * n
    np.testing.assert_allclose(v, expected, rtol=1e-12, atol=1e-12)
    # momentum conserved (only with m_b: masses differ here), equal normal velocities at d and c
    np.testing.assert_allclose(momentum(v, m), momentum(v0, m), atol=1e-12)
    und = (1 - al) * v[0] @ n + al * v[1] @ n
    unc = (1 - be) * v[2] @ n + be * v[3] @ n
    assert und == pytest.approx(unc, abs=1e-12)


def test_random_crossings_conserve_momentum_and_close_the_gap():
    rng = np.random.default_rng(5)
    hits = 0
    for _ in range(60):
        a, b = rng.normal(size=(2, 3))
        e, f = rng.normal(size=(2, 3))
        al, be = rng.uniform(0.05, 0.95, 2)
        d = a + al * (b - a)
        c = e + be * (f - e)
        n = np.cross(b - a, f - e)
        n /= np.linalg.norm(n)
        shift = d + n * rng.uniform(1e-3, 1e-2) - c  # put c just beyond d along n
        x = np.array([a, b, e + shift, f + shift])
        v = rng.normal(size=(4, 3))
        v[:2] += n * 50.0
        m = rng.uniform(0.5, 3.0, 4)
        v0 = v.copy()
        J = edge_edge_correct(0, 1, 2, 3, x, v, m, TAU, 0.0, 0.0, 1.0, *NO_NU)
        np.testing.assert_allclose(momentum(v, m), momentum(v0, m), atol=1e-12)
        assert np.all(np.isfinite(v))
        if J > 0:
            hits += 1
            # after the correction the edges do not cross during the step: the cubic's sign
            # at the end matches its sign at the start (or they stay touching)
            def det(t):
                y = x + t * v
                return np.linalg.det(np.array([y[1] - y[0], y[2] - y[0], y[3] - y[0]]))
            scale = np.abs(x).max() ** 3
            assert det(0) * det(TAU) >= -1e-9 * scale
    assert hits >= 10


def test_parallel_and_collinear_edges_give_no_correction_and_no_nan():
    x = np.array([[-0.5, 0, 0.01], [0.5, 0, 0.01], [-0.5, 0, 0.0], [0.5, 0, 0.0]])
    v = np.array([[0, 0, -100.0]] * 2 + [[0, 0, 0.0]] * 2)
    for band in (0.0, 1e-3):
        vv = v.copy()
        assert edge_edge_correct(0, 1, 2, 3, x, vv, np.ones(4), TAU, 0.0, band, 1.0, 0, 0, -2) == 0
        assert np.array_equal(vv, v)
    # collinear, overlapping and sliding along the line
    x = np.array([[0.0, 0, 0], [1.0, 0, 0], [0.5, 0, 0], [2.0, 0, 0]])
    v = np.array([[10.0, 0, 0]] * 2 + [[-10.0, 0, 0]] * 2)
    vv = v.copy()
    assert edge_edge_correct(0, 1, 2, 3, x, vv, np.ones(4), TAU, 0.0, 1e-3, 1.0, 1, 0, 0) == 0
    assert np.array_equal(vv, v) and np.all(np.isfinite(vv))
    # a degenerate (zero-length) edge
    x = np.array([[0.2, 0, 0.01], [0.2, 0, 0.01], [0.2, -0.5, 0], [0.2, 0.5, 0]])
    vv = np.array([[0, 0, -100.0]] * 2 + [[0, 0, 0.0]] * 2)
    edge_edge_correct(0, 1, 2, 3, x, vv, np.ones(4), TAU, 0.0, 1e-3, 1.0, 0, 0, -2)
    assert np.all(np.isfinite(vv))


def test_lines_meeting_outside_the_segments_give_nothing():
    x, v, m = crossing_setup()
    x[2:, 1] = [0.2, 0.7]  # edge 2 now spans y in [0.2, 0.7]: the lines meet at y = 0
    v0 = v.copy()
    assert edge_edge_correct(0, 1, 2, 3, x, v, m, TAU, 0.0, 0.0, 1.0, *NO_NU) == 0
    assert np.array_equal(v, v0)


def test_separating_or_far_edges_are_untouched():
    for v1 in ((0, 0, 100.0), (0, 0, -5.0)):  # moving away; approaching but not reaching
        x, v, m = crossing_setup(v1=v1)
        v0 = v.copy()
        assert edge_edge_correct(0, 1, 2, 3, x, v, m, TAU, 0.0, 0.0, 1.0, *NO_NU) == 0
        assert np.array_equal(v, v0)


def test_touching_edges_crossed_by_round_off_are_held_by_the_band():
    x, v, m = crossing_setup()
    x[:2, 2] = -1e-12  # body 1's edge a hair below body 2's: crossed by round-off
    nu = (0.0, 0.0, -2.0)  # outward normals: body 1 (above) -z, body 2 (below) +z
    vv = v.copy()
    assert edge_edge_correct(0, 1, 2, 3, x, vv, m, TAU, 0.0, 1e-6, 1.0, *nu) > 0
    assert (0.3 * vv[0, 2] + 0.7 * vv[1, 2]) == pytest.approx(0.5 * vv[2, 2] + 0.5 * vv[3, 2])
    # leaving: untouched
    x2, v2, m2 = crossing_setup(v1=(0, 0, 50.0))
    x2[:2, 2] = -1e-12
    v20 = v2.copy()
    assert edge_edge_correct(0, 1, 2, 3, x2, v2, m2, TAU, 0.0, 1e-6, 1.0, *nu) == 0
    assert np.array_equal(v2, v20)


@pytest.mark.parametrize("mu", [0.2, 50.0])
def test_coulomb_friction_conserves_momentum_and_respects_the_cone(mu):
    x, v, m = crossing_setup(v1=(20.0, 40.0, -100.0))
    v0 = v.copy()
    J = edge_edge_correct(0, 1, 2, 3, x, v, m, TAU, mu, 0.0, 1.0, *NO_NU)
    np.testing.assert_allclose(momentum(v, m), momentum(v0, m), atol=1e-12)
    Jt = np.linalg.norm(m[2:, None] * (v[2:, :2] - v0[2:, :2]), axis=1).sum()
    assert Jt <= mu * J * (1 + 1e-12)
    al, be = 0.698, 0.504  # the crossing at t = 1e-4, after body 1 slid by (2, 4) mm
    rel = ((1 - al) * v[0] + al * v[1]) - ((1 - be) * v[2] + be * v[3])
    if mu == 50.0:
        np.testing.assert_allclose(rel, 0.0, atol=1e-10)


def test_sweep_is_gauss_seidel_and_bit_identical():
    # one edge of body 1 falling across two parallel edges of body 2
    x = np.array([[-0.5, 0, 0.01], [0.5, 0, 0.01], [-0.2, -0.5, 0], [-0.2, 0.5, 0],
                  [0.2, -0.5, 0], [0.2, 0.5, 0]])
    v = np.zeros((6, 3))
    v[:2, 2] = -100.0
    m = np.ones(6)
    edges = np.array([[0, 1], [2, 3], [4, 5]], np.int32)
    pairs = np.array([[0, 1], [0, 2]], np.int64)
    normals = np.zeros((3, 3))
    out = []
    for _ in range(2):
        vv = v.copy()
        active = np.zeros(2, np.uint8)
        stamp = np.zeros(6, np.int64)
        out.append((edge_edge_sweep(pairs, edges, normals, x, vv, m, TAU, 0.0, 0.0, 1.0, active,
                                    stamp, 1, 0, np.zeros((2, 7)), 0.0), vv))
    assert out[0][0] == out[1][0] and np.array_equal(out[0][1], out[1][1])
    applied, total, jump = out[0][0]
    assert applied == 2  # the second pair sees the first correction, and still approaches
    assert np.all(active == 1) and jump > 0
    np.testing.assert_allclose(momentum(out[0][1], m), momentum(v, m), atol=1e-12)
    # Jacobi (both from U*) would differ from the sequential result
    vj = v.copy()
    for k in range(2):
        vk = v.copy()
        edge_edge_sweep(pairs[k:k + 1], edges, normals, x, vk, m, TAU, 0.0, 0.0, 1.0,
                        np.zeros(1, np.uint8), np.zeros(6, np.int64), 1, 0, np.zeros((1, 7)), 0.0)
        vj += vk - v
    assert not np.allclose(vj, out[0][1])


def test_edge_normals_of_a_closed_tet():
    x = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    faces = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]], np.int32)
    edges = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]], np.int32)
    lookup = {tuple(e): i for i, e in enumerate(edges)}
    fe = np.array([[lookup[tuple(sorted((f[i], f[(i + 1) % 3])))] for i in range(3)]
                   for f in faces], np.int64)
    out = np.empty((6, 3))
    edge_normals(x, faces, fe, out)
    centroid = x.mean(axis=0)
    mid = x[edges].mean(axis=1)
    assert np.all(np.einsum("ij,ij->i", out, mid - centroid) > 0)  # outward


def test_stay_apart_only_skips_pairs_the_full_test_leaves_alone():
    """stay_apart (the sweep's test before the cubic) is conservative: whenever it says two
    moving segments stay apart, edge_edge_detect gives no impulse, touching band included; and
    it does skip pairs (near misses within the broad phase's pad would not be skipped)."""
    from impactsim.contact.edgeedge import GEO_COLS, edge_edge_detect, stay_apart

    rng = np.random.default_rng(7)
    band = 1e-3
    skipped = hits = 0
    for trial in range(4000):
        x = rng.uniform(-1.0, 1.0, (4, 3))
        if trial % 2:  # near-coplanar pairs in a thin slab, as in a flat contact
            x[:, 2] *= rng.choice([1e-4, 1e-3, 1e-2])
        v = rng.normal(0.0, 300.0, (4, 3))
        m = rng.uniform(0.5, 2.0, 4)
        nu = rng.normal(size=3)
        apart = stay_apart(0, 1, 2, 3, x, v, TAU, band)
        v1 = v.copy()
        J = edge_edge_detect(0, 1, 2, 3, x, v1, m, TAU, 0.0, band, 1.0, *nu,
                             np.zeros((1, GEO_COLS)), 0, np.zeros((0, 3)))
        hits += J > 0.0
        if apart:
            skipped += 1
            assert J == 0.0 and np.array_equal(v1, v), trial
    assert skipped > 400 and hits > 100  # both kinds of pairs occur


def test_touching_edges_without_impulse_are_revisited_through_their_touching_row():
    """Edges touching at t = 0 (1e-7 apart, band 1e-6) that separate get no impulse and keep
    their touching row (active 2, edgeedge.HELD); when a later sweep finds them approaching,
    the row gives the impulse a new test gives (the same arithmetic: alpha, beta, n and the
    gap depend on the positions at t = 0 alone), and the pair becomes an ordinary row."""
    x = np.array([[-0.5, 0.0, 1e-7], [0.5, 0.0, 1e-7], [0.2, -0.5, 0.0], [0.2, 0.5, 0.0]])
    m = np.array([1.0, 3.0, 2.0, 5.0])
    edges = np.array([[0, 1], [2, 3]], np.int32)
    pairs = np.array([[0, 1]], np.int64)
    normals = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0]])  # outward: body 1 above body 2
    band = 1e-6
    v = np.zeros((4, 3))
    v[:2, 2] = 1.0  # body 1 moves away
    active = np.zeros(1, np.uint8)
    stamp = np.zeros(4, np.int64)
    geo = np.zeros((1, 7))
    applied, _, _ = edge_edge_sweep(pairs, edges, normals, x, v, m, TAU, 0.0, band, 1.0, active,
                                    stamp, 1, 0, geo, 0.0)
    assert applied == 0 and active[0] == 2 and np.all(v[:2, 2] == 1.0)
    v[:2, 2] = -100.0  # now it approaches: a later sweep (nodes changed in sweep 2)
    stamp[:] = 2
    fresh = v.copy()
    J = edge_edge_correct(0, 1, 2, 3, x, fresh, m, TAU, 0.0, band, 1.0, 0.0, 0.0, -2.0)
    applied, total, _ = edge_edge_sweep(pairs, edges, normals, x, v, m, TAU, 0.0, band, 1.0,
                                        active, stamp, 3, 2, geo, 0.0)
    assert J > 0 and applied == 1 and total == J and active[0] == 1 and geo[0, 0] == J
    assert np.array_equal(v, fresh)


def test_a_kept_separating_axis_only_skips_pairs_the_full_test_leaves_alone():
    """A pair found apart (apart_axis, the sweep's first visit) keeps its axis; a later sweep
    with changed velocities skips it while still_apart holds, and then edge_edge_detect gives
    no impulse either; pairs that close in on the axis are tested again (still_apart False)."""
    from impactsim.contact.edgeedge import GEO_COLS, apart_axis, edge_edge_detect, still_apart

    rng = np.random.default_rng(11)
    band = 1e-3
    kept = closed = 0
    for trial in range(3000):
        x = rng.uniform(-1.0, 1.0, (4, 3))
        if trial % 2:  # near-coplanar pairs, as in a flat contact
            x[:, 2] *= rng.choice([1e-4, 1e-3, 1e-2])
        v = rng.normal(0.0, 300.0, (4, 3))
        out = apart_axis(0, 1, 2, 3, x, v, TAU, band)
        if not out[0]:
            continue
        geo = np.array([out[1:]])
        v2 = v + rng.normal(0.0, 600.0, (4, 3))  # the corrections of later sweeps
        if still_apart(0, 1, 2, 3, v2, TAU, geo, 0):
            kept += 1
            v3 = v2.copy()
            J = edge_edge_detect(0, 1, 2, 3, x, v3, np.ones(4), TAU, 0.0, band, 1.0,
                                 *rng.normal(size=3), np.zeros((1, GEO_COLS)), 0,
                                 np.zeros((0, 3)))
            assert J == 0.0 and np.array_equal(v3, v2), trial
        else:
            closed += 1
    assert kept > 300 and closed > 30


def test_far_apart_pairs_stay_apart_while_the_list_is_kept():
    """far_apart marks the pairs of a kept candidate list that no move within the reach (per
    axis, at both ends of the step) brings within the touching band: for those the full test
    gives nothing at any such step; and it marks some, not all."""
    from impactsim.contact.edgeedge import FAR, GEO_COLS, edge_edge_detect, far_apart

    rng = np.random.default_rng(3)
    reach = 0.02
    band = 1e-3
    edges = np.arange(8, dtype=np.int32).reshape(4, 2)
    pairs = np.array([[0, 1], [2, 3]], np.int64)
    flagged = total = 0
    for trial in range(1500):
        x = rng.uniform(-0.3, 0.3, (8, 3))
        x[:, 2] *= rng.choice([1e-3, 1.0])  # flat contacts and anything
        out = np.zeros(2, np.uint8)
        far_apart(pairs, edges, x, band, reach, out)
        total += 2
        for k in np.flatnonzero(out == FAR):
            flagged += 1
            ia, ib = edges[pairs[k, 0]]
            ie, jf = edges[pairs[k, 1]]
            for _ in range(5):  # a later step: positions at 0 and tau within the reach
                x1 = x + rng.uniform(-0.999, 0.999, x.shape) * reach
                end = x + rng.uniform(-0.999, 0.999, x.shape) * reach
                v = (end - x1) / TAU
                v1 = v.copy()
                J = edge_edge_detect(ia, ib, ie, jf, x1, v1, np.ones(8), TAU, 0.0, band, 1.0,
                                     0.0, 0.0, 1.0, np.zeros((1, GEO_COLS)), 0,
                                     np.zeros((0, 3)))
                assert J == 0.0 and np.array_equal(v1, v), trial
    assert 0 < flagged < total


def test_normals_at_the_pairs_edges_are_the_full_normals():
    """The edge-edge pass computes normals only at the faces of its pairs' edges
    (faces_at_edges, then edge_normals_of): at every edge of a pair they are, bit for bit,
    those of edge_normals over every face, on a real boundary surface."""
    from impactsim.contact.edgeedge import edge_normals_of, faces_at_edges
    from impactsim.contact.surface import Surface
    from impactsim.mesh.structured import structured_box

    x, conn = structured_box((3e-3, 2e-3, 1e-3), 0.5e-3)
    rng = np.random.default_rng(11)
    x = x + rng.normal(0.0, 2e-5, x.shape)
    s = Surface(conn, np.zeros(conn.shape[0], np.int32))
    full = np.empty((s.n_edges, 3))
    edge_normals(x, s.faces, s.face_edges, full)
    pairs = np.sort(rng.integers(0, s.n_edges, (40, 2)), axis=0)
    mark = np.zeros(s.n_edges, bool)
    fsel = np.empty(s.n_faces, np.int64)
    k = faces_at_edges(pairs, s.face_edges, mark, fsel)
    assert not mark.any() and 0 < k < s.n_faces
    out = np.full((s.n_edges, 3), np.nan)
    edge_normals_of(x, s.faces, s.face_edges, fsel[:k], out)
    used = np.unique(pairs)
    np.testing.assert_array_equal(out[used], full[used])
