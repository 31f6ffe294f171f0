"""Mesh topology of large meshes in linear time: faces and edges in buckets of their least node.

A run asks for the neighbour across every element face five or six times (the estimate's
boundary faces, the contact surface, the fracture boundary, the fragments at the end) and for
the mesh's edges once (the contact surface). With numpy, `topology.face_adjacency`,
`topology.unique_edges` and `fracture.separation.face_adjacency_k` sort one key per face or
edge (O(N log N)): 0.1-0.4 s each for 160,000 tets, more than a second of sphere-plate's setup
(docs/performance.md, "Whole scenes, session 19"). Here each face's (edge's) sorted node tuple
goes into the bucket of its least node by a counting sort, and the twenty to forty tuples of a
bucket are compared with each other: one pass over the faces, about a tenth of the time.

The results are the same arrays as numpy's (a manifold mesh has one adjacency; the edges come
in the same lexicographic order). The callers keep numpy below KERNEL_MIN_ROWS faces or edges,
so that a small case's first run compiles no kernel for them.
"""

from __future__ import annotations

import numba
import numpy as np

KERNEL_MIN_ROWS = 100_000  # element faces (edges) from which the callers use these kernels
NON_MANIFOLD = -1  # `_match`'s return when a face belongs to more than two elements


def match_faces(conn: np.ndarray, faces: np.ndarray, active: np.ndarray | None = None
                ) -> np.ndarray | None:
    """(n, f) int64 neighbour element across each local face (faces: (f, w) local corner
    lists), -1 on the boundary and on inactive elements' rows; None when a face is shared by
    more than two (active) elements."""
    conn = np.ascontiguousarray(conn, dtype=np.int64)
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    n, f = conn.shape[0], faces.shape[0]
    adj = np.full((n, f), -1, np.int64)
    if n == 0:
        return adj
    live = (np.ones(n, np.uint8) if active is None
            else np.ascontiguousarray(active, dtype=np.bool_).view(np.uint8))
    if _match(conn, faces, live, int(conn.max()) + 1, adj) == NON_MANIFOLD:
        return None
    return adj


def unique_edges(conn: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct edges of a mesh (edges: (k, 2) local corner pairs): ((m, 2) int32 with the
    smaller node first, in lexicographic order; (n, k) int64 index of each local edge into
    them), as `topology.unique_edges`."""
    conn = np.ascontiguousarray(conn, dtype=np.int64)
    edges = np.ascontiguousarray(edges, dtype=np.int64)
    n, k = conn.shape[0], edges.shape[0]
    out = np.empty((n * k, 2), np.int32)
    index = np.empty((n, k), np.int64)
    m = _edges(conn, edges, int(conn.max()) + 1 if n else 0, out, index)
    return out[:m].copy(), index


@numba.njit(cache=True, inline="always")
def _bucket(lead, live, per, n_node):
    """Rows in buckets of their lead node (lead[row], rows of element e: e*per .. e*per + per
    - 1, live elements only), each bucket in row order: (start (n_node + 1), rows)."""
    start = np.zeros(n_node + 1, np.int64)
    n = live.shape[0]
    for e in range(n):
        if live[e] != 0:
            for row in range(e * per, e * per + per):
                start[lead[row] + 1] += 1
    for j in range(n_node):
        start[j + 1] += start[j]
    fill = start[:-1].copy()
    rows = np.empty(start[n_node], np.int64)
    for e in range(n):
        if live[e] != 0:
            for row in range(e * per, e * per + per):
                j = lead[row]
                rows[fill[j]] = row
                fill[j] += 1
    return start, rows


@numba.njit(cache=True)
def _match(conn, faces, live, n_node, adj):
    """Fill adj (n, f), all -1 on entry; returns the number of inner faces matched, or
    NON_MANIFOLD."""
    n, f, w = conn.shape[0], faces.shape[0], faces.shape[1]
    keys = np.empty((n * f, w), np.int64)  # each face's nodes in increasing order
    for e in range(n):
        if live[e] == 0:
            continue
        for i in range(f):
            row = e * f + i
            for j in range(w):  # insertion sort of w <= 4 nodes
                node = conn[e, faces[i, j]]
                k = j
                while k > 0 and keys[row, k - 1] > node:
                    keys[row, k] = keys[row, k - 1]
                    k -= 1
                keys[row, k] = node
    start, bucket = _bucket(keys[:, 0], live, f, n_node)
    matched = 0
    for k in range(n_node):
        for p in range(start[k], start[k + 1]):
            a = bucket[p]
            if adj[a // f, a % f] >= 0:
                continue  # matched with an earlier face of the bucket
            for q in range(p + 1, start[k + 1]):
                b = bucket[q]
                same = True
                for j in range(1, w):
                    same &= keys[a, j] == keys[b, j]
                if not same:
                    continue
                if adj[a // f, a % f] >= 0:
                    return NON_MANIFOLD  # a third element with this face
                adj[a // f, a % f] = b // f
                adj[b // f, b % f] = a // f
                matched += 1
    return matched


@numba.njit(cache=True)
def _edges(conn, edges, n_node, out, index):
    """Write the distinct edges into out (in lexicographic order) and each local edge's index
    into index; returns their number."""
    n, k = conn.shape[0], edges.shape[0]
    lo = np.empty(n * k, np.int64)
    hi = np.empty(n * k, np.int64)
    for e in range(n):
        for j in range(k):
            a, b = conn[e, edges[j, 0]], conn[e, edges[j, 1]]
            lo[e * k + j] = min(a, b)
            hi[e * k + j] = max(a, b)
    start, bucket = _bucket(lo, np.ones(n, np.uint8), k, n_node)
    m = 0
    for a in range(n_node):
        s0, s1 = start[a], start[a + 1]
        for p in range(s0 + 1, s1):  # the bucket's rows by their other node (insertion sort)
            row = bucket[p]
            q = p
            while q > s0 and hi[bucket[q - 1]] > hi[row]:
                bucket[q] = bucket[q - 1]
                q -= 1
            bucket[q] = row
        for p in range(s0, s1):
            row = bucket[p]
            if p == s0 or hi[row] != hi[bucket[p - 1]]:
                out[m, 0] = a
                out[m, 1] = hi[row]
                m += 1
            index[row // k, row % k] = m - 1
    return m
