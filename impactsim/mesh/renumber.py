"""Renumbering for memory locality: drop unused nodes, order nodes and elements along a Z-curve.

Nodes are sorted by the Morton (Z-order) code of their coordinates, elements by the Morton code
of their centroid on the same grid, so that elements next to each other in memory touch nodes
next to each other in memory (the element loop gathers and scatters node data nearby). Both orders
are permutations: the renumbered mesh is the same mesh (same node set, same tets, same volume),
only listed in another order. Ties are broken by the previous index (stable sort), so the result
is deterministic. The node order inside each tet is kept, so orientation is unchanged.
"""

from __future__ import annotations

import numpy as np

MORTON_BITS = 21  # bits per axis: 3 * 21 = 63 bits fit a uint64


def _spread_bits(v: np.ndarray) -> np.ndarray:
    """Insert two zero bits after each of the low 21 bits of v (uint64) -> uint64."""
    v = v & np.uint64(0x1FFFFF)
    v = (v | (v << np.uint64(32))) & np.uint64(0x1F00000000FFFF)
    v = (v | (v << np.uint64(16))) & np.uint64(0x1F0000FF0000FF)
    v = (v | (v << np.uint64(8))) & np.uint64(0x100F00F00F00F00F)
    v = (v | (v << np.uint64(4))) & np.uint64(0x10C30C30C30C30C3)
    v = (v | (v << np.uint64(2))) & np.uint64(0x1249249249249249)
    return v


def morton_codes(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Z-order code of each point x (m, 3) on a 2^21 grid spanning the box [lo, hi]: (m,) uint64."""
    span = np.where(hi > lo, hi - lo, 1.0)
    top = float(2**MORTON_BITS - 1)
    q = np.clip(np.floor((x - lo) / span * top), 0.0, top).astype(np.uint64)
    return _spread_bits(q[:, 0]) | (_spread_bits(q[:, 1]) << np.uint64(1)) | (
        _spread_bits(q[:, 2]) << np.uint64(2))


def remove_unused_nodes(points: np.ndarray, tets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Keep only nodes referenced by some tet (in their previous order); reindex the tets.

    Returns (points (k, 3) float64, tets (e, 4) int32).
    """
    used = np.zeros(len(points), dtype=bool)
    used[tets.ravel()] = True
    new_index = np.cumsum(used) - 1
    return np.ascontiguousarray(points[used], dtype=np.float64), new_index[tets].astype(np.int32)


def morton_order(points: np.ndarray, tets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(node permutation, element permutation): new node i is old node node_perm[i], etc."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    node_perm = np.argsort(morton_codes(points, lo, hi), kind="stable")
    centroids = points[tets].mean(axis=1)
    elem_perm = np.argsort(morton_codes(centroids, lo, hi), kind="stable")
    return node_perm, elem_perm


def renumber(points: np.ndarray, tets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Remove unused nodes, then order nodes and elements along the Z-curve (module docstring).

    points: (n, 3) float64 [m]; tets: (e, 4) integer. Returns (points (k, 3) float64 C-contiguous,
    tets (e, 4) int32 C-contiguous) describing the same mesh.
    """
    points, tets = remove_unused_nodes(points, tets)
    if len(tets) == 0:
        return points, tets
    node_perm, elem_perm = morton_order(points, tets)
    old_to_new = np.empty(len(node_perm), dtype=np.int32)
    old_to_new[node_perm] = np.arange(len(node_perm), dtype=np.int32)
    new_points = np.ascontiguousarray(points[node_perm])
    new_tets = np.ascontiguousarray(old_to_new[tets[elem_perm]], dtype=np.int32)
    return new_points, new_tets
