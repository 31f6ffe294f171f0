"""Candidate lists kept between steps with a skin (a Verlet list) for the contact passes.

The broad phase of a contact pass (``passes.ContactPass._broad_phase``) pairs entities whose
swept boxes of this step, [x, x + tau U] padded by pad, overlap. Building it (bounds, selection,
spatial hash, query) every step cost as much as the sweeps over its pairs. Instead, a
``SkinList`` builds the pairs of *static* boxes at the positions x_b of its build, padded by
pad_b = pad + skin / 2, and keeps them while every surface node stays within reach:

    max over the surface nodes of (|x - x_b|_inf + tau |U|_inf) + pad <= pad_b   (a little less)

Then each entity's swept box of this step lies inside its static box of the build, so every pair
whose swept boxes overlap now is in the kept list. Each step the kept pairs are filtered with
this step's swept, padded boxes, by the same comparisons as the hash query; the list is sorted
as a fresh broad phase's (by query row, then hashed row) and filtering keeps that order, so the
candidate pairs, and everything computed from them, are bit-identical to a broad phase run afresh
every step, whenever the rebuilds happen (a resumed run rebuilds at its first step). The list is
built again when a node has moved too far, the mean edge length has grown past what the pass's
far-apart flags allow, the surface was rebuilt or reconnected (node separation) or the
self-contact keys change. The penetration measure keeps its pairs the same way
(``diagnostics.PenetrationMeter``).

Through surface changes (erosion removes elements at the contact at almost every step of an
oblique-sphere run) the list is followed, not built (``SkinList.follow``): it stays the list a
build at the build's positions x_b over the current surface would give. Every node's x_b is kept
(``_xb``, the whole mesh), so a node that erosion exposes has its position of the build, and the
reach test covers it from then on. The pairs of entities that left are dropped and the rest
renumbered: the surface's compact arrays keep their canonical order (faces by element slot,
edges by mesh edge, nodes by index; ``ContactContext.identities``), so the new row of an entity
that stays is increasing in its old row and the sorted order survives (``match_rows``,
``remap_pairs``). Each entity that joined gets its static box at x_b padded as at the build, and
its pairs with the other side: the build's hash of the hashed side (kept in the pass), a hash of
the build's queries (``q_hash``, node-face), the entities that joined since the build, and each
other (a scan: they are few). A build leaves rows out (``ContactPass._fresh_pairs``): those whose
box meets no other body's box (the bodies' boxes), and those of no occupancy cell another body's
rows touch. Such a row is in no pair of the build, but a joining entity could meet it, so the
build records what it selected against (``BuildRecord``: the bodies' boxes and the cells of the
rows the occupancy grid left out, per side), and a joining entity whose box leaves its body's
box of the build, or touches a cell of a left-out row of another body, has the list built afresh
instead (``_covers``; counted as ``uncovered``). Erosion exposes material inside a body, so its
new entities lie within the body's box and, in oblique-sphere, next to rows the grid kept: 0.2
to 4 % of the follows end in a build. A list built after one that followed changes has the larger
skin SKIN_CHANGING (fewer builds while erosion goes on).
"""

from __future__ import annotations

import numba
import numpy as np

from impactsim.contact.broadphase import Occupancy, SpatialHash, _shares_node, keep_touching

SKIN = 0.2  # the skin, a fraction of the mean surface edge length h
SKIN_CHANGING = 0.4  # the skin of a list built after one that followed surface changes (erosion
#                      goes on: the list is followed at every step, and a larger skin builds it
#                      less often)
REACH = 0.999  # share of the skin's half a node may use (round-off of the box arithmetic)


