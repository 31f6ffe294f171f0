"""Broad phase: the spatial hash finds exactly the overlapping boxes, grows its buffers, and is
deterministic."""

import numpy as np
import pytest

from impactsim.contact.broadphase import SpatialHash, grid_for, swept_boxes


def random_boxes(rng, n, size=1.0, extent=10.0):
    lo = rng.uniform(0.0, extent, size=(n, 3))
    hi = lo + rng.uniform(0.0, size, size=(n, 3))
    return lo, hi


def brute(qlo, qhi, elo, ehi, qbody, ebody, same_set):
    out = set()
    for i in range(len(qlo)):
        for j in range(len(elo)):
            if same_set and j <= i or qbody[i] == ebody[j]:
                continue
            if np.all(qlo[i] <= ehi[j]) and np.all(elo[j] <= qhi[i]):
                out.add((i, j))
    return out


def test_swept_boxes_cover_the_motion():
    x = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [5.0, 5.0, 5.0]])
    v = np.array([[1.0, -1.0, 0.0], [0.0, 0.0, -10.0], [0.0, 0.0, 0.0]])
    ent = np.array([[0, 1], [2, 2]], dtype=np.int32)
    lo = np.empty((2, 3))
    hi = np.empty((2, 3))
    swept_boxes(x, v, 0.5, ent, 0.1, lo, hi)
    np.testing.assert_allclose(lo[0], [-0.1, -0.6, -2.1])
    np.testing.assert_allclose(hi[0], [1.1, 2.1, 3.1])
    np.testing.assert_allclose(lo[1], [4.9, 4.9, 4.9])


@pytest.mark.parametrize("cell", [0.3, 1.0, 4.0])
def test_pairs_equal_brute_force(cell):
    rng = np.random.default_rng(7)
    qlo, qhi = random_boxes(rng, 150, size=0.8)
    elo, ehi = random_boxes(rng, 120, size=1.5)
    qbody = rng.integers(0, 3, 150).astype(np.int32)
    ebody = rng.integers(0, 3, 120).astype(np.int32)
    qent = np.arange(150, dtype=np.int32).reshape(-1, 1)
    eent = np.arange(1000, 1120, dtype=np.int32).reshape(-1, 1)
    origin, h = grid_for([(qlo, qhi), (elo, ehi)], cell)
    hs = SpatialHash(entry_capacity=16, pair_capacity=16)  # forces growth
    hs.build(elo, ehi, origin, h)
    pairs = hs.query(qlo, qhi, qent, qbody, eent, ebody, False, False)
    assert hs.grows >= 2
    assert {tuple(p) for p in pairs} == brute(qlo, qhi, elo, ehi, qbody, ebody, False)
    assert len({tuple(p) for p in pairs}) == len(pairs)  # each pair once
    keys = pairs[:, 0] * 120 + pairs[:, 1]
    assert np.all(np.diff(keys) > 0)  # sorted


@pytest.mark.parametrize("cell", [0.4, 1.0, 3.0])
def test_each_box_is_entered_in_exactly_the_cells_it_covers(cell):
    """The hash holds one entry per cell a box covers, with the box's first cell along each
    axis marked (boxes of one or two cells a side take a branch-free path in the build)."""
    import math

    lo, hi = random_boxes(np.random.default_rng(3), 300, size=1.5)
    h = SpatialHash(entry_capacity=16)
    origin = np.zeros(3)
    h.build(lo, hi, origin, cell)
    got = {}
    for k in range(h.n_entries):
        key, j = int(h.keys[k]), int(h.ents[k])
        ijk = ((key >> 43) & 0xFFFFF, (key >> 23) & 0xFFFFF, (key >> 3) & 0xFFFFF)
        got.setdefault(j, []).append((ijk, key & 7))
    for j in range(len(lo)):
        first = [math.floor(lo[j, d] / cell) for d in range(3)]
        last = [math.floor(hi[j, d] / cell) for d in range(3)]
        want = sorted(((ix, iy, iz), int(ix == first[0]) | int(iy == first[1]) << 1
                       | int(iz == first[2]) << 2)
                      for ix in range(first[0], last[0] + 1)
                      for iy in range(first[1], last[1] + 1)
                      for iz in range(first[2], last[2] + 1))
        assert sorted(got[j]) == want, j


