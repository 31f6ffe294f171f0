"""The independent penetration measure (history.csv max_penetration)."""

import numpy as np
import pytest

from impactsim.contact.diagnostics import (PenetrationMeter, max_penetration,
                                           point_triangle_distance)
from impactsim.contact.surface import Surface
from impactsim.mesh.structured import structured_box


def rot(axis, deg):
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    i, j = [k for k in range(3) if k != axis]
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


def assemble(parts):
    """parts: [(points, tets)] -> x, conn, elem_body, surface."""
    xs, conns, bodies, off = [], [], [], 0
    for b, (p, t) in enumerate(parts):
        xs.append(p)
        conns.append(t + off)
        bodies.append(np.full(len(t), b))
        off += len(p)
    x = np.vstack(xs)
    conn = np.vstack(conns).astype(np.int32)
    eb = np.concatenate(bodies).astype(np.int32)
    return x, conn, eb, Surface(conn, eb)


def measure(parts, status=None):
    x, conn, eb, s = assemble(parts)
    if status is not None:
        s.sync(status)
    return PenetrationMeter().measure(x, conn, eb, status, s)


def box(size, h, centre):
    p, t = structured_box(size, h)
    return p + np.asarray(centre, float), t


def test_point_triangle_distance():
    tri = (0, 0, 0, 1, 0, 0, 0, 1, 0)
    assert point_triangle_distance(0.2, 0.2, 0.5, *tri) == pytest.approx(0.5)
    assert point_triangle_distance(-1.0, 0.0, 0.0, *tri) == pytest.approx(1.0)
    assert point_triangle_distance(1.0, 1.0, 0.0, *tri) == pytest.approx(np.sqrt(0.5))


@pytest.mark.parametrize("delta", [1e-3, 0.05])
def test_overlapping_boxes_report_the_overlap(delta):
    out = measure([box((1, 1, 1), 0.5, (0, 0, 0)), box((1, 1, 1), 0.5, (0.1, 0.2, 1 - delta))])
    assert out["nodes_inside"] > 0
    assert out["max_penetration"] == pytest.approx(delta, rel=1e-9)


def test_separate_and_touching_boxes_report_zero():
    assert measure([box((1, 1, 1), 0.5, (0, 0, 0)),
                    box((1, 1, 1), 0.5, (0, 0, 1.001))])["max_penetration"] == 0.0
    touching = measure([box((1, 1, 1), 0.5, (0, 0, 0)), box((1, 1, 1), 0.5, (0.25, 0, 1.0))])
    assert touching["max_penetration"] <= 1e-15


def test_deep_penetration_is_the_distance_to_the_surface():
    out = measure([box((4, 4, 4), 0.5, (0, 0, 0)), box((0.5, 0.5, 0.5), 0.25, (0.3, 0, 0))])
    # the deepest boundary node of the small box is the centre of its face at x = 0.05
    assert out["max_penetration"] == pytest.approx(2.0 - 0.05, rel=1e-12)


def test_grazing_edge_over_a_nearly_coplanar_face_is_shallow():
    # a box tilted by 1e-4 rad over another: its edge dips 1e-5 below the lower top face
    a = box((1, 1, 1), 0.5, (0, 0, 0))
    p, t = structured_box((1, 1, 1), 0.5)
    p = p @ rot(0, np.degrees(1e-4)).T + [0.1, 0.05, 1.0]
    out = measure([a, (p, t)])
    assert 0.0 < out["max_penetration"] <= 1e-4 * 0.55


