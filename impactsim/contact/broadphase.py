"""Broad phase: candidate pairs from swept bounding boxes in a spatial hash (ALGORITHMS.md 3.2,
"Cost": pre-select candidate pairs before the cubic).

Entities are rows of node indices (a node is a row of one, an edge two, a face three, a tet
four). Each entity's box covers its nodes over one step, [x, x + tau U] (tau = 0: a static box),
padded by ``pad``. Boxes are inserted into a uniform grid of cell size h (about the mean surface
edge length): the grid is a hash table of 2**tbits buckets over packed cell keys, filled by a
stable counting sort, so building it costs O(entries) and every query scans only the entries of
the cells its own box covers. A pair of overlapping boxes is reported once, in the cell that holds
the lower corner of their intersection, so no deduplication pass is needed. The host sorts the
pairs by (query, entry), which makes the order canonical (independent of the grid parameters).

Buffers have a capacity; a kernel that needs more returns the count it needed and the host grows
the buffer and runs it again. Nothing is dropped silently.
"""

from __future__ import annotations

import math

import numba
import numpy as np

_AXIS_BITS = 21
_AXIS_CELLS = 1 << _AXIS_BITS
_GOLDEN = np.uint64(11400714819323198485)


@numba.njit(cache=True)
def swept_boxes(x, v, tau, ent, pad, lo, hi):
    """Boxes of entity rows ``ent (k, w)`` swept over [x, x + tau v], padded (ALGORITHMS.md 3.2,
    "bounding boxes of the swept edges"). Writes lo, hi (k, 3) [m]."""
    for i in range(ent.shape[0]):
        for d in range(3):
            lo[i, d] = np.inf
            hi[i, d] = -np.inf
        for j in range(ent.shape[1]):
            k = ent[i, j]
            for d in range(3):
                p0 = x[k, d]
                p1 = p0 + tau * v[k, d]
                if p0 < lo[i, d]:
                    lo[i, d] = p0
                if p1 < lo[i, d]:
                    lo[i, d] = p1
                if p0 > hi[i, d]:
                    hi[i, d] = p0
                if p1 > hi[i, d]:
                    hi[i, d] = p1
        for d in range(3):
            lo[i, d] -= pad
            hi[i, d] += pad


@numba.njit(cache=True)
def _cell(p, o, inv_h):
    """Grid cell index of coordinate p (clamped to the key range; ALGORITHMS.md 3.2 hash)."""
    c = int(math.floor((p - o) * inv_h))
    if c < 0:
        return 0
    if c >= _AXIS_CELLS:
        return _AXIS_CELLS - 1
    return c


@numba.njit(cache=True)
def _key(ix, iy, iz):
    """Packed int64 key of cell (ix, iy, iz), 21 bits each (ALGORITHMS.md 3.2 hash)."""
    return (np.int64(ix) << 42) | (np.int64(iy) << 21) | np.int64(iz)


@numba.njit(cache=True)
def _bucket(key, tbits):
    """Bucket of a cell key: Fibonacci hashing to tbits bits (ALGORITHMS.md 3.2 hash)."""
    return np.int64((np.uint64(key) * _GOLDEN) >> np.uint64(64 - tbits))


