"""The distortion guard's pre-test (fracture/criteria.py ``guard_reach``, ``guard_clear``) never
clears a tet the full guard flags: on random tets of many sizes and places, on tets that the
velocities crush, and on tets placed right at the pre-test's threshold; so the fracture
kernel's actions are those of the full guard, bit for bit."""

import numpy as np
import pytest

from impactsim.fracture.criteria import (GUARD_FRACTION, GUARD_K, _volume6, guard_clear,
                                         guard_reach)


def _clear(x, i0, i1, i2, i3, reach, lim):
    """guard_clear with the reciprocal the fracture kernel passes."""
    inv = 1.0 / (2.0 * GUARD_K * reach) if reach > 0.0 else np.inf
    return guard_clear(x, i0, i1, i2, i3, reach, inv, lim)


def _flagged(x, v, dt, t, lim):
    return (_volume6(x, v, 1.1 * dt, *t) < lim) or (_volume6(x, v, 2.2 * dt, *t) < lim)


def _tets(rng, n, scale, offset):
    """n random tets (4 nodes each, own nodes), positively oriented, of size ``scale`` [m]
    around ``offset``."""
    base = offset + scale * rng.standard_normal((n, 1, 3)) * 10.0
    pts = base + scale * rng.standard_normal((n, 4, 3))
    a, b, c = (pts[:, k] - pts[:, 0] for k in (1, 2, 3))
    neg = np.einsum("ij,ij->i", a, np.cross(b, c)) < 0
    pts[neg, 1], pts[neg, 2] = pts[neg, 2].copy(), pts[neg, 1].copy()
    return pts.reshape(-1, 3), np.arange(4 * n, dtype=np.int64).reshape(n, 4)


def _check(x, v, dt, conn, vol0):
    """(tets cleared, tets flagged); asserts no cleared tet is flagged."""
    reach = guard_reach(x, v, 2.2 * dt)
    cleared = flagged = 0
    for e, t in enumerate(conn):
        lim = 6.0 * GUARD_FRACTION * vol0[e]
        c = _clear(x, t[0], t[1], t[2], t[3], reach, lim)
        f = _flagged(x, v, dt, tuple(t), lim)
        assert not (c and f), (e, x[t], v[t], lim)
        cleared += c
        flagged += f
    return cleared, flagged


@pytest.mark.parametrize("scale,offset", [(1e-3, 0.0), (1e-5, 0.0), (1e-4, 100.0), (10.0, -5.0)])
def test_random_tets_cleared_are_never_flagged(scale, offset):
    """Random tets, velocities and steps across scales: most tets are cleared (the test is
    not empty), some are flagged, none both."""
    rng = np.random.default_rng(int(scale * 1e6) + int(offset))
    x, conn = _tets(rng, 3000, scale, offset)
    speed = 300.0 * rng.lognormal(0.0, 1.0)
    v = speed * rng.standard_normal(x.shape)
    vol = np.array([_volume6(x, v, 0.0, *t) for t in conn]) / 6.0
    # a step at which the fastest nodes cross about a hundredth of a tet, and reference volumes
    # from a hundredth to ten times the present one (so the limit is sometimes near it)
    dt = 0.002 * scale / speed
    vol0 = vol * 10.0 ** rng.uniform(-2.0, 3.5, vol.shape[0])
    cleared, flagged = _check(x, v, dt, conn, vol0)
    assert cleared > 1000
    assert flagged > 10


def test_crushed_tets_are_not_cleared():
    """A tet whose apex flies at its base: the full guard flags it from some speed on; the
    pre-test clears it only at speeds well below that."""
    rng = np.random.default_rng(7)
    for _ in range(300):
        x, conn = _tets(rng, 1, 1e-3, 0.0)
        t = tuple(conn[0])
        n = np.cross(x[2] - x[0], x[3] - x[0])
        n /= np.linalg.norm(n)
        h6 = _volume6(x, np.zeros_like(x), 0.0, *t)
        dt = 1e-8
        hit = None
        for speed in np.geomspace(1.0, 1e6, 400):
            v = np.zeros_like(x)
            v[1] = -speed * n * np.sign(np.dot(x[1] - x[0], n))
            reach = guard_reach(x, v, 2.2 * dt)
            lim = 6.0 * GUARD_FRACTION * h6 / 6.0
            c = _clear(x, *t, reach, lim)
            f = _flagged(x, v, dt, t, lim)
            assert not (c and f)
            if f and hit is None:
                hit = speed
        assert hit is not None


