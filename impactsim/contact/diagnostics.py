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
body only, with candidate pairs kept from row to row while nodes move less than a skin; the
nearest-face search runs first in a hash of the faces near another body and, for a point deeper
than that resolves, in a hash of every boundary face (the same pairs and the same distances as a
search afresh: ``PenetrationMeter``). Self-penetration of one body is not measured.
"""

from __future__ import annotations

import math
from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor
from concurrent.futures import wait as futures_wait

import numba
import numpy as np

from impactsim.background import background_thread
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
    growing Chebyshev radius k around p's cell until every face closer than the best distance
    has a cell in the shells seen: the best distance is <= k h, or below the distance from p to
    the boundary of the block of cells seen (less 1e-6 h for the round-off of the cell
    boundaries), which usually ends a shallow point's search after its own cell instead of 27.
    inf when the body has no face."""
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
        m = min(px - (origin[0] + (cx - k) * h), origin[0] + (cx + k + 1) * h - px,
                py - (origin[1] + (cy - k) * h), origin[1] + (cy + k + 1) * h - py,
                pz - (origin[2] + (cz - k) * h), origin[2] + (cz + k + 1) * h - pz)
        if best < m - 1e-6 * h:
            break
    return best


@numba.njit(cache=True, nogil=True)
def nodes_in_tets(cand, near, nodes, conn, status, eroded, x, inside):
    """Penetration measure, nodes (ALGORITHMS.md 3: no body crosses another).

    ``cand (m, 2)`` (tet, boundary node row) candidates, a tet of one body and the node
    ``nodes[j]`` of another. A candidate is a pair of the broad phase when the tet is alive
    (``status`` != ``eroded``; an empty status: all alive), the node is near another body
    (``near[j]``) and the tet's box holds the node; its node is inside when it lies in the tet
    (all barycentric coordinates >= 0). Writes those (tet, row) pairs to ``inside``, in order,
    and returns how many."""
    n = 0
    some_eroded = status.shape[0] > 0
    for k in range(cand.shape[0]):
        t = cand[k, 0]
        j = cand[k, 1]
        if not near[j] or (some_eroded and status[t] == eroded):
            continue
        p = nodes[j]
        i0 = conn[t, 0]
        i1 = conn[t, 1]
        i2 = conn[t, 2]
        i3 = conn[t, 3]
        px = x[p, 0]
        py = x[p, 1]
        pz = x[p, 2]
        if not (min(x[i0, 0], x[i1, 0], x[i2, 0], x[i3, 0]) <= px
                <= max(x[i0, 0], x[i1, 0], x[i2, 0], x[i3, 0])
                and min(x[i0, 1], x[i1, 1], x[i2, 1], x[i3, 1]) <= py
                <= max(x[i0, 1], x[i1, 1], x[i2, 1], x[i3, 1])
                and min(x[i0, 2], x[i1, 2], x[i2, 2], x[i3, 2]) <= pz
                <= max(x[i0, 2], x[i1, 2], x[i2, 2], x[i3, 2])):
            continue
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
        rx = px - ax
        ry = py - ay
        rz = pz - az
        det = det3(c1x, c1y, c1z, c2x, c2y, c2z, c3x, c3y, c3z)
        if det == 0.0:
            continue
        l1 = det3(rx, ry, rz, c2x, c2y, c2z, c3x, c3y, c3z) / det
        l2 = det3(c1x, c1y, c1z, rx, ry, rz, c3x, c3y, c3z) / det
        l3 = det3(c1x, c1y, c1z, c2x, c2y, c2z, rx, ry, rz) / det
        if l1 < 0.0 or l2 < 0.0 or l3 < 0.0 or l1 + l2 + l3 > 1.0:
            continue
        inside[n, 0] = t
        inside[n, 1] = j
        n += 1
    return n