def test_same_set_and_self_contact_filters():
    rng = np.random.default_rng(3)
    lo, hi = random_boxes(rng, 100, size=2.0, extent=6.0)
    body = np.zeros(100, np.int32)
    body[50:] = 1
    ent = rng.integers(0, 60, size=(100, 2)).astype(np.int32)
    origin, h = grid_for([(lo, hi)], 1.0)
    hs = SpatialHash()
    hs.build(lo, hi, origin, h)
    pairs = {tuple(p) for p in hs.query(lo, hi, ent, body, ent, body, True, False)}
    assert pairs == brute(lo, hi, lo, hi, body, body, True)
    # self contact: same-body pairs come back unless they share a node
    pairs_sc = {tuple(p) for p in hs.query(lo, hi, ent, body, ent, body, True, True)}
    extra = pairs_sc - pairs
    assert extra and all(body[i] == body[j] and not set(ent[i]) & set(ent[j]) for i, j in extra)
    everything = brute(lo, hi, lo, hi, body, np.full(100, 9, np.int32), True)
    assert pairs_sc == {(i, j) for i, j in everything
                        if body[i] != body[j] or not set(ent[i]) & set(ent[j])}


def test_result_does_not_depend_on_cell_size_or_capacity():
    rng = np.random.default_rng(11)
    qlo, qhi = random_boxes(rng, 80)
    elo, ehi = random_boxes(rng, 90)
    qb = np.zeros(80, np.int32)
    eb = np.ones(90, np.int32)
    qe = np.zeros((80, 1), np.int32)
    ee = np.zeros((90, 1), np.int32)
    results = []
    for cell, cap in ((0.5, 16), (2.0, 10_000), (0.5, 10_000)):
        origin, h = grid_for([(qlo, qhi), (elo, ehi)], cell)
        hs = SpatialHash(entry_capacity=cap, pair_capacity=cap)
        hs.build(elo, ehi, origin, h)
        results.append(hs.query(qlo, qhi, qe, qb, ee, eb, False, False))
    for r in results[1:]:
        np.testing.assert_array_equal(r, results[0])


@pytest.mark.parametrize("same_set, self_contact", [(False, False), (True, False), (True, True)])
def test_threaded_query_gives_the_serial_pairs(monkeypatch, same_set, self_contact):
    """The query runs fixed chunks of query rows on the threads: the same pairs in the same
    order as one serial pass, for one thread or two, also when a chunk's share of the pair
    buffer is too small and the buffer grows."""
    import numba

    from impactsim.contact import broadphase

    rng = np.random.default_rng(5)
    lo, hi = random_boxes(rng, 700, size=1.2)
    body = rng.integers(0, 3, 700).astype(np.int32)
    ent = rng.integers(0, 400, size=(700, 2)).astype(np.int32)
    origin, h = grid_for([(lo, hi)], 1.0)
    serial = SpatialHash()
    serial.build(lo, hi, origin, h)
    ref = np.array(serial.query(lo, hi, ent, body, ent, body, same_set, self_contact))
    assert ref.shape[0] > 100
    monkeypatch.setattr(broadphase, "QUERY_CHUNK", 64)  # 11 chunks
    monkeypatch.setattr(broadphase, "QUERY_MIN_CHUNKS", 2)
    threads = numba.get_num_threads()
    try:
        for n_threads in sorted({1, threads}):
            numba.set_num_threads(n_threads)
            hs = SpatialHash(pair_capacity=16)
            hs.build(lo, hi, origin, h)
            pairs = hs.query(lo, hi, ent, body, ent, body, same_set, self_contact)
            np.testing.assert_array_equal(pairs, ref)
            assert hs.grows >= (1 if n_threads > 1 else 0)
    finally:
        numba.set_num_threads(threads)


