"""Hex bodies in contact (contact/hexes.py): boundary quads, their split into two triangles
(the same diagonal from both sides), the edges edge-edge sees, and the tet cover for the
penetration measure."""

import numpy as np

from impactsim.case.schema import Body, Case, Output, Run
from impactsim.contact.hexes import HexSurface, ProxyTets, boundary_quads, split_quads
from impactsim.mesh.hexes import box_hexes, cylinder_hexes, fix_hex_orientation, hex_volumes
from impactsim.mesh.orient import signed_volumes
from impactsim.solver.build import build_model
from tests.builders import material


def _model(mesh):
    mat = material()
    body = Body(name="b", material=mat.name, shape="box", dimensions={"size": (1, 1, 1)},
                mesh_size=0.25, element="hex8")
    case = Case(source=None, run=Run(name="t", end_time=1e-3), materials={mat.name: mat},
                bodies=[body], output=Output())
    return build_model(case, [mesh])


def test_boundary_quads_outward_and_counted():
    pts, hexes = box_hexes((0.3, 0.2, 0.1), 0.1)
    hexes, _ = fix_hex_orientation(pts, hexes)
    quads, elem, local = boundary_quads(hexes)
    assert len(quads) == 2 * (3 * 2 + 2 * 1 + 1 * 3)
    a, b, c, d = (pts[quads[:, k]] for k in range(4))
    normal = np.cross(c - a, d - b)
    outward = (a + b + c + d) / 4 - pts[hexes[elem]].mean(axis=1)
    assert np.all(np.einsum("ij,ij->i", normal, outward) > 0)


def test_split_is_the_same_from_both_sides():
    """A face seen from its two hexes (reversed order, any starting corner) gets the same
    diagonal, and the two triangles cover the quad."""
    rng = np.random.default_rng(0)
    for _ in range(50):
        q = rng.choice(1000, 4, replace=False)
        t1 = split_quads(q[None, :])
        other = np.roll(q[::-1], rng.integers(4))
        t2 = split_quads(other[None, :])
        diag = lambda t: frozenset(t[0]) & frozenset(t[1])  # noqa: E731
        assert diag(t1) == diag(t2) and min(q) in diag(t1)
        assert set(t1.ravel()) == set(q)


def test_surface_edges_are_the_quads_edges_and_the_split_creases():
    """Edge-edge sees every element edge of the boundary quads and the diagonal of each split
    (the crease of its two triangles, contact/hexes.py), never an edge inside the body; every
    triangle lists its three edges."""
    pts, hexes = cylinder_hexes(0.5, 0.6, (0, 0, 1), 0.2)
    hexes, _ = fix_hex_orientation(pts, hexes)
    model = _model((pts, hexes.astype(np.int32)))
    s = HexSurface(model)
    quads, _, _ = boundary_quads(model.blocks[0].conn)
    assert s.n_faces == 2 * len(quads)
    true_edges = {frozenset(e) for q in quads for e in zip(q, np.roll(q, -1))}
    tris = s.faces.reshape(-1, 2, 3)
    creases = {frozenset(set(t[0]) & set(t[1])) for t in tris}
    assert len(creases) == len(quads) and not (creases & true_edges)
    assert {frozenset(e) for e in s.edges} == true_edges | creases
    assert np.all(s.face_edges >= 0)
    for f, tri in enumerate(s.faces):
        assert {frozenset(s.edges[g]) for g in s.face_edges[f]} == {
            frozenset((tri[j], tri[(j + 1) % 3])) for j in range(3)}
    assert set(s.nodes) == set(np.unique(quads))
    # the triangles close the surface: every edge borders two triangles
    tri_edges = np.sort(np.stack([s.faces, np.roll(s.faces, -1, axis=1)], -1).reshape(-1, 2), 1)
    _, counts = np.unique(tri_edges, axis=0, return_counts=True)
    assert np.all(counts == 2)


def test_proxy_tets_cover_the_hexes():
    pts, hexes = box_hexes((0.3, 0.2, 0.1), 0.05)
    hexes, _ = fix_hex_orientation(pts, hexes)
    rng = np.random.default_rng(1)
    inner = np.all(np.abs(pts) < [0.149, 0.099, 0.049], axis=1)
    pts = pts.copy()
    pts[inner] += 0.005 * rng.uniform(-1, 1, (inner.sum(), 3))
    model = _model((pts, hexes.astype(np.int32)))
    proxy = ProxyTets(model)
    x, conn, eb, st = proxy.update(model)
    vol = signed_volumes(x, conn)
    assert vol.min() > 0
    # the tets fill the body bounded by the split faces: its volume, the box's, exactly (the
    # boundary is plane) and each hex's within its warping
    assert abs(vol.sum() - 0.006) < 1e-15
    per_hex = vol.reshape(-1, 12).sum(axis=1)
    np.testing.assert_allclose(per_hex, hex_volumes(pts, hexes), rtol=0.02)