@numba.njit(cache=True)
def _resolved(d, kmax, h, strict):
    """True when a nearest-face search may be taken: always without ``strict``; with it, only a
    search that closed within its kmax shells (d <= kmax h, the test ``nearest_face_distance``
    stops on), which on a hash of the faces near the query points is the exact answer (see
    ``PenetrationMeter``)."""
    return (not strict) or d <= kmax * h


@numba.njit(cache=True, nogil=True)
def inside_node_depths(inside, elem_body, nodes, x, hfaces, hbody, origin, inv_h, h, tbits,
                       bucket_start, keys, ents, kmax, strict):
    """Penetration measure, nodes (ALGORITHMS.md 3). Depth [m] of the deepest node of the
    (tet, node row) pairs ``inside`` of ``nodes_in_tets``: its distance to the boundary surface
    of the tet's body (nearest face, searched in a face hash: faces ``hfaces``, bodies
    ``hbody``, the rows its entries name). Returns (depth, searches not resolved: see
    ``_resolved``; none without ``strict``)."""
    deepest = 0.0
    unresolved = 0
    for k in range(inside.shape[0]):
        p = nodes[inside[k, 1]]
        d = nearest_face_distance(x[p, 0], x[p, 1], x[p, 2], elem_body[inside[k, 0]], hfaces,
                                  hbody, x, origin, inv_h, h, tbits, bucket_start, keys, ents,
                                  kmax)
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


@numba.njit(cache=True, nogil=True)
def crossing_pairs(cand, edges, faces, x, cuts):
    """Penetration measure, edges cutting through faces (ALGORITHMS.md 3.2).

    ``cand (m, 2)`` (boundary edge, boundary face of another body) candidates: those whose
    boxes overlap (the pairs of the broad phase) and whose edge crosses the triangle are written
    to ``cuts``, in order; returns how many."""
    n = 0
    for k in range(cand.shape[0]):
        g = cand[k, 0]
        f = cand[k, 1]
        p = edges[g, 0]
        q = edges[g, 1]
        a = faces[f, 0]
        b = faces[f, 1]
        c = faces[f, 2]
        if not (min(x[p, 0], x[q, 0]) <= max(x[a, 0], x[b, 0], x[c, 0])
                and min(x[a, 0], x[b, 0], x[c, 0]) <= max(x[p, 0], x[q, 0])
                and min(x[p, 1], x[q, 1]) <= max(x[a, 1], x[b, 1], x[c, 1])
                and min(x[a, 1], x[b, 1], x[c, 1]) <= max(x[p, 1], x[q, 1])
                and min(x[p, 2], x[q, 2]) <= max(x[a, 2], x[b, 2], x[c, 2])
                and min(x[a, 2], x[b, 2], x[c, 2]) <= max(x[p, 2], x[q, 2])):
            continue
        t, sgn = _crossing(p, q, a, b, c, x)
        if sgn != 0:
            cuts[n, 0] = g
            cuts[n, 1] = f
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


@numba.njit(cache=True, nogil=True)
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


@numba.njit(cache=True, nogil=True)
def near_other_body(x, nodes, node_body, blo, bhi, near):
    """near[j] = 1 for the nodes ``nodes[j]`` that lie in the box (blo, bhi) of a body other
    than their own ``node_body[j]`` (the broad phase's selection of points, ALGORITHMS.md 3.2
    "Cost"); returns how many."""
    n = 0
    for j in range(nodes.shape[0]):
        p = nodes[j]
        near[j] = 0
        for b in range(blo.shape[0]):
            if (b != node_body[j] and blo[b, 0] <= x[p, 0] <= bhi[b, 0]
                    and blo[b, 1] <= x[p, 1] <= bhi[b, 1] and blo[b, 2] <= x[p, 2] <= bhi[b, 2]):
                near[j] = 1
                n += 1
                break
    return n


@numba.njit(cache=True, nogil=True)
def moved_beyond(x, ref, limit):
    """True when a node has moved more than ``limit`` [m] along an axis from ``ref`` (the
    positions the kept candidates of the penetration measure were found at)."""
    for i in range(x.shape[0]):
        for d in range(3):
            if abs(x[i, d] - ref[i, d]) > limit:
                return True
    return False