@numba.njit(cache=True)
def within_reach(x, v, tau, nodes, xb, limit):
    """True when every node ``nodes[k]`` has |x - xb|_inf + tau |v|_inf <= limit, xb the
    positions of every node at the build (also the nodes that joined the surface since: their
    positions then, when they were inside the body); False for a non-finite position or
    velocity (the list is then built afresh, and the broad phase reports it)."""
    for k in range(nodes.shape[0]):
        i = nodes[k]
        for d in range(3):
            reach = abs(x[i, d] - xb[i, d]) + tau * abs(v[i, d])
            if not reach <= limit:
                return False
    return True


@numba.njit(cache=True)
def overlapping_pairs(pairs, qlo, qhi, elo, ehi, qmap, emap, far, out, out_far):
    """The rows of ``pairs (k, 2)`` (query row, hashed row: rows of the boxes) whose boxes
    (qlo, qhi)[query] and (elo, ehi)[hashed] overlap (closed boxes, the comparisons of the hash
    query), in order, into ``out`` as entity rows (qmap[query], emap[hashed]), and their flags
    ``far[k]`` (``SkinList.keep``) into ``out_far``; returns their number."""
    n = 0
    for k in range(pairs.shape[0]):
        i = pairs[k, 0]
        j = pairs[k, 1]
        if (qlo[i, 0] <= ehi[j, 0] and elo[j, 0] <= qhi[i, 0]
                and qlo[i, 1] <= ehi[j, 1] and elo[j, 1] <= qhi[i, 1]
                and qlo[i, 2] <= ehi[j, 2] and elo[j, 2] <= qhi[i, 2]):
            out[n, 0] = qmap[i]
            out[n, 1] = emap[j]
            out_far[n] = far[k]
            n += 1
    return n


@numba.njit(cache=True)
def increasing(keys):
    """True when ``keys`` is strictly increasing (a count without an early exit: it
    vectorises)."""
    bad = 0
    for k in range(1, keys.shape[0]):
        bad += np.int64(not keys[k - 1] < keys[k])
    return bad == 0


@numba.njit(cache=True)
def face_identities(face_elem, face_local, out):
    """A face's identity (``ContactContext.identities``): 32 * element + 2 * local face, + 1
    for the second triangle of a hex quad (the rows after one of the same element and local
    face). True when they increase (the canonical order)."""
    bad = 0
    prev = -1
    for k in range(face_elem.shape[0]):
        f = np.int64(face_elem[k]) * 16 + np.int64(face_local[k])
        out[k] = 2 * f + np.int64(f == prev)
        prev = f
        if k > 0:
            bad += np.int64(not out[k - 1] < out[k])
    return bad == 0


@numba.njit(cache=True)
def match_rows(old_key, new_key, remap, fresh):
    """Follow a surface change for one kind of entity: ``old_key``, ``new_key`` the entities'
    identities before and after (strictly increasing: the compact arrays' canonical order,
    checked where they are made). Writes remap[i] = the new row of old row i (-1: gone) and
    the new rows with no old one to ``fresh``; returns how many fresh."""
    no = old_key.shape[0]
    nn = new_key.shape[0]
    i = 0
    j = 0
    nf = 0
    while i < no and j < nn:
        a = old_key[i]
        b = new_key[j]
        if a == b:
            remap[i] = j
            i += 1
            j += 1
        elif a < b:
            remap[i] = -1
            i += 1
        else:
            fresh[nf] = j
            nf += 1
            j += 1
    while i < no:
        remap[i] = -1
        i += 1
    while j < nn:
        fresh[nf] = j
        nf += 1
        j += 1
    return nf


@numba.njit(cache=True)
def joined_boxes(old_ident, ident, ent, body, key, node_key, xb, pad, remap, fresh, lo, hi, keys,
                 bodies):
    """``match_rows``, then for each entity that joined (rows ``fresh[:n]``): its static box
    at the build's positions ``xb`` padded by ``pad`` (``broadphase.select_boxes`` with tau =
    0: the same values), its keys (through ``node_key`` unless it is empty) and body. Returns
    n."""
    nf = match_rows(old_ident, ident, remap, fresh)
    use_key = node_key.shape[0] > 0
    for k in range(nf):
        r = fresh[k]
        for d in range(3):
            lo[k, d] = np.inf
            hi[k, d] = -np.inf
        for j in range(ent.shape[1]):
            i = ent[r, j]
            for d in range(3):
                lo[k, d] = min(lo[k, d], xb[i, d])
                hi[k, d] = max(hi[k, d], xb[i, d])
        for d in range(3):
            lo[k, d] -= pad
            hi[k, d] += pad
        for c in range(key.shape[1]):
            keys[k, c] = node_key[key[r, c]] if use_key else key[r, c]
        bodies[k] = body[r]
    return nf