def test_edges_cutting_through_faces_with_all_nodes_outside():
    # two unit cubes (6 tets each) meeting edge to edge with perpendicular edges, crossed by
    # delta: no node of either is inside the other, only edges cut through faces
    delta = 0.01
    p1, t1 = structured_box((1, 1, 1), 1.0)
    p2, t2 = structured_box((1, 1, 1), 1.0)
    p1 = p1 @ rot(2, 45).T
    p2 = p2 @ rot(1, 45).T + [np.sqrt(2) - delta, 0, 0]
    out = measure([(p1, t1), (p2, t2)])
    assert out["nodes_inside"] == 0 and out["edge_cuts"] > 0
    # the deepest point of either edge inside the other cube is delta / sqrt(2) deep
    assert out["max_penetration"] == pytest.approx(delta / np.sqrt(2), rel=1e-9)
    p2 = p2 + [2 * delta, 0, 0]
    assert max_penetration(*assemble([(p1, t1), (p2, t2)])[:3], None,
                           assemble([(p1, t1), (p2, t2)])[3]) == 0.0


def test_eroded_elements_do_not_count():
    a = box((1, 1, 1), 0.5, (0, 0, 0))
    b = box((1, 1, 1), 0.5, (0, 0, 0.99))
    status = np.zeros(len(a[1]) + len(b[1]), np.int8)
    status[:] = 3  # everything eroded
    assert measure([a, b], status)["max_penetration"] == 0.0


def approach(n=12, step=0.03, start=0.8):
    """Two boxes, the upper one tilted and moving down into the lower one (from apart to deeper
    than a cell with the defaults): conn, elem_body, surface and the positions of each frame."""
    a = box((1, 1, 1), 0.25, (0, 0, 0))
    p, t = structured_box((0.5, 0.5, 0.5), 0.125)
    p = p @ rot(0, 3.0).T @ rot(1, 2.0).T
    frames = []
    for k in range(n):
        x, conn, eb, s = assemble([a, (p + [0.1, 0.05, start - step * k], t)])
        frames.append(x)
    return conn, eb, s, frames


def test_a_meter_kept_over_calls_gives_what_a_new_one_gives():
    # the meter keeps buffers, hashes and candidate pairs from call to call; what it gives
    # must not depend on it: steps longer than the skin, shorter ones (candidates kept), back
    conn, eb, s, coarse = approach()
    fine = approach(40, 0.002, 0.54)[3]
    kept = PenetrationMeter()
    seen = set()
    for x in coarse + fine + fine[::-1] + coarse[::-1]:
        got = kept.measure(x, conn, eb, None, s)
        assert got == PenetrationMeter().measure(x, conn, eb, None, s)
        seen.add((got["nodes_inside"] > 0, got["edge_cuts"] > 0))
    assert (False, False) in seen and (True, True) in seen
    assert kept.builds < len(coarse) + len(fine)  # (kept over the short steps)