@numba.njit(cache=True, nogil=True)
def came_back(status, ref, eroded):
    """True when an element eroded in ``ref`` is not in ``status`` (the kept candidates of the
    penetration measure leave eroded tets out)."""
    for e in range(status.shape[0]):
        if ref[e] == eroded and status[e] != eroded:
            return True
    return False


@numba.njit(cache=True, nogil=True)
def lift_rows(pairs, first, second):
    """Pairs of rows of two selections -> pairs of what they select, in place (the order is
    kept: the selections are increasing)."""
    for k in range(pairs.shape[0]):
        pairs[k, 0] = first[pairs[k, 0]]
        pairs[k, 1] = second[pairs[k, 1]]


FLOOR = 1e-4  # cut pieces whose depth bound is below FLOOR x cell size report the bound
NEAR_CELLS = 3  # the hash of the faces near another body holds those within NEAR_CELLS cells of
#                 its box; a search there that closes within NEAR_CELLS - 1 shells is exact
#                 (the meter's docstring), one that does not goes to the hash of every face
SKIN = 0.1  # candidates are found with boxes padded by SKIN x cell size and kept until a node
#             has moved that far
PAIR_CELL = 1.5  # cell of the hashes that find the candidates, in cell sizes (cost only: the
#                  pairs do not depend on it; 1.5 against 1: sphere-plate 8.5 -> 7.5 ms a row)
MAX_PENDING = 8  # measures handed to the meter's thread and not done before the next waits


