"""Broad phase: candidate pairs from swept bounding boxes in a spatial hash (ALGORITHMS.md 3.2,
"Cost": pre-select candidate pairs before the cubic).

Entities are rows of node indices (a node is a row of one, an edge two, a face three, a tet
four). Each entity's box covers its nodes over one step, [x, x + tau U] (tau = 0: a static box),
padded by ``pad``. Boxes are inserted into a uniform grid of cell size h (about the mean surface
edge length): the grid is a hash table of 2**tbits buckets over packed cell keys, filled by a
stable counting sort, so building it costs O(entries) and every query scans only the entries of
the cells its own box covers. Each entry holds, beside its cell key, the bits saying whether its
cell is the entity's first along each axis; the boxes are kept one row (a cache line) each. A
pair of overlapping boxes is reported once, in the cell that holds the lower corner of their
intersection, so no deduplication pass is needed. The pairs of a query row are sorted by entry,
so the pairs come sorted by (query, entry): the order is canonical (independent of the grid
parameters and of the number of threads, which run fixed chunks of query rows).

Buffers have a capacity; a kernel that needs more returns the count it needed and the host grows
the buffer and runs it again. Nothing is dropped silently.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from impactsim.contact.geometry import segment
from impactsim.solver.workqueue import fetch_add

_AXIS_BITS = 20  # per axis of a cell key; the key is shifted by 3 in an entry (its first-cell bits)
_AXIS_CELLS = 1 << _AXIS_BITS
_GOLDEN = np.uint64(11400714819323198485)
QUERY_CHUNK = 1024  # query rows per chunk of the threaded query (fixed: results do not depend
#                     on the number of threads)
QUERY_MIN_CHUNKS = 8  # fewer chunks run in one thread: a parallel launch does not pay for itself
#                       there, least of all when another thread (the frame writer) holds a core


@numba.njit(cache=True, nogil=True)
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
    """Packed int64 key of cell (ix, iy, iz), 20 bits each (ALGORITHMS.md 3.2 hash)."""
    return (np.int64(ix) << 40) | (np.int64(iy) << 20) | np.int64(iz)


@numba.njit(cache=True)
def _bucket(key, tbits):
    """Bucket of a cell key: Fibonacci hashing to tbits bits (ALGORITHMS.md 3.2 hash)."""
    return np.int64((np.uint64(key) * _GOLDEN) >> np.uint64(64 - tbits))


@numba.njit(cache=True, nogil=True)
def build_hash(lo, hi, origin, inv_h, tbits, tmp_keys, tmp_ents, bucket_start, keys, ents,
               boxes):
    """Insert every box into each grid cell it covers (ALGORITHMS.md 3.2, spatial hash).

    Counting sort by bucket: ``bucket_start (2**tbits + 1,)`` offsets into the entries:
    ``keys`` (the cell key shifted left by 3, its low bits d = 0, 1, 2 set when the cell is the
    entity's first along axis d: the query's once-only rule without floors, in the word it
    loads anyway) and ``ents`` (entity). The boxes go to ``boxes (n, 8)``, one row (a cache
    line) per entity, so that the query gathers a box with one load: columns 0-2 the upper
    corner, 3-5 the lower corner negated (the query's overlap test is then six subtractions and
    one sign, ``_query_rows``), 6 the entity's body (written by ``SpatialHash.query``), 7
    unused. Returns the number of entries needed; when it exceeds the capacity (len(keys))
    nothing usable is built and the caller grows the buffers."""
    cap = keys.shape[0]
    n = 0
    for i in range(lo.shape[0]):
        for d in range(3):
            boxes[i, d] = hi[i, d]
            boxes[i, 3 + d] = -lo[i, d]
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
                    tmp_keys[n] = ((_key(ix, iy, iz) << 3) | np.int64(ix == x0)
                                   | (np.int64(iy == y0) << 1) | (np.int64(iz == z0) << 2))
                    tmp_ents[n] = i
                    n += 1
    if n > cap:
        return n
    nb = bucket_start.shape[0] - 1
    for b in range(nb + 1):
        bucket_start[b] = 0
    for k in range(n):
        bucket_start[_bucket(tmp_keys[k] >> 3, tbits) + 1] += 1
    for b in range(nb):
        bucket_start[b + 1] += bucket_start[b]
    for k in range(n):  # stable scatter; bucket_start[b] runs from the start to the end of b
        b = _bucket(tmp_keys[k] >> 3, tbits)
        q = bucket_start[b]
        keys[q] = tmp_keys[k]
        ents[q] = tmp_ents[k]
        bucket_start[b] = q + 1
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


@numba.njit(cache=True, inline="always", fastmath={"nnan", "ninf"})
def _gap(boxes, r, ql0, ql1, ql2, qh0, qh1, qh2):
    """How far the box of the row at r of ``boxes`` (flat; ``build_hash``: upper corner, lower
    corner negated) overlaps the query box along the axis where it overlaps least: >= 0 exactly
    when the boxes overlap (for finite numbers a rounded difference is >= 0 exactly when the
    exact one is)."""
    return min(min(min(boxes[r] - ql0, boxes[r + np.uint64(1)] - ql1),
                   min(boxes[r + np.uint64(2)] - ql2, boxes[r + np.uint64(3)] + qh0)),
               min(boxes[r + np.uint64(4)] + qh1, boxes[r + np.uint64(5)] + qh2))


@numba.njit(cache=True, error_model="numpy", fastmath={"nnan", "ninf"})
def _query_rows(i0, i1, qlo, qhi, qent, qbody, eent, same_set, self_contact, origin, inv_h,
                tbits, bucket_start, keys, ents, boxes, out, o0, o1):
    """The pairs of query rows [i0, i1) (see ``query_pairs``) into rows o0 .. o1 - 2 of ``out``
    (the (cap, 2) pair array flattened; row o1 - 1 takes the writes of the entries past the
    last row); returns their number (o1 - o0 or more: only the first ones were written).

    An entry is tested for the cell's key, the once-only rule, j > i for ``same_set``, another
    body (column 6 of the entity's row of ``boxes``) and the overlap, the least of six
    differences (the upper corners minus the query's lower corner, the query's upper corner
    plus the row's negated lower corner) against 0: for finite numbers a rounded difference is
    >= 0 exactly when the exact one is. The entry is written to the next free row whether it
    counts or not, and the query row's index goes in once its pairs are known. Three loops:
    a query row of no body (a particle) tests every entry without a branch; the contact
    passes' rows (their hashes hold both bodies' entities) pass an entry of another cell, of
    j <= i or of their own body by with a branch, the rest without; under ``self_contact`` a
    pair of one body branches to look for a shared node. Against the tests one by one, on
    boxes indexed in two dimensions with the bodies in an array of their own: 17-27 % less
    time on oblique-sphere's particle queries, the contact passes' as before
    (docs/performance.md, session 18). Unsigned indices: numba does not test them for
    wraparound."""
    cap = o1 - o0 - 1  # rows for pairs; the last one takes the writes beyond them
    n = 0
    last = np.uint64(max(cap, 0))
    base = np.uint64(2 * o0)
    for i in range(i0, i1):
        ql0 = qlo[i, 0]
        ql1 = qlo[i, 1]
        ql2 = qlo[i, 2]
        qh0 = qhi[i, 0]
        qh1 = qhi[i, 1]
        qh2 = qhi[i, 2]
        qb = np.float64(qbody[i])
        jmin = i + 1 if same_set else 0
        x0 = _cell(ql0, origin[0], inv_h)
        x1 = _cell(qh0, origin[0], inv_h)
        y0 = _cell(ql1, origin[1], inv_h)
        y1 = _cell(qh1, origin[1], inv_h)
        z0 = _cell(ql2, origin[2], inv_h)
        z1 = _cell(qh2, origin[2], inv_h)
        row = n
        for ix in range(x0, x1 + 1):
            fx = 0 if ix == x0 else 1
            for iy in range(y0, y1 + 1):
                fy = 0 if iy == y0 else 2
                for iz in range(z0, z1 + 1):
                    # the first-cell bits an entry needs: the axes where this is not the
                    # query's first cell
                    need = np.int64(fx | fy | (0 if iz == z0 else 4))
                    key = _key(ix, iy, iz)
                    # an entry counts when its word, with the bits not needed set, is this
                    # cell's key with all three bits set
                    spare = 7 ^ need
                    want = (key << 3) | 7
                    b = np.uint64(_bucket(key, tbits))
                    k = np.uint64(bucket_start[b])
                    k1 = np.uint64(bucket_start[b + np.uint64(1)])
                    # three loops: the shared-node test's live values, in a loop of every
                    # query, pushed the others out of the registers; an entry of another cell
                    # (a rare collision in the bucket), of j <= i (same_set: a bucket's first
                    # entries, as they come in entity order) or of the row's own body is
                    # passed by with a branch where the hash holds both bodies' entities
                    # (tested without one, the contact passes' queries took a third more);
                    # a row of no body (a particle) meets no entry of its own body, and its
                    # loop has no branch (7 % of its time)
                    if self_contact:
                        while k < k1:
                            e = keys[k]
                            j = ents[k]
                            if (e | 7) == want and j >= jmin:
                                r = np.uint64(j) * np.uint64(8)
                                gap = _gap(boxes, r, ql0, ql1, ql2, qh0, qh1, qh2)
                                other = boxes[r + np.uint64(6)] != qb
                                hit = ((e | spare) == want) & (gap >= 0.0)
                                if hit and not other:
                                    other = not _shares_node(qent, i, eent, j)
                                out[base + np.uint64(2) * min(np.uint64(n), last)
                                    + np.uint64(1)] = j
                                n += hit & other
                            k += np.uint64(1)
                    elif qb < 0.0:  # a row of no body (a particle): every entry is another's
                        while k < k1:
                            e = keys[k]
                            j = ents[k]
                            r = np.uint64(j) * np.uint64(8)
                            gap = _gap(boxes, r, ql0, ql1, ql2, qh0, qh1, qh2)
                            hit = ((e | spare) == want) & (j >= jmin) & (gap >= 0.0)
                            out[base + np.uint64(2) * min(np.uint64(n), last)
                                + np.uint64(1)] = j
                            n += hit
                            k += np.uint64(1)
                    else:
                        while k < k1:
                            e = keys[k]
                            j = ents[k]
                            r = np.uint64(j) * np.uint64(8)
                            if ((e | 7) == want and j >= jmin
                                    and boxes[r + np.uint64(6)] != qb):
                                gap = _gap(boxes, r, ql0, ql1, ql2, qh0, qh1, qh2)
                                hit = ((e | spare) == want) & (gap >= 0.0)
                                out[base + np.uint64(2) * min(np.uint64(n), last)
                                    + np.uint64(1)] = j
                                n += hit
                            k += np.uint64(1)
        if n <= cap:
            for a in range(row, n):
                out[2 * (o0 + a)] = i
            for a in range(row + 1, n):  # the row sorted by j (insertion: a row holds a few)
                j = out[2 * (o0 + a) + 1]
                c = a
                while c > row and out[2 * (o0 + c - 1) + 1] > j:
                    out[2 * (o0 + c) + 1] = out[2 * (o0 + c - 1) + 1]
                    c -= 1
                out[2 * (o0 + c) + 1] = j
    return n


@numba.njit(cache=True, nogil=True)
def query_pairs(qlo, qhi, qent, qbody, eent, same_set, self_contact, origin, inv_h, tbits,
                bucket_start, keys, ents, boxes, out):
    """Candidate pairs (ALGORITHMS.md 3.2, "Cost": the broad phase before the cubic).

    (i, j): query box i overlaps hashed box j, of different bodies (or of the
    same body when ``self_contact`` and the entities share no node); with ``same_set`` (both sides
    the same entity list) only j > i. Each pair once, sorted by (i, j). Writes ``out (cap, 2)``
    and returns the number of pairs found (more than cap: the caller grows ``out`` and repeats).

    A pair is reported in the cell that holds the lower corner of the two boxes' intersection:
    along each axis the cell of max(lo_i, lo_j), which is the larger of the two boxes' first
    cells (the cell index is monotone in the coordinate), so the entry in cell ix counts when ix
    is the query's first cell or the entry's (its first-cell bit). The pairs of a query row are
    sorted by j before the next row. ``boxes``: the hashed rows of ``build_hash``, the
    entities' bodies in column 6 (``SpatialHash.query`` writes them there)."""
    n = _query_rows(0, qlo.shape[0], qlo, qhi, qent, qbody, eent, same_set, self_contact,
                    origin, inv_h, tbits, bucket_start, keys, ents, boxes.reshape(-1),
                    out.reshape(-1), 0, out.shape[0])
    return n if n < out.shape[0] else n + 1  # the last row is the kernel's: one more needed


@numba.njit(cache=True, parallel=True)
def query_pairs_chunked(chunk, counts, qlo, qhi, qent, qbody, eent, same_set, self_contact,
                        origin, inv_h, tbits, bucket_start, keys, ents, boxes, out, threads,
                        counter):
    """``query_pairs`` over ``threads`` threads: query rows in fixed chunks of ``chunk`` rows
    (``counts (n_chunk,)``, n_chunk = ceil(n_query / chunk)), chunk c writing to its share
    out[c * per:(c + 1) * per], per = len(out) // n_chunk; the shares are then moved together
    in chunk order. Each thread takes the next chunk from ``counter`` (zero on entry,
    ``solver.workqueue``): the chunks' costs differ with the pairs they find. The chunks do not
    depend on the number of threads or on which thread runs which, so neither does the result:
    the pairs of ``query_pairs``, in the same order. Returns their number, or, when a chunk had
    more than its share (all rows but the last, which is the kernel's), a capacity that gives
    every chunk enough (more than len(out): the caller grows ``out`` and repeats)."""
    nq = qlo.shape[0]
    nc = counts.shape[0]
    per = out.shape[0] // nc
    flat = out.reshape(-1)
    rows = boxes.reshape(-1)
    for _ in numba.prange(threads):
        while True:
            c = fetch_add(counter, 1)
            if c >= nc:
                break
            i0 = c * chunk
            counts[c] = _query_rows(i0, min(nq, i0 + chunk), qlo, qhi, qent, qbody, eent,
                                    same_set, self_contact, origin, inv_h, tbits, bucket_start,
                                    keys, ents, rows, flat, c * per, (c + 1) * per)
    worst = 0
    for c in range(nc):
        worst = max(worst, counts[c])
    if worst >= per:  # a share's last row is the kernel's
        return (worst + 1) * nc
    n = counts[0]
    for c in range(1, nc):
        src = c * per
        for a in range(counts[c]):
            out[n + a, 0] = out[src + a, 0]
            out[n + a, 1] = out[src + a, 1]
        n += counts[c]
    return n


@numba.njit(cache=True, nogil=True)
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


@numba.njit(cache=True, inline="always")
def _grown(x0, y0, z0, x1, y1, z1, px, py, pz):
    """The box (x0, y0, z0) - (x1, y1, z1) grown to hold the point (px, py, pz)."""
    return min(x0, px), min(y0, py), min(z0, pz), max(x1, px), max(y1, py), max(z1, pz)


@numba.njit(cache=True, nogil=True)
def select_boxes(x, v, tau, ent, pad, body, blo, bhi, keep_all, skip, sel, lo, hi):
    """Broad-phase pre-selection (ALGORITHMS.md 3.2, "Cost").

    Swept, padded boxes of the rows of ``ent`` that can meet another body: rows whose box
    meets the bounding box (blo, bhi) of a body other than their own (all rows with
    ``keep_all``, for self-contact); rows with skip[i] != 0 are left out (``skip`` may be empty).
    Writes their indices (increasing) to sel and their boxes to lo, hi; returns how many."""
    n = 0
    n_body = blo.shape[0]
    use_skip = skip.shape[0] > 0
    swept = tau != 0.0  # else the box of the nodes alone (v is not read)
    for i in range(ent.shape[0]):
        if use_skip and skip[i] != 0:
            continue
        k = np.uint64(ent[i, 0])  # unsigned: no wraparound test on the node index
        x0 = x1 = x[k, 0]
        y0 = y1 = x[k, 1]
        z0 = z1 = x[k, 2]
        for j in range(ent.shape[1]):
            k = np.uint64(ent[i, j])
            px = x[k, 0]
            py = x[k, 1]
            pz = x[k, 2]
            x0, y0, z0, x1, y1, z1 = _grown(x0, y0, z0, x1, y1, z1, px, py, pz)
            if swept:
                x0, y0, z0, x1, y1, z1 = _grown(x0, y0, z0, x1, y1, z1, px + tau * v[k, 0],
                                                py + tau * v[k, 1], pz + tau * v[k, 2])
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
def _occ_cell(p, o, inv_c, dim):
    """Cell index of coordinate p on one axis of an occupancy grid (clamped to [0, dim - 1];
    monotone in p, so two overlapping intervals keep a common cell)."""
    t = (p - o) * inv_c
    if not t > 0.0:  # also NaN (the callers check finiteness first)
        return 0
    if t >= dim - 1:
        return dim - 1
    return int(t)


@numba.njit(cache=True, inline="always")
def _occ_range(lo, hi, k, origin, inv_c, dims):
    """The cells (x0, x1, y0, y1, z0, z1), bounds included, that box k (lo, hi)[k] touches."""
    return (_occ_cell(lo[k, 0], origin[0], inv_c, dims[0]),
            _occ_cell(hi[k, 0], origin[0], inv_c, dims[0]),
            _occ_cell(lo[k, 1], origin[1], inv_c, dims[1]),
            _occ_cell(hi[k, 1], origin[1], inv_c, dims[1]),
            _occ_cell(lo[k, 2], origin[2], inv_c, dims[2]),
            _occ_cell(hi[k, 2], origin[2], inv_c, dims[2]))


@numba.njit(cache=True)
def mark_cells(sel, lo, hi, body, origin, inv_c, dims, gen, bits, g):
    """Occupancy for the pre-selection of ``ContactContext.select`` (ALGORITHMS.md 3.2,
    "Cost"): every cell of the coarse grid (origin, 1 / inv_c, dims (3,)) that box k (lo, hi)[k]
    touches gets the bit ``1 << body[sel[k]]``. A cell's bits count only while ``gen`` of the
    cell equals ``g`` (an older generation reads as empty: no clearing between uses)."""
    for k in range(sel.shape[0]):
        bit = np.int64(1) << np.int64(body[sel[k]])
        x0, x1, y0, y1, z0, z1 = _occ_range(lo, hi, k, origin, inv_c, dims)
        for ix in range(x0, x1 + 1):
            for iy in range(y0, y1 + 1):
                c = (ix * dims[1] + iy) * dims[2]
                for iz in range(z0, z1 + 1):
                    if gen[c + iz] != g:
                        gen[c + iz] = g
                        bits[c + iz] = bit
                    else:
                        bits[c + iz] |= bit


@numba.njit(cache=True)
def keep_touching(sel, lo, hi, body, origin, inv_c, dims, gen, bits, g):
    """Keep, in order and in place, the rows k of (sel, lo, hi) whose box touches a cell of
    generation g (``mark_cells``) holding a bit of a body other than ``body[sel[k]]``; returns
    how many are kept. Two overlapping boxes share a cell (the cell of any common point), so a
    box that overlaps a marked box of another body is always kept: the pairs of the hash query
    over the kept rows are all the pairs of the rows given."""
    n = 0
    for k in range(sel.shape[0]):
        other = ~(np.int64(1) << np.int64(body[sel[k]]))
        x0, x1, y0, y1, z0, z1 = _occ_range(lo, hi, k, origin, inv_c, dims)
        touch = False
        for ix in range(x0, x1 + 1):
            for iy in range(y0, y1 + 1):
                c = (ix * dims[1] + iy) * dims[2]
                for iz in range(z0, z1 + 1):
                    if gen[c + iz] == g and (bits[c + iz] & other) != 0:
                        touch = True
                        break
                if touch:
                    break
            if touch:
                break
        if touch:
            sel[n] = sel[k]
            for d in range(3):
                lo[n, d] = lo[k, d]
                hi[n, d] = hi[k, d]
            n += 1
    return n


OCC_CELL = 1.0  # cell of the occupancy grid, a multiple of the hash's cell
OCC_MAX_CELLS = 1 << 22  # cells of the occupancy grid, at most (larger cells beyond)
OCC_MAX_BODIES = 63  # bodies the occupancy bits can tell apart


def occupancy_grid(lo, hi, cell):
    """(origin, inv_c, dims (3,) int64): a grid over the box (lo, hi) (3,) with cells of ``cell``
    [m], larger when the box would need more than OCC_MAX_CELLS."""
    lo = np.asarray(lo, np.float64)
    ext = np.maximum(np.asarray(hi, np.float64) - lo, 0.0)
    cell = max(float(cell), float(ext.max()) / (1 << 20), 1e-300)
    while True:
        dims = np.floor(ext / cell).astype(np.int64) + 1
        if int(dims.prod()) <= OCC_MAX_CELLS:
            break
        cell *= (float(dims.prod()) / OCC_MAX_CELLS) ** (1.0 / 3.0) * 1.01
    return lo, 1.0 / cell, dims


class Occupancy:
    """A coarse grid of which bodies' boxes touch each cell, to pre-select the rows of a broad
    phase (``mark_cells``, ``keep_touching``): a row whose box touches no cell of another body's
    boxes cannot be in a pair, and leaving it out of the hash and the queries changes no pair.
    Kept between steps (generations instead of clearing)."""

    def __init__(self):
        self.gen = np.zeros(16, np.int32)
        self.bits = np.zeros(16, np.int64)
        self.g = 0
        self.dims = np.ones(3, np.int64)
        self.origin = np.zeros(3)
        self.inv_c = 1.0

    def grid(self, lo, hi, cell) -> None:
        """The grid over the box (lo, hi) (3,) with cells of ``cell`` [m] (larger when the box
        would need more than OCC_MAX_CELLS); starts a new generation."""
        self.origin, self.inv_c, self.dims = occupancy_grid(lo, hi, cell)
        size = int(self.dims.prod())
        if self.gen.shape[0] < size:
            self.gen = np.zeros(size, np.int32)
            self.bits = np.zeros(size, np.int64)
            self.g = 0
        self.next()

    def next(self) -> None:
        """A new generation: every cell reads as empty."""
        self.g += 1
        if self.g >= 2**31 - 1:
            self.gen[:] = 0
            self.g = 1

    def mark(self, sel, lo, hi, body) -> None:
        mark_cells(sel, lo, hi, body, self.origin, self.inv_c, self.dims, self.gen, self.bits,
                   self.g)

    def keep(self, sel, lo, hi, body):
        """(sel, lo, hi) cut to the rows that touch another body's marked cells (in order)."""
        k = keep_touching(sel, lo, hi, body, self.origin, self.inv_c, self.dims, self.gen,
                          self.bits, self.g)
        return sel[:k], lo[:k], hi[:k]


@numba.njit(cache=True, nogil=True)
def mean_length(x, edges):
    """Mean length [m] of the segments ``edges (g, 2)`` (0 for none): the hash cell size and
    the touching band of ALGORITHMS.md 3 scale with it."""
    if edges.shape[0] == 0:
        return 0.0
    total = 0.0
    for g in range(edges.shape[0]):
        total += segment(x, edges[g, 0], x, edges[g, 1])[3]
    return total / edges.shape[0]


class SpatialHash:
    """Host side of the hash grid: owns the growable buffers (entries and pairs).

    ``chunked``: large queries run on the threads (``query_pairs_chunked``), from
    QUERY_MIN_CHUNKS chunks of query rows on, or from ``min_chunks`` where that is fewer (read
    at each query: the warm-up and the tests lower QUERY_MIN_CHUNKS); False keeps every query
    in the calling thread (a hash used outside the run's thread: the penetration measure,
    contact/diagnostics.py)."""

    def __init__(self, entry_capacity: int = 1024, pair_capacity: int = 1024,
                 chunked: bool = True, min_chunks: int | None = None):
        self.chunked = bool(chunked)
        self.min_chunks = min_chunks
        self._alloc_entries(entry_capacity)
        self.pairs_buf = np.zeros((max(pair_capacity, 16), 2), dtype=np.int64)
        self.grows = 0  # how often a buffer had to grow (reported in the pass summary)
        self.chunk_counts = np.zeros(1, dtype=np.int64)
        self.counter = np.zeros(1, dtype=np.int64)  # the threaded query's (solver/workqueue.py)
        self.box_rows = np.zeros((16, 8))  # the hashed boxes, a row each (build_hash)
        self.n_entries = 0
        self._bodies_of = None

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
        if self.box_rows.shape[0] < lo.shape[0]:
            self.grows += 1
            self.box_rows = np.zeros((int(lo.shape[0] * 1.5) + 16, 8))
        self.boxes = self.box_rows[:lo.shape[0]]
        self._bodies_of = None  # the bodies' array last written into the rows (query)
        while True:
            n = build_hash(lo, hi, self.origin, self.inv_h, self.tbits, self.tmp_keys,
                           self.tmp_ents, self.bucket_start, self.keys, self.ents, self.boxes)
            if n <= self.keys.shape[0]:
                self.n_entries = n
                return
            self.grows += 1
            self._alloc_entries(int(n * 1.5) + 16)

    def query(self, qlo, qhi, qent, qbody, eent, ebody, same_set: bool, self_contact: bool):
        """Candidate pairs (k, 2) int64 of (query row, hashed row), sorted; see ``query_pairs``.
        The result is a view of this hash's pair buffer: valid until its next query. The hashed
        rows' bodies ``ebody`` go into the box rows at the first query after a build and again
        only for another array object: an array changed in place between two queries of one
        build is not seen (the callers pass fresh arrays or ones they never change)."""
        nq = qlo.shape[0]
        n_chunk = -(-nq // QUERY_CHUNK)
        least = QUERY_MIN_CHUNKS if self.min_chunks is None else min(self.min_chunks,
                                                                      QUERY_MIN_CHUNKS)
        chunked = (self.chunked and n_chunk >= least
                   and numba.get_num_threads() > 1)
        if chunked and self.chunk_counts.shape[0] < n_chunk:
            self.chunk_counts = np.zeros(n_chunk, dtype=np.int64)
        if ebody is not self._bodies_of:  # beside their boxes (query_pairs), once a build
            self.boxes[:, 6] = ebody
            self._bodies_of = ebody
        while True:
            args = (qlo, qhi, qent, qbody, eent, same_set, self_contact, self.origin,
                    self.inv_h, self.tbits, self.bucket_start, self.keys, self.ents, self.boxes,
                    self.pairs_buf)
            if chunked:
                self.counter[0] = 0
                n = query_pairs_chunked(QUERY_CHUNK, self.chunk_counts[:n_chunk], *args,
                                        numba.get_num_threads(), self.counter)
            else:
                n = query_pairs(*args)
            if n <= self.pairs_buf.shape[0]:
                return self.pairs_buf[:n]
            self.grows += 1
            self.pairs_buf = np.zeros((int(n * 1.5) + 16, 2), dtype=np.int64)


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
    """``grid_for`` from the overall lowest and highest corners (3,) of the boxes (the origin a
    copy of lo). On three floats each in Python: numpy's calls on them took 9 us a call, and the
    passes call this every step."""
    lo = np.array(lo, dtype=np.float64)
    corners = lo.tolist() + np.asarray(hi, dtype=np.float64).tolist()
    if not all(math.isfinite(c) for c in corners):
        raise FloatingPointError("non-finite position or velocity in the contact broad phase")
    extent = max(corners[3] - corners[0], corners[4] - corners[1], corners[5] - corners[2])
    h = float(h) if h > 0.0 else max(extent, 1e-12)
    h = max(h, extent / (_AXIS_CELLS - 4), 1e-300)
    return lo, h