def _particles_and_faces(seed):
    """300 query boxes of no body (particles) and 200 hashed boxes of three bodies, the rows
    (unused), and the grid: (qlo, qhi, qbody, elo, ehi, ebody, rows, origin, h)."""
    rng = np.random.default_rng(seed)
    qlo, qhi = random_boxes(rng, 300, size=0.8, extent=5.0)
    elo, ehi = random_boxes(rng, 200, size=1.5, extent=5.0)
    qbody = np.full(300, -1, np.int32)
    ebody = rng.integers(0, 3, 200).astype(np.int32)
    origin, h = grid_for([(qlo, qhi), (elo, ehi)], 1.0)
    return qlo, qhi, qbody, elo, ehi, ebody, np.zeros((1, 1), np.int32), origin, h


def test_a_hash_may_take_fewer_chunks_to_the_threads(monkeypatch):
    """``min_chunks`` below QUERY_MIN_CHUNKS (the particle hash's) sends a query of that many
    chunks to the threads, with the serial query's pairs; QUERY_MIN_CHUNKS, where lower (the
    warm-up), still bounds it."""
    import numba

    from impactsim.contact import broadphase

    if numba.get_num_threads() < 2:
        pytest.skip(f"NUMBA_NUM_THREADS={numba.config.NUMBA_NUM_THREADS}")
    qlo, qhi, qbody, elo, ehi, ebody, rows, origin, h = _particles_and_faces(12)
    monkeypatch.setattr(broadphase, "QUERY_CHUNK", 100)  # 3 chunks, fewer than 8
    threaded = {}
    for least, default in ((None, 8), (2, 8), (8, 2), (3, 8), (4, 8)):
        monkeypatch.setattr(broadphase, "QUERY_MIN_CHUNKS", default)
        hs = SpatialHash(min_chunks=least)
        hs.build(elo, ehi, origin, h)
        pairs = np.array(hs.query(qlo, qhi, rows, qbody, rows, ebody, False, False))
        assert {tuple(p) for p in pairs} == brute(qlo, qhi, elo, ehi, qbody, ebody, False)
        threaded[(least, default)] = hs.chunk_counts.shape[0] == 3  # sized by a chunked query
    assert threaded == {(None, 8): False, (2, 8): True, (8, 2): True, (3, 8): True,
                        (4, 8): False}


@pytest.mark.parametrize("chunked", [False, True])
def test_pair_buffer_filled_to_its_last_rows(monkeypatch, chunked):
    """A pair buffer of as many rows as there are pairs, one fewer or one more: the query
    writes every scanned entry to its next free row (the buffer's last row takes the writes
    beyond it), so a buffer exactly full must still grow, never lose its last pair."""
    import numba

    from impactsim.contact import broadphase

    qlo, qhi, qbody, elo, ehi, ebody, rows, origin, h = _particles_and_faces(11)
    ref_hash = SpatialHash()
    ref_hash.build(elo, ehi, origin, h)
    ref = np.array(ref_hash.query(qlo, qhi, rows, qbody, rows, ebody, False, False))
    assert {tuple(p) for p in ref} == brute(qlo, qhi, elo, ehi, qbody, ebody, False)
    m = ref.shape[0]
    assert m > 100
    if chunked:
        monkeypatch.setattr(broadphase, "QUERY_CHUNK", 100)  # 3 chunks
        monkeypatch.setattr(broadphase, "QUERY_MIN_CHUNKS", 2)
    threads = numba.get_num_threads()
    numba.set_num_threads(min(2, threads))
    try:
        for cap in (m - 1, m, m + 1, 3 * m - 1, 3 * m, 3 * m + 1, 3 * m + 3):
            hs = SpatialHash(pair_capacity=cap)
            hs.build(elo, ehi, origin, h)
            np.testing.assert_array_equal(hs.query(qlo, qhi, rows, qbody, rows, ebody, False,
                                                   False), ref)
    finally:
        numba.set_num_threads(threads)