@numba.njit(cache=True)
def build_hash(lo, hi, origin, inv_h, tbits, tmp_keys, tmp_ents, bucket_start, keys, ents):
    """Insert every box into each grid cell it covers (ALGORITHMS.md 3.2, spatial hash).

    Counting sort by bucket: ``bucket_start (2**tbits + 1,)`` offsets into ``keys``/``ents`` (the
    cell key and entity of each entry). Returns the number of entries needed; when it exceeds the
    capacity (len(keys)) nothing usable is built and the caller grows the buffers."""
    cap = keys.shape[0]
    n = 0
    for i in range(lo.shape[0]):
        x0 = _cell(lo[i, 0], origin[0], inv_h)
        x1 = _cell(hi[i, 0], origin[0], inv_h)
        y0 = _cell(lo[i, 1], origin[1], inv_h)
        y1 = _cell(hi[i, 1], origin[1], inv_h)
        z0 = _cell(lo[i, 2], origin[2], inv_h)
        z1 = _cell(hi[i, 2], origin[2], inv_h)
        need = (x1 - x0 + 1) * (y1 - y0 + 1) * (z1 - z0 + 1)
        if n + need > cap:
            n += need
            continue
        for ix in range(x0, x1 + 1):
            for iy in range(y0, y1 + 1):
                for iz in range(z0, z1 + 1):
                    tmp_keys[n] = _key(ix, iy, iz)
                    tmp_ents[n] = i
                    n += 1
    if n > cap:
        return n
    nb = bucket_start.shape[0] - 1
    for b in range(nb + 1):
        bucket_start[b] = 0
    for k in range(n):
        bucket_start[_bucket(tmp_keys[k], tbits) + 1] += 1
    for b in range(nb):
        bucket_start[b + 1] += bucket_start[b]
    for k in range(n):  # stable scatter; bucket_start[b] runs from the start to the end of b
        b = _bucket(tmp_keys[k], tbits)
        keys[bucket_start[b]] = tmp_keys[k]
        ents[bucket_start[b]] = tmp_ents[k]
        bucket_start[b] += 1
    for b in range(nb, 0, -1):
        bucket_start[b] = bucket_start[b - 1]
    bucket_start[0] = 0
    return n


@numba.njit(cache=True)
def _shares_node(qent, i, eent, j):
    """True when rows i and j share a node (self-contact exclusion, ALGORITHMS.md 3.2)."""
    for a in range(qent.shape[1]):
        for b in range(eent.shape[1]):
            if qent[i, a] == eent[j, b]:
                return True
    return False


@numba.njit(cache=True)
def query_pairs(qlo, qhi, qent, qbody, elo, ehi, eent, ebody, same_set, self_contact,
                origin, inv_h, tbits, bucket_start, keys, ents, out):
    """Candidate pairs (ALGORITHMS.md 3.2, "Cost": the broad phase before the cubic).

    (i, j): query box i overlaps hashed box j, of different bodies (or of the
    same body when ``self_contact`` and the entities share no node); with ``same_set`` (both sides
    the same entity list) only j > i. Each pair once, in query order. Writes ``out (cap, 2)`` and
    returns the number of pairs found (more than cap: the caller grows ``out`` and repeats)."""
    cap = out.shape[0]
    n = 0
    for i in range(qlo.shape[0]):
        x0 = _cell(qlo[i, 0], origin[0], inv_h)
        x1 = _cell(qhi[i, 0], origin[0], inv_h)
        y0 = _cell(qlo[i, 1], origin[1], inv_h)
        y1 = _cell(qhi[i, 1], origin[1], inv_h)
        z0 = _cell(qlo[i, 2], origin[2], inv_h)
        z1 = _cell(qhi[i, 2], origin[2], inv_h)
        for ix in range(x0, x1 + 1):
            for iy in range(y0, y1 + 1):
                for iz in range(z0, z1 + 1):
                    key = _key(ix, iy, iz)
                    b = _bucket(key, tbits)
                    for k in range(bucket_start[b], bucket_start[b + 1]):
                        if keys[k] != key:
                            continue
                        j = ents[k]
                        if same_set and j <= i:
                            continue
                        if qbody[i] == ebody[j]:
                            if not self_contact or _shares_node(qent, i, eent, j):
                                continue
                        if (qlo[i, 0] > ehi[j, 0] or elo[j, 0] > qhi[i, 0]
                                or qlo[i, 1] > ehi[j, 1] or elo[j, 1] > qhi[i, 1]
                                or qlo[i, 2] > ehi[j, 2] or elo[j, 2] > qhi[i, 2]):
                            continue
                        # report in the cell of the intersection's lower corner only
                        if (_cell(max(qlo[i, 0], elo[j, 0]), origin[0], inv_h) != ix
                                or _cell(max(qlo[i, 1], elo[j, 1]), origin[1], inv_h) != iy
                                or _cell(max(qlo[i, 2], elo[j, 2]), origin[2], inv_h) != iz):
                            continue
                        if n < cap:
                            out[n, 0] = i
                            out[n, 1] = j
                        n += 1
    return n


