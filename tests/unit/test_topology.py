"""Mesh topology against brute force on small structured meshes built here (6 tets per hex)."""

from collections import Counter
from itertools import permutations, product

import numpy as np
import pytest

from impactsim.mesh.topology import (FACE_EDGES, LOCAL_EDGES, LOCAL_FACES, boundary_edges,
                                     boundary_faces, boundary_nodes, face_adjacency, face_keys,
                                     unique_edges)


def kuhn_mesh(nx, ny, nz, seed=None):
    """Unit-spaced grid of nx*ny*nz hexes, each split into 6 positive tets; optionally with the
    elements shuffled and each tet's nodes rotated by an even permutation (orientation kept)."""
    idx = np.arange((nx + 1) * (ny + 1) * (nz + 1)).reshape(nx + 1, ny + 1, nz + 1)
    pts = np.array(list(product(range(nx + 1), range(ny + 1), range(nz + 1))), float)
    tets = []
    for i, j, k in product(range(nx), range(ny), range(nz)):
        for perm in permutations(range(3)):
            c = [i, j, k]
            t = [idx[tuple(c)]]
            for p in perm:
                c = list(c)
                c[p] += 1
                t.append(idx[tuple(c)])
            tets.append(t)
    tets = np.array(tets)
    d = signed_volumes(pts, tets)
    tets[d < 0] = tets[d < 0][:, [0, 2, 1, 3]]
    if seed is not None:
        rng = np.random.default_rng(seed)
        tets = tets[rng.permutation(len(tets))]
        even = np.array([[0, 1, 2, 3], [1, 2, 0, 3], [2, 0, 1, 3], [1, 0, 3, 2]])
        tets = np.take_along_axis(tets, even[rng.integers(0, 4, len(tets))], axis=1)
    return pts, tets.astype(np.int32)


def signed_volumes(x, tets):
    a = x[tets[:, 0]]
    return np.einsum("ij,ij->i", np.cross(x[tets[:, 1]] - a, x[tets[:, 2]] - a),
                     x[tets[:, 3]] - a) / 6.0


def brute_boundary(tets):
    count = Counter(tuple(sorted(t[list(f)])) for t in tets for f in LOCAL_FACES)
    return {k for k, c in count.items() if c == 1}


def test_local_faces_point_outward_and_are_opposite_their_node():
    x = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    centroid = x.mean(axis=0)
    for i, f in enumerate(LOCAL_FACES):
        assert i not in f
        n = np.cross(x[f[1]] - x[f[0]], x[f[2]] - x[f[0]])
        assert n @ (x[f].mean(axis=0) - centroid) > 0
        assert set(LOCAL_EDGES[FACE_EDGES[i]].ravel()) == set(f)


@pytest.mark.parametrize("shape,seed", [((1, 1, 1), None), ((2, 3, 2), 1), ((3, 1, 2), 7)])
def test_boundary_faces_match_brute_force_and_point_outward(shape, seed):
    x, tets = kuhn_mesh(*shape, seed=seed)
    faces, elem, local = boundary_faces(tets)
    assert faces.dtype == np.int32 and elem.dtype == np.int64 and local.dtype == np.int8
    assert {tuple(k) for k in face_keys(faces)} == brute_boundary(tets)
    assert len(faces) == 4 * (shape[0] * shape[1] + shape[1] * shape[2] + shape[0] * shape[2])
    # the face is local face `local` of its owner, and its normal points away from the owner
    np.testing.assert_array_equal(faces, tets[elem[:, None], LOCAL_FACES[local]])
    n = np.cross(x[faces[:, 1]] - x[faces[:, 0]], x[faces[:, 2]] - x[faces[:, 0]])
    out = x[faces].mean(axis=1) - x[tets[elem]].mean(axis=1)
    assert np.all(np.einsum("ij,ij->i", n, out) > 0)
    # and from the body: the outward normal points out of the bounding box
    centre = x.mean(axis=0)
    assert np.all(np.einsum("ij,ij->i", n, x[faces].mean(axis=1) - centre) > 0)


def test_face_adjacency_matches_brute_force():
    x, tets = kuhn_mesh(2, 2, 2, seed=3)
    adj = face_adjacency(tets)
    owners = {}
    for e, t in enumerate(tets):
        for i, f in enumerate(LOCAL_FACES):
            owners.setdefault(tuple(sorted(t[f])), []).append((e, i))
    expected = np.full((len(tets), 4), -1)
    for occ in owners.values():
        if len(occ) == 2:
            (e1, i1), (e2, i2) = occ
            expected[e1, i1] = e2
            expected[e2, i2] = e1
    np.testing.assert_array_equal(adj, expected)
    # local face i of e is opposite node i: the neighbour does not contain that node
    for e, i in zip(*np.nonzero(adj >= 0)):
        assert tets[e, i] not in tets[adj[e, i]]


def test_active_mask_equals_the_submesh():
    x, tets = kuhn_mesh(2, 2, 1, seed=5)
    active = np.ones(len(tets), bool)
    active[[0, 3, 7, 10]] = False
    faces, elem, _ = boundary_faces(tets, active)
    sub = np.flatnonzero(active)
    f2, e2, _ = boundary_faces(tets[sub])
    assert {tuple(k) for k in face_keys(faces)} == {tuple(k) for k in face_keys(f2)}
    assert np.all(active[elem])
    adj = face_adjacency(tets, active)
    assert np.all(adj[~active] == -1) and not np.isin(np.flatnonzero(~active), adj).any()


def test_edges_and_nodes():
    x, tets = kuhn_mesh(2, 1, 1)
    faces, _, _ = boundary_faces(tets)
    edges = boundary_edges(faces)
    brute = {tuple(sorted((f[a], f[b]))) for f in faces for a, b in ((0, 1), (1, 2), (2, 0))}
    assert {tuple(e) for e in edges} == brute and np.all(edges[:, 0] < edges[:, 1])
    assert edges.dtype == np.int32
    np.testing.assert_array_equal(boundary_nodes(faces), np.unique(faces))
    all_edges, elem_edges = unique_edges(tets)
    brute_all = {tuple(sorted(t[list(le)])) for t in tets for le in LOCAL_EDGES}
    assert {tuple(e) for e in all_edges} == brute_all
    np.testing.assert_array_equal(np.sort(all_edges[elem_edges], axis=2),
                                  np.sort(tets[:, LOCAL_EDGES], axis=2))


def test_large_node_numbers_use_the_lexicographic_path():
    x, tets = kuhn_mesh(1, 2, 1, seed=2)
    big = tets.astype(np.int64) * 1_000_003 + (1 << 22)
    f1, e1, l1 = boundary_faces(tets)
    f2, e2, l2 = boundary_faces(big)
    np.testing.assert_array_equal(e1, e2)
    np.testing.assert_array_equal(l1, l2)
    np.testing.assert_array_equal(face_adjacency(tets), face_adjacency(big))


def test_non_manifold_face_is_an_error():
    tets = np.array([[0, 1, 2, 3], [0, 2, 1, 4], [0, 1, 2, 5]])
    with pytest.raises(ValueError, match="non-manifold"):
        face_adjacency(tets)
