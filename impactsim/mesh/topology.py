"""Topology of a tetrahedral mesh: faces, face adjacency, boundary surface, edges.

Conventions (used by every caller; contact and erosion rely on them):

- A tet ``(n0, n1, n2, n3)`` is positive when det[x1-x0, x2-x0, x3-x0] > 0.
- Local face ``i`` is the face opposite local node ``i``. Its nodes, in the order that makes the
  right-hand normal point out of a positive tet (``LOCAL_FACES``)::

      face 0: (1, 2, 3)    face 1: (0, 3, 2)    face 2: (0, 1, 3)    face 3: (0, 2, 1)

- Local edges (``LOCAL_EDGES``): 0 (0,1), 1 (0,2), 2 (0,3), 3 (1,2), 4 (1,3), 5 (2,3).
  ``FACE_EDGES[i]`` lists the three local edges of local face ``i``.

Faces are matched by a hash of their sorted node triples (packed into one int64 key when the
node numbers fit in 21 bits, otherwise sorted lexicographically): O(N log N), no Python loops;
from `buckets.KERNEL_MIN_ROWS` element faces (edges) on, `face_adjacency` and `unique_edges`
match them in linear time instead (`buckets.py`).
"""

from __future__ import annotations

import numpy as np

from impactsim.mesh import buckets

LOCAL_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]], dtype=np.int64)
LOCAL_EDGES = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]], dtype=np.int64)
FACE_EDGES = np.array([[3, 4, 5], [1, 2, 5], [0, 2, 4], [0, 1, 3]], dtype=np.int64)

_BITS = 21  # node numbers below 2**21 pack three to an int64 key


def _sorted_keys(rows: np.ndarray) -> np.ndarray:
    """Order-independent sort keys of integer rows (k, w), w = 2 or 3: a permutation that brings
    equal (as sets) rows together, and a boolean 'same as the previous row' per sorted position.
    """
    s = np.sort(rows.astype(np.int64), axis=1)
    if s.size and s.max() < (1 << _BITS):
        key = np.zeros(s.shape[0], dtype=np.int64)
        for j in range(s.shape[1]):
            key = (key << _BITS) | s[:, j]
        order = np.argsort(key, kind="stable")
        ks = key[order]
        same = np.zeros(ks.shape[0], dtype=bool)
        same[1:] = ks[1:] == ks[:-1]
    else:
        order = np.lexsort(s.T[::-1])
        ss = s[order]
        same = np.zeros(ss.shape[0], dtype=bool)
        if ss.shape[0] > 1:
            same[1:] = np.all(ss[1:] == ss[:-1], axis=1)
    return order, same


def all_faces(tets: np.ndarray) -> np.ndarray:
    """(4e, 3) int64 outward-oriented faces of every tet, row ``4*e + i`` = local face i of e."""
    tets = np.asarray(tets)
    return tets[:, LOCAL_FACES].reshape(-1, 3).astype(np.int64)


def face_adjacency(tets: np.ndarray, active: np.ndarray | None = None) -> np.ndarray:
    """(e, 4) int64: the neighbour element across each local face, -1 on the boundary.

    ``active`` (e,) bool restricts the mesh to those elements (inactive rows are all -1 and never
    appear as neighbours). Raises ValueError when a face is shared by more than two elements.
    """
    tets = np.asarray(tets)
    n_elem = tets.shape[0]
    if 4 * n_elem >= buckets.KERNEL_MIN_ROWS:  # linear time (buckets.py)
        adj = buckets.match_faces(tets, LOCAL_FACES, active)
        if adj is None:
            raise ValueError("non-manifold mesh: a face is shared by more than two tetrahedra")
        return adj
    adj = np.full((n_elem, 4), -1, dtype=np.int64)
    if n_elem == 0:
        return adj
    ids = np.arange(4 * n_elem, dtype=np.int64)
    if active is not None:
        ids = ids[np.repeat(np.asarray(active, dtype=bool), 4)]
    faces = all_faces(tets)[ids]
    order, same = _sorted_keys(faces)
    if same.size > 2 and np.any(same[1:] & same[:-1]):
        raise ValueError("non-manifold mesh: a face is shared by more than two tetrahedra")
    second = np.flatnonzero(same)
    a = ids[order[second - 1]]
    b = ids[order[second]]
    adj.reshape(-1)[a] = b // 4
    adj.reshape(-1)[b] = a // 4
    return adj


def boundary_faces(tets: np.ndarray, active: np.ndarray | None = None):
    """Boundary faces of a tet mesh (faces that belong to exactly one active element).

    Returns ``(faces (f,3) int32, owner_elem (f,) int64, owner_local_face (f,) int8)``, ordered by
    ``4*owner_elem + owner_local_face``; face nodes in ``LOCAL_FACES`` order, so the right-hand
    normal points out of the body for positively oriented tets.
    """
    tets = np.asarray(tets)
    adj = face_adjacency(tets, active)
    flag = adj.reshape(-1) < 0
    if active is not None:
        flag &= np.repeat(np.asarray(active, dtype=bool), 4)
    ids = np.flatnonzero(flag)
    elem = ids // 4
    local = ids % 4
    faces = tets[elem[:, None], LOCAL_FACES[local]].astype(np.int32)
    return faces, elem.astype(np.int64), local.astype(np.int8)


def face_keys(faces: np.ndarray) -> np.ndarray:
    """(f, 3) int64 sorted node triples: the orientation-free identity of each face."""
    return np.sort(np.asarray(faces, dtype=np.int64), axis=1)


def unique_edges(tets: np.ndarray):
    """All distinct edges of a tet mesh.

    Returns ``(edges (m,2) int32 with edges[:,0] < edges[:,1], sorted lexicographically,
    elem_edges (e,6) int64 index of each local edge (``LOCAL_EDGES`` order) into edges)``.
    """
    tets = np.asarray(tets)
    n_elem = tets.shape[0]
    if 6 * n_elem >= buckets.KERNEL_MIN_ROWS:  # linear time (buckets.py)
        return buckets.unique_edges(tets, LOCAL_EDGES)
    pairs = tets[:, LOCAL_EDGES].reshape(-1, 2).astype(np.int64)
    pairs.sort(axis=1)
    if pairs.size and pairs.max() < (1 << 31):
        key = (pairs[:, 0] << 31) | pairs[:, 1]
        uniq, inverse = np.unique(key, return_inverse=True)
        edges = np.stack([uniq >> 31, uniq & ((1 << 31) - 1)], axis=1)
    else:
        edges, inverse = np.unique(pairs, axis=0, return_inverse=True)
    return edges.astype(np.int32), inverse.reshape(n_elem, 6).astype(np.int64)


def boundary_edges(faces: np.ndarray) -> np.ndarray:
    """(g, 2) int32 unique edges of a triangle set, each with its smaller node first, sorted."""
    faces = np.asarray(faces, dtype=np.int64)
    if faces.shape[0] == 0:
        return np.zeros((0, 2), dtype=np.int32)
    pairs = faces[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2)
    pairs.sort(axis=1)
    return np.unique(pairs, axis=0).astype(np.int32)


def boundary_nodes(faces: np.ndarray) -> np.ndarray:
    """(h,) int32 sorted unique nodes of a triangle set."""
    return np.unique(np.asarray(faces)).astype(np.int32)
