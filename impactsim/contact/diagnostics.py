"""Penetration measured independently of the contact passes (history.csv ``max_penetration``).

Two measures at the current positions, from the mesh alone (conn, status, the boundary surface):

- a boundary node of body A inside an alive tet of body B != A: its depth is its distance to the
  boundary surface of B (nearest boundary face of B, searched shell by shell in a hash grid);
- an edge of A's surface cutting through B (an edge can cut through a body while both its ends
  stay outside, the case the edge-edge pass exists for [D19]): the crossings of the edge with
  B's faces, ordered along it, give the pieces of the edge inside B; a piece's depth is the
  largest distance to B's surface of three points on it (``edge_cut_depths``: a touching or
  grazing edge gives about 0, an edge sliced through a corner of B about the depth of the cut).

Both use the spatial hash of the broad phase (no quadratic search). Self-penetration of one body
is not measured.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from impactsim.contact.broadphase import (_AXIS_CELLS, SpatialHash, _bucket, _cell, _key,
                                          body_bounds, grid_from_bounds, select_boxes,
                                          swept_boxes)
from impactsim.contact.cubic import det3
from impactsim.contact.geometry import barycentric_numerators, triangle_normal


@numba.njit(cache=True)
def _dot(ax, ay, az, bx, by, bz):
    """a . b (geometry of the penetration measure, ALGORITHMS.md 3: bodies never interpenetrate)."""
    return ax * bx + ay * by + az * bz


@numba.njit(cache=True)
def point_segment_distance(px, py, pz, ax, ay, az, bx, by, bz):
    """Euclidean distance of point p from segment [a, b] (penetration measure, ALGORITHMS.md 3)."""
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
    projection falls inside, else the distance to the nearest side (penetration measure,
    ALGORITHMS.md 3)."""
    e1x, e1y, e1z, e2x, e2y, e2z, nx, ny, nz, nn = triangle_normal(ax, ay, az, bx, by, bz, cx,
                                                                   cy, cz)
    if nn > 0.0:
        rx = px - ax
        ry = py - ay
        rz = pz - az
        sb, sc = barycentric_numerators(rx, ry, rz, e1x, e1y, e1z, e2x, e2y, e2z, nx, ny, nz)
        wb = sb / nn
        wc = sc / nn
        if wb >= 0.0 and wc >= 0.0 and wb + wc <= 1.0:
            return abs(_dot(rx, ry, rz, nx, ny, nz)) / math.sqrt(nn)
    d = point_segment_distance(px, py, pz, ax, ay, az, bx, by, bz)
    d = min(d, point_segment_distance(px, py, pz, bx, by, bz, cx, cy, cz))
    return min(d, point_segment_distance(px, py, pz, cx, cy, cz, ax, ay, az))


@numba.njit(cache=True)
def nearest_face_distance(px, py, pz, body, faces, face_body, x, origin, inv_h, h, tbits,
                          bucket_start, keys, ents, kmax):
    """Depth of a penetrating point (ALGORITHMS.md 3: no body crosses another).

    Distance of p from the nearest boundary face of ``body``: cells searched in shells of
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
                        if keys[q] >> 3 != key:  # (the low 3 bits: first-cell flags)
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
def nodes_in_tets(pairs, nodes, tets, x, inside):
    """Penetration measure, nodes (ALGORITHMS.md 3: no body crosses another).

    For candidate (boundary node, tet of another body) pairs: inside[k] = 1 when the node lies
    in the tet (all barycentric coordinates >= 0). Returns the number of such pairs."""
    count = 0
    for k in range(pairs.shape[0]):
        inside[k] = 0
        p = nodes[pairs[k, 0]]
        t = pairs[k, 1]
        i0 = tets[t, 0]
        i1 = tets[t, 1]
        i2 = tets[t, 2]
        i3 = tets[t, 3]
        ax = x[i0, 0]
        ay = x[i0, 1]
        az = x[i0, 2]
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
        inside[k] = 1
        count += 1
    return count


@numba.njit(cache=True)
def inside_node_depths(pairs, inside, nodes, tet_body, x, faces, face_body, origin, inv_h, h,
                       tbits, bucket_start, keys, ents, kmax):
    """Penetration measure, nodes (ALGORITHMS.md 3). Depth [m] of the deepest node flagged by
    ``nodes_in_tets``: its distance to the boundary
    surface of the tet's body (nearest face, searched in the face hash)."""
    deepest = 0.0
    for k in range(pairs.shape[0]):
        if not inside[k]:
            continue
        p = nodes[pairs[k, 0]]
        d = nearest_face_distance(x[p, 0], x[p, 1], x[p, 2], tet_body[pairs[k, 1]], faces,
                                  face_body, x, origin, inv_h, h, tbits, bucket_start, keys,
                                  ents, kmax)
        if d < np.inf and d > deepest:
            deepest = d
    return deepest


