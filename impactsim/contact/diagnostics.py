"""Penetration measured independently of the contact passes (history.csv ``max_penetration``).

Two measures at the current positions, from the mesh alone (conn, status, the boundary surface):

- a boundary node of body A inside an alive tet of body B != A: its depth is its distance to the
  boundary surface of B (nearest boundary face of B, searched shell by shell in a hash grid);
- an edge of A's surface cutting through B (an edge can cut through a body while both its ends
  stay outside, the case the edge-edge pass exists for [D19]): the crossings of the edge with
  B's faces, ordered along it, give the pieces of the edge inside B; a piece's depth is the
  largest distance to B's surface of three points on it (``edge_cut_depths``: a touching or
  grazing edge gives about 0, an edge sliced through a corner of B about the depth of the cut).

Both use the spatial hash of the broad phase (no quadratic search), on the entities near another
body only; the nearest-face search runs first in a hash of the faces near the points it is asked
about and, for a point deeper than it resolves, in a hash of every boundary face (the same
distance either way: ``PenetrationMeter``). Self-penetration of one body is not measured.
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
from impactsim.contact.surface import ERODED


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
def nodes_in_tets(pairs, tets, nodes, conn, x, inside):
    """Penetration measure, nodes (ALGORITHMS.md 3: no body crosses another).

    For candidate (tet row, node row) pairs, the tet ``conn[tets[i]]`` of one body and the
    boundary node ``nodes[j]`` of another: inside[k] = 1 when the node lies in the tet (all
    barycentric coordinates >= 0). Returns the number of such pairs."""
    count = 0
    for k in range(pairs.shape[0]):
        inside[k] = 0
        t = tets[pairs[k, 0]]
        p = nodes[pairs[k, 1]]
        i0 = conn[t, 0]
        i1 = conn[t, 1]
        i2 = conn[t, 2]
        i3 = conn[t, 3]
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
def _resolved(d, kmax, h, strict):
    """True when a nearest-face search may be taken: always without ``strict``; with it, only a
    search that closed within its kmax shells (d <= kmax h, the test ``nearest_face_distance``
    stops on), which on a hash of the faces near the query points is the exact answer (see
    ``PenetrationMeter``)."""
    return (not strict) or d <= kmax * h


@numba.njit(cache=True)
def inside_node_depths(pairs, inside, tets, elem_body, nodes, x, hfaces, hbody, origin, inv_h, h,
                       tbits, bucket_start, keys, ents, kmax, strict):
    """Penetration measure, nodes (ALGORITHMS.md 3). Depth [m] of the deepest node flagged by
    ``nodes_in_tets``: its distance to the boundary surface of the tet's body (nearest face,
    searched in a face hash: faces ``hfaces``, bodies ``hbody``, the rows its entries name).
    Returns (depth, searches not resolved: see ``_resolved``; none without ``strict``)."""
    deepest = 0.0
    unresolved = 0
    for k in range(pairs.shape[0]):
        if not inside[k]:
            continue
        p = nodes[pairs[k, 1]]
        d = nearest_face_distance(x[p, 0], x[p, 1], x[p, 2], elem_body[tets[pairs[k, 0]]],
                                  hfaces, hbody, x, origin, inv_h, h, tbits, bucket_start, keys,
                                  ents, kmax)
        if not _resolved(d, kmax, h, strict):
            unresolved += 1
            continue
        if d < np.inf and d > deepest:
            deepest = d
    return deepest, unresolved


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
def crossing_pairs(pairs, esel, fsel, edges, faces, x):
    """Penetration measure, edges cutting through faces (ALGORITHMS.md 3.2).

    ``pairs (k, 2)`` of (edge row, face row) of the selections ``esel``, ``fsel``: the pairs
    whose edge crosses the triangle are moved to the front, in order, as (edge, face) indices
    into ``edges``, ``faces``; returns how many."""
    n = 0
    for k in range(pairs.shape[0]):
        g = esel[pairs[k, 0]]
        f = fsel[pairs[k, 1]]
        t, sgn = _crossing(edges[g, 0], edges[g, 1], faces[f, 0], faces[f, 1], faces[f, 2], x)
        if sgn != 0:
            pairs[n, 0] = g
            pairs[n, 1] = f
            n += 1
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
def _segment_depth(p, q, t0, t1, fa, fb, deepest, floor, search, strict, body, faces, x, hfaces,
                   hbody, origin, inv_h, h, tbits, bucket_start, keys, ents, kmax):
    """Penetration measure, edges (ALGORITHMS.md 3.2: edges cutting through faces).

    Largest distance to the surface of ``body`` among points at 1/4, 1/2, 3/4 of the piece
    [t0, t1] of segment p -> q (a piece inside that body, entered through face fa and left
    through face fb, -1 for none), or ``deepest`` if none is deeper.

    The distance to the triangles fa, fb bounds the depth from above: a point whose bound cannot
    beat ``deepest`` is skipped, and a bound below ``floor`` is taken as the depth (an upper
    bound of a negligible depth). Otherwise the face hash (hfaces .. kmax, see
    ``inside_node_depths``) is searched; with ``search`` False (no hash yet) the function only
    reports that a search is needed, with ``strict`` it reports a search not resolved
    (``_resolved``) and leaves that point out. Returns (depth, needed)."""
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
        d = nearest_face_distance(px, py, pz, body, hfaces, hbody, x, origin, inv_h, h, tbits,
                                  bucket_start, keys, ents, kmax)
        if not _resolved(d, kmax, h, strict):
            needed = True
            continue
        if d < np.inf and d > best:
            best = d
    return best, needed


@numba.njit(cache=True)
def edge_cut_depths(pairs, edges, faces, face_body, x, floor, search, strict, hfaces, hbody,
                    origin, inv_h, h, tbits, bucket_start, keys, ents, kmax, ts, signs, fs):
    """Edges of A cutting through the surface of another body B (ALGORITHMS.md 3.2: "without
    it, edges of one body cut through faces of the other").

    ``pairs (k, 2)`` (edge, face) candidates sorted by edge. For each edge and body the crossings
    with B's faces are ordered along the edge; between an entering and the next leaving crossing
    (or an end of the edge) the edge is inside B, and the depth of that piece is the largest
    distance to B's surface of three points on it. A touching or grazing edge gives about 0, an
    edge sliced through a corner of B about the depth of the cut. ``floor``, ``search``,
    ``strict``: see ``_segment_depth`` (the face hash, the arguments hfaces .. kmax, is read only
    with search). ``ts``, ``signs``, ``fs``: scratch arrays (their length caps the crossings
    kept per edge). Returns (max depth [m], crossings, whether a search is needed: without
    ``search``, one to run; with ``strict``, one not resolved)."""
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
                                                   floor, search, strict, body, faces, x, hfaces,
                                                   hbody, origin, inv_h, h, tbits, bucket_start,
                                                   keys, ents, kmax)
                    needed = needed or need
            if inside:
                deepest, need = _segment_depth(p, q, start, 1.0, f_in, -1, deepest, floor,
                                               search, strict, body, faces, x, hfaces, hbody,
                                               origin, inv_h, h, tbits, bucket_start, keys, ents,
                                               kmax)
                needed = needed or need
        k = k_end
    return deepest, count, needed


@numba.njit(cache=True)
def depth_zones(pairs, inside, nodes, node_body, cuts, edges, edge_body, x, pad, zlo, zhi):
    """Where the depth searches of one measure start (penetration measure, ALGORITHMS.md 3):
    per body A, the bounding box (zlo, zhi) (n_body, 3) of its boundary nodes flagged inside
    another body (``pairs``, ``inside`` of ``nodes_in_tets``, node rows ``nodes``, bodies
    ``node_body``) and of its edges in the crossings ``cuts`` (the pieces of an edge lie in the
    edge's box), padded by ``pad``; +inf / -inf for a body with neither."""
    for b in range(zlo.shape[0]):
        for d in range(3):
            zlo[b, d] = np.inf
            zhi[b, d] = -np.inf
    for k in range(pairs.shape[0]):
        if inside[k]:
            j = pairs[k, 1]
            b = node_body[j]
            p = nodes[j]
            for d in range(3):
                zlo[b, d] = min(zlo[b, d], x[p, d])
                zhi[b, d] = max(zhi[b, d], x[p, d])
    for k in range(cuts.shape[0]):
        g = cuts[k, 0]
        b = edge_body[g]
        for e in range(2):
            p = edges[g, e]
            for d in range(3):
                zlo[b, d] = min(zlo[b, d], x[p, d])
                zhi[b, d] = max(zhi[b, d], x[p, d])
    for b in range(zlo.shape[0]):
        if zlo[b, 0] <= zhi[b, 0]:
            for d in range(3):
                zlo[b, d] -= pad
                zhi[b, d] += pad


FLOOR = 1e-4  # cut pieces whose depth bound is below FLOOR x cell size report the bound
ZONE_CELLS = 3  # the zone hash holds the faces within ZONE_CELLS cells of the depth queries; a
#                 search that closes within ZONE_CELLS - 1 shells there is exact (the meter's
#                 docstring), one that does not goes to the hash of every face


class PenetrationMeter:
    """Measures penetration between bodies (see the module docstring); owns its buffers.

    Only entities whose box meets another body's box take part (the rest cannot touch), so on a
    history row the cost follows the size of the contact zone:

    - nodes in tets: the boundary nodes near another body are hashed (one cell each) and the
      alive tets are the queries, only those that meet the box of another body's hashed nodes
      (a tet that holds such a node meets it), so the (tet, node) pairs are the pairs of
      overlapping boxes, the same as with the tets hashed and the nodes as queries;
    - edges through faces: the boundary faces near another body are hashed, the boundary edges
      near another body are the queries;
    - depths: the nearest face of the penetrated body is first searched in a hash of only the
      faces of other bodies that meet, padded by ZONE_CELLS cells h, the box of the points a
      body has inside others (``depth_zones``). A search there that closes within
      ZONE_CELLS - 1 shells (best distance <= (ZONE_CELLS - 1) h) is exact: every face within
      that distance of the point has its box within (ZONE_CELLS - 1) h of the zone and is in
      that hash (the last cell is a margin for round-off), and it has been seen, so the distance
      is the minimum over all faces of the body, the same number the hash of every face gives.
      A search that does not close there (a point deeper than about h) is run again in the hash
      of every boundary face, built only then (``full_searches`` counts those measures).

    Buffers are kept from call to call and grow when they must (no allocation per call once
    they have grown)."""

    def __init__(self):
        self.node_hash = SpatialHash()  # boundary nodes near another body (queried by tets)
        self.cut_hash = SpatialHash()  # boundary faces near another body (queried by edges)
        self.zone_hash = SpatialHash()  # faces near the depth queries
        self.depth_hash = SpatialHash()  # every boundary face, for searches the zone leaves open
        self.full_searches = 0
        self._ts = np.empty(256)
        self._signs = np.empty(256, np.int64)
        self._faces = np.empty(256, np.int64)
        self._buf = {}

    def measure(self, x, conn, elem_body, status, surface) -> dict:
        """{"max_penetration" [m], "node_depth" [m], "edge_depth" [m], "nodes_inside",
        "edge_cuts"} at positions x."""
        out = {"max_penetration": 0.0, "node_depth": 0.0, "edge_depth": 0.0,
               "nodes_inside": 0, "edge_cuts": 0}
        s = surface
        if s.n_faces == 0:
            return out
        x = np.ascontiguousarray(x, dtype=np.float64)
        n_body = int(max(s.node_body.max(), np.max(elem_body)) + 1)
        blo = self._buffer("body.lo", (n_body, 3))
        bhi = self._buffer("body.hi", (n_body, 3))
        if not body_bounds(x, x, 0.0, s.nodes, s.node_body, 0.0, blo, bhi):
            raise FloatingPointError("non-finite position in the penetration measure")
        qsel, qlo, qhi = self._select("node", x, s.nodes.reshape(-1, 1), s.node_body, blo, bhi)
        if qsel.shape[0] == 0:
            return out
        live = blo[:, 0] <= bhi[:, 0]
        h = s.mean_edge_length(x)
        origin, h = grid_from_bounds(blo[live].min(axis=0), bhi[live].max(axis=0), h)
        floor = FLOOR * h
        nodes = self._take("node.id", s.nodes, qsel)
        node_body = self._take("node.body", s.node_body, qsel)
        # boundary nodes inside tets of another body
        pairs, inside, tets, count = self._nodes_in_tets(x, conn, elem_body, status, n_body,
                                                         origin, h, qlo, qhi, nodes, node_body)
        # boundary edges cutting through boundary faces of another body
        cuts = self._cuts(x, s, blo, bhi, origin, h)
        need = False
        if cuts.shape[0]:
            unread = self._grid(self.cut_hash, s.faces, s.face_body, 0)  # not read: no search
            depth, n_cut, need = edge_cut_depths(cuts, s.edges, s.faces, s.face_body, x, floor,
                                                 False, False, *unread, self._ts, self._signs,
                                                 self._faces)
            out["edge_depth"] = float(depth)
            out["edge_cuts"] = int(n_cut)
        if count or need:
            # depths below the other body's surface: nearest boundary face, from the zone hash
            zone = self._zone_hash(x, s, n_body, origin, h, pairs, inside, nodes, node_body,
                                   cuts)
            redo_nodes = redo_edges = False
            if count:
                depth, left = inside_node_depths(pairs, inside, tets, elem_body, nodes, x, *zone,
                                                 True)
                out["node_depth"] = float(depth)
                out["nodes_inside"] = int(count)
                redo_nodes = left > 0
            if need:
                depth, _, redo_edges = edge_cut_depths(cuts, s.edges, s.faces, s.face_body, x,
                                                       floor, True, True, *zone, self._ts,
                                                       self._signs, self._faces)
                out["edge_depth"] = float(depth)
            if redo_nodes or redo_edges:
                self.full_searches += 1
                full = self._full_hash(x, s, origin, h)
                if redo_nodes:
                    out["node_depth"] = float(inside_node_depths(
                        pairs, inside, tets, elem_body, nodes, x, *full, False)[0])
                if redo_edges:
                    out["edge_depth"] = float(edge_cut_depths(
                        cuts, s.edges, s.faces, s.face_body, x, floor, True, False, *full,
                        self._ts, self._signs, self._faces)[0])
        out["max_penetration"] = max(out["node_depth"], out["edge_depth"])
        return out

    def _nodes_in_tets(self, x, conn, elem_body, status, n_body, origin, h, qlo, qhi, nodes,
                       node_body):
        """(pairs (tet row, node row), inside flags, tets (rows -> conn), count): the boundary
        nodes ``nodes`` (boxes qlo, qhi) tested against the alive tets that can hold one."""
        nlo = self._buffer("node.body.lo", (n_body, 3))
        nhi = self._buffer("node.body.hi", (n_body, 3))
        body_bounds(x, x, 0.0, nodes, node_body, 0.0, nlo, nhi)
        skip = _NO_SKIP
        if status is not None:
            eroded = self._buffer("tet.eroded", conn.shape[0], np.bool_)
            np.equal(status, ERODED, out=eroded)
            skip = eroded.view(np.uint8)
        tets, tlo, thi = self._select("tet", x, conn, elem_body, nlo, nhi, skip)
        if tets.shape[0] == 0:
            return _NO_PAIRS, _NO_FLAGS, tets, 0
        self.node_hash.build(qlo, qhi, origin, h)
        pairs = self.node_hash.query(tlo, thi, _NO_ROWS, self._take("tet.body", elem_body, tets),
                                     _NO_ROWS, node_body, False, False)
        inside = self._buffer("tet.inside", pairs.shape[0], np.uint8)
        count = nodes_in_tets(pairs, tets, nodes, conn, x, inside)
        return pairs, inside, tets, count

    def _cuts(self, x, s, blo, bhi, origin, h):
        """(edge, face) pairs (k, 2), sorted, of boundary edges crossing boundary faces of
        another body (a view of the cut hash's pair buffer)."""
        fsel, flo, fhi = self._select("face", x, s.faces, s.face_body, blo, bhi)
        esel, elo, ehi = self._select("edge", x, s.edges, s.edge_body, blo, bhi)
        if fsel.shape[0] == 0 or esel.shape[0] == 0:
            return _NO_PAIRS
        self.cut_hash.build(flo, fhi, origin, h)
        pairs = self.cut_hash.query(elo, ehi, _NO_ROWS, self._take("edge.body", s.edge_body, esel),
                                    _NO_ROWS, self._take("face.body", s.face_body, fsel), False,
                                    False)
        return pairs[:crossing_pairs(pairs, esel, fsel, s.edges, s.faces, x)]

    def _zone_hash(self, x, s, n_body, origin, h, pairs, inside, nodes, node_body, cuts):
        """The zone hash (class docstring) as the face-hash arguments of the depth kernels."""
        zlo = self._buffer("zone.body.lo", (n_body, 3))
        zhi = self._buffer("zone.body.hi", (n_body, 3))
        depth_zones(pairs, inside, nodes, node_body, cuts, s.edges, s.edge_body, x,
                    ZONE_CELLS * h, zlo, zhi)
        zsel, flo, fhi = self._select("zone", x, s.faces, s.face_body, zlo, zhi)
        self.zone_hash.build(flo, fhi, origin, h)
        return self._grid(self.zone_hash, self._take("zone.faces", s.faces, zsel),
                          self._take("zone.body", s.face_body, zsel), ZONE_CELLS - 1)

    def _full_hash(self, x, s, origin, h):
        """The hash of every boundary face as the face-hash arguments of the depth kernels."""
        alo = self._buffer("all.lo", (s.n_faces, 3))
        ahi = self._buffer("all.hi", (s.n_faces, 3))
        swept_boxes(x, x, 0.0, s.faces, 0.0, alo, ahi)
        self.depth_hash.build(alo, ahi, origin, h)
        kmax = int(np.ceil(float((ahi.max(axis=0) - origin).max()) / h)) + 1
        return self._grid(self.depth_hash, s.faces, s.face_body, kmax)

    @staticmethod
    def _grid(fh, hfaces, hbody, kmax):
        return (hfaces, hbody, fh.origin, fh.inv_h, fh.h, fh.tbits, fh.bucket_start, fh.keys,
                fh.ents, kmax)

    def _select(self, name, x, ent, body, blo, bhi, skip=None):
        """Rows of ent whose (static) box meets another body's box (blo, bhi), with their boxes
        (``broadphase.select_boxes``; rows with skip != 0 left out)."""
        n = ent.shape[0]
        sel = self._buffer(name + ".sel", n, np.int64)
        lo = self._buffer(name + ".lo", (n, 3))
        hi = self._buffer(name + ".hi", (n, 3))
        k = select_boxes(x, x, 0.0, ent, 0.0, body, blo, bhi, False,
                         _NO_SKIP if skip is None else skip, sel, lo, hi)
        return sel[:k], lo[:k], hi[:k]

    def _take(self, name, a, idx):
        """a[idx] (rows) in a buffer of this meter."""
        out = self._buffer(name, (idx.shape[0],) + a.shape[1:], a.dtype)
        np.take(a, idx, axis=0, out=out)
        return out

    def _buffer(self, name, shape, dtype=np.float64):
        """A reusable scratch array (contents undefined), reallocated only when it must grow
        (to half as large again)."""
        shape = shape if isinstance(shape, tuple) else (shape,)
        b = self._buf.get(name)
        if b is None or b.shape[0] < shape[0] or b.shape[1:] != shape[1:] \
                or b.dtype != np.dtype(dtype):
            b = np.empty((max(int(1.5 * shape[0]), 16),) + shape[1:], dtype=dtype)
            self._buf[name] = b
        return b[:shape[0]]


_NO_SKIP = np.zeros(0, np.uint8)
_NO_FLAGS = np.zeros(0, np.uint8)
_NO_PAIRS = np.zeros((0, 2), np.int64)
_NO_ROWS = np.zeros((0, 1), np.int32)  # entity rows the hash query reads only for self-contact


def max_penetration(x, conn, elem_body, status, surface) -> float:
    """Deepest penetration [m] between different bodies at positions x (module docstring)."""
    return PenetrationMeter().measure(x, conn, elem_body, status, surface)["max_penetration"]
