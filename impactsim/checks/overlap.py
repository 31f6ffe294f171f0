"""Initial interpenetration: bodies starting inside each other or behind a rigid wall.

``wall_penetrations(points, walls)`` and ``body_overlaps(meshes)`` look at the meshed, placed
bodies before the first step. A node of body A lies inside body B when it is inside one of B's
tetrahedra (barycentric coordinates >= -tol); the candidates are the tets whose centroid is
within their largest centroid-to-corner distance of the node (a KD-tree query, so no tet that
could hold the node is missed). Its depth is its distance to B's nearest boundary face plane
among the nearest faces (an estimate, exact for flat faces). Both directions are checked, since
a small body can sit wholly inside a large one without any node of the large one inside it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Overlap:
    what: str  # 'body "a" and body "b"' or 'body "a" and wall[0]'
    depth: float  # [m] deepest node
    nodes: int  # nodes found inside


def wall_penetrations(names, meshes, walls, tol: float) -> list[Overlap]:
    """Bodies with nodes behind a wall plane (point, normal into the allowed side)."""
    out = []
    for w_i, wall in enumerate(walls):
        p, n = np.asarray(wall.point, float), np.asarray(wall.normal, float)
        for name, (points, _) in zip(names, meshes):
            d = (points - p) @ n
            inside = d < -tol
            if inside.any():
                out.append(Overlap(f"body {name!r} and wall[{w_i}]", float(-d.min()),
                                   int(inside.sum())))
    return out


def body_overlaps(names, meshes, tol: float) -> list[Overlap]:
    """Pairs of bodies with nodes of one inside the other (either way round)."""
    boxes = [(pts.min(axis=0), pts.max(axis=0)) for pts, _ in meshes]
    out = []
    for a in range(len(meshes)):
        for b in range(a + 1, len(meshes)):
            (lo_a, hi_a), (lo_b, hi_b) = boxes[a], boxes[b]
            if (np.minimum(hi_a, hi_b) < np.maximum(lo_a, lo_b) - tol).any():
                continue
            depth, count = 0.0, 0
            for i, j in ((a, b), (b, a)):
                d, k = _nodes_inside(meshes[i][0], meshes[j], tol)
                depth, count = max(depth, d), count + k
            if count:
                out.append(Overlap(f"body {names[a]!r} and body {names[b]!r}", depth, count))
    return out


def _nodes_inside(points: np.ndarray, mesh, tol: float) -> tuple[float, int]:
    """(deepest depth, count) of `points` inside the tet mesh `mesh`."""
    from scipy.spatial import cKDTree

    from impactsim.mesh.topology import boundary_faces

    x, tets = mesh
    lo, hi = x.min(axis=0) - tol, x.max(axis=0) + tol
    cand = np.flatnonzero(((points >= lo) & (points <= hi)).all(axis=1))
    if not len(cand):
        return 0.0, 0
    corners = x[tets]  # (e, 4, 3)
    centroid = corners.mean(axis=1)
    reach = float(np.sqrt(((corners - centroid[:, None]) ** 2).sum(axis=2)).max())
    tree = cKDTree(centroid)
    inv = _inverse_edges(corners)
    inside = np.zeros(len(cand), bool)
    for k, near in enumerate(tree.query_ball_point(points[cand], reach)):
        if not near:
            continue
        near = np.asarray(near)
        lam = np.einsum("eij,ej->ei", inv[near], points[cand[k]] - corners[near, 0])
        bary = np.column_stack([1.0 - lam.sum(axis=1), lam])
        # inside or on a face; nodes on B's surface are dropped below by their depth
        if (bary.min(axis=1) >= -1e-12).any():
            inside[k] = True
    hits = cand[inside]
    if not len(hits):
        return 0.0, 0
    faces = boundary_faces(tets)[0]
    fc = x[faces]
    normal = np.cross(fc[:, 1] - fc[:, 0], fc[:, 2] - fc[:, 0])
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    ftree = cKDTree(fc.mean(axis=1))
    _, idx = ftree.query(points[hits], k=min(8, len(faces)))
    idx = np.atleast_2d(idx.reshape(len(hits), -1))
    dist = np.abs(np.einsum("hkj,hkj->hk", points[hits][:, None] - fc[idx, 0], normal[idx]))
    depth = dist.min(axis=1)
    keep = depth > tol
    return (float(depth[keep].max()) if keep.any() else 0.0), int(keep.sum())


def _inverse_edges(corners: np.ndarray) -> np.ndarray:
    """(e, 3, 3) inverses of the edge matrices [x1-x0, x2-x0, x3-x0] (columns)."""
    edges = np.stack([corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0],
                      corners[:, 3] - corners[:, 0]], axis=2)
    return np.linalg.inv(edges)


def initial_overlaps(case, meshes, tol: float | None = None) -> list[Overlap]:
    """Every overlap of the case's meshed bodies with each other and with its walls. `tol`:
    depths below it are contact, not overlap (default 1e-3 of the smallest element length)."""
    from impactsim.mesh.quality import altitudes

    present = [(b.name, m) for b, m in zip(case.bodies, meshes) if m is not None]
    if not present:
        return []
    names, ms = [p[0] for p in present], [p[1] for p in present]
    if tol is None:
        tol = 1e-3 * min(float(altitudes(*m).min()) for m in ms)
    return wall_penetrations(names, ms, case.walls, tol) + body_overlaps(names, ms, tol)