@numba.njit(cache=True)
def body_bounds(x, v, tau, nodes, node_body, pad, blo, bhi):
    """Broad-phase pre-selection (ALGORITHMS.md 3.2, "Cost").

    Bounding box (n_body, 3) of each body's ``nodes`` swept over [x, x + tau v], padded; an
    empty body gets +inf / -inf. Returns False when a coordinate is not finite (a NaN or
    infinite position or velocity must not pass unnoticed)."""
    for b in range(blo.shape[0]):
        for d in range(3):
            blo[b, d] = np.inf
            bhi[b, d] = -np.inf
    for k in range(nodes.shape[0]):
        i = nodes[k]
        b = node_body[k]
        for d in range(3):
            p0 = x[i, d]
            p1 = p0 + tau * v[i, d]
            if not (math.isfinite(p0) and math.isfinite(p1)):
                return False
            lo = min(p0, p1) - pad
            hi = max(p0, p1) + pad
            if lo < blo[b, d]:
                blo[b, d] = lo
            if hi > bhi[b, d]:
                bhi[b, d] = hi
    return True


@numba.njit(cache=True)
def select_boxes(x, v, tau, ent, pad, body, blo, bhi, keep_all, skip, sel, lo, hi):
    """Broad-phase pre-selection (ALGORITHMS.md 3.2, "Cost").

    Swept, padded boxes of the rows of ``ent`` that can meet another body: rows whose box
    meets the bounding box (blo, bhi) of a body other than their own (all rows with
    ``keep_all``, for self-contact); rows with skip[i] != 0 are left out (``skip`` may be empty).
    Writes their indices (increasing) to sel and their boxes to lo, hi; returns how many."""
    n = 0
    n_body = blo.shape[0]
    use_skip = skip.shape[0] > 0
    for i in range(ent.shape[0]):
        if use_skip and skip[i] != 0:
            continue
        x0 = np.inf
        y0 = np.inf
        z0 = np.inf
        x1 = -np.inf
        y1 = -np.inf
        z1 = -np.inf
        for j in range(ent.shape[1]):
            k = ent[i, j]
            px = x[k, 0]
            py = x[k, 1]
            pz = x[k, 2]
            qx = px + tau * v[k, 0]
            qy = py + tau * v[k, 1]
            qz = pz + tau * v[k, 2]
            x0 = min(x0, px, qx)
            y0 = min(y0, py, qy)
            z0 = min(z0, pz, qz)
            x1 = max(x1, px, qx)
            y1 = max(y1, py, qy)
            z1 = max(z1, pz, qz)
        x0 -= pad
        y0 -= pad
        z0 -= pad
        x1 += pad
        y1 += pad
        z1 += pad
        keep = keep_all
        if not keep:
            for b in range(n_body):
                if (b != body[i] and x0 <= bhi[b, 0] and blo[b, 0] <= x1 and y0 <= bhi[b, 1]
                        and blo[b, 1] <= y1 and z0 <= bhi[b, 2] and blo[b, 2] <= z1):
                    keep = True
                    break
        if keep:
            sel[n] = i
            lo[n, 0] = x0
            lo[n, 1] = y0
            lo[n, 2] = z0
            hi[n, 0] = x1
            hi[n, 1] = y1
            hi[n, 2] = z1
            n += 1
    return n


@numba.njit(cache=True)
def mean_length(x, edges):
    """Mean length [m] of the segments ``edges (g, 2)`` (0 for none): the hash cell size and
    the touching band of ALGORITHMS.md 3 scale with it."""
    if edges.shape[0] == 0:
        return 0.0
    total = 0.0
    for g in range(edges.shape[0]):
        a = edges[g, 0]
        b = edges[g, 1]
        dx = x[b, 0] - x[a, 0]
        dy = x[b, 1] - x[a, 1]
        dz = x[b, 2] - x[a, 2]
        total += math.sqrt(dx * dx + dy * dy + dz * dz)
    return total / edges.shape[0]