def test_bodies_follow_each_build():
    """The query keeps the hashed entities' bodies beside their boxes, written once a build: a
    body array changed in place before the next build, or another array for the same build,
    gives that build's pairs of other bodies (never the previous bodies')."""
    rng = np.random.default_rng(4)
    qlo, qhi = random_boxes(rng, 120, size=0.8, extent=5.0)
    elo, ehi = random_boxes(rng, 90, size=1.5, extent=5.0)
    qbody = rng.integers(0, 2, 120).astype(np.int32)
    ebody = rng.integers(0, 2, 90).astype(np.int32)
    rows = np.zeros((1, 1), np.int32)
    origin, h = grid_for([(qlo, qhi), (elo, ehi)], 1.0)
    hs = SpatialHash()

    def check(body):
        pairs = hs.query(qlo, qhi, rows, qbody, rows, body, False, False)
        assert {tuple(p) for p in pairs} == brute(qlo, qhi, elo, ehi, qbody, body, False)

    hs.build(elo, ehi, origin, h)
    check(1 - ebody)  # another array for the same build
    check(ebody)
    ebody[:] = 1 - ebody  # the array the last query had, changed in place, then built again
    hs.build(elo, ehi, origin, h)
    check(ebody)


def test_non_finite_boxes_are_an_error():
    lo = np.array([[0.0, 0.0, np.nan]])
    with pytest.raises(FloatingPointError):
        grid_for([(lo, lo + 1.0)], 1.0)


def test_huge_extent_keeps_the_grid_within_its_key_range():
    lo = np.array([[0.0, 0.0, 0.0], [1e6, 0.0, 0.0]])
    hi = lo + 1e-3
    origin, h = grid_for([(lo, hi)], 1e-3)
    assert (1e6 + 1e-3) / h < 2**21
    hs = SpatialHash()
    hs.build(lo, hi, origin, h)
    body = np.array([0, 1], np.int32)
    ent = np.array([[0], [1]], np.int32)
    assert len(hs.query(lo, hi, ent, body, ent, body, True, False)) == 0


