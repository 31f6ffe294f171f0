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
built again when a node has moved too far, the surface changes (erosion, separation) or the
self-contact keys change; while the surface changes every step (erosion, particle conversion)
the plain broad phase runs instead (``SkinList.state``). Each step's boxes are made only for
the entities in kept pairs. The penetration measure keeps its pairs the same way
(``diagnostics.PenetrationMeter``).
"""

from __future__ import annotations

import numba
import numpy as np

SKIN = 0.2  # the skin, a fraction of the mean surface edge length h
REACH = 0.999  # share of the skin's half a node may use (round-off of the box arithmetic)


@numba.njit(cache=True)
def within_reach(x, v, tau, nodes, xb, limit):
    """True when every node ``nodes[k]`` has |x - xb[k]|_inf + tau |v|_inf <= limit (False
    for a non-finite position or velocity: the list is then built afresh, and the broad phase
    reports it)."""
    for k in range(nodes.shape[0]):
        i = nodes[k]
        for d in range(3):
            reach = abs(x[i, d] - xb[k, d]) + tau * abs(v[i, d])
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


class SkinList:
    """The kept candidate pairs of one contact pass (module docstring)."""

    def __init__(self, skin: float = SKIN):
        """``skin`` a fraction of h; 0: no list kept (the broad phase runs afresh every
        step)."""
        self.skin_rel = float(skin)
        self.pairs = None  # (k, 2) int64, sorted; None: build at the next step
        self._key = None
        self._xb = None
        self._pad_b = 0.0
        self.builds = 0  # how often the list was built (reported in the pass summary)

    def _key_of(self, surface, node_key, ents):
        """What the kept list depends on besides positions: the surface (its object, version
        and compact arrays), the self-contact keys and the entity rows' shapes."""
        return ((surface, surface.version, node_key, surface.faces, surface.edges, surface.nodes)
                + tuple(e.shape for e in ents))

    def _same(self, key) -> bool:
        old = self._key
        return (old is not None and len(key) == len(old)
                and all(a is b for a, b in zip(key[:6], old)) and key[1] == old[1]
                and key[6:] == old[6:])

    def state(self, surface, node_key, ents, x, v, tau, pad) -> str:
        """"kept": the kept list still holds every pair of this step (module docstring);
        "build": build it (none yet, or a node has moved too far); "changed": the surface or
        the self-contact keys changed since the last step. A surface that changes every step
        (erosion, particle conversion) would have the list built every step, at a larger cost
        than the plain broad phase: the caller runs the plain broad phase then and builds the
        list at the first step without a change."""
        key = self._key_of(surface, node_key, ents)
        if not self._same(key):
            first = self._key is None
            self._key = key
            self.pairs = None
            return "build" if first else "changed"
        if self.pairs is None:
            return "build"
        limit = REACH * (self._pad_b - pad)
        ok = limit > 0.0 and within_reach(x, v, tau, surface.nodes, self._xb, limit)
        return "kept" if ok else "build"

    def keep(self, surface, node_key, ents, x, pairs, pad_b, far=None) -> None:
        """Keep ``pairs`` (the broad phase of static boxes at x padded by pad_b). Only the
        entities in kept pairs have their boxes made each step: ``hashed`` (rows ``ents[0]``)
        and ``queries`` (``ents[1]``, or the same as hashed), with ``pairs`` in their positions
        (``local``) and the maps back to entity rows (increasing: the order is kept). ``far``
        (uint8 per pair, or None: zeros): what the pass's sweep starts each step with for the
        pair (its ``far_apart``: the pairs apart for as long as the list is kept)."""
        self.pairs = np.array(pairs, dtype=np.int64, copy=True)
        self.far = (np.zeros(self.pairs.shape[0], np.uint8) if far is None
                    else np.ascontiguousarray(far, dtype=np.uint8))
        if len(ents) == 1:
            used = np.unique(self.pairs)
            self.e_map = self.q_map = used
            self.e_ent = self.q_ent = np.ascontiguousarray(ents[0][used])
            self.local = np.searchsorted(used, self.pairs)
        else:
            self.e_map = np.unique(self.pairs[:, 1])
            self.q_map = np.unique(self.pairs[:, 0])
            self.e_ent = np.ascontiguousarray(ents[0][self.e_map])
            self.q_ent = np.ascontiguousarray(ents[1][self.q_map])
            self.local = np.stack([np.searchsorted(self.q_map, self.pairs[:, 0]),
                                   np.searchsorted(self.e_map, self.pairs[:, 1])], axis=1)
        self._key = self._key_of(surface, node_key, ents)
        self._xb = np.ascontiguousarray(x[surface.nodes])
        self._pad_b = float(pad_b)
        self.builds += 1
