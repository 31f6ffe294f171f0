"""The particle-face sweep's screen (fracture/particle_screen.py) changes no correction: the
screened sweep gives the unscreened one's impulses, work and velocities bit for bit, on pairs
put on each of the exact test's thresholds (within 1e-13 of it on both sides) and over a plate
in a cloud of particles; a window starts again after an impulse, so a pair whose face an
earlier pair of its window has just pushed is tested on the new velocities; and the screen
flags every pair that takes an impulse (a superset), few of those that do not."""

import numpy as np
import pytest

from impactsim.fracture import particle_screen as PS
from impactsim.fracture.particles import (NODE_COLS, pack_face_nodes, particle_face_sweep_packed)
from tests.unit.test_fracture_particle_contact import _particles_over_a_plate

TAU = 1e-8
EPS = 1e-6
NO_LOCK = np.ones((0, 3))


def _sweep(pairs, px, pv, pm, pr, faces, x, v, mass, screened):
    """The sweep on copies; returns (applied, work, particle velocities, node velocities)."""
    pv, v = pv.copy(), v.copy()
    table = np.zeros((x.shape[0], NODE_COLS))
    pack_face_nodes(faces, faces.shape[0], x, v, mass, table)
    applied, work = particle_face_sweep_packed(pairs, px, pv, pm, pr, faces, table, v, mass,
                                               np.zeros_like(v), 0.0, TAU, EPS, NO_LOCK,
                                               screened)
    return applied, work, pv, v


def _same(a, b):
    assert a[0] == b[0]
    assert np.float64(a[1]).view(np.int64) == np.float64(b[1]).view(np.int64)
    np.testing.assert_array_equal(a[2], b[2])
    np.testing.assert_array_equal(a[3], b[3])


def _on_the_thresholds(seed=5):
    """A triangle of 1 mm legs (normal +z before the turn) seen by particles placed on each
    threshold of the exact test, inside and outside by a hair (within the rounding of the test,
    1e-12) and by a little more than the screen's widening (1e-7): the projection on an edge
    (w = -eps), the centre on the plane, the closing speed at the gap's limit (u = -g0 / tau);
    then particles at random near the triangle, in front of it and behind, closing and opening;
    the whole scene turned about a random axis."""
    rng = np.random.default_rng(seed)
    h = 1e-3
    x = np.array([[0.0, 0.0, 0.0], [h, 0.0, 0.0], [0.0, h, 0.0]])
    v = np.zeros((3, 3))
    faces = np.array([[0, 1, 2]], np.int32)
    mass = np.full(3, 1e-9)
    px, pv, pr = [], [], []
    r = 1e-4
    for hair in (-1e-7, -1e-12, 0.0, 1e-12, 1e-7):
        # on the edge b-c's outside: w_a = -eps (1 + hair), the particle resting on the plane
        # and closing at 10 m/s
        wa = -EPS * (1.0 + hair)
        s = 0.5 * (1.0 - wa)
        px.append([s * h, s * h, r + 1e-9])
        pv.append([0.0, 0.0, -10.0 - (1e-9 / TAU)])
        # the centre a hair in front of the plane, closing
        px.append([0.3 * h, 0.3 * h, hair * h])
        pv.append([0.0, 0.0, -5.0])
        # the closing speed at the gap's limit: g0 / tau = 1 m/s
        g0 = 1e-8
        px.append([0.2 * h, 0.25 * h, r + g0])
        pv.append([0.0, 0.0, -(g0 / TAU) * (1.0 + hair)])
    for _ in range(120):  # and at random near the triangle
        px.append([rng.uniform(-0.05, 0.8) * h, rng.uniform(-0.05, 0.8) * h,
                   r * rng.choice([-1.0, 1.0]) + rng.uniform(-3e-7, 3e-7)])
        pv.append(rng.normal(0.0, 30.0, 3))
    # the scene turned about a random axis: no test on a coordinate axis
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    x, px, pv = x @ q.T, np.array(px) @ q.T, np.array(pv) @ q.T
    pr = np.full(px.shape[0], r)
    pm = np.full(px.shape[0], 1e-10)
    pairs = np.array([[p, 0] for p in range(px.shape[0])], np.int64)
    return pairs, px, pv, pm, pr, faces, x, v, mass