@numba.njit(cache=True)
def covered(lo, hi, bodies, blo, bhi, marks, origin, inv_c, dims, gen, bits, g):
    """``SkinList._covers``: every box k (lo, hi)[k] of body bodies[k] within that body's box
    (blo, bhi)[bodies[k]], and, with ``marks``, touching no cell of the occupancy grid
    (origin, inv_c, dims, gen, bits, g) that holds a bit of another body (``keep_touching``'s
    test)."""
    for k in range(lo.shape[0]):
        b = bodies[k]
        for d in range(3):
            if not (lo[k, d] >= blo[b, d] and hi[k, d] <= bhi[b, d]):
                return False
    if not marks:
        return True
    sel = np.arange(lo.shape[0])
    return keep_touching(sel, lo.copy(), hi.copy(), bodies, origin, inv_c, dims, gen, bits,
                         g) == 0


@numba.njit(cache=True)
def remap_pairs(pairs, far, rq, re, out, out_far):
    """The pairs (rows, flags ``far``) whose two entities are still on the surface, their rows
    renumbered (``rq`` for column 0, ``re`` for column 1, from ``match_rows``), in order into
    ``out``, ``out_far``; returns how many. The renumbering is increasing over the kept rows,
    so the order (by column 0, then 1) is kept."""
    n = 0
    for k in range(pairs.shape[0]):
        a = rq[pairs[k, 0]]
        b = re[pairs[k, 1]]
        if a >= 0 and b >= 0:
            out[n, 0] = a
            out[n, 1] = b
            out_far[n] = far[k]
            n += 1
    return n


@numba.njit(cache=True)
def remap_rows(rows, remap):
    """rows[k] = remap[rows[k]] in place (-1 stays -1)."""
    for k in range(rows.shape[0]):
        if rows[k] >= 0:
            rows[k] = remap[rows[k]]


@numba.njit(cache=True)
def box_pairs(qlo, qhi, qkey, qbody, elo, ehi, ekey, ebody, same_set, self_contact, out):
    """Every pair (i, j) of box i of (qlo, qhi) and box j of (elo, ehi) that overlap (closed
    boxes, the comparisons of the hash query), of different bodies or, with ``self_contact``,
    without a shared key node (``broadphase.query_pairs``'s rule); with ``same_set`` j > i.
    A scan of every pair, for the few entities a surface change adds; ``out`` holds at least
    len(qlo) * len(elo) rows. Returns how many, sorted by (i, j)."""
    n = 0
    for i in range(qlo.shape[0]):
        for j in range(i + 1 if same_set else 0, elo.shape[0]):
            if (qlo[i, 0] <= ehi[j, 0] and elo[j, 0] <= qhi[i, 0]
                    and qlo[i, 1] <= ehi[j, 1] and elo[j, 1] <= qhi[i, 1]
                    and qlo[i, 2] <= ehi[j, 2] and elo[j, 2] <= qhi[i, 2]
                    and (qbody[i] != ebody[j]
                         or (self_contact and not _shares_node(qkey, i, ekey, j)))):
                out[n, 0] = i
                out[n, 1] = j
                n += 1
    return n