@numba.njit(cache=True)
def _crossing(p, q, a, b, c, x):
    """Penetration measure, edges (ALGORITHMS.md 3.2: edges cutting through faces).

    Parameter t in [0, 1] along p -> q where the segment crosses triangle (a, b, c), and +1
    when it enters the body behind the face (outward normal (b - a) x (c - a)), -1 when it
    leaves; (-1.0, 0) when it does not cross the triangle."""
    e1x, e1y, e1z, e2x, e2y, e2z, nx, ny, nz, nn = triangle_normal(
        x[a, 0], x[a, 1], x[a, 2], x[b, 0], x[b, 1], x[b, 2], x[c, 0], x[c, 1], x[c, 2])
    if not nn > 0.0:
        return -1.0, 0
    sp = _dot(x[p, 0] - x[a, 0], x[p, 1] - x[a, 1], x[p, 2] - x[a, 2], nx, ny, nz)
    sq = _dot(x[q, 0] - x[a, 0], x[q, 1] - x[a, 1], x[q, 2] - x[a, 2], nx, ny, nz)
    if (sp >= 0.0 and sq >= 0.0) or (sp <= 0.0 and sq <= 0.0):
        return -1.0, 0
    t = sp / (sp - sq)
    sb, sc = barycentric_numerators(
        x[p, 0] + t * (x[q, 0] - x[p, 0]) - x[a, 0], x[p, 1] + t * (x[q, 1] - x[p, 1]) - x[a, 1],
        x[p, 2] + t * (x[q, 2] - x[p, 2]) - x[a, 2], e1x, e1y, e1z, e2x, e2y, e2z, nx, ny, nz)
    wb = sb / nn
    wc = sc / nn
    if wb < 0.0 or wc < 0.0 or wb + wc > 1.0:
        return -1.0, 0
    return t, (1 if sp > 0.0 else -1)


@numba.njit(cache=True)
def crossing_pairs(pairs, edges, faces, x, keep):
    """keep[k] = 1 for the (edge, face) pairs whose edge crosses the triangle; returns how many
    (penetration measure, edges cutting through faces: ALGORITHMS.md 3.2)."""
    n = 0
    for k in range(pairs.shape[0]):
        f = pairs[k, 1]
        t, sgn = _crossing(edges[pairs[k, 0], 0], edges[pairs[k, 0], 1], faces[f, 0],
                           faces[f, 1], faces[f, 2], x)
        keep[k] = 1 if sgn != 0 else 0
        n += keep[k]
    return n


@numba.njit(cache=True)
def _tri_distance(px, py, pz, f, faces, x):
    """Distance of p from boundary face f (penetration measure, ALGORITHMS.md 3)."""
    a = faces[f, 0]
    b = faces[f, 1]
    c = faces[f, 2]
    return point_triangle_distance(px, py, pz, x[a, 0], x[a, 1], x[a, 2], x[b, 0], x[b, 1],
                                   x[b, 2], x[c, 0], x[c, 1], x[c, 2])


@numba.njit(cache=True)
def _segment_depth(p, q, t0, t1, fa, fb, deepest, floor, search, body, faces, face_body, x,
                   origin, inv_h, h, tbits, bucket_start, keys, ents, kmax):
    """Penetration measure, edges (ALGORITHMS.md 3.2: edges cutting through faces).

    Largest distance to the surface of ``body`` among points at 1/4, 1/2, 3/4 of the piece
    [t0, t1] of segment p -> q (a piece inside that body, entered through face fa and left
    through face fb, -1 for none), or ``deepest`` if none is deeper.

    The distance to the triangles fa, fb bounds the depth from above: a point whose bound cannot
    beat ``deepest`` is skipped, and a bound below ``floor`` is taken as the depth (an upper
    bound of a negligible depth). Otherwise the face hash is searched; with ``search`` False
    (no hash yet) the function only reports that a search is needed. Returns (depth, needed)."""
    best = deepest
    needed = False
    for j in range(1, 4):
        t = t0 + 0.25 * j * (t1 - t0)
        px = x[p, 0] + t * (x[q, 0] - x[p, 0])
        py = x[p, 1] + t * (x[q, 1] - x[p, 1])
        pz = x[p, 2] + t * (x[q, 2] - x[p, 2])
        bound = np.inf
        if fa >= 0:
            bound = _tri_distance(px, py, pz, fa, faces, x)
        if fb >= 0:
            bound = min(bound, _tri_distance(px, py, pz, fb, faces, x))
        if bound <= best:
            continue
        if bound <= floor:
            best = bound
            continue
        if not search:
            needed = True
            continue
        d = nearest_face_distance(px, py, pz, body, faces, face_body, x, origin, inv_h, h, tbits,
                                  bucket_start, keys, ents, kmax)
        if d < np.inf and d > best:
            best = d
    return best, needed