class SpatialHash:
    """Host side of the hash grid: owns the growable buffers (entries and pairs)."""

    def __init__(self, entry_capacity: int = 1024, pair_capacity: int = 1024):
        self._alloc_entries(entry_capacity)
        self.pairs_buf = np.zeros((max(pair_capacity, 16), 2), dtype=np.int64)
        self.grows = 0  # how often a buffer had to grow (reported in the pass summary)
        self.n_entries = 0

    def _alloc_entries(self, cap: int) -> None:
        cap = max(int(cap), 16)
        self.tmp_keys = np.zeros(cap, dtype=np.int64)
        self.tmp_ents = np.zeros(cap, dtype=np.int64)
        self.keys = np.zeros(cap, dtype=np.int64)
        self.ents = np.zeros(cap, dtype=np.int64)
        self.tbits = max(4, int(math.ceil(math.log2(cap))))
        self.bucket_start = np.zeros((1 << self.tbits) + 1, dtype=np.int64)

    def build(self, lo, hi, origin, h) -> None:
        """Hash the boxes (lo, hi) on a grid of cell size h from ``origin``."""
        self.origin = np.ascontiguousarray(origin, dtype=np.float64)
        self.h = float(h)
        self.inv_h = 1.0 / self.h
        self.lo, self.hi = lo, hi
        while True:
            n = build_hash(lo, hi, self.origin, self.inv_h, self.tbits, self.tmp_keys,
                           self.tmp_ents, self.bucket_start, self.keys, self.ents)
            if n <= self.keys.shape[0]:
                self.n_entries = n
                return
            self.grows += 1
            self._alloc_entries(int(n * 1.5) + 16)

    def query(self, qlo, qhi, qent, qbody, eent, ebody, same_set: bool, self_contact: bool):
        """Sorted candidate pairs (k, 2) int64 of (query row, hashed row); see ``query_pairs``."""
        while True:
            n = query_pairs(qlo, qhi, qent, qbody, self.lo, self.hi, eent, ebody, same_set,
                            self_contact, self.origin, self.inv_h, self.tbits, self.bucket_start,
                            self.keys, self.ents, self.pairs_buf)
            if n <= self.pairs_buf.shape[0]:
                break
            self.grows += 1
            self.pairs_buf = np.zeros((int(n * 1.5) + 16, 2), dtype=np.int64)
        pairs = self.pairs_buf[:n]
        n_hashed = max(int(eent.shape[0]), 1)
        order = np.argsort(pairs[:, 0] * n_hashed + pairs[:, 1], kind="stable")
        return np.ascontiguousarray(pairs[order])


def grid_for(boxes, h):
    """Origin and cell size for a set of (lo, hi) box arrays: the origin is the lowest corner;
    the cell size is h, enlarged if needed so that every axis fits in 2**21 cells. Raises
    FloatingPointError on non-finite boxes (a NaN velocity must not pass unnoticed)."""
    los = [lo.min(axis=0) for lo, hi in boxes if lo.shape[0]]
    his = [hi.max(axis=0) for lo, hi in boxes if hi.shape[0]]
    if not los:
        return np.zeros(3), max(float(h), 1.0)
    return grid_from_bounds(np.min(los, axis=0), np.max(his, axis=0), h)


def grid_from_bounds(lo, hi, h):
    """``grid_for`` from the overall lowest and highest corners (3,) of the boxes."""
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        raise FloatingPointError("non-finite position or velocity in the contact broad phase")
    extent = float((hi - lo).max())
    h = float(h) if h > 0.0 else max(extent, 1e-12)
    h = max(h, extent / (_AXIS_CELLS - 4), 1e-300)
    return lo, h