@numba.njit(cache=True)
def merge_pairs(a, fa, b, fb, out, out_far):
    """The sorted pair lists a and b (no pair in both) merged, sorted by (column 0, column 1),
    with their flags, into ``out``, ``out_far``."""
    i = 0
    j = 0
    n = 0
    na = a.shape[0]
    nb = b.shape[0]
    while i < na or j < nb:
        if j >= nb or (i < na and (a[i, 0] < b[j, 0]
                                   or (a[i, 0] == b[j, 0] and a[i, 1] < b[j, 1]))):
            out[n, 0] = a[i, 0]
            out[n, 1] = a[i, 1]
            out_far[n] = fa[i]
            i += 1
        else:
            out[n, 0] = b[j, 0]
            out[n, 1] = b[j, 1]
            out_far[n] = fb[j]
            j += 1
        n += 1


@numba.njit(cache=True)
def pair_maps(pairs, same_set, pos_q, pos_e, q_map, e_map, local, e_rows, q_rows, e_ent,
              q_ent):
    """The entities of the kept pairs: ``e_map`` the rows in column 1 (both columns with
    ``same_set``), ``q_map`` those in column 0 (the same as e_map with same_set), increasing,
    each once, and ``local`` the pairs as positions in the maps. ``pos_q``, ``pos_e`` (one slot
    per row) are zero on entry and on return. The maps' entity rows (of ``e_rows``,
    ``q_rows``) to ``e_ent``, ``q_ent`` (q_ent not written with same_set). Returns
    (len(q_map), len(e_map))."""
    for k in range(pairs.shape[0]):
        if same_set:
            pos_e[pairs[k, 0]] = 1
        else:
            pos_q[pairs[k, 0]] = 1
        pos_e[pairs[k, 1]] = 1
    ne = 0
    for r in range(pos_e.shape[0]):
        if pos_e[r] != 0:
            e_map[ne] = r
            ne += 1
            pos_e[r] = ne  # position + 1
    nq = ne
    if same_set:
        for k in range(pairs.shape[0]):
            local[k, 0] = pos_e[pairs[k, 0]] - 1
            local[k, 1] = pos_e[pairs[k, 1]] - 1
        for k in range(ne):
            q_map[k] = e_map[k]
    else:
        nq = 0
        for r in range(pos_q.shape[0]):
            if pos_q[r] != 0:
                q_map[nq] = r
                nq += 1
                pos_q[r] = nq
        for k in range(pairs.shape[0]):
            local[k, 0] = pos_q[pairs[k, 0]] - 1
            local[k, 1] = pos_e[pairs[k, 1]] - 1
        for k in range(nq):
            pos_q[q_map[k]] = 0
    for k in range(ne):
        pos_e[e_map[k]] = 0
        for c in range(e_rows.shape[1]):
            e_ent[k, c] = e_rows[e_map[k], c]
    if not same_set:
        for k in range(nq):
            for c in range(q_rows.shape[1]):
                q_ent[k, c] = q_rows[q_map[k], c]
    return nq, ne


class BuildRecord:
    """What a build of the list selected against, for following surface changes
    (``SkinList.follow``): filled by the broad phase (``ContactPass._fresh_pairs``)."""

    def __init__(self, marks):
        self.marks = marks  # two Occupancy grids for the rows left out (the list's own)
        self.grid = None  # (origin, cell) of the build's hash
        self.complete = False  # the broad phase reached its hash (else: nothing to follow from)
        self.blo = self.bhi = None  # the bodies' static boxes (body_bounds)
        # per side (0: hashed, 1: queries): rows in the hash (build rows), their keys and bodies,
        # and the occupancy marks of the rows the grid left out (None: no occupancy grid)
        self.rows = [None, None]
        self.keys = [None, None]
        self.bodies = [None, None]
        self.dropped = [None, None]
        self.q_boxes = None  # (lo, hi) of the hashed queries (node-face)


