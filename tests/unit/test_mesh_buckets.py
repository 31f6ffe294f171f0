"""The linear-time faces and edges (mesh/buckets.py) against numpy's sort and brute force."""

import numpy as np
import pytest

from impactsim.fracture.separation import HEX_FACES, face_adjacency_k
from impactsim.mesh import buckets
from impactsim.mesh.buckets import KERNEL_MIN_ROWS, match_faces
from impactsim.mesh.hexes import box_hexes
from impactsim.mesh.structured import structured_box
from impactsim.mesh.topology import LOCAL_EDGES, LOCAL_FACES, face_adjacency, unique_edges


def _scrambled(tets, n_node, seed):
    """The same mesh with its node numbers permuted (buckets of every size, in any order)."""
    perm = np.random.default_rng(seed).permutation(n_node)
    return perm[tets]


def _brute(conn, faces, alive):
    """Neighbour across each face by a dictionary of sorted node tuples."""
    out = np.full((len(conn), len(faces)), -1)
    seen = {}
    for e in np.flatnonzero(alive):
        for i, f in enumerate(faces):
            key = tuple(sorted(int(n) for n in conn[e][f]))
            if key in seen:
                b, j = seen[key]
                out[e, i], out[b, j] = b, e
            else:
                seen[key] = (e, i)
    return out


@pytest.mark.parametrize("seed", [0, 1])
def test_tets_and_hexes_match_brute_force(seed):
    pts, tets = structured_box((1.0, 0.75, 0.5), 0.25)
    tets = _scrambled(tets, len(pts), seed)
    alive = np.random.default_rng(seed).random(len(tets)) > 0.3
    for live in (None, alive):
        want = _brute(tets, LOCAL_FACES, np.ones(len(tets), bool) if live is None else live)
        assert np.array_equal(match_faces(tets, LOCAL_FACES, live), want)
    hpts, hexes = box_hexes((1.0, 0.75, 0.5), 0.25)
    hexes = _scrambled(hexes, len(hpts), seed)
    assert np.array_equal(match_faces(hexes, HEX_FACES),
                          _brute(hexes, HEX_FACES, np.ones(len(hexes), bool)))


def test_large_meshes_take_the_kernel_and_agree_with_the_sort(monkeypatch):
    """Above KERNEL_MIN_ROWS both callers use the kernel: the same arrays as their numpy sort
    (forced by raising the threshold); a closed box's boundary is two triangles (one quad) on
    each outer square of the grid, and every match is mutual."""
    pts, tets = structured_box((1.0, 1.0, 1.0), 1 / 16)  # 24,576 tets, 98,304 faces
    tets = np.concatenate([tets, _scrambled(tets, len(pts), 2) + len(pts)])
    assert 4 * len(tets) >= KERNEL_MIN_ROWS
    alive = np.random.default_rng(5).random(len(tets)) > 0.2
    fast = [face_adjacency(tets), face_adjacency(tets, alive)]
    hpts, hexes = box_hexes((1.0, 1.0, 2.5), 1 / 16)  # 10,240 hexes, 61,440 faces
    hexes = np.concatenate([hexes, hexes + len(hpts)])
    assert 6 * len(hexes) >= KERNEL_MIN_ROWS
    fast_hex = face_adjacency_k(hexes, HEX_FACES)
    fast_edges = unique_edges(tets)
    monkeypatch.setattr(buckets, "KERNEL_MIN_ROWS", 10 ** 12)
    assert np.array_equal(fast[0], face_adjacency(tets))
    assert np.array_equal(fast[1], face_adjacency(tets, alive))
    assert np.array_equal(fast_hex, face_adjacency_k(hexes, HEX_FACES))
    slow_edges = unique_edges(tets)
    for a, b in zip(fast_edges, slow_edges):
        assert a.dtype == b.dtype and np.array_equal(a, b)
    # each of the two boxes: 6 sides of 16 x 16 squares, 2 triangles a square
    assert np.count_nonzero(fast[0] < 0) == 2 * 6 * 16 * 16 * 2
    assert np.count_nonzero(fast_hex < 0) == 2 * (2 * 16 * 16 + 4 * 16 * 40)
    # every match is mutual
    e, i = np.nonzero(fast[0] >= 0)
    assert np.all(np.any(fast[0][fast[0][e, i]] == e[:, None], axis=1))


def test_a_face_of_three_elements_is_refused(monkeypatch):
    tets = np.array([[0, 1, 2, 3], [0, 2, 1, 4], [0, 1, 2, 5]])
    assert match_faces(tets, LOCAL_FACES) is None
    assert match_faces(tets, LOCAL_FACES, np.array([True, True, False]))[0, 3] == 1
    monkeypatch.setattr(buckets, "KERNEL_MIN_ROWS", 0)
    with pytest.raises(ValueError, match="non-manifold"):
        face_adjacency(tets)


@pytest.mark.parametrize("seed", [0, 1])
def test_edges_match_brute_force(seed):
    """Every local edge points at its own two nodes, no edge twice, in lexicographic order,
    and a box of 6-tet cells has as many edges as Euler's formula gives."""
    pts, tets = structured_box((1.0, 0.75, 0.5), 0.25)
    tets = _scrambled(tets, len(pts), seed)
    edges, index = buckets.unique_edges(tets, LOCAL_EDGES)
    assert edges.dtype == np.int32 and np.all(edges[:, 0] < edges[:, 1])
    assert np.all(np.diff(edges[:, 0].astype(np.int64) * len(pts) + edges[:, 1]) > 0)
    want = np.sort(tets[:, LOCAL_EDGES], axis=2)
    assert np.array_equal(edges[index], want)
    # V - E + F - C = 1 for a ball: the mesh's faces F = (4 C + boundary faces) / 2
    n_b = np.count_nonzero(match_faces(tets, LOCAL_FACES) < 0)
    faces = (4 * len(tets) + n_b) // 2
    assert len(pts) - len(edges) + faces - len(tets) == 1