@numba.njit(cache=True)
def edge_cut_depths(pairs, edges, faces, face_body, x, floor, search, origin, inv_h, h, tbits,
                    bucket_start, keys, ents, kmax, ts, signs, fs):
    """Edges of A cutting through the surface of another body B (ALGORITHMS.md 3.2: "without
    it, edges of one body cut through faces of the other").

    ``pairs (k, 2)`` (edge, face) candidates sorted by edge. For each edge and body the crossings
    with B's faces are ordered along the edge; between an entering and the next leaving crossing
    (or an end of the edge) the edge is inside B, and the depth of that piece is the largest
    distance to B's surface of three points on it. A touching or grazing edge gives about 0, an
    edge sliced through a corner of B about the depth of the cut. ``floor``, ``search``: see
    ``_segment_depth`` (the face hash, the arguments origin .. kmax, is read only with search).
    ``ts``, ``signs``, ``fs``: scratch arrays (their length caps the crossings kept per edge).
    Returns (max depth [m], crossings, whether a search is needed)."""
    deepest = 0.0
    count = 0
    needed = False
    k = 0
    cap = ts.shape[0]
    while k < pairs.shape[0]:
        g = pairs[k, 0]
        k_end = k
        while k_end < pairs.shape[0] and pairs[k_end, 0] == g:
            k_end += 1
        p = edges[g, 0]
        q = edges[g, 1]
        # bodies met by this edge, one at a time
        for k_body in range(k, k_end):
            body = face_body[pairs[k_body, 1]]
            first = True
            for j in range(k, k_body):
                if face_body[pairs[j, 1]] == body:
                    first = False
                    break
            if not first:
                continue
            n = 0
            for j in range(k, k_end):
                f = pairs[j, 1]
                if face_body[f] != body:
                    continue
                t, sgn = _crossing(p, q, faces[f, 0], faces[f, 1], faces[f, 2], x)
                if sgn == 0 or n >= cap:
                    continue
                count += 1
                # insertion into the sorted list
                i = n
                while i > 0 and ts[i - 1] > t:
                    ts[i] = ts[i - 1]
                    signs[i] = signs[i - 1]
                    fs[i] = fs[i - 1]
                    i -= 1
                ts[i] = t
                signs[i] = sgn
                fs[i] = f
                n += 1
            if n == 0:
                continue
            inside = signs[0] < 0  # the first crossing leaves B: the edge starts inside
            start = 0.0
            f_in = -1
            for i in range(n):
                if signs[i] > 0 and not inside:
                    inside = True
                    start = ts[i]
                    f_in = fs[i]
                elif signs[i] < 0 and inside:
                    inside = False
                    deepest, need = _segment_depth(p, q, start, ts[i], f_in, fs[i], deepest,
                                                   floor, search, body, faces, face_body, x,
                                                   origin, inv_h, h, tbits, bucket_start, keys,
                                                   ents, kmax)
                    needed = needed or need
            if inside:
                deepest, need = _segment_depth(p, q, start, 1.0, f_in, -1, deepest, floor,
                                               search, body, faces, face_body, x, origin, inv_h,
                                               h, tbits, bucket_start, keys, ents, kmax)
                needed = needed or need
        k = k_end
    return deepest, count, needed


FLOOR = 1e-4  # cut pieces whose depth bound is below FLOOR x cell size report the bound