class SkinList:
    """The kept candidate pairs of one contact pass (module docstring)."""

    # what following a surface change needs of the build (solver/checkpoint.py leaves it out:
    # a resumed run builds the list at its first surface change instead of following it, which
    # gives the same pairs)
    CHECKPOINT_TRANSIENT = ("_record", "_added")

    def __init__(self, skin: float = SKIN):
        """``skin`` a fraction of h; 0: no list kept (the broad phase runs afresh every
        step)."""
        self.skin_rel = float(skin)
        self.skin_change = SKIN_CHANGING
        self._followed = False  # the list followed a surface change since its build
        self.pairs = None  # (k, 2) int64, sorted; None: build at the next step
        self._key = None
        self._xb = None
        self._pad_b = 0.0
        self._h_max = 0.0
        self.builds = 0  # how often the list was built (reported in the pass summary)
        self.follows = 0  # surface changes followed without a build
        self.uncovered = 0  # builds because a new entity fell outside the build's selection
        self.version = 0  # changes with every build and followed change
        self.q_hash = SpatialHash()  # the queries' static boxes of the build (node-face)
        self._drop = [Occupancy(), Occupancy()]
        self._pos = [np.zeros(16, np.int64), np.zeros(16, np.int64)]
        self._bufs = {}

    def _buffer(self, name, shape, dtype=np.int64):
        """A reusable scratch array (contents undefined), reallocated only when it must grow
        (``ContactContext.buffer``)."""
        b = self._bufs.get(name)
        rows = shape[0] if isinstance(shape, tuple) else shape
        if b is None or b.shape[0] < rows:
            full = (int(rows * 1.25) + 16,) + (tuple(shape[1:]) if isinstance(shape, tuple)
                                               else ())
            b = self._bufs[name] = np.empty(full, dtype=dtype)
        return b[:rows]

    def state(self, surface, node_key, topology, x, v, tau, pad, h) -> str:
        """"kept": the kept list still holds every pair of this step (module docstring);
        "build": build it (none yet, a node has moved too far, the mean edge length has grown
        past what the list's far-apart flags allow, or the surface was rebuilt or
        reconnected); "changed": the surface changed (erosion) since the last step, and the
        list is still within reach: ``follow`` it."""
        key = (surface, node_key, topology)
        old = self._key
        if (self.pairs is None or old is None or any(a is not b for a, b in zip(key, old))
                or key[2] != old[2] or self._xb.shape != x.shape):
            return "build"
        if not h <= self._h_max:
            return "build"
        limit = REACH * (self._pad_b - pad)
        if not (limit > 0.0 and within_reach(x, v, tau, surface.nodes, self._xb, limit)):
            return "build"
        return "kept" if surface.version == self._version else "changed"

    def keep(self, surface, node_key, topology, sides, x, pairs, pad_b, h_max, far=None,
             record=None, self_contact=False) -> None:
        """Keep ``pairs`` (the broad phase of static boxes at x padded by pad_b). Only the
        entities in kept pairs have their boxes made each step: ``hashed`` (rows ``sides[0]``)
        and ``queries`` (``sides[1]``, or the same as hashed), with ``pairs`` in their positions
        (``local``) and the maps back to entity rows (increasing: the order is kept). ``far``
        (uint8 per pair, or None: zeros): what the pass's sweep starts each step with for the
        pair (its ``far_apart``: the pairs apart for as long as the list is kept). ``sides``:
        per side (entity rows, bodies, keys, identities) (``ContactPass._sides``); ``record``
        what the build selected against (``BuildRecord``), to follow surface changes;
        ``h_max`` the largest mean edge length the far flags allow."""
        self.pairs = np.array(pairs, dtype=np.int64, copy=True)
        self.far = (np.zeros(self.pairs.shape[0], np.uint8) if far is None
                    else np.array(far, dtype=np.uint8, copy=True))
        self._key = (surface, node_key, topology)
        self._version = surface.version
        self._followed = False
        self._xb = np.array(x, copy=True)
        self._pad_b = float(pad_b)
        self._h_max = float(h_max)
        self._self_contact = bool(self_contact)
        self._record = record if record is not None and record.complete else None
        self._sides = [s[3] for s in sides]
        if self._record is not None:
            r = self._record
            self._h_rows = [None if r.rows[t] is None else r.rows[t].copy()
                            for t in range(2)]
            if r.q_boxes is not None:  # the queries' static boxes in a hash of their own
                self.q_hash.build(r.q_boxes[0], r.q_boxes[1], r.grid[0], r.grid[1])
            r.q_boxes = None
            self._added = [_Added(), _Added()]
        self.builds += 1
        self._index(sides)

    def _index(self, sides) -> None:
        """The maps and entity rows of the kept pairs (``pair_maps``)."""
        same = len(sides) == 1
        ne_rows = sides[0][0].shape[0]
        nq_rows = sides[-1][0].shape[0]
        for t, n in ((0, nq_rows), (1, ne_rows)):
            if self._pos[t].shape[0] < n:
                self._pos[t] = np.zeros(int(n * 1.25) + 16, np.int64)
        k = self.pairs.shape[0]
        q_map = self._buffer("q_map", nq_rows)
        e_map = self._buffer("e_map", ne_rows)
        self.local = self._buffer("local", (k, 2))
        e_rows, q_rows = sides[0][0], sides[-1][0]
        e_ent = self._buffer("e_ent", (ne_rows if k else 0, e_rows.shape[1]), e_rows.dtype)
        q_ent = e_ent if same else self._buffer("q_ent", (nq_rows if k else 0,
                                                          q_rows.shape[1]), q_rows.dtype)
        nq, ne = pair_maps(self.pairs, same, self._pos[0][:nq_rows], self._pos[1][:ne_rows],
                           q_map, e_map, self.local, e_rows, q_rows, e_ent, q_ent)
        self.e_map = e_map[:ne]
        self.q_map = self.e_map if same else q_map[:nq]
        self.e_ent = e_ent[:ne]
        self.q_ent = self.e_ent if same else q_ent[:nq]
        self.version += 1

    def build_skin(self) -> float:
        """The skin (a fraction of h) of the next build: SKIN_CHANGING (at least skin_rel)
        when the list being replaced followed surface changes, else skin_rel."""
        if self.pairs is not None and self._followed:
            return max(self.skin_rel, self.skin_change)
        return self.skin_rel

    def new_record(self) -> BuildRecord:
        return BuildRecord(self._drop)

    def follow(self, surface, sides, node_key, e_hash, far_fn) -> bool:
        """Follow a surface change (erosion) without a build: the pairs of entities that left
        dropped, the rest renumbered (the compact arrays keep their canonical order, so the
        sorted order survives: ``match_rows``, ``remap_pairs``), and the pairs of every entity
        that joined, from static boxes at the build's positions, padded as at the build:
        against the build's hashes of the other side (``e_hash`` of the hashed side, ``q_hash``
        of the queries), against the entities that joined since the build and among
        themselves (``box_pairs``). The list is then the one a build at the build's positions
        over the current surface gives. False (the caller builds the list) when the build
        left out an entity of the other side that a joining one may meet (``_covers``) or the
        change is not a removal the identities follow. ``far_fn(pairs, xb)``: the far-apart
        flags of new pairs at the build's positions."""
        r = self._record
        if r is None:
            return False
        same = len(sides) == 1
        remaps = []
        new = []
        for t, (ent, body, key, ident) in enumerate(sides):
            old_ident = self._sides[t]
            if ident is None or old_ident is None:
                return False  # identities out of order
            remap = self._buffer(f"remap{t}", old_ident.shape[0])
            fresh = self._buffer(f"fresh{t}", ident.shape[0])
            m = ident.shape[0]  # room for every row (only the joined ones are written)
            lo = self._buffer(f"lo{t}", (m, 3), np.float64)
            hi = self._buffer(f"hi{t}", (m, 3), np.float64)
            keys = self._buffer(f"keys{t}", (m, key.shape[1]))
            bodies = self._buffer(f"bodies{t}", m, body.dtype)
            nf = joined_boxes(old_ident, ident, ent, body, key,
                              _NO_KEY if node_key is None else node_key, self._xb,
                              self._pad_b, remap, fresh, lo, hi, keys, bodies)
            remaps.append(remap)
            new.append((fresh[:nf].copy(), lo[:nf].copy(), hi[:nf].copy(), keys[:nf].copy(),
                        bodies[:nf].copy()))
        for t in range(len(sides)):  # a new entity meets the other side's rows
            if new[t][0].shape[0] and not self._covers(0 if same else 1 - t, new[t][1],
                                                       new[t][2], new[t][4]):
                self.uncovered += 1
                return False
        re = remaps[0]
        rq = re if same else remaps[1]
        out = self._buffer("kept", self.pairs.shape)
        out_far = self._buffer("kept_far", self.pairs.shape[0], np.uint8)
        n = remap_pairs(self.pairs, self.far, rq, re, out, out_far)
        kept, kept_far = out[:n], out_far[:n]
        for t in range(len(sides)):
            if self._h_rows[t] is not None:
                remap_rows(self._h_rows[t], remaps[t])
            self._added[t].remap(remaps[t])
        sc = self._self_contact
        parts = []
        if same:
            fr, lo, hi, k, b = new[0]
            if fr.shape[0]:
                i, j = _hash_pairs(e_hash, lo, hi, k, b, r, 0, self._h_rows[0], sc)
                parts.append(_ordered(fr[i], j))
                i, j = self._added[0].pairs(lo, hi, k, b, sc)
                parts.append(_ordered(fr[i], j))
                bp = np.empty((fr.shape[0] * fr.shape[0], 2), np.int64)
                m = box_pairs(lo, hi, k, b, lo, hi, k, b, True, sc, bp)
                parts.append(np.stack([fr[bp[:m, 0]], fr[bp[:m, 1]]], axis=1))
        else:
            fe, elo, ehi, ek, eb = new[0]
            fq, qlo, qhi, qk, qb = new[1]
            if fq.shape[0]:
                i, j = _hash_pairs(e_hash, qlo, qhi, qk, qb, r, 0, self._h_rows[0], sc)
                parts.append(np.stack([fq[i], j], axis=1))
                i, j = self._added[0].pairs(qlo, qhi, qk, qb, sc)
                parts.append(np.stack([fq[i], j], axis=1))
            if fe.shape[0]:
                i, j = _hash_pairs(self.q_hash, elo, ehi, ek, eb, r, 1, self._h_rows[1], sc)
                parts.append(np.stack([j, fe[i]], axis=1))
                i, j = self._added[1].pairs(elo, ehi, ek, eb, sc)
                parts.append(np.stack([j, fe[i]], axis=1))
            if fq.shape[0] and fe.shape[0]:
                bp = np.empty((fq.shape[0] * fe.shape[0], 2), np.int64)
                m = box_pairs(qlo, qhi, qk, qb, elo, ehi, ek, eb, False, sc, bp)
                parts.append(np.stack([fq[bp[:m, 0]], fe[bp[:m, 1]]], axis=1))
        for t in range(len(sides)):
            self._added[t].append(*new[t])
        if parts:
            add = np.concatenate(parts).astype(np.int64)
            add = np.ascontiguousarray(add[np.lexsort((add[:, 1], add[:, 0]))])
        else:
            add = np.zeros((0, 2), np.int64)
        if add.shape[0]:
            add_far = np.ascontiguousarray(far_fn(add, self._xb), dtype=np.uint8)
            self.pairs = np.empty((kept.shape[0] + add.shape[0], 2), np.int64)
            self.far = np.empty(self.pairs.shape[0], np.uint8)
            merge_pairs(kept, kept_far, add, add_far, self.pairs, self.far)
        else:
            self.pairs = np.ascontiguousarray(kept)
            self.far = np.ascontiguousarray(kept_far)
        self._sides = [s[3] for s in sides]
        self._version = surface.version
        self._followed = True
        self.follows += 1
        self._index(sides)
        return True

    def _covers(self, t, lo, hi, bodies) -> bool:
        """True when every entity of side t the build left out lies apart from the boxes
        (lo, hi) of bodies ``bodies``: each box within its body's static box of the build
        (so that any entity of another body it meets met that body's box, and was selected),
        and no cell of it (the build's occupancy grid) touched by a row of another body the
        grid left out (``BuildRecord.dropped``; ``keep_touching``'s test). With self-contact
        the build keeps every row."""
        if self._self_contact:
            return True
        r = self._record
        d = r.dropped[t]
        if d is None:
            return covered(lo, hi, bodies, r.blo, r.bhi, False, _ZERO3, 1.0, _ONES3, _NO_GEN,
                           _NO_BITS, 0)
        return covered(lo, hi, bodies, r.blo, r.bhi, True, d.origin, d.inv_c, d.dims, d.gen,
                       d.bits, d.g)


