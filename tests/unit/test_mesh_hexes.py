"""Hex meshes (mesh/hexes.py): boxes, O-grid cylinders, cube-spheres, imported hexahedra,
orientation and the hex quality measures."""

from pathlib import Path

import meshio
import numpy as np
import pytest

from impactsim.case.schema import Body
from impactsim.mesh import MeshError, mesh_body
from impactsim.mesh.hexes import (MIRROR, box_hexes, cylinder_hexes, fix_hex_orientation,
                                  hex_quality, hex_quality_summary, hex_volumes, read_hexes,
                                  sphere_hexes)


def _conforming(points, hexes):
    """Every quad face is shared by two hexes or lies on the boundary exactly once, and no two
    nodes coincide (the blocks are merged)."""
    from impactsim.solver.hex8 import FACES

    faces = np.sort(hexes[:, FACES].reshape(-1, 4), axis=1)
    _, counts = np.unique(faces, axis=0, return_counts=True)
    assert counts.max() <= 2
    assert len(np.unique(np.round(points, 12), axis=0)) == len(points)
    return faces, counts


def test_box_is_exact_and_perfect():
    pts, hexes = box_hexes((0.1, 0.05, 0.02), 0.01)
    hexes, flipped = fix_hex_orientation(pts, hexes)
    assert flipped == 0 and len(hexes) == 10 * 5 * 2
    assert hex_volumes(pts, hexes).sum() == pytest.approx(1e-4, rel=1e-12)
    s = hex_quality_summary(pts, hexes)
    assert s["min_scaled_jacobian"] == pytest.approx(1.0) and s["max_warping_deg"] < 1e-9
    _conforming(pts, hexes)


@pytest.mark.parametrize("h", [0.2, 0.1, 0.05])
def test_cylinder_o_grid(h):
    """Volume converges to pi R^2 H (second order in h: the polygon of the circle), all corner
    Jacobians well positive, the mesh conforming, the boundary quads on the surface."""
    pts, hexes = cylinder_hexes(0.5, 1.0, (0.0, 1.0, 0.0), h)
    hexes, _ = fix_hex_orientation(pts, hexes)
    vol = hex_volumes(pts, hexes)
    assert vol.min() > 0
    exact = np.pi * 0.25
    assert abs(vol.sum() - exact) / exact < (h / 0.5) ** 2
    assert hex_quality(pts, hexes)["scaled_jacobian"].min() > 0.5
    faces, counts = _conforming(pts, hexes)
    radial = np.hypot(pts[:, 0], pts[:, 2])
    assert radial.max() == pytest.approx(0.5) and np.abs(pts[:, 1]).max() == pytest.approx(0.5)


def test_cube_sphere():
    """Positive, conforming, surface nodes on the sphere; the volume error falls about as h^2
    (the polyhedron of the sphere)."""
    err = []
    for h in (0.1, 0.05):
        pts, hexes = sphere_hexes(0.5, h)
        hexes, _ = fix_hex_orientation(pts, hexes)
        vol = hex_volumes(pts, hexes)
        assert vol.min() > 0
        exact = 4.0 / 3.0 * np.pi * 0.125
        err.append(abs(vol.sum() - exact) / exact)
        q = hex_quality(pts, hexes)
        assert q["scaled_jacobian"].min() > 0.4 and q["aspect_ratio"].max() < 4.0
        _conforming(pts, hexes)
        assert np.linalg.norm(pts, axis=1).max() == pytest.approx(0.5)
    assert err[1] < 0.35 * err[0] and err[1] < 0.03


def test_quality_flags_a_tangled_hex():
    pts, hexes = box_hexes((1.0, 1.0, 1.0), 1.0)
    pts = pts.copy()
    pts[hexes[0, 6]] = [-0.4, -0.4, -0.4]  # the top corner pushed through the element
    assert hex_quality(pts, hexes)["scaled_jacobian"][0] < 0