@pytest.mark.parametrize("cell,bodies", [(0.25, 3), (1.0, 2), (3.0, 5), (1e-3, 4)])
def test_occupancy_keeps_every_row_of_a_pair(cell, bodies):
    """The pre-selection by a coarse grid of the bodies' boxes (broadphase.Occupancy, used by
    the contact passes' broad phase) keeps, in order, every row with a partner of another body
    (brute force), whatever the cell (the last forces OCC_MAX_CELLS' larger cells); the pairs
    of the hash over the kept rows are the pairs over all rows. Rows it drops have no
    partner."""
    from impactsim.contact.broadphase import Occupancy

    rng = np.random.default_rng(11)
    qlo, qhi = random_boxes(rng, 300, size=0.6, extent=12.0)
    elo, ehi = random_boxes(rng, 200, size=1.2, extent=12.0)
    qbody = rng.integers(0, bodies, 300).astype(np.int32)
    ebody = rng.integers(0, bodies, 200).astype(np.int32)
    want = brute(qlo, qhi, elo, ehi, qbody, ebody, False)
    occ = Occupancy()
    lo_all = np.minimum(qlo.min(axis=0), elo.min(axis=0))
    hi_all = np.maximum(qhi.max(axis=0), ehi.max(axis=0))
    occ.grid(lo_all, hi_all, cell)
    qsel, ql, qh = np.arange(300), qlo.copy(), qhi.copy()
    esel, el, eh = np.arange(200), elo.copy(), ehi.copy()
    occ.mark(qsel, ql, qh, qbody)
    esel, el, eh = occ.keep(esel, el, eh, ebody)
    occ.next()
    occ.mark(esel, el, eh, ebody)
    qsel, ql, qh = occ.keep(qsel, ql, qh, qbody)
    assert {j for _, j in want} <= set(esel.tolist())
    assert {i for i, _ in want} <= set(qsel.tolist())
    assert np.all(np.diff(esel) > 0) and np.all(np.diff(qsel) > 0)
    np.testing.assert_array_equal(el, elo[esel])
    np.testing.assert_array_equal(qh, qhi[qsel])
    if cell == 0.25:  # a fine grid drops rows (else the test would not test the dropping)
        assert len(qsel) < 300 and len(esel) < 200
    origin, h = grid_for([(qlo, qhi), (elo, ehi)], 1.0)
    hs = SpatialHash()
    hs.build(el, eh, origin, h)
    pairs = hs.query(ql, qh, qsel.reshape(-1, 1).astype(np.int32), qbody[qsel],
                     esel.reshape(-1, 1).astype(np.int32) + 1000, ebody[esel], False, False)
    lifted = np.stack([qsel[pairs[:, 0]], esel[pairs[:, 1]]], axis=1)
    hs.build(elo, ehi, origin, h)
    full = hs.query(qlo, qhi, np.arange(300, dtype=np.int32).reshape(-1, 1), qbody,
                    np.arange(1000, 1200, dtype=np.int32).reshape(-1, 1), ebody, False, False)
    np.testing.assert_array_equal(lifted, full)
    # a generation left behind reads as empty
    occ.next()
    assert occ.keep(np.arange(200), elo.copy(), ehi.copy(), ebody)[0].shape[0] == 0


@pytest.mark.parametrize("tau,keep_all", [(0.0, False), (1e-3, False), (-2e-3, False),
                                          (1e-3, True)])
def test_select_boxes_against_numpy(tau, keep_all):
    """The pre-selection's rows and padded boxes against numpy: the box of every row's nodes and
    (tau != 0) their ends x + tau v, padded, kept when it meets the box of another body (all
    with keep_all), skipped rows left out, in increasing order."""
    from impactsim.contact.broadphase import select_boxes

    rng = np.random.default_rng(7)
    x = rng.uniform(0.0, 1.0, (200, 3))
    v = rng.normal(0.0, 50.0, (200, 3))
    ent = rng.integers(0, 200, (300, 4)).astype(np.int32)
    body = rng.integers(0, 3, 300).astype(np.int32)
    blo = np.array([[0.0, 0.0, 0.0], [0.2, 0.3, 0.1], [0.7, 0.7, 0.7]])
    bhi = np.array([[0.3, 0.3, 0.3], [0.4, 0.6, 0.5], [1.0, 1.0, 1.0]])
    skip = (rng.random(300) < 0.1).astype(np.uint8)
    pad = 0.01
    pts = np.concatenate([x[ent], (x + tau * v)[ent]], axis=1)
    lo, hi = pts.min(axis=1) - pad, pts.max(axis=1) + pad
    meets = np.zeros(300, bool)
    for b in range(3):
        meets |= ((body != b) & np.all(lo <= bhi[b], axis=1) & np.all(blo[b] <= hi, axis=1))
    want = np.flatnonzero((meets | keep_all) & (skip == 0))
    sel, glo, ghi = np.empty(300, np.int64), np.empty((300, 3)), np.empty((300, 3))
    k = select_boxes(x, v, tau, ent, pad, body, blo, bhi, keep_all, skip, sel, glo, ghi)
    assert 0 < k < 300 or keep_all
    assert np.array_equal(sel[:k], want)
    assert np.array_equal(glo[:k], lo[want]) and np.array_equal(ghi[:k], hi[want])