def test_the_screen_changes_nothing_on_the_thresholds():
    case = _on_the_thresholds()
    plain = _sweep(*case, screened=False)
    screened = _sweep(*case, screened=True)
    assert plain[0] >= 20  # the case does take impulses, on and off the thresholds
    _same(screened, plain)


def test_the_screen_flags_every_pair_that_takes_an_impulse():
    """Each pair screened alone against the exact sweep of that pair alone: an impulse only
    where flagged, and most unflagged (the screen does screen)."""
    pairs, px, pv, pm, pr, faces, x, v, mass = _on_the_thresholds(seed=11)
    table = np.zeros((x.shape[0], NODE_COLS))
    pack_face_nodes(faces, 1, x, v, mass, table)
    flags = np.zeros(PS.LANES, np.uint8)
    buf = np.empty(PS.ROWS * PS.LANES)
    flagged = took = 0
    for k in range(pairs.shape[0]):
        PS.screen_window(pairs, k, k + 1, px, pv, pr, faces, table, TAU, EPS, flags, buf)
        one = _sweep(pairs[k:k + 1], px, pv, pm, pr, faces, x, v, mass, screened=False)
        assert one[0] == 0 or flags[0] == 1, k
        flagged += int(flags[0])
        took += one[0]
    assert 10 <= took <= flagged < pairs.shape[0] - 10


def test_a_window_starts_again_after_an_impulse():
    """A sheet of one triangle with both sides as faces: a particle strikes its top, and the
    impulse pushes the nodes onto a particle resting under the bottom face, in the same window.
    Screened on the velocities before the first impulse, the second pair would take none."""
    h = 1e-3
    x = np.array([[0.0, 0.0, 0.0], [h, 0.0, 0.0], [0.0, h, 0.0]])
    v = np.zeros((3, 3))
    faces = np.array([[0, 1, 2], [0, 2, 1]], np.int32)  # top (+z) and bottom (-z)
    mass = np.full(3, 1e-9)
    r = 1e-4
    px = np.array([[0.3 * h, 0.3 * h, r + 1e-6], [0.3 * h, 0.3 * h, -r - 1e-6]])
    pv = np.array([[0.0, 0.0, -1000.0], [0.0, 0.0, 0.0]])
    pm = np.full(2, 1e-9)
    pr = np.full(2, r)
    pairs = np.array([[0, 0], [0, 1], [1, 0], [1, 1]], np.int64)
    plain = _sweep(pairs, px, pv, pm, pr, faces, x, v, mass, screened=False)
    screened = _sweep(pairs, px, pv, pm, pr, faces, x, v, mass, screened=True)
    assert plain[0] == 2 and plain[2][1, 2] < 0.0  # the resting particle was struck
    _same(screened, plain)


@pytest.mark.parametrize("n", [300, 1500])
def test_the_screen_changes_nothing_over_a_plate(n):
    """The particle pass's own pairs (plate in a cloud of particles, one step): the same."""
    from impactsim.fracture import passes as FP

    dt = 2e-9
    out = []
    for screened in (False, True):
        model, ppass = _particles_over_a_plate(n, False)
        model.energy_terms["contact_dissipated"] = 0.0
        sweep = particle_face_sweep_packed

        def chosen(*args, screened=screened):
            return sweep(*args, screened)

        FP.particle_face_sweep_packed, saved = chosen, FP.particle_face_sweep_packed
        try:
            ppass.run(model, dt)
        finally:
            FP.particle_face_sweep_packed = saved
        out.append((ppass.impacts, model.energy_terms["contact_dissipated"],
                    ppass.s.particles.v[:n].copy(), model.v.copy()))
    assert out[0][0] > n // 20
    _same(out[1], out[0])
