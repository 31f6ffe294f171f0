"""Structured box (Kuhn split) and the 12-tet cube: geometry and conformity."""

import numpy as np
import pytest

from impactsim.case.schema import Body
from impactsim.mesh import mesh_body
from impactsim.mesh.orient import signed_volumes
from impactsim.mesh.structured import cells_per_axis, cube12, structured_box


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("IMPACTSIM_CACHE", str(tmp_path / "cache"))


def face_counts(tets):
    """Each distinct triangular face (sorted node triple) and how many tets share it."""
    faces = tets[:, [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]].reshape(-1, 3)
    return np.unique(np.sort(faces, axis=1), axis=0, return_counts=True)


def triangle_areas(points, faces):
    a, b, c = points[faces[:, 0]], points[faces[:, 1]], points[faces[:, 2]]
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


def test_cells_per_axis_rounds_and_keeps_one_layer():
    assert cells_per_axis((0.03, 0.02, 0.0012), 0.01) == (3, 2, 1)
    assert cells_per_axis((0.034, 0.036, 0.004), 0.01) == (3, 4, 1)


def test_structured_box_is_conforming_and_fills_the_box():
    size = (0.03, 0.02, 0.04)
    points, tets = structured_box(size, 0.01)
    assert points.shape == (4 * 3 * 5, 3) and tets.shape == (6 * 3 * 2 * 4, 4)
    assert tets.dtype == np.int32
    volumes = signed_volumes(points, tets)
    assert volumes.min() > 0.0
    assert volumes.sum() == pytest.approx(0.03 * 0.02 * 0.04, rel=1e-12)

    faces, counts = face_counts(tets)
    assert counts.max() == 2  # no face shared by three tets
    boundary = faces[counts == 1]
    lx, ly, lz = size
    surface = 2 * (lx * ly + ly * lz + lx * lz)
    assert triangle_areas(points, boundary).sum() == pytest.approx(surface, rel=1e-12)
    # every boundary face lies in one of the box's six faces, so every interior face is shared by 2
    on_side = np.isclose(np.abs(points[boundary]), 0.5 * np.array(size), rtol=0, atol=1e-12)
    assert np.all(on_side.all(axis=1).any(axis=1))
    # Euler characteristic of a ball: V - E + F - T = 1
    edges = np.unique(np.sort(tets[:, [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]]
                              .reshape(-1, 2), axis=1), axis=0)
    assert len(points) - len(edges) + len(faces) - len(tets) == 1


def test_structured_body_is_placed_and_renumbered():
    body = Body("b", "al", "plate", {"size": (0.02, 0.01, 0.001)}, position=(1.0, 2.0, 3.0),
                mesh_size=0.005, mesher="structured")
    points, tets = mesh_body(body)
    assert len(tets) == 6 * 4 * 2 * 1
    assert signed_volumes(points, tets).sum() == pytest.approx(2e-7, rel=1e-12)
    np.testing.assert_allclose(points.min(axis=0), [0.99, 1.995, 2.9995], atol=1e-12)
    np.testing.assert_allclose(points.max(axis=0), [1.01, 2.005, 3.0005], atol=1e-12)


def test_cube12_matches_the_two_cubes_scene():
    a = 0.02
    points, tets = mesh_body(Body("c", "al", "cube12", {"size": a}, position=(0.1, 0.0, -0.1)))
    assert points.shape == (9, 3) and tets.shape == (12, 4)
    volumes = signed_volumes(points, tets)
    assert volumes.min() > 0.0
    assert volumes.sum() == pytest.approx(a**3, rel=1e-12)
    centre = np.flatnonzero(np.all(np.isclose(points, [0.1, 0.0, -0.1], atol=1e-12), axis=1))
    assert len(centre) == 1
    assert np.all((tets == centre[0]).any(axis=1))  # every tet has the centre node
    faces, counts = face_counts(tets)
    assert (counts == 1).sum() == 12  # the 12 surface triangles
    assert (counts == 2).sum() == 18  # centre joined to the 12 cube edges and 6 diagonals
    assert triangle_areas(points, faces[counts == 1]).sum() == pytest.approx(6 * a * a)


def test_cube12_diagonals_join_even_corners():
    points, tets = cube12(1.0)
    corners = np.rint(points[:8] + 0.5).astype(int)
    even = corners.sum(axis=1) % 2 == 0
    faces, counts = face_counts(tets)
    boundary = faces[counts == 1]
    diagonal_edges = set()
    for tri in boundary:
        for i, j in ((0, 1), (0, 2), (1, 2)):
            p, q = tri[i], tri[j]
            if np.abs(corners[p] - corners[q]).sum() == 2:
                diagonal_edges.add((min(p, q), max(p, q)))
    assert len(diagonal_edges) == 6
    assert all(even[p] and even[q] for p, q in diagonal_edges)
