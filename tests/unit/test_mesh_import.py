"""Import of tet meshes with meshio: tetra cells only, orientation repaired, bad meshes refused."""

import meshio
import numpy as np
import pytest

from impactsim.case.schema import Body
from impactsim.mesh import MeshError, mesh_body
from impactsim.mesh.orient import signed_volumes
from impactsim.mesh.structured import structured_box


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("IMPACTSIM_CACHE", str(tmp_path / "cache"))


def file_body(path, scale=1.0, position=(0.0, 0.0, 0.0)):
    return Body("f", "al", "file", {"path": path, "scale": scale}, position=position)


def test_flipped_tets_are_fixed_and_extras_dropped(tmp_path):
    points, tets = structured_box((20.0, 10.0, 10.0), 5.0)  # in mm, centred at 0
    tets = tets.astype(np.int64)
    tets[::3, [0, 1]] = tets[::3, [1, 0]]  # invert every third tet
    assert (signed_volumes(points, tets) < 0).sum() == len(tets[::3])
    points = np.vstack([points + [50.0, 0.0, 0.0], [[999.0, 999.0, 999.0]]])  # unused node
    triangles = np.array([[0, 1, 2]])
    path = tmp_path / "part.vtu"
    meshio.write(path, meshio.Mesh(points, [("triangle", triangles), ("tetra", tets)]))

    out_points, out_tets = mesh_body(file_body(path, scale=1e-3, position=(0.0, 0.0, 0.5)))
    volumes = signed_volumes(out_points, out_tets)
    assert volumes.min() > 0.0
    assert volumes.sum() == pytest.approx(20e-3 * 10e-3 * 10e-3, rel=1e-12)
    assert len(out_tets) == len(tets) and len(out_points) == len(points) - 1
    # the volume centroid of an imported mesh is its centre: placed at `position`
    np.testing.assert_allclose(out_points.min(axis=0), [-0.01, -0.005, 0.495], atol=1e-12)
    np.testing.assert_allclose(out_points.max(axis=0), [0.01, 0.005, 0.505], atol=1e-12)


def test_file_without_tets_is_an_error(tmp_path):
    path = tmp_path / "surface.vtu"
    meshio.write(path, meshio.Mesh(np.eye(3), [("triangle", np.array([[0, 1, 2]]))]))
    with pytest.raises(MeshError, match="no 4-node tetrahedra.*triangle"):
        mesh_body(file_body(path))


def test_degenerate_tet_is_an_error(tmp_path):
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0]], dtype=float)
    tets = np.array([[0, 1, 2, 3], [0, 1, 2, 4]])  # the second is flat (z = 0)
    path = tmp_path / "flat.vtu"
    meshio.write(path, meshio.Mesh(points, [("tetra", tets)]))
    with pytest.raises(MeshError, match="1 degenerate"):
        mesh_body(file_body(path))


def test_missing_file_is_an_error(tmp_path):
    with pytest.raises(MeshError, match="cannot read|not found"):
        mesh_body(file_body(tmp_path / "nope.vtu"))
