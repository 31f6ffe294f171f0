"""Particle-face contact (ALGORITHMS.md 4.1 with the node-face algebra of 3.1): which side of a
face a particle meets it from, crossing within one step, momentum."""

import numpy as np
import pytest

from impactsim.fracture.particles import particle_face_sweep

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
