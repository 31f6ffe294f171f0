"""gmsh primitives: volume, orientation, placement, determinism, errors."""

import math

import numpy as np
import pytest

from impactsim.case import errors
from impactsim.case.schema import Body
from impactsim.mesh import MeshError, mesh_body
from impactsim.mesh.orient import rotation_matrix, signed_volumes


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("IMPACTSIM_CACHE", str(tmp_path / "cache"))


def volume_centroid(points, tets):
    v = signed_volumes(points, tets)
    return (points[tets].mean(axis=1) * v[:, None]).sum(axis=0) / v.sum()


def test_box_volume_is_exact_and_tets_positive():
    points, tets = mesh_body(Body("b", "al", "box", {"size": (0.02, 0.01, 0.005)},
                                  mesh_size=0.0025))
    assert points.dtype == np.float64 and tets.dtype == np.int32
    volumes = signed_volumes(points, tets)
    assert volumes.min() > 0.0
    assert volumes.sum() == pytest.approx(1e-6, rel=1e-12)
    np.testing.assert_allclose(points.min(axis=0), [-0.01, -0.005, -0.0025], atol=1e-15)
    assert np.unique(tets).size == len(points)  # no unused nodes


def test_plate_thinner_than_mesh_size_is_valid():
    points, tets = mesh_body(Body("p", "al", "plate", {"size": (0.03, 0.03, 0.0005)},
                                  mesh_size=0.004))
    volumes = signed_volumes(points, tets)
    assert volumes.min() > 0.0
    assert volumes.sum() == pytest.approx(0.03 * 0.03 * 0.0005, rel=1e-12)
    np.testing.assert_allclose(np.unique(points[:, 2]), [-0.00025, 0.00025], atol=1e-15)


def test_thin_disk_meshes_quickly_and_validly():
    r, height = 0.015, 0.0005
    points, tets = mesh_body(Body("d", "al", "cylinder", {"radius": r, "height": height,
                                                          "axis": (0, 0, 1)}, mesh_size=0.004))
    volumes = signed_volumes(points, tets)
    assert volumes.min() > 0.0
    assert volumes.sum() == pytest.approx(math.pi * r * r * height, rel=0.03)
    np.testing.assert_allclose(np.unique(points[:, 2]), [-0.00025, 0.00025], atol=1e-15)


def test_cylinder_volume_axis_and_placement():
    r, height = 0.01, 0.02
    axis = np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0)
    position = np.array([0.1, -0.2, 0.3])
    body = Body("c", "al", "cylinder", {"radius": r, "height": height, "axis": tuple(axis)},
                position=tuple(position), mesh_size=0.0025)
    points, tets = mesh_body(body)
    volumes = signed_volumes(points, tets)
    assert volumes.min() > 0.0
    assert volumes.sum() == pytest.approx(math.pi * r * r * height, rel=0.03)
    np.testing.assert_allclose(volume_centroid(points, tets), position, atol=1e-4)
    rel = points - position
    along = rel @ axis
    assert along.min() == pytest.approx(-height / 2, abs=1e-12)
    assert along.max() == pytest.approx(height / 2, abs=1e-12)
    radial = np.linalg.norm(rel - along[:, None] * axis, axis=1)
    assert radial.max() == pytest.approx(r, rel=1e-9)


def test_rotation_maps_the_cylinder_axis():
    # intrinsic x-y-z: R = Rx(pi/2) Ry(0) Rz(0) turns the local z axis into -y
    body = Body("c", "al", "cylinder", {"radius": 0.005, "height": 0.03, "axis": (0, 0, 1)},
                position=(0.0, 0.0, 1.0), rotation=(math.pi / 2, 0.0, 0.0), mesh_size=0.003)
    points, tets = mesh_body(body)
    assert signed_volumes(points, tets).min() > 0.0
    extent = points.max(axis=0) - points.min(axis=0)
    assert extent[1] == pytest.approx(0.03, rel=1e-12)  # the axis now runs along y
    assert np.hypot(points[:, 0], points[:, 2] - 1.0).max() == pytest.approx(0.005, rel=1e-9)
    np.testing.assert_allclose(rotation_matrix((math.pi / 2, 0, 0)) @ [0, 0, 1], [0, -1, 0],
                               atol=1e-15)
    # composition order: Rx @ Ry @ Rz
    a, b, c = 0.3, -0.7, 1.1
    rx, ry, rz = (rotation_matrix((a, 0, 0)), rotation_matrix((0, b, 0)),
                  rotation_matrix((0, 0, c)))
    np.testing.assert_allclose(rotation_matrix((a, b, c)), rx @ ry @ rz, atol=1e-15)


def test_sphere_volume():
    r = 0.01
    points, tets = mesh_body(Body("s", "steel", "sphere", {"radius": r}, mesh_size=0.002))
    volumes = signed_volumes(points, tets)
    assert volumes.min() > 0.0
    assert volumes.sum() == pytest.approx(4 / 3 * math.pi * r**3, rel=0.03)
    assert np.linalg.norm(points, axis=1).max() == pytest.approx(r, rel=1e-9)


def test_same_body_gives_bit_identical_arrays_without_the_cache():
    body = Body("s", "steel", "sphere", {"radius": 0.01}, mesh_size=0.003,
                rotation=(0.1, 0.2, 0.3), position=(0.01, 0.0, 0.0))
    p1, t1 = mesh_body(body, use_cache=False)
    p2, t2 = mesh_body(body, use_cache=False)
    assert p1.tobytes() == p2.tobytes() and t1.tobytes() == t2.tobytes()


@pytest.mark.parametrize("body, message", [
    (Body("s", "al", "sphere", {"radius": 0.01}, mesh_size=0.0), "mesh_size"),
    (Body("s", "al", "sphere", {"radius": 0.01}, mesh_size=0.001, mesher="structured"),
     "structured"),
    (Body("s", "al", "torus", {"radius": 0.01}, mesh_size=0.001), "unknown shape"),
    (Body("s", "al", "cylinder", {"radius": 0.01}, mesh_size=0.001), "height"),
    (Body("s", "al", "cylinder", {"radius": 0.01, "height": 0.01, "axis": (0, 0, 0)},
          mesh_size=0.001), "axis"),
])
def test_bad_bodies_raise_mesh_error(body, message):
    with pytest.raises(MeshError, match=message) as info:
        mesh_body(body)
    assert isinstance(info.value, errors.CaseError)
