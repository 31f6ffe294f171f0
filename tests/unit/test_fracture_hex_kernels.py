"""Kernels of hex fracture (fracture/hexes.py) and the hex contact surface as hexes erode
(contact/hexes.py): the exact volume of the guard, the principal stretch, the free quads and the
contact surface updated in O(change) equal to the ones built afresh."""

import numpy as np
import pytest

from impactsim.contact.hexes import HexSurface, boundary_quads, split_quads
from impactsim.fracture.hexes import XI, HexBoundary, hex_stretch, hex_volume
from impactsim.mesh.hexes import box_hexes, fix_hex_orientation
from impactsim.model import ERODED
from impactsim.solver.hex8 import hex_volumes
from tests.unit.test_contact_hexes import _model


def _box(size=(0.4, 0.3, 0.2), h=0.1):
    pts, hexes = box_hexes(size, h)
    hexes, _ = fix_hex_orientation(pts, hexes)
    return pts, hexes.astype(np.int32)


def test_guard_volume_is_the_exact_hex_volume():
    """hex_volume (LULESH's closed form) equals the block kernel's exact volume on distorted
    hexes, at x and at x + h v."""
    pts, hexes = _box()
    rng = np.random.default_rng(1)
    x = pts + 0.02 * rng.standard_normal(pts.shape)
    v = rng.standard_normal(pts.shape)
    ref = hex_volumes(x + 0.01 * v, hexes)
    got = np.array([hex_volume(x, v, 0.01, hexes, e) for e in range(len(hexes))])
    np.testing.assert_allclose(got, ref, rtol=1e-12)


def test_principal_stretch_of_a_homogeneous_deformation():
    """A homogeneous F (stretch 1.3 along a rotated axis, rotation on top) gives 1.3."""
    pts, hexes = _box()
    c, s = np.cos(0.4), np.sin(0.4)
    rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    f = rot @ np.diag([1.3, 0.9, 1.1]) @ rot.T
    x = pts @ (rot @ f).T
    for e in range(0, len(hexes), 5):
        assert hex_stretch(x, pts, hexes, e, XI) == pytest.approx(1.3, rel=1e-12)


def _free_triangles(conn, alive):
    quads, _, _ = boundary_quads(conn, np.where(alive, 0, ERODED))
    return {tuple(sorted(t)) for t in split_quads(quads)}


def test_free_quads_follow_removals_as_built_afresh():
    """HexBoundary after removals in several batches lists the triangles of the free quads of
    the live hexes (the split of contact/hexes.py), two rows per quad, as one built afresh."""
    pts, hexes = _box()
    b = HexBoundary(hexes, np.zeros(len(hexes), np.int32))
    rng = np.random.default_rng(2)
    order = rng.permutation(len(hexes))
    for batch in np.array_split(order[:len(hexes) - 3], 5):
        b.remove(np.sort(batch))
        alive = b.alive
        got = {tuple(sorted(t)) for t in b.faces[:b.n]}
        assert got == _free_triangles(hexes, alive)
        assert b.n == 2 * int(b.face_flag.sum())
        fresh = HexBoundary(hexes, np.zeros(len(hexes), np.int32), alive)
        assert np.array_equal(fresh.face_flag, b.face_flag)
        pairs = b.face_slot[:b.n].reshape(-1, 2)
        assert np.all(pairs[:, 0] == pairs[:, 1])


def test_contact_surface_follows_hex_erosion():
    """The contact surface of a hex body after hexes erode (sync with the blocks' status)
    equals the surface built afresh for that state: faces, edges with their keys, nodes."""
    model = _model(_box())
    blk = model.blocks[0]
    s = HexSurface(model)
    rng = np.random.default_rng(3)
    order = rng.permutation(blk.n_elem)
    for batch in np.array_split(order[:blk.n_elem - 4], 4):
        blk.status[batch] = ERODED
        assert s.sync(model.status)
        fresh = HexSurface(model)
        for name in ("faces", "face_elem", "face_local", "face_body", "face_edges", "edges",
                     "nodes", "node_body", "edge_body", "face_key", "edge_key"):
            assert np.array_equal(getattr(s, name), getattr(fresh, name)), name
        assert not s.sync(model.status)
    # a triangle's key is its quad: the other triangle's node is in it
    tris = s.faces.reshape(-1, 2, 3)
    keys = s.face_key.reshape(-1, 2, 4)
    for t, k in zip(tris, keys):
        assert set(t[0]) | set(t[1]) == set(k[0]) == set(k[1])