def test_a_kept_meter_follows_erosion():
    # elements of the lower box near the contact erode one by one (the surface changes under
    # kept candidates), then all come back (a rebuilt surface)
    conn, eb, s, frames = approach(30, 0.002, 0.54)
    top = np.flatnonzero((eb == 0) & (np.arange(len(eb)) % 7 == 0))
    status = np.zeros(len(eb), np.int8)
    kept = PenetrationMeter()
    for k, x in enumerate(frames):
        if k % 3 == 0 and k < 24:
            status[top[k // 3::8]] = 3
        if k == 24:
            status[:] = 0
        s.sync(status)
        fresh = Surface(conn, eb, status)
        assert kept.measure(x, conn, eb, status, s) == \
            PenetrationMeter().measure(x, conn, eb, status, fresh)
    assert kept.builds < len(frames)


def test_the_faces_near_give_the_depths_of_the_hash_of_every_face(monkeypatch):
    from impactsim.contact import diagnostics

    conn, eb, s, frames = approach()
    near = [PenetrationMeter().measure(x, conn, eb, None, s) for x in frames]
    monkeypatch.setattr(diagnostics, "NEAR_CELLS", 1)  # no search closes: all in the full hash
    full = PenetrationMeter()
    assert [full.measure(x, conn, eb, None, s) for x in frames] == near
    assert full.full_searches == sum(z["max_penetration"] > 0 for z in near)


def test_nearest_face_distance_is_the_minimum_over_every_face():
    # the shell search stops early (k h, or the boundary of the cells seen): never before the
    # nearest face, whatever the point's place in its cell
    from impactsim.contact.broadphase import SpatialHash, swept_boxes
    from impactsim.contact.diagnostics import nearest_face_distance

    x, conn, eb, s = assemble([box((1, 1, 1), 0.25, (0, 0, 0))])
    h = s.mean_edge_length(x)
    lo = np.empty((s.n_faces, 3))
    hi = np.empty((s.n_faces, 3))
    swept_boxes(x, x, 0.0, s.faces, 0.0, lo, hi)
    fh = SpatialHash()
    fh.build(lo, hi, lo.min(axis=0), h)
    rng = np.random.default_rng(3)
    for p in rng.uniform(-0.55, 0.55, (300, 3)):
        got = nearest_face_distance(*p, 0, s.faces, s.face_body, x, fh.origin, fh.inv_h, fh.h,
                                    fh.tbits, fh.bucket_start, fh.keys, fh.ents, 40)
        want = min(point_triangle_distance(*p, *x[f[0]], *x[f[1]], *x[f[2]]) for f in s.faces)
        assert got == want


def test_the_measure_in_the_meters_thread_is_the_measure_at_the_call():
    # measure_later copies the positions and statuses and views the surface at the call: the
    # caller then spoils the nodes, erodes every element and changes the surface before the
    # meter's thread may start (a gate), and the results are still those of a meter called at
    # each moment (its candidates kept as in the run, the same number of builds)
    import threading

    conn, eb, s, frames = approach(30, 0.002, 0.54)
    top = np.flatnonzero((eb == 0) & (np.arange(len(eb)) % 7 == 0))
    status = np.zeros(len(eb), np.int8)
    x = frames[0].copy()
    later, now = PenetrationMeter(), PenetrationMeter()
    gates = []
    taken = later.measure

    def gated(*args):  # the meter's thread waits until the caller has moved on
        assert gates.pop(0).wait(30)
        return taken(*args)

    later.measure = gated
    seen, futures, expected = [], [], []
    for k, frame in enumerate(frames):
        if k % 3 == 0:
            status[top[k // 3::8]] = 3
        x[:] = frame
        s.sync(status)
        gate = threading.Event()
        gates.append(gate)
        futures.append(later.measure_later(x, conn, eb, status, s, 0) if k % 2 else
                       later.measure_later(x, conn, eb, status, s, 0,
                                           lambda m: seen.append(m) or m["max_penetration"]))
        expected.append(now.measure(x, conn, eb, status, s))
        kept = status.copy()
        x[:] = np.nan
        status[:] = 3
        s.sync(status)
        gate.set()
        status[:] = kept
    got = [f.result() for f in futures]
    later.close()
    assert got[1::2] == expected[1::2] and seen == expected[::2]
    assert got[::2] == [e["max_penetration"] for e in expected[::2]]
    assert any(e["nodes_inside"] for e in expected) and later.builds == now.builds


def test_the_meter_holds_at_most_max_pending_measures(monkeypatch):
    # each measure handed over holds copies of the positions and statuses: beyond MAX_PENDING
    # not yet done, the caller waits for the oldest
    import threading

    from impactsim.contact import diagnostics

    monkeypatch.setattr(diagnostics, "MAX_PENDING", 2)
    conn, eb, s, frames = approach(3)
    meter = PenetrationMeter()
    release = threading.Event()
    taken = meter.measure

    def held(*args):
        assert release.wait(30)
        return taken(*args)

    meter.measure = held
    first = [meter.measure_later(x, conn, eb, None, s, 0) for x in frames[:2]]
    third = threading.Thread(target=meter.measure_later, args=(frames[2], conn, eb, None, s, 0))
    third.start()
    third.join(0.3)
    assert third.is_alive() and not any(f.done() for f in first)
    release.set()
    third.join(30)
    assert not third.is_alive()
    meter.close()
    assert [f.result() for f in first] == [PenetrationMeter().measure(x, conn, eb, None, s)
                                           for x in frames[:2]]