@pytest.mark.parametrize("scale,offset,drift,spread", [
    (1e-3, 0.02, 0.0, 500.0),  # tets of a millimetre flying apart at hundreds of m/s
    (1e-6, 1e3, 1e3, 1e-12),  # far from the origin, translating fast, hardly deforming: the
    # full test's rounding of x + h v (1e-13 m) is all there is
])
def test_tets_at_the_threshold(scale, offset, drift, spread):
    """Limits a hair either side of where the pre-test stops clearing each tet: none of the
    cleared ones is flagged (the margins cover the rounding of both tests)."""
    rng = np.random.default_rng(3)
    x, conn = _tets(rng, 1000, scale, offset)
    v = drift + spread * rng.standard_normal(x.shape)
    dt = 2e-9
    reach = guard_reach(x, v, 2.2 * dt)
    near = 0
    for e, t in enumerate(conn):
        v6 = _volume6(x, v, 0.0, *t)
        lo, hi = 0.0, 2.0 * abs(v6)
        for _ in range(80):  # the largest limit still cleared
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if _clear(x, *t, reach, mid) else (lo, mid)
        for lim in (lo, np.nextafter(lo, np.inf), hi):
            if _clear(x, *t, reach, lim):
                assert not _flagged(x, v, dt, tuple(t), lim), (e, lim)
        near += lo > 0.5 * v6
    assert near > 500  # most tets are cleared up to a limit near their volume


def test_a_non_finite_velocity_clears_nothing():
    """A nan or infinite velocity anywhere: the reach is nan and no tet is cleared (the full
    guard, and the watch, see the state)."""
    rng = np.random.default_rng(5)
    x, conn = _tets(rng, 50, 1e-3, 0.0)
    for bad in (np.nan, np.inf):
        v = rng.standard_normal(x.shape)
        v[17, 1] = bad
        reach = guard_reach(x, v, 1e-8)
        assert np.isnan(reach)
        assert not any(_clear(x, *t, reach, 0.0) for t in conn)


def _hexes(rng, scale, offset, noise):
    from impactsim.mesh.hexes import box_hexes, fix_hex_orientation

    pts, hexes = box_hexes((4 * scale, 3 * scale, 2 * scale), scale)
    hexes, _ = fix_hex_orientation(pts, hexes)
    x = offset + pts + noise * scale * rng.standard_normal(pts.shape)
    return x, hexes.astype(np.int32)


@pytest.mark.parametrize("scale,offset,drift,spread,noise", [
    (1e-3, 0.02, 0.0, 300.0, 0.15),  # distorted hexes flying apart
    # far out, translating fast, hardly deforming, across a power of two (there x + h v rounds
    # differently on either side)
    (1e-6, 1024.0 - 2e-6, 1e3, 1e-12, 0.05),
])
def test_hexes_cleared_are_never_flagged(scale, offset, drift, spread, noise):
    """The hexes' pre-test (fracture/hexes.py ``hex_clear``) at limits a hair either side of
    where it stops clearing each hex, and at random limits: no cleared hex is flagged by the
    full guard (``hex_volume`` at 1.1 and 2.2 dt)."""
    from impactsim.fracture.hexes import hex_clear, hex_volume

    rng = np.random.default_rng(11)
    for _ in range(20):
        x, hexes = _hexes(rng, scale, offset, noise)
        v = drift + spread * rng.standard_normal(x.shape)
        dt = 1e-3 * scale / max(spread, 1.0) if spread > 1.0 else 2e-9
        reach = guard_reach(x, v, 2.2 * dt)
        near = 0
        for e in range(hexes.shape[0]):
            vol = hex_volume(x, v, 0.0, hexes, e)
            lo, hi = 0.0, 2.0 * abs(vol)
            for _ in range(80):
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if hex_clear(x, hexes, e, reach, mid) else (lo, mid)
            for lim in (lo, np.nextafter(lo, np.inf), hi, rng.uniform(0.0, 2.0) * vol):
                if hex_clear(x, hexes, e, reach, lim):
                    assert not (hex_volume(x, v, 1.1 * dt, hexes, e) < lim
                                or hex_volume(x, v, 2.2 * dt, hexes, e) < lim), (e, lim)
            near += lo > 0.5 * vol
        assert near > hexes.shape[0] // 2


