"""Penetration measured independently of the contact passes (history.csv ``max_penetration``).

Two measures at the current positions, from the mesh alone (conn, status, the boundary surface):

- a boundary node of body A inside an alive tet of body B != A: its depth is its distance to the
  boundary surface of B (nearest boundary face of B, searched shell by shell in a hash grid);
- an edge of A's surface crossing a face of B's surface (an edge can cut through a body while
  both its ends stay outside, the case the edge-edge pass exists for [D19]): its depth is the
  smallest of the two endpoint distances to the face's plane and the crossing point's distance to
  the triangle's border (a touching edge gives 0, an edge sliced through a corner of B about the
  depth of the cut).

Both use the spatial hash of the broad phase (no quadratic search). Self-penetration of one body
is not measured.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from impactsim.contact.cubic import det3
from impactsim.contact.broadphase import (SpatialHash, _bucket, _cell, _key, _AXIS_CELLS,
                                          grid_for, swept_boxes)


@numba.njit(cache=True)
def _dot(ax, ay, az, bx, by, bz):
    return ax * bx + ay * by + az * bz


@numba.njit(cache=True)
def point_segment_distance(px, py, pz, ax, ay, az, bx, by, bz):
    """Euclidean distance of point p from segment [a, b]."""
    dx = bx - ax
    dy = by - ay
    dz = bz - az
    dd = dx * dx + dy * dy + dz * dz
    t = 0.0
    if dd > 0.0:
        t = min(max(((px - ax) * dx + (py - ay) * dy + (pz - az) * dz) / dd, 0.0), 1.0)
    qx = ax + t * dx - px
    qy = ay + t * dy - py
    qz = az + t * dz - pz
    return math.sqrt(qx * qx + qy * qy + qz * qz)


@numba.njit(cache=True)
def point_triangle_distance(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """Euclidean distance of point p from triangle (a, b, c): the plane distance when the
    projection falls inside, else the distance to the nearest side."""
    e1x = bx - ax
    e1y = by - ay
    e1z = bz - az
    e2x = cx - ax
    e2y = cy - ay
    e2z = cz - az
    nx = e1y * e2z - e1z * e2y
    ny = e1z * e2x - e1x * e2z
    nz = e1x * e2y - e1y * e2x
    nn = nx * nx + ny * ny + nz * nz
    if nn > 0.0:
        rx = px - ax
        ry = py - ay
        rz = pz - az
        wb = _dot(ry * e2z - rz * e2y, rz * e2x - rx * e2z, rx * e2y - ry * e2x, nx, ny, nz) / nn
        wc = _dot(e1y * rz - e1z * ry, e1z * rx - e1x * rz, e1x * ry - e1y * rx, nx, ny, nz) / nn
        if wb >= 0.0 and wc >= 0.0 and wb + wc <= 1.0:
            return abs(_dot(rx, ry, rz, nx, ny, nz)) / math.sqrt(nn)
    d = point_segment_distance(px, py, pz, ax, ay, az, bx, by, bz)
    d = min(d, point_segment_distance(px, py, pz, bx, by, bz, cx, cy, cz))
    return min(d, point_segment_distance(px, py, pz, cx, cy, cz, ax, ay, az))


@numba.njit(cache=True)
def nearest_face_distance(px, py, pz, body, faces, face_body, x, origin, inv_h, h, tbits,
                          bucket_start, keys, ents, kmax):
    """Distance of p from the nearest boundary face of ``body``: cells searched in shells of
    growing Chebyshev radius k around p's cell until the best distance is <= k h (every face
    closer than that has a cell in the shells seen). inf when the body has no face."""
    cx = _cell(px, origin[0], inv_h)
    cy = _cell(py, origin[1], inv_h)
    cz = _cell(pz, origin[2], inv_h)
    best = np.inf
    for k in range(kmax + 1):
        for ix in range(cx - k, cx + k + 1):
            if ix < 0 or ix >= _AXIS_CELLS:
                continue
            for iy in range(cy - k, cy + k + 1):
                if iy < 0 or iy >= _AXIS_CELLS:
                    continue
                for iz in range(cz - k, cz + k + 1):
                    if iz < 0 or iz >= _AXIS_CELLS:
                        continue
                    if max(abs(ix - cx), abs(iy - cy), abs(iz - cz)) != k:
                        continue
                    key = _key(ix, iy, iz)
                    b = _bucket(key, tbits)
                    for q in range(bucket_start[b], bucket_start[b + 1]):
                        if keys[q] != key:
                            continue
                        f = ents[q]
                        if face_body[f] != body:
                            continue
                        a = faces[f, 0]
                        bb = faces[f, 1]
                        c = faces[f, 2]
                        d = point_triangle_distance(px, py, pz, x[a, 0], x[a, 1], x[a, 2],
                                                    x[bb, 0], x[bb, 1], x[bb, 2],
                                                    x[c, 0], x[c, 1], x[c, 2])
                        if d < best:
                            best = d
        if best <= k * h:
            break
    return best


@numba.njit(cache=True)
def node_in_tet_depths(pairs, nodes, tets, tet_body, x, faces, face_body, origin, inv_h, h,
                       tbits, bucket_start, keys, ents, kmax):
    """For candidate (boundary node, tet of another body) pairs: nodes inside the tet (all
    barycentric coordinates >= 0) get their depth below that body's surface. Returns
    (max depth [m], number of node-in-tet pairs)."""
    deepest = 0.0
    count = 0
    for k in range(pairs.shape[0]):
        p = nodes[pairs[k, 0]]
        t = pairs[k, 1]
        i0 = tets[t, 0]
        ax = x[i0, 0]
        ay = x[i0, 1]
        az = x[i0, 2]
        i1 = tets[t, 1]
        i2 = tets[t, 2]
        i3 = tets[t, 3]
        # columns c_j = x_j - x_0; Cramer's rule for r = l1 c1 + l2 c2 + l3 c3
        c1x = x[i1, 0] - ax
        c1y = x[i1, 1] - ay
        c1z = x[i1, 2] - az
        c2x = x[i2, 0] - ax
        c2y = x[i2, 1] - ay
        c2z = x[i2, 2] - az
        c3x = x[i3, 0] - ax
        c3y = x[i3, 1] - ay
        c3z = x[i3, 2] - az
        rx = x[p, 0] - ax
        ry = x[p, 1] - ay
        rz = x[p, 2] - az
        det = det3(c1x, c1y, c1z, c2x, c2y, c2z, c3x, c3y, c3z)
        if det == 0.0:
            continue
        l1 = det3(rx, ry, rz, c2x, c2y, c2z, c3x, c3y, c3z) / det
        l2 = det3(c1x, c1y, c1z, rx, ry, rz, c3x, c3y, c3z) / det
        l3 = det3(c1x, c1y, c1z, c2x, c2y, c2z, rx, ry, rz) / det
        if l1 < 0.0 or l2 < 0.0 or l3 < 0.0 or l1 + l2 + l3 > 1.0:
            continue
        count += 1
        d = nearest_face_distance(x[p, 0], x[p, 1], x[p, 2], tet_body[t], faces, face_body, x,
                                  origin, inv_h, h, tbits, bucket_start, keys, ents, kmax)
        if d < np.inf and d > deepest:
            deepest = d
    return deepest, count


@numba.njit(cache=True)
def edge_face_cut_depths(pairs, edges, faces, x):
    """For candidate (boundary edge of A, boundary face of B) pairs: edges crossing the triangle.
    Depth = min(endpoint distances to the face's plane, crossing point's distance to the
    triangle's border). Returns (max depth [m], number of crossings)."""
    deepest = 0.0
    count = 0
    for k in range(pairs.shape[0]):
        p = edges[pairs[k, 0], 0]
        q = edges[pairs[k, 0], 1]
        a = faces[pairs[k, 1], 0]
        b = faces[pairs[k, 1], 1]
        c = faces[pairs[k, 1], 2]
        e1x = x[b, 0] - x[a, 0]
        e1y = x[b, 1] - x[a, 1]
        e1z = x[b, 2] - x[a, 2]
        e2x = x[c, 0] - x[a, 0]
        e2y = x[c, 1] - x[a, 1]
        e2z = x[c, 2] - x[a, 2]
        nx = e1y * e2z - e1z * e2y
        ny = e1z * e2x - e1x * e2z
        nz = e1x * e2y - e1y * e2x
        nl = math.sqrt(nx * nx + ny * ny + nz * nz)
        if not nl > 0.0:
            continue
        sp = _dot(x[p, 0] - x[a, 0], x[p, 1] - x[a, 1], x[p, 2] - x[a, 2], nx, ny, nz) / nl
        sq = _dot(x[q, 0] - x[a, 0], x[q, 1] - x[a, 1], x[q, 2] - x[a, 2], nx, ny, nz) / nl
        if (sp > 0.0 and sq > 0.0) or (sp < 0.0 and sq < 0.0) or sp == sq:
            continue
        s = sp / (sp - sq)
        X = x[p, 0] + s * (x[q, 0] - x[p, 0])
        Y = x[p, 1] + s * (x[q, 1] - x[p, 1])
        Z = x[p, 2] + s * (x[q, 2] - x[p, 2])
        rx = X - x[a, 0]
        ry = Y - x[a, 1]
        rz = Z - x[a, 2]
        nn = nl * nl
        wb = _dot(ry * e2z - rz * e2y, rz * e2x - rx * e2z, rx * e2y - ry * e2x, nx, ny, nz) / nn
        wc = _dot(e1y * rz - e1z * ry, e1z * rx - e1x * rz, e1x * ry - e1y * rx, nx, ny, nz) / nn
        if wb < 0.0 or wc < 0.0 or wb + wc > 1.0:
            continue
        count += 1
        d = min(abs(sp), abs(sq))
        d = min(d, point_segment_distance(X, Y, Z, x[a, 0], x[a, 1], x[a, 2],
                                          x[b, 0], x[b, 1], x[b, 2]))
        d = min(d, point_segment_distance(X, Y, Z, x[b, 0], x[b, 1], x[b, 2],
                                          x[c, 0], x[c, 1], x[c, 2]))
        d = min(d, point_segment_distance(X, Y, Z, x[c, 0], x[c, 1], x[c, 2],
                                          x[a, 0], x[a, 1], x[a, 2]))
        if d > deepest:
            deepest = d
    return deepest, count


class PenetrationMeter:
    """Measures penetration between bodies (see the module docstring); owns its hash buffers."""

    def __init__(self):
        self.face_hash = SpatialHash()
        self.tet_hash = SpatialHash()

    def measure(self, x, conn, elem_body, status, surface) -> dict:
        """{"max_penetration" [m], "node_depth" [m], "edge_depth" [m], "nodes_inside",
        "edge_cuts"} at positions x."""
        out = {"max_penetration": 0.0, "node_depth": 0.0, "edge_depth": 0.0,
               "nodes_inside": 0, "edge_cuts": 0}
        if surface.n_faces == 0:
            return out
        x = np.ascontiguousarray(x, dtype=np.float64)
        zero_v = x  # tau = 0: static boxes, the velocity argument is not read
        nodes2 = surface.nodes.reshape(-1, 1)
        nlo = np.empty((surface.n_nodes, 3))
        nhi = np.empty((surface.n_nodes, 3))
        swept_boxes(x, zero_v, 0.0, nodes2, 0.0, nlo, nhi)
        flo = np.empty((surface.n_faces, 3))
        fhi = np.empty((surface.n_faces, 3))
        swept_boxes(x, zero_v, 0.0, surface.faces, 0.0, flo, fhi)
        # alive tets of a body whose box meets the surface nodes' box of another body
        alive = np.flatnonzero(np.asarray(status) != 3) if status is not None else \
            np.arange(conn.shape[0])
        tets = np.ascontiguousarray(conn[alive], dtype=np.int32)
        tet_body = np.ascontiguousarray(elem_body[alive], dtype=np.int32)
        tlo = np.empty((tets.shape[0], 3))
        thi = np.empty((tets.shape[0], 3))
        swept_boxes(x, zero_v, 0.0, tets, 0.0, tlo, thi)
        bodies = np.unique(surface.node_body)
        keep = np.zeros(tets.shape[0], dtype=bool)
        for b in bodies:
            sel = surface.node_body == b
            blo = nlo[sel].min(axis=0)
            bhi = nhi[sel].max(axis=0)
            keep |= (tet_body != b) & np.all(tlo <= bhi, axis=1) & np.all(thi >= blo, axis=1)
        tets, tet_body, tlo, thi = tets[keep], tet_body[keep], tlo[keep], thi[keep]
        h = surface.mean_edge_length(x)
        origin, h = grid_for([(nlo, nhi), (flo, fhi), (tlo, thi)], h)
        self.face_hash.build(flo, fhi, origin, h)
        kmax = int(np.ceil(float((fhi.max(axis=0) - origin).max()) / h)) + 1
        if tets.shape[0]:
            self.tet_hash.build(np.ascontiguousarray(tlo), np.ascontiguousarray(thi), origin, h)
            pairs = self.tet_hash.query(nlo, nhi, nodes2, surface.node_body, tets, tet_body,
                                        False, False)
            fh = self.face_hash
            depth, count = node_in_tet_depths(pairs, surface.nodes, tets, tet_body, x,
                                              surface.faces, surface.face_body, fh.origin,
                                              fh.inv_h, fh.h, fh.tbits, fh.bucket_start, fh.keys,
                                              fh.ents, kmax)
            out["node_depth"] = float(depth)
            out["nodes_inside"] = int(count)
        if surface.n_edges:
            elo = np.empty((surface.n_edges, 3))
            ehi = np.empty((surface.n_edges, 3))
            swept_boxes(x, zero_v, 0.0, surface.edges, 0.0, elo, ehi)
            pairs = self.face_hash.query(elo, ehi, surface.edges, surface.edge_body,
                                         surface.faces, surface.face_body, False, False)
            depth, count = edge_face_cut_depths(pairs, surface.edges, surface.faces, x)
            out["edge_depth"] = float(depth)
            out["edge_cuts"] = int(count)
        out["max_penetration"] = max(out["node_depth"], out["edge_depth"])
        return out


def max_penetration(x, conn, elem_body, status, surface) -> float:
    """Deepest penetration [m] between different bodies at positions x (module docstring)."""
    return PenetrationMeter().measure(x, conn, elem_body, status, surface)["max_penetration"]