def _hash_pairs(hsh, lo, hi, keys, bodies, record, t, rows, self_contact):
    """(i, rows): the boxes (lo, hi) against the build's hash ``hsh`` of side t: the box's
    index and the current row of each entry it meets (entries whose entity left dropped)."""
    if rows is None or rows.shape[0] == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    p = hsh.query(lo, hi, keys, bodies, record.keys[t], record.bodies[t], False, self_contact)
    j = rows[p[:, 1]]
    ok = j >= 0
    return p[ok, 0].copy(), j[ok]


def _ordered(a, b):
    """Pairs of one entity list (edge-edge), the smaller row first."""
    return np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)


class _Added:
    """The entities of one side that joined the surface since the list's build: their current
    rows, static boxes at the build's positions, keys and bodies."""

    def __init__(self):
        self.rows = np.zeros(0, np.int64)
        self.lo = np.zeros((0, 3))
        self.hi = np.zeros((0, 3))
        self.keys = None
        self.bodies = np.zeros(0, np.int32)

    def remap(self, remap) -> None:
        if self.rows.shape[0] == 0:
            return
        remap_rows(self.rows, remap)
        ok = self.rows >= 0
        if not ok.all():
            self.rows, self.lo, self.hi = self.rows[ok], self.lo[ok], self.hi[ok]
            self.keys, self.bodies = self.keys[ok], self.bodies[ok]

    def append(self, rows, lo, hi, keys, bodies) -> None:
        if rows.shape[0] == 0:
            return
        if self.keys is None or self.rows.shape[0] == 0:
            self.rows, self.lo, self.hi, self.keys, self.bodies = (
                rows.copy(), lo, hi, keys, bodies.astype(np.int32))
            return
        self.rows = np.concatenate([self.rows, rows])
        self.lo = np.concatenate([self.lo, lo])
        self.hi = np.concatenate([self.hi, hi])
        self.keys = np.concatenate([self.keys, keys])
        self.bodies = np.concatenate([self.bodies, bodies.astype(np.int32)])

    def pairs(self, lo, hi, keys, bodies, self_contact):
        """(i, rows): the pairs of the boxes (lo, hi) with these entities."""
        if self.rows.shape[0] == 0 or lo.shape[0] == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        out = np.empty((lo.shape[0] * self.rows.shape[0], 2), np.int64)
        m = box_pairs(lo, hi, keys, bodies, self.lo, self.hi, self.keys, self.bodies, False,
                      self_contact, out)
        return out[:m, 0].copy(), self.rows[out[:m, 1]]


_NO_KEY = np.zeros(0, np.int64)
_ZERO3 = np.zeros(3)
_ONES3 = np.ones(3, np.int64)
_NO_GEN = np.zeros(0, np.int32)
_NO_BITS = np.zeros(0, np.int64)