class PenetrationMeter:
    """Measures penetration between bodies (see the module docstring); owns its buffers.

    Only entities whose box meets another body's box take part (the rest cannot touch), so on a
    history row the cost follows the size of the contact zone."""

    def __init__(self):
        self.depth_hash = SpatialHash()
        self.cut_hash = SpatialHash()
        self.tet_hash = SpatialHash()
        self._ts = np.empty(256)
        self._signs = np.empty(256, np.int64)
        self._faces = np.empty(256, np.int64)

    def measure(self, x, conn, elem_body, status, surface) -> dict:
        """{"max_penetration" [m], "node_depth" [m], "edge_depth" [m], "nodes_inside",
        "edge_cuts"} at positions x."""
        out = {"max_penetration": 0.0, "node_depth": 0.0, "edge_depth": 0.0,
               "nodes_inside": 0, "edge_cuts": 0}
        if surface.n_faces == 0:
            return out
        x = np.ascontiguousarray(x, dtype=np.float64)
        n_body = int(max(surface.node_body.max(), np.max(elem_body)) + 1)
        blo = np.empty((n_body, 3))
        bhi = np.empty((n_body, 3))
        if not body_bounds(x, x, 0.0, surface.nodes, surface.node_body, 0.0, blo, bhi):
            raise FloatingPointError("non-finite position in the penetration measure")
        nodes2 = surface.nodes.reshape(-1, 1)
        qsel, qlo, qhi = _select(x, nodes2, surface.node_body, blo, bhi)
        if qsel.shape[0] == 0:
            return out
        live = blo[:, 0] <= bhi[:, 0]
        h = surface.mean_edge_length(x)
        origin, h = grid_from_bounds(blo[live].min(axis=0), bhi[live].max(axis=0), h)
        # boundary nodes inside tets of another body
        skip = (np.asarray(status) == 3).view(np.uint8) if status is not None else _NO_SKIP
        tsel, tlo, thi = _select(x, conn, elem_body, blo, bhi, skip)
        count, pairs, inside, nodes_q = 0, None, None, surface.nodes[qsel]
        if tsel.shape[0]:
            tets = np.ascontiguousarray(conn[tsel], dtype=np.int32)
            tet_body = np.ascontiguousarray(elem_body[tsel], dtype=np.int32)
            self.tet_hash.build(tlo, thi, origin, h)
            pairs = self.tet_hash.query(qlo, qhi, nodes2[qsel], surface.node_body[qsel], tets,
                                        tet_body, False, False)
            inside = np.zeros(pairs.shape[0], np.uint8)
            count = nodes_in_tets(pairs, nodes_q, tets, x, inside)
        # boundary edges cutting through boundary faces of another body
        cut_pairs = np.zeros((0, 2), np.int64)
        fsel, flo, fhi = _select(x, surface.faces, surface.face_body, blo, bhi)
        esel, elo, ehi = _select(x, surface.edges, surface.edge_body, blo, bhi)
        if fsel.shape[0] and esel.shape[0]:
            self.cut_hash.build(flo, fhi, origin, h)
            cut_pairs = self.cut_hash.query(elo, ehi, surface.edges[esel],
                                            surface.edge_body[esel], surface.faces[fsel],
                                            surface.face_body[fsel], False, False)
            cut_pairs[:, 0] = esel[cut_pairs[:, 0]]
            cut_pairs[:, 1] = fsel[cut_pairs[:, 1]]
            keep = np.empty(cut_pairs.shape[0], np.uint8)
            if crossing_pairs(cut_pairs, surface.edges, surface.faces, x, keep):
                cut_pairs = cut_pairs[keep.view(bool)]
            else:
                cut_pairs = cut_pairs[:0]
        floor = FLOOR * h
        need = False
        if cut_pairs.shape[0]:
            ch = self.cut_hash  # a valid grid to pass; not read without search
            grid = (ch.origin, ch.inv_h, ch.h, ch.tbits, ch.bucket_start, ch.keys, ch.ents, 0)
            depth, n_cut, need = edge_cut_depths(cut_pairs, surface.edges, surface.faces,
                                                 surface.face_body, x, floor, False, *grid,
                                                 self._ts, self._signs, self._faces)
            out["edge_depth"] = float(depth)
            out["edge_cuts"] = int(n_cut)
        if count or need:
            # depths below the other body's surface: nearest boundary face, from a hash of all
            alo = np.empty((surface.n_faces, 3))
            ahi = np.empty((surface.n_faces, 3))
            swept_boxes(x, x, 0.0, surface.faces, 0.0, alo, ahi)
            fh = self.depth_hash
            fh.build(alo, ahi, origin, h)
            kmax = int(np.ceil(float((ahi.max(axis=0) - origin).max()) / h)) + 1
            grid = (fh.origin, fh.inv_h, fh.h, fh.tbits, fh.bucket_start, fh.keys, fh.ents, kmax)
            if count:
                out["node_depth"] = float(inside_node_depths(
                    pairs, inside, nodes_q, tet_body, x, surface.faces, surface.face_body,
                    *grid))
                out["nodes_inside"] = int(count)
            if need:
                depth, n_cut, _ = edge_cut_depths(cut_pairs, surface.edges, surface.faces,
                                                  surface.face_body, x, floor, True, *grid,
                                                  self._ts, self._signs, self._faces)
                out["edge_depth"] = float(depth)
        out["max_penetration"] = max(out["node_depth"], out["edge_depth"])
        return out


_NO_SKIP = np.zeros(0, np.uint8)


def _select(x, ent, body, blo, bhi, skip=_NO_SKIP):
    """Rows of ent whose (static) box meets another body's box, with their boxes."""
    n = ent.shape[0]
    sel = np.empty(n, np.int64)
    lo = np.empty((n, 3))
    hi = np.empty((n, 3))
    k = select_boxes(x, x, 0.0, ent, 0.0, body, blo, bhi, False, skip, sel, lo, hi)
    return sel[:k], lo[:k], hi[:k]


def max_penetration(x, conn, elem_body, status, surface) -> float:
    """Deepest penetration [m] between different bodies at positions x (module docstring)."""
    return PenetrationMeter().measure(x, conn, elem_body, status, surface)["max_penetration"]