class PenetrationMeter:
    """Measures penetration between bodies (see the module docstring); owns its buffers.

    The pairs to test are those of the broad phase at the current positions: (boundary node,
    alive tet of another body) whose tet's box holds the node, the node lying in the box of
    another body; (boundary edge, boundary face of another body) whose boxes overlap. Only
    entities whose box meets another body's box take part (the rest cannot touch), so on a
    history row the cost follows the size of the contact zone.

    Candidates kept over rows: the pairs are taken from candidate lists found with every box
    padded by ``skin`` (SKIN h, h the cell size then). They hold every pair of the broad phase
    as long as no node has moved more than ``skin`` along an axis since (a pair's boxes then
    lie within the padded boxes of the lists, and so does a node's body box), the surface is
    the same (its ``version``) and no eroded element has come back (the lists leave out the
    tets eroded then). Each row tests the candidates at the current positions
    (``nodes_in_tets``, ``crossing_pairs``): the same pairs, in the same order, as a broad
    phase run afresh. When a condition fails the lists are found again (``builds`` counts it):
    the boundary nodes near another body are hashed, one cell each, and the alive tets near
    them are the queries; the boundary faces near another body are hashed and the boundary
    edges near another body are the queries. While the surface changes from row to row
    (erosion) the lists would not outlive a row, and they are found with no skin.

    Depths: the nearest face of the penetrated body is first searched in a hash, kept with the
    candidates, of the faces (boxes padded by the skin) that meet the box of another body
    padded by skin + R, R = NEAR_CELLS cells. A search there that closes within
    NEAR_CELLS - 1 shells (best distance d <= R - 1 cell) is exact. The point lies in the box
    of its own body A, so a face f of the other body at distance d has a point within d of
    A's box; since the lists were found, A's box and f have moved at most ``skin``, so f's box
    then was within 2 skin + d of A's box then, f's padded box meets A's box padded by
    skin + R (a cell to spare for round-off) and f is in the hash, registered in every cell it
    now covers: the search has seen every face within d and its distance is the minimum over
    all faces of the body, the number the hash of every face gives (the same triangles, the
    same arithmetic). A search that does not close there (a point deeper than
    about 2 cells) runs again in the hash of every boundary face, built only then
    (``full_searches`` counts those measures).

    Buffers are kept from call to call and grow when they must (no allocation per call once
    they have grown).

    In the meter's own thread (``measure_later``): the run hands over copies of the positions
    and statuses and a view of the surface (``Surface.view``) and goes on while the measure is
    taken; the calls run one after the other in the order they were made, so the results are
    those of ``measure`` called in the run's thread at the same moments. Its kernels release
    the GIL, and its hashes query in the calling thread (``SpatialHash(chunked=False)``)."""

    # the meter's thread and what it was handed, and the arrays its kept candidates were found
    # for (compared by identity): a resumed run starts them afresh (solver/checkpoint.py; its
    # first measure finds the candidates again, the same pairs)
    CHECKPOINT_TRANSIENT = ("_pool", "_pending", "_mesh", "_mesh_of", "_mesh_topology", "_of")

    def __init__(self, skin: float = SKIN):
        self.skin_rel = float(skin)
        # boundary nodes near another body (queried by tets)
        self.node_hash = SpatialHash(chunked=False)
        # boundary faces near another body (queried by edges)
        self.cut_hash = SpatialHash(chunked=False)
        # boundary faces near another body, for the depths
        self.near_hash = SpatialHash(chunked=False)
        # every boundary face, for searches not closed near
        self.depth_hash = SpatialHash(chunked=False)
        self.builds = 0
        self.full_searches = 0
        self._ts = np.empty(256)
        self._signs = np.empty(256, np.int64)
        self._faces = np.empty(256, np.int64)
        self._buf = {}
        self._key = None  # what the kept candidates were found for: sizes, surface version
        self._of = (None, None, None)  # ... and arrays (conn, elem_body, surface)
        self._skin = 0.0
        self._node_tet = _NO_PAIRS
        self._edge_face = _NO_PAIRS
        self._near = None
        self._pool = None  # the meter's thread (measure_later), started on first use
        self._pending = deque()  # the Futures of the measures handed to it, not known done
        self._mesh_of = (None, None)  # what the copies of conn and elem_body were taken of
        self._mesh_topology = None
        self._mesh = None

    def measure_later(self, x, conn, elem_body, status, surface, topology, then=None) -> Future:
        """``measure`` in the meter's own thread (class docstring) on copies of x and status
        and a view of ``surface`` taken now: a Future of ``then(result)`` (called in the
        meter's thread), or of the result without ``then``. conn and elem_body are copied again
        only when the arrays or ``topology`` (a count of the changes made to conn in place, node
        separation) change."""
        if (topology != self._mesh_topology or self._mesh_of[0] is not conn
                or self._mesh_of[1] is not elem_body):
            self._mesh = (conn.copy(), elem_body.copy())
            self._mesh_topology = topology
            self._mesh_of = (conn, elem_body)  # (held: compared by identity)
        conn_c, body_c = self._mesh
        args = (x.copy(), conn_c, body_c, None if status is None else status.copy(),
                surface.view())
        if self._pool is None:
            self._pool = ThreadPoolExecutor(1, thread_name_prefix="impactsim-penetration",
                                            initializer=background_thread)
        while self._pending and self._pending[0].done():
            self._pending.popleft()
        if len(self._pending) >= MAX_PENDING:  # (each holds copies of x and status)
            futures_wait([self._pending.popleft()])

        def task():
            out = self.measure(*args)
            return out if then is None else then(out)

        self._pending.append(self._pool.submit(task))
        return self._pending[-1]

    def wait(self) -> None:
        """Wait for the measures handed to the meter's thread so far (their errors stay with
        their Futures)."""
        if self._pending:
            futures_wait([self._pending[-1]])  # (they run one after the other)

    def close(self) -> None:
        """Wait for the measures still being taken and stop the meter's thread."""
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None

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
        near = self._buffer("node.near", s.n_nodes, np.uint8)
        if near_other_body(x, s.nodes, s.node_body, blo, bhi, near) == 0:
            return out
        live = blo[:, 0] <= bhi[:, 0]
        h = s.mean_edge_length(x)
        origin, h = grid_from_bounds(blo[live].min(axis=0), bhi[live].max(axis=0), h)
        floor = FLOOR * h
        status = _ALL_ALIVE if status is None else np.asarray(status)
        self._candidates(x, conn, elem_body, status, s, n_body, blo, bhi, h)
        # boundary nodes inside tets of another body
        inside = self._buffer("inside", (self._node_tet.shape[0], 2), np.int64)
        inside = inside[:nodes_in_tets(self._node_tet, near, s.nodes, conn, status, ERODED, x,
                                       inside)]
        count = inside.shape[0]
        # boundary edges cutting through boundary faces of another body
        cuts = self._buffer("cuts", (self._edge_face.shape[0], 2), np.int64)
        cuts = cuts[:crossing_pairs(self._edge_face, s.edges, s.faces, x, cuts)]
        # depths below the other body's surface: nearest boundary face, first among those near
        need = False
        if cuts.shape[0]:
            depth, n_cut, need = edge_cut_depths(cuts, s.edges, s.faces, s.face_body, x, floor,
                                                 False, False, *self._near, self._ts,
                                                 self._signs, self._faces)
            out["edge_depth"] = float(depth)
            out["edge_cuts"] = int(n_cut)
        redo_nodes = redo_edges = False
        if count:
            depth, left = inside_node_depths(inside, elem_body, s.nodes, x, *self._near, True)
            out["node_depth"] = float(depth)
            out["nodes_inside"] = int(count)
            redo_nodes = left > 0
        if need:
            depth, _, redo_edges = edge_cut_depths(cuts, s.edges, s.faces, s.face_body, x, floor,
                                                   True, True, *self._near, self._ts,
                                                   self._signs, self._faces)
            out["edge_depth"] = float(depth)
        if redo_nodes or redo_edges:
            self.full_searches += 1
            full = self._full_hash(x, s, origin, h)
            if redo_nodes:
                out["node_depth"] = float(inside_node_depths(inside, elem_body, s.nodes, x,
                                                             *full, False)[0])
            if redo_edges:
                out["edge_depth"] = float(edge_cut_depths(
                    cuts, s.edges, s.faces, s.face_body, x, floor, True, False, *full, self._ts,
                    self._signs, self._faces)[0])
        out["max_penetration"] = max(out["node_depth"], out["edge_depth"])
        return out

    def _candidates(self, x, conn, elem_body, status, s, n_body, blo, bhi, h) -> None:
        """Keep the candidate lists and the hash of the faces near another body, or find them
        again (class docstring); blo, bhi: the bodies' boxes now."""
        key = (conn.shape, s.version, x.shape, status.shape, status.dtype)
        source = getattr(s, "source", s)  # a view's surface (``Surface.view``)
        same = (key == self._key and self._of[0] is conn and self._of[1] is elem_body
                and self._of[2] is source)
        ref_x = self._buffer("ref.x", x.shape)
        ref_status = self._buffer("ref.status", status.shape, status.dtype)
        if same:
            if not (moved_beyond(x, ref_x, 0.999 * self._skin)
                    or (status.shape[0] and came_back(status, ref_status, ERODED))):
                return
            skin = self.skin_rel * h
        else:
            skin = self.skin_rel * h if self._key is None else 0.0  # a changing surface
        self.builds += 1
        plo = self._buffer("pad.lo", (n_body, 3))
        phi = self._buffer("pad.hi", (n_body, 3))
        np.subtract(blo, skin, out=plo)
        np.add(bhi, skin, out=phi)
        live = plo[:, 0] <= phi[:, 0]
        origin, cell = grid_from_bounds(plo[live].min(axis=0), phi[live].max(axis=0),
                                        PAIR_CELL * h)
        # (tet, node row): boundary nodes near another body, hashed, against the tets near them
        nsel, nlo, nhi = self._select("cand.node", x, s.nodes.reshape(-1, 1), s.node_body, plo,
                                      phi, skin)
        nodes = self._take("cand.node.id", s.nodes, nsel)
        node_body = self._take("cand.node.body", s.node_body, nsel)
        zlo = self._buffer("cand.zone.lo", (n_body, 3))
        zhi = self._buffer("cand.zone.hi", (n_body, 3))
        body_bounds(x, x, 0.0, nodes, node_body, skin, zlo, zhi)
        skip = _NO_SKIP
        if status.shape[0]:
            skip = self._buffer("cand.eroded", status.shape[0], np.bool_)
            np.equal(status, ERODED, out=skip)
            skip = skip.view(np.uint8)
        tsel, tlo, thi = self._select("cand.tet", x, conn, elem_body, zlo, zhi, skin, skip)
        self._node_tet = _NO_PAIRS
        if nsel.shape[0] and tsel.shape[0]:
            self.node_hash.build(nlo, nhi, origin, cell)
            self._node_tet = self.node_hash.query(
                tlo, thi, _NO_ROWS, self._take("cand.tet.body", elem_body, tsel), _NO_ROWS,
                node_body, False, False)  # kept in the hash's pair buffer until the next build
            lift_rows(self._node_tet, tsel, nsel)
        # (edge, face): boundary faces near another body, hashed, against the edges near one
        fsel, flo, fhi = self._select("cand.face", x, s.faces, s.face_body, plo, phi, skin)
        esel, elo, ehi = self._select("cand.edge", x, s.edges, s.edge_body, plo, phi, skin)
        self._edge_face = _NO_PAIRS
        if fsel.shape[0] and esel.shape[0]:
            self.cut_hash.build(flo, fhi, origin, cell)
            self._edge_face = self.cut_hash.query(
                elo, ehi, _NO_ROWS, self._take("cand.edge.body", s.edge_body, esel), _NO_ROWS,
                self._take("cand.face.body", s.face_body, fsel), False, False)
            lift_rows(self._edge_face, esel, fsel)
        # the faces near another body, for the depths
        _, cell = grid_from_bounds(blo[live].min(axis=0), bhi[live].max(axis=0), h)
        reach = NEAR_CELLS * cell
        np.subtract(blo, skin + reach, out=plo)
        np.add(bhi, skin + reach, out=phi)
        origin, cell = grid_from_bounds(plo[live].min(axis=0), phi[live].max(axis=0), cell)
        rsel, rlo, rhi = self._select("near", x, s.faces, s.face_body, plo, phi, skin)
        self.near_hash.build(rlo, rhi, origin, cell)
        self._near = self._grid(self.near_hash, self._take("near.faces", s.faces, rsel),
                                self._take("near.body", s.face_body, rsel),
                                max(int(reach / cell + 1e-9) - 1, 0))
        ref_x[:] = x
        ref_status[:] = status
        self._skin = skin
        self._key = key
        self._of = (conn, elem_body, source)  # (held: compared by identity)

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
        """A face hash as the arguments hfaces .. kmax of the depth kernels."""
        return (hfaces, hbody, fh.origin, fh.inv_h, fh.h, fh.tbits, fh.bucket_start, fh.keys,
                fh.ents, kmax)

    def _select(self, name, x, ent, body, blo, bhi, pad=0.0, skip=None):
        """Rows of ent whose (static) box, padded, meets another body's box (blo, bhi), with
        their padded boxes (``broadphase.select_boxes``; rows with skip != 0 left out)."""
        n = ent.shape[0]
        sel = self._buffer(name + ".sel", n, np.int64)
        lo = self._buffer(name + ".lo", (n, 3))
        hi = self._buffer(name + ".hi", (n, 3))
        k = select_boxes(x, x, 0.0, ent, pad, body, blo, bhi, False,
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
_ALL_ALIVE = np.zeros(0, np.int8)  # no status: no element eroded
_NO_PAIRS = np.zeros((0, 2), np.int64)
_NO_ROWS = np.zeros((0, 1), np.int32)  # entity rows the hash query reads only for self-contact


def max_penetration(x, conn, elem_body, status, surface) -> float:
    """Deepest penetration [m] between different bodies at positions x (module docstring)."""
    return PenetrationMeter().measure(x, conn, elem_body, status, surface)["max_penetration"]