def test_import_fixes_orientation_and_rejects_degenerate(tmp_path):
    pts, hexes = box_hexes((0.02, 0.02, 0.04), 0.01)
    hexes, _ = fix_hex_orientation(pts, hexes)
    bad = hexes.copy()
    bad[::3] = bad[::3][:, MIRROR]  # every third cell inside out
    path = tmp_path / "m.vtu"
    meshio.write(path, meshio.Mesh(pts * 1000.0, [("hexahedron", bad)]))
    p2, h2, flipped = read_hexes(path, scale=1e-3)
    assert flipped == len(bad[::3])
    assert hex_volumes(p2, h2).min() > 0
    assert hex_volumes(p2, h2).sum() == pytest.approx(1.6e-5, rel=1e-12)
    flat = pts.copy()
    flat[:, 2] = 0.0
    meshio.write(path, meshio.Mesh(flat, [("hexahedron", hexes)]))
    with pytest.raises(MeshError, match="degenerate"):
        read_hexes(path)
    meshio.write(path, meshio.Mesh(pts, [("tetra", np.array([[0, 1, 2, 3]]))]))
    with pytest.raises(MeshError, match="hexahedron"):
        read_hexes(path)


@pytest.mark.parametrize("shape,dims", [
    ("box", {"size": (0.02, 0.01, 0.01)}),
    ("cylinder", {"radius": 0.01, "height": 0.02, "axis": (1.0, 0.0, 0.0)}),
    ("sphere", {"radius": 0.01})])
def test_mesh_body_hex8_placed_and_positive(shape, dims):
    body = Body(name="b", material="m", shape=shape, dimensions=dims, mesh_size=0.004,
                position=(1.0, 2.0, 3.0), rotation=(0.3, 0.0, 0.0), element="hex8")
    pts, hexes = mesh_body(body)
    assert hexes.shape[1] == 8 and hexes.dtype == np.int32
    vol = hex_volumes(pts, hexes)
    assert vol.min() > 0
    centre = (vol @ pts[hexes].mean(axis=1)) / vol.sum()
    np.testing.assert_allclose(centre, [1.0, 2.0, 3.0], atol=1e-9)


def test_case_keys(tmp_path):
    """element / hourglass / hourglass_coefficient read from the case, with the defaults of the
    form, and errors naming the key."""
    from impactsim.case import CaseError, load_case

    src = (Path(__file__).parents[2] / "cases" / "elastic-bar-wall-hex.toml").read_text()
    case = load_case(Path(__file__).parents[2] / "cases" / "elastic-bar-wall-hex.toml")
    b = case.bodies[0]
    assert (b.element, b.hourglass, b.hourglass_coefficient) == ("hex8", "viscous", 0.1)
    p = tmp_path / "c.toml"
    p.write_text(src.replace('\nelement = "hex8"', '\nelement = "hex8"\nhourglass = "stiffness"'))
    assert load_case(p).bodies[0].hourglass_coefficient == 0.03
    p.write_text(src.replace('\nelement = "hex8"', '\nhourglass_coefficient = 0.05'))
    with pytest.raises(CaseError, match="hourglass_coefficient"):
        load_case(p)
    p.write_text(src.replace('\nelement = "hex8"', '\nelement = "hex20"'))
    with pytest.raises(CaseError, match="element"):
        load_case(p)


def test_mesh_report_of_a_hex_body(tmp_path):
    """`impactsim mesh` covers hexes: corner Jacobians, aspect ratio, warping, the stable step
    from V / largest face area, and mesh.vtu with a hexahedron block."""
    from impactsim.case import load_case
    from impactsim.mesh.report import mesh_case

    case = load_case(Path(__file__).parents[2] / "cases" / "taylor-bar-hex.toml")
    text = mesh_case(case, tmp_path)
    assert "scaled corner Jacobian min 0.707" in text and "warping worst" in text
    assert "O-grid" in text and "warning" not in text
    mesh = meshio.read(tmp_path / "mesh.vtu")
    assert [b.type for b in mesh.cells] == ["hexahedron"]


def test_cost_estimate_counts_hexes():
    """`impactsim check`'s estimate meshes a hex body to count it (exact), takes its smallest
    V / face area for the step, and weighs a hex-step as HEX_COST tet-steps."""
    from impactsim.case import load_case
    from impactsim.case.estimate import ELEMENT_TE, HEX_COST, NODES_TE, estimate_cost

    case = load_case(Path(__file__).parents[2] / "cases" / "taylor-bar-hex.toml")
    pts, hexes = mesh_body(case.bodies[0])
    speed = {"seconds_per_step": 0.0, "ns_per_element_step": 100.0}
    e = estimate_cost(case, speed=speed)
    assert e.elements == len(hexes)
    from impactsim.mesh.hexes import hex_report

    assert e.l_min == pytest.approx(hex_report(pts, hexes, 1.0, 1.0)["length_min"], rel=1e-9)
    assert e.seconds["elements"] == pytest.approx(
        e.steps * len(hexes) * (ELEMENT_TE * HEX_COST + NODES_TE) * 1e-7)
