"""Quality measures against hand calculations."""

import math

import numpy as np
import pytest

from impactsim.mesh import quality
from impactsim.mesh.quality import (altitudes, aspect_ratios, dihedral_angles, sound_speed,
                                    stable_dt, unique_edge_lengths)
from impactsim.mesh.structured import structured_box

REGULAR = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float)  # edge 2 sqrt 2
CORNER = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
ONE = np.array([[0, 1, 2, 3]], dtype=np.int32)


def positive(points):
    """The single tet on `points`, node order fixed so it is positive."""
    a, b, c = points[1] - points[0], points[2] - points[0], points[3] - points[0]
    return ONE if np.dot(a, np.cross(b, c)) > 0 else ONE[:, [0, 1, 3, 2]]


def test_regular_tet():
    tets = positive(REGULAR)
    edge = 2.0 * math.sqrt(2.0)
    q = quality(REGULAR, tets)
    assert q["aspect_max"] == pytest.approx(1.0, rel=1e-12)
    assert q["dihedral_min"] == pytest.approx(70.528779, abs=1e-6)
    assert q["dihedral_max"] == pytest.approx(70.528779, abs=1e-6)
    assert q["altitude_min"] == pytest.approx(edge * math.sqrt(2.0 / 3.0), rel=1e-12)
    assert q["volume"] == pytest.approx(edge**3 / (6.0 * math.sqrt(2.0)), rel=1e-12)
    assert q["edge_min"] == pytest.approx(edge) and q["edge_max"] == pytest.approx(edge)
    assert q["nodes"] == 4 and q["elements"] == 1


def test_corner_tet():
    tets = positive(CORNER)
    # V = 1/6, largest face the slanted one, area sqrt(3)/2: altitude 3V/A = 1/sqrt(3)
    assert altitudes(CORNER, tets)[0] == pytest.approx(1.0 / math.sqrt(3.0), rel=1e-12)
    angles = np.sort(dihedral_angles(CORNER, tets)[0])
    expected = np.sort([90.0] * 3 + [math.degrees(math.acos(1.0 / math.sqrt(3.0)))] * 3)
    np.testing.assert_allclose(angles, expected, atol=1e-9)
    # R = sqrt(3)/2, r = 3V / S = 0.5 / (1.5 + sqrt(3)/2)
    r = 0.5 / (1.5 + math.sqrt(3.0) / 2.0)
    assert aspect_ratios(CORNER, tets)[0] == pytest.approx(math.sqrt(3.0) / 2.0 / (3.0 * r))


def test_flat_tet_has_infinite_aspect_ratio():
    flat = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], dtype=float)
    assert np.isinf(aspect_ratios(flat, ONE)[0])


def test_stable_dt_and_sound_speed():
    c = sound_speed(2700.0, 70e9, 26e9)
    assert c == pytest.approx(math.sqrt((70e9 + 4 * 26e9 / 3) / 2700.0))
    tets = positive(CORNER)
    points = CORNER * 1e-3
    dt = stable_dt(points, tets, c, cfl=0.5)
    assert dt == pytest.approx(0.5 * 1e-3 / math.sqrt(3.0) / c, rel=1e-12)
    assert quality(points, tets, wave_speed=c, cfl=0.5)["stable_dt"] == pytest.approx(dt)


def test_unique_edges_of_a_kuhn_cube():
    points, tets = structured_box((1.0, 1.0, 1.0), 1.0)
    lengths = np.sort(unique_edge_lengths(points, tets))
    # 12 cube edges, 6 face diagonals, 1 main diagonal
    expected = np.sort([1.0] * 12 + [math.sqrt(2.0)] * 6 + [math.sqrt(3.0)])
    np.testing.assert_allclose(lengths, expected, rtol=1e-12)
    q = quality(points, tets)
    assert q["volume"] == pytest.approx(1.0) and q["dihedral_max"] == pytest.approx(90.0)


def test_altitudes_are_the_face_area_formula_bit_for_bit():
    """``altitudes`` (face by face on coordinate arrays) gives the numbers of 3 |V| / max_k |A_k|
    with the (e, 4, 3) face area vectors of ``face_area_vectors``, bit for bit, on a distorted
    box mesh; the smallest is a hand value on the corner tet (1/sqrt 3: 3 V = 1/2 over the
    largest face, sqrt 3 / 2)."""
    import importlib

    q = importlib.import_module("impactsim.mesh.quality")
    pts, tets = structured_box((1e-3, 2e-3, 5e-4), 2.5e-4)
    pts = pts + 3e-5 * np.random.default_rng(3).normal(size=pts.shape)
    vectors = q.face_area_vectors(pts, tets)
    expected = 3.0 * np.abs(q.signed_volumes(pts, tets)) / np.linalg.norm(vectors, axis=2).max(
        axis=1)
    np.testing.assert_array_equal(altitudes(pts, tets), expected)
    assert altitudes(CORNER, positive(CORNER))[0] == pytest.approx(1.0 / math.sqrt(3.0),
                                                                  rel=1e-15)
