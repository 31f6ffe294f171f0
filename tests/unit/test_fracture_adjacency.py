"""Face adjacency and the incremental surface updates against brute force (ALGORITHMS.md 4.2)."""

import itertools

import numpy as np
import pytest

from impactsim.contact.surface import Surface
from impactsim.fracture.boundary import Boundary
from impactsim.mesh.structured import structured_box
from impactsim.mesh.topology import LOCAL_FACES, boundary_faces, face_adjacency
from impactsim.model import ERODED


def _brute_adjacency(tets, alive):
    out = np.full((len(tets), 4), -1)
    for a, b in itertools.combinations(range(len(tets)), 2):
        if not (alive[a] and alive[b]):
            continue
        for i in range(4):
            fa = set(tets[a][LOCAL_FACES[i]])
            for j in range(4):
                if fa == set(tets[b][LOCAL_FACES[j]]):
                    out[a, i], out[b, j] = b, a
    return out


def _brute_boundary(tets, alive):
    """Boundary faces as {(sorted triple): (element, oriented triple)}."""
    count = {}
    for e, t in enumerate(tets):
        if not alive[e]:
            continue
        for i in range(4):
            tri = tuple(int(n) for n in t[LOCAL_FACES[i]])
            count.setdefault(tuple(sorted(tri)), []).append((e, tri))
    return {k: v[0] for k, v in count.items() if len(v) == 1}


def _mesh(seed):
    pts, tets = structured_box((1.0, 1.0, 1.0), 1 / 3)
    perm = np.random.default_rng(seed).permutation(len(pts))  # scramble node numbers
    inv = np.argsort(perm)
    return pts[perm], inv[tets]


@pytest.mark.parametrize("seed", [0, 1])
def test_face_adjacency_matches_brute_force(seed):
    _, tets = _mesh(seed)
    alive = np.random.default_rng(seed).random(len(tets)) > 0.3
    assert np.array_equal(face_adjacency(tets, alive), _brute_adjacency(tets, alive))
    assert np.array_equal(face_adjacency(tets), _brute_adjacency(tets, np.ones(len(tets), bool)))


def test_boundary_faces_match_brute_force_and_point_out():
    pts, tets = _mesh(3)
    faces, owner, _ = boundary_faces(tets)
    brute = _brute_boundary(tets, np.ones(len(tets), bool))
    got = {tuple(sorted(f)): (int(e), tuple(int(n) for n in f)) for f, e in zip(faces, owner)}
    assert got == brute
    centre = pts[tets[owner]].mean(axis=1)
    n = np.cross(pts[faces[:, 1]] - pts[faces[:, 0]], pts[faces[:, 2]] - pts[faces[:, 0]])
    assert np.all(np.einsum("ij,ij->i", n, pts[faces[:, 0]] - centre) > 0)


def test_incremental_surface_update_equals_recomputation():
    """Deleting elements batch after batch gives, every time, the surface a rebuild gives."""
    pts, tets = _mesh(4)
    n = len(tets)
    status = np.zeros(n, np.int8)
    surf = Surface(tets, np.zeros(n, np.int32))
    rng = np.random.default_rng(5)
    order = rng.permutation(n)
    for batch in np.array_split(order[: int(0.9 * n)], 12):
        status[batch] = ERODED
        surf.remove_elements(batch)
        ref = Surface(tets, np.zeros(n, np.int32), status)
        for name in ("face_flag", "faces", "face_elem", "face_local", "edges", "nodes",
                     "face_edges", "edge_count", "node_count"):
            assert np.array_equal(getattr(surf, name), getattr(ref, name)), name
        brute = _brute_boundary(tets, status != ERODED)
        got = {tuple(sorted(f)): (int(e), tuple(int(k) for k in f))
               for f, e in zip(surf.faces, surf.face_elem)}
        assert got == brute


def test_free_faces_follow_removals_in_proportion_to_them():
    """fracture.boundary.Boundary, updated removal after removal, has the free faces (flags,
    oriented triples, bodies) of a Surface rebuilt from scratch, and its row index is exact."""
    pts, tets = _mesh(6)
    n = len(tets)
    body = (np.arange(n) % 2).astype(np.int32)
    status = np.zeros(n, np.int8)
    b = Boundary(tets, body)
    rng = np.random.default_rng(7)
    for batch in np.array_split(rng.permutation(n), 10):
        batch = np.sort(batch)
        status[batch] = ERODED
        assert b.remove(np.concatenate([batch, batch[:3]])) == batch.size  # repeats skipped
        ref = Surface(tets, body, status)
        assert np.array_equal(b.face_flag, ref.face_flag)
        got = sorted(zip(map(tuple, b.faces[:b.n].tolist()), b.face_body[:b.n].tolist()))
        want = sorted(zip(map(tuple, ref.faces.tolist()), ref.face_body.tolist()))
        assert got == want
        assert np.array_equal(b.pos[b.face_slot[:b.n]], np.arange(b.n))
        assert np.count_nonzero(b.pos >= 0) == b.n
    assert b.n == 0
