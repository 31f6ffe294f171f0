"""Closest points on triangulated surfaces, and which bodies touch where.

``locate`` finds, for each query point, the nearest point of a set of triangles (a k-d tree of
triangle centroids proposes candidates; the exact point-triangle distance decides), with its
barycentric coordinates. ``detect`` finds the contact patches of two bodies: boundary facets of
each that face the other (opposed normals) within a gap tolerance; any number of disjoint
patches per pair come out as one facet set.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


def _closest_on_triangles(p: np.ndarray, a, b, c):
    """Closest points of triangles (a, b, c each (..., 3)) to points p (..., 3):
    (barycentrics (..., 3), squared distance (...))."""
    e0, e1 = b - a, c - a
    n = np.cross(e0, e1)
    nn = np.einsum("...i,...i", n, n)
    w = p - a
    # barycentrics of the projection on the plane
    l1 = np.einsum("...i,...i", np.cross(w, e1), n) / nn
    l2 = np.einsum("...i,...i", np.cross(e0, w), n) / nn
    l0 = 1 - l1 - l2
    bary = np.stack([l0, l1, l2], axis=-1)
    q = a + l1[..., None] * e0 + l2[..., None] * e1
    d2 = np.einsum("...i,...i", p - q, p - q)
    inside = (l0 >= 0) & (l1 >= 0) & (l2 >= 0)
    best_d2 = np.where(inside, d2, np.inf)
    best = bary.copy()
    verts = (a, b, c)
    for i, j in ((0, 1), (1, 2), (0, 2)):
        s, e = verts[i], verts[j]
        se = e - s
        t = np.clip(np.einsum("...i,...i", p - s, se) / np.einsum("...i,...i", se, se), 0, 1)
        q = s + t[..., None] * se
        d2e = np.einsum("...i,...i", p - q, p - q)
        better = (~inside) & (d2e < best_d2)
        be = np.zeros_like(bary)
        be[..., i] = 1 - t
        be[..., j] = t
        best = np.where(better[..., None], be, best)
        best_d2 = np.where(better, d2e, best_d2)
    return best, best_d2


def locate(points: np.ndarray, triangles: np.ndarray, candidates: int = 8):
    """Nearest point on `triangles` (nf, 3, 3) of each of `points` (n, 3):
    (triangle index (n,), barycentrics (n, 3), distance (n,))."""
    points = np.asarray(points, float)
    nf = len(triangles)
    k = min(candidates, nf)
    tree = cKDTree(triangles.mean(axis=1))
    _, cand = tree.query(points, k=k)
    cand = cand.reshape(len(points), k)
    a, b, c = (triangles[cand, i] for i in range(3))
    bary, d2 = _closest_on_triangles(points[:, None, :], a, b, c)
    j = np.argmin(d2, axis=1)
    rows = np.arange(len(points))
    return cand[rows, j], bary[rows, j], np.sqrt(d2[rows, j])


def detect(xa: np.ndarray, na: np.ndarray, xb: np.ndarray, nb: np.ndarray, tolerance: float):
    """Facets of A (xa (nfa, 3, 3), outward normals na) near B and facets of B near A:
    a facet is in contact when its centroid is within `tolerance` of the other surface (and not
    deeper than `tolerance` inside) with opposed normals (n_a . n_b < -0.5)."""
    return _near(xa, na, xb, nb, tolerance), _near(xb, nb, xa, na, tolerance)


def _near(x, n, xo, no, tolerance):
    """Facets of x near the other surface xo: their centroid is within tolerance of it, or
    a vertex or centroid of a facet of xo that is near x lands on them (a large facet under a
    small face)."""
    own = _centroid_near(x, n, xo, no, tolerance)
    other = _centroid_near(xo, no, x, n, tolerance)
    if not len(other):
        return own
    pts = np.concatenate([xo[other].reshape(-1, 3), xo[other].mean(axis=1)])
    f, bary, d = locate(pts, x)
    proj_inside = bary.min(axis=1) >= -1e-9
    normals = np.concatenate([np.repeat(no[other], 3, axis=0), no[other]])
    opposed = np.einsum("ij,ij->i", n[f], normals) < -0.5
    hit = f[(d <= tolerance) & opposed & proj_inside]
    # and facets of x with a vertex, an edge midpoint or the centroid over xo's near facets
    lo, hi = xo[other].min(axis=(0, 1)) - tolerance, xo[other].max(axis=(0, 1)) + tolerance
    cand = np.nonzero(np.all((x.min(axis=1) <= hi) & (x.max(axis=1) >= lo), axis=1))[0]
    if len(cand):
        xc = x[cand]
        probe = np.concatenate([xc, (xc + np.roll(xc, 1, axis=1)) / 2,
                                xc.mean(axis=1, keepdims=True)], axis=1)  # (m, 7, 3)
        g, bary2, d2 = locate(probe.reshape(-1, 3), xo[other])
        ok = (d2 <= tolerance) & (bary2.min(axis=1) >= -1e-9) & \
            (np.einsum("ij,ij->i", np.repeat(n[cand], 7, axis=0), no[other][g]) < -0.5)
        hit = np.union1d(hit, cand[ok.reshape(-1, 7).any(axis=1)])
    return np.union1d(own, hit)


def _centroid_near(x, n, xo, no, tolerance):
    lo, hi = xo.min(axis=(0, 1)) - tolerance, xo.max(axis=(0, 1)) + tolerance
    cen = x.mean(axis=1)
    box = np.all((cen >= lo) & (cen <= hi), axis=1)
    idx = np.nonzero(box)[0]
    if not len(idx):
        return idx
    f, _, d = locate(cen[idx], xo)
    opposed = np.einsum("ij,ij->i", n[idx], no[f]) < -0.5
    return idx[(d <= tolerance) & opposed]


def boxes_overlap(lo: np.ndarray, hi: np.ndarray, tolerance: float) -> list[tuple[int, int]]:
    """Pairs (i < j) of axis-aligned boxes (n, 3) closer than tolerance (sort and sweep on x)."""
    order = np.argsort(lo[:, 0], kind="stable")
    pairs = []
    for a_pos, i in enumerate(order):
        for j in order[a_pos + 1:]:
            if lo[j, 0] > hi[i, 0] + tolerance:
                break
            if np.all(lo[j] <= hi[i] + tolerance) and np.all(lo[i] <= hi[j] + tolerance):
                pairs.append((min(i, j), max(i, j)))
    return sorted(pairs)