def test_crushed_hexes_are_not_cleared():
    """A hex whose top corners fly down at its bottom: the full guard flags it from some
    speed on, and the pre-test never clears it then."""
    from impactsim.fracture.hexes import hex_clear, hex_volume

    rng = np.random.default_rng(2)
    x, hexes = _hexes(rng, 1e-3, 0.0, 0.05)
    dt = 1e-8
    for e in range(0, hexes.shape[0], 3):
        vol = hex_volume(x, x, 0.0, hexes, e)
        lim = GUARD_FRACTION * vol
        hit = None
        for speed in np.geomspace(1.0, 1e6, 200):
            v = np.zeros_like(x)
            v[hexes[e, 4:], 2] = -speed
            reach = guard_reach(x, v, 2.2 * dt)
            c = hex_clear(x, hexes, e, reach, lim)
            f = (hex_volume(x, v, 1.1 * dt, hexes, e) < lim
                 or hex_volume(x, v, 2.2 * dt, hexes, e) < lim)
            assert not (c and f)
            hit = speed if f and hit is None else hit
        assert hit is not None


@pytest.mark.parametrize("height,slack", [(0.3, 0.25), (0.05, 0.1), (0.005, 0.1)])
def test_a_flat_cap_closing_head_on_is_cleared_only_just_in_time(height, slack):
    """The case where the pre-test's bound is nearly reached: a low cap (the apex above the
    centroid of an equilateral base) whose apex and base fly at each other at the largest
    speeds the reach allows, so the volume falls at the bound's first-order rate. The largest
    limit the pre-test clears is not flagged, and it lies within a few per cent of the volume
    the full guard predicts (``slack`` of the predicted fall; a bound cut by a third would
    clear flagged caps)."""
    s = 1e-3
    base = s * np.array([[1.0, 0.0, 0.0], [-0.5, 0.75 ** 0.5, 0.0], [-0.5, -(0.75 ** 0.5), 0.0]])
    x = np.vstack([[0.0, 0.0, height * s], base])
    t = (0, 1, 2, 3)
    if _volume6(x, np.zeros_like(x), 0.0, *t) < 0:
        x[[1, 2]] = x[[2, 1]]
    speed, dt = 200.0, 1e-9
    v = np.zeros_like(x)
    v[0, 2], v[1:, 2] = -speed, speed
    reach = guard_reach(x, v, 2.2 * dt)
    lo, hi = 0.0, 2.0 * _volume6(x, v, 0.0, *t)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _clear(x, *t, reach, mid) else (lo, mid)
    assert not _flagged(x, v, dt, t, lo)
    worst = min(_volume6(x, v, 1.1 * dt, *t), _volume6(x, v, 2.2 * dt, *t))
    assert worst > lo > worst - slack * (_volume6(x, v, 0.0, *t) - worst)


def test_the_pretest_rests_where_it_clears_few_cells_and_is_tried_again():
    """GuardPretest (criteria.py): off after a step where it cleared less than MIN_SHARE of the
    tested cells (its reach is then inf: the kernels run the full guard alone), on again after
    PROBE steps; it decides cost only (the guard's actions do not depend on it)."""
    import math

    from impactsim.fracture.criteria import GuardPretest

    class M:
        x = np.zeros((3, 3))
        v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0]])

    g = GuardPretest()
    assert 0.0 < g.reach(M, 1e-6) < math.inf
    g.count(100, 90)
    g.end_step()
    assert g.on  # 90 % cleared: it pays
    g.count(100, 10)
    g.end_step()
    assert not g.on and g.reach(M, 1e-6) == math.inf
    for _ in range(GuardPretest.PROBE - 1):
        g.end_step()
        assert not g.on
    g.end_step()
    assert g.on and g.reach(M, 1e-6) < math.inf
    g.end_step()  # a step without tested cells keeps it on
    assert g.on
