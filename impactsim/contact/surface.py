"""The contact surface: boundary faces, edges and nodes of every body, updatable in place.

State (fixed size, one slot per element face / mesh edge / node):

- ``face_flag (4 e,) bool``: slot ``4*elem + local`` is a boundary face (alive element whose
  neighbour across that face is missing or eroded);
- ``edge_count (m,) int32``: number of boundary faces using mesh edge ``k`` (a reference count;
  the edge is on the surface when it is positive);
- ``node_count (n,) int32``: number of boundary faces using node ``k``.

Removing an element (erosion) touches only its four faces (``remove_elements``,
``free_face_changes``): a boundary face of it disappears, an interior face becomes a boundary face
of the neighbour. The compact arrays the contact passes read are kept in canonical order (faces
by ``4*elem + local``, edges and nodes by index), so an incremental update gives exactly the
arrays a recomputation gives: after a removal ``_compact_changes`` merges the changed faces,
edges and nodes into the previous arrays (cost: a copy of the surface, lookups for the changes
only); a rebuild or a reconnection regenerates them from the flags (``_compact``).

Compact arrays (``_compact_kernel``, ``_compact_changes``):
  faces (f,3) int32 outward-oriented node triples; face_elem (f,) int64; face_local (f,) int8;
  face_body (f,) int32; face_edges (f,3) int64 indices into ``edges``;
  edges (g,2) int32 (smaller node first); edge_body (g,) int32; edge_mesh (g,) int64 index into
  ``mesh_edges``; nodes (h,) int32 sorted; node_body (h,) int32.
"""

from __future__ import annotations

import numba
import numpy as np

from impactsim.contact.broadphase import mean_length
from impactsim.mesh.topology import (FACE_EDGES, LOCAL_EDGES, LOCAL_FACES, face_adjacency,
                                     unique_edges)

ERODED = 3  # impactsim.model.ERODED (kept literal so this module stays free of the model)


@numba.njit(cache=True)
def free_face_changes(ids, adj, alive, face_flag, events):
    """The free faces after removing elements ``ids`` in order (ALGORITHMS.md 4.2: the surface
    follows erosion; already removed ids are skipped), for every structure that keeps them
    (``Surface`` here, ``impactsim.fracture.boundary.Boundary``). For each newly removed element
    e and local face i: a free face of e stops being one; an inner face (alive neighbour nb)
    becomes nb's free face, with nb's local numbering. Updates ``alive`` and ``face_flag``
    (slot ``4*elem + local``) and writes the changes in that order to ``events`` (room for 4
    per id): slot s for a face that becomes free, -1 - s for one that stops being free.
    Returns (events written, elements removed).

    The element's face count is ``adj.shape[1]`` (4 for tets, 6 for hexes, whose quads
    ``impactsim.contact.hexes`` and ``impactsim.fracture.hexes`` follow with it): slots are
    ``nf*elem + local`` and ``events`` needs room for nf per id."""
    nf = adj.shape[1]
    m = 0
    removed = 0
    for k in range(ids.shape[0]):
        e = ids[k]
        if not alive[e]:
            continue
        alive[e] = False
        removed += 1
        for i in range(nf):
            slot = nf * e + i
            if face_flag[slot]:
                face_flag[slot] = False
                events[m] = -1 - slot
                m += 1
                continue
            nb = adj[e, i]
            if nb < 0 or not alive[nb]:
                continue
            for jn in range(nf):
                if adj[nb, jn] == e:
                    face_flag[nf * nb + jn] = True
                    events[m] = nf * nb + jn
                    m += 1
                    break
    return m, removed


@numba.njit(cache=True)
def _remove_elements_kernel(ids, conn, adj, elem_edges, alive, face_flag, edge_count, node_count,
                            local_faces, face_edges, events):
    """Incremental surface update for deleted elements: the face changes of
    ``free_face_changes``, then the reference counts of the changed faces' edges and nodes.
    Returns (elements actually removed, face changes written to ``events``)."""
    m, removed = free_face_changes(ids, adj, alive, face_flag, events)
    for k in range(m):
        s = events[k]
        step = 1
        if s < 0:
            s = -1 - s
            step = -1
        e = s // 4
        i = s % 4
        for j in range(3):
            edge_count[elem_edges[e, face_edges[i, j]]] += step
            node_count[conn[e, local_faces[i, j]]] += step
    return removed, m


@numba.njit(cache=True)
def _face_counts(elems, conn, elem_edges, face_flag, edge_count, node_count, local_faces,
                 face_edges, step):
    """Add ``step`` (+1 / -1) to the edge and node counts of the free faces of ``elems``."""
    for k in range(elems.shape[0]):
        e = elems[k]
        for i in range(4):
            if face_flag[4 * e + i]:
                for j in range(3):
                    edge_count[elem_edges[e, face_edges[i, j]]] += step
                    node_count[conn[e, local_faces[i, j]]] += step


@numba.njit(cache=True)
def _open_faces(changed, conn, adj, local_faces):
    """Cut the adjacency across every face of the ``changed`` elements whose two sides no
    longer share its three nodes (node separation repointed a corner): both sides become -1.
    A release only ever opens faces (its new nodes are shared by the part that took them)."""
    for k in range(changed.shape[0]):
        e = changed[k]
        for i in range(4):
            nb = adj[e, i]
            if nb < 0:
                continue
            a0, a1, a2 = conn[e, local_faces[i, 0]], conn[e, local_faces[i, 1]], \
                conn[e, local_faces[i, 2]]
            for jn in range(4):
                if adj[nb, jn] != e:
                    continue
                same = 0
                for j in range(3):
                    c = conn[nb, local_faces[jn, j]]
                    if c == a0 or c == a1 or c == a2:
                        same += 1
                if same < 3:
                    adj[e, i] = -1
                    adj[nb, jn] = -1
                break


@numba.njit(cache=True)
def _reflag(elems, adj, alive, face_flag):
    """face_flag of the faces of ``elems`` from the adjacency and ``alive`` (as ``rebuild``)."""
    for k in range(elems.shape[0]):
        e = elems[k]
        for i in range(4):
            nb = adj[e, i]
            face_flag[4 * e + i] = alive[e] and not (nb >= 0 and alive[nb])


@numba.njit(cache=True)
def _compact_kernel(face_flag, conn, elem_body, elem_edges, mesh_edges, edge_count, node_count,
                    node_body_all, local_faces, face_edges_local, edge_index):
    """The compact arrays of the module docstring from the flags and reference counts:
    (faces, face_elem, face_local, face_body, face_edges, edges, edge_mesh, edge_body, nodes,
    node_body), faces in slot order, edges and nodes in index order. ``edge_index (m,) int64``
    is scratch (mesh edge -> surface edge). One pass over each of the three slot arrays; the
    same arrays as the numpy formulas (flatnonzero and gathers) it replaces, at a fraction of
    their cost (tests/unit/test_contact_surface.py)."""
    nf = 0
    for s in range(face_flag.shape[0]):
        if face_flag[s]:
            nf += 1
    ng = 0
    for m in range(edge_count.shape[0]):
        if edge_count[m] > 0:
            ng += 1
    nh = 0
    for i in range(node_count.shape[0]):
        if node_count[i] > 0:
            nh += 1
    edges = np.empty((ng, 2), dtype=np.int32)
    edge_mesh = np.empty(ng, dtype=np.int64)
    edge_body = np.empty(ng, dtype=np.int32)
    g = 0
    for m in range(edge_count.shape[0]):
        edge_index[m] = -1
        if edge_count[m] > 0:
            edge_mesh[g] = m
            edges[g, 0] = mesh_edges[m, 0]
            edges[g, 1] = mesh_edges[m, 1]
            edge_body[g] = node_body_all[mesh_edges[m, 0]]
            edge_index[m] = g
            g += 1
    faces = np.empty((nf, 3), dtype=np.int32)
    face_elem = np.empty(nf, dtype=np.int64)
    face_local = np.empty(nf, dtype=np.int8)
    face_body = np.empty(nf, dtype=np.int32)
    face_edges = np.empty((nf, 3), dtype=np.int64)
    k = 0
    for s in range(face_flag.shape[0]):
        if face_flag[s]:
            e = s // 4
            i = s - 4 * e
            face_elem[k] = e
            face_local[k] = i
            face_body[k] = elem_body[e]
            for j in range(3):
                faces[k, j] = conn[e, local_faces[i, j]]
                face_edges[k, j] = edge_index[elem_edges[e, face_edges_local[i, j]]]
            k += 1
    nodes = np.empty(nh, dtype=np.int32)
    node_body = np.empty(nh, dtype=np.int32)
    h = 0
    for i in range(node_count.shape[0]):
        if node_count[i] > 0:
            nodes[h] = i
            node_body[h] = node_body_all[i]
            h += 1
    return (faces, face_elem, face_local, face_body, face_edges, edges, edge_mesh, edge_body,
            nodes, node_body)


@numba.njit(cache=True, inline="always")
def _lower(keys, key):
    """First index of the ascending ``keys`` whose value is not below ``key``."""
    lo, hi = 0, keys.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if keys[mid] < key:
            lo = mid + 1
        else:
            hi = mid
    return lo


@numba.njit(cache=True, inline="always")
def _joins_and_leaves(changed, keys, count):
    """Of the ``changed`` keys (mesh edges or nodes, ascending), those that join the ascending
    list ``keys`` (count > 0 now, not listed) with the position of the old entry they go
    before, and the positions of those that leave it (listed, count 0 now): (joining keys,
    their positions, leaving positions, how many join, how many leave)."""
    add = np.empty(changed.shape[0], np.int64)
    ins = np.empty(changed.shape[0], np.int64)
    dele = np.empty(changed.shape[0], np.int64)
    na = 0
    nd = 0
    for k in range(changed.shape[0]):
        c = changed[k]
        at = _lower(keys, c)
        was = at < keys.shape[0] and keys[at] == c
        if count[c] > 0 and not was:
            add[na] = c
            ins[na] = at
            na += 1
        elif was and not count[c] > 0:
            dele[nd] = at
            nd += 1
    return add, ins, dele, na, nd


@numba.njit(cache=True, inline="always")
def _lower_face(face_elem, face_local, slot):
    """``_lower`` over the face keys 4 * face_elem + face_local (ascending)."""
    lo, hi = 0, face_elem.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if 4 * face_elem[mid] + face_local[mid] < slot:
            lo = mid + 1
        else:
            hi = mid
    return lo


@numba.njit(cache=True, inline="always")
def _next_stop(dels, nd, di, ins, na, ai, n):
    """The old position where the next run of kept entries stops: the next deletion or
    insertion point, or n."""
    stop = n
    if di < nd:
        stop = dels[di]
    if ai < na and ins[ai] < stop:
        stop = ins[ai]
    return stop


@numba.njit(cache=True)
def _changed_slots(events, m):
    """The face slots of ``events[:m]`` (``free_face_changes``), sorted, each once."""
    cs = np.empty(m, np.int64)
    for k in range(m):
        s = events[k]
        cs[k] = s if s >= 0 else -1 - s
    return np.unique(cs)


@numba.njit(cache=True)
def _compact_changes(events, m, face_flag, edge_count, node_count, conn, elem_body, elem_edges,
                     mesh_edges, node_body_all, local_faces, face_edges_local, faces, face_elem,
                     face_local, face_body, face_edges, edges, edge_mesh, edge_body, nodes,
                     node_body):
    """The compact arrays of ``_compact_kernel`` after the face changes ``events[:m]`` of a
    removal (``_remove_elements_kernel``), from the arrays before it: only the changed faces
    and their edges and nodes are looked up in the flags and counts, the rest is copied in
    order (kept faces' edge indices renumbered). The same arrays as ``_compact_kernel``
    (tests/unit/test_contact_surface.py) without its scans of every face slot and mesh edge
    and its gathers of every boundary face's element rows."""
    cs = _changed_slots(events, m)
    nc = cs.shape[0]
    # the changed faces, edges and nodes: which join (and before which old entry), which
    # leave (their positions in the old lists)
    add_f = np.empty(nc, np.int64)
    ins_f = np.empty(nc, np.int64)
    del_f = np.empty(nc, np.int64)
    na_f = 0
    nd_f = 0
    ce = np.empty(3 * nc, np.int64)
    cn = np.empty(3 * nc, np.int64)
    nf_old = face_elem.shape[0]
    for k in range(nc):
        s = cs[k]
        e = s // 4
        i = s - 4 * e
        for j in range(3):
            ce[3 * k + j] = elem_edges[e, face_edges_local[i, j]]
            cn[3 * k + j] = conn[e, local_faces[i, j]]
        at = _lower_face(face_elem, face_local, s)
        was = at < nf_old and 4 * face_elem[at] + face_local[at] == s
        if face_flag[s] and not was:
            add_f[na_f] = s
            ins_f[na_f] = at
            na_f += 1
        elif was and not face_flag[s]:
            del_f[nd_f] = at
            nd_f += 1
    ce = np.unique(ce)
    cn = np.unique(cn)
    add_e, ins_e, del_e, na_e, nd_e = _joins_and_leaves(ce, edge_mesh, edge_count)
    add_n, ins_n, del_n, na_n, nd_n = _joins_and_leaves(cn, nodes, node_count)
    # each list: runs of kept old entries copied whole, new entries inserted before the old
    # entry their lower bound names, deleted ones skipped
    # edges (mesh index order), with the old -> new index of each kept edge
    ng_old = edge_mesh.shape[0]
    ng = ng_old - nd_e + na_e
    n_edges = np.empty((ng, 2), np.int32)
    n_edge_mesh = np.empty(ng, np.int64)
    n_edge_body = np.empty(ng, np.int32)
    remap = np.empty(ng_old, np.int64)
    o = 0
    g = 0
    a = 0
    d = 0
    while True:
        stop = _next_stop(del_e, nd_e, d, ins_e, na_e, a, ng_old)
        ln = stop - o
        n_edges[g:g + ln] = edges[o:stop]
        n_edge_mesh[g:g + ln] = edge_mesh[o:stop]
        n_edge_body[g:g + ln] = edge_body[o:stop]
        for t in range(ln):
            remap[o + t] = g + t
        g += ln
        o = stop
        if a < na_e and ins_e[a] == o:
            me = add_e[a]
            n_edges[g, 0] = mesh_edges[me, 0]
            n_edges[g, 1] = mesh_edges[me, 1]
            n_edge_mesh[g] = me
            n_edge_body[g] = node_body_all[mesh_edges[me, 0]]
            g += 1
            a += 1
        elif d < nd_e and del_e[d] == o:
            remap[o] = -1
            o += 1
            d += 1
        else:
            break
    same_edges = na_e == 0 and nd_e == 0
    # faces (slot order)
    nf = nf_old - nd_f + na_f
    n_faces = np.empty((nf, 3), np.int32)
    n_face_elem = np.empty(nf, np.int64)
    n_face_local = np.empty(nf, np.int8)
    n_face_body = np.empty(nf, np.int32)
    n_face_edges = np.empty((nf, 3), np.int64)
    o = 0
    k = 0
    a = 0
    d = 0
    while True:
        stop = _next_stop(del_f, nd_f, d, ins_f, na_f, a, nf_old)
        ln = stop - o
        n_faces[k:k + ln] = faces[o:stop]
        n_face_elem[k:k + ln] = face_elem[o:stop]
        n_face_local[k:k + ln] = face_local[o:stop]
        n_face_body[k:k + ln] = face_body[o:stop]
        if same_edges:
            n_face_edges[k:k + ln] = face_edges[o:stop]
        else:
            for t in range(ln):
                for j in range(3):
                    n_face_edges[k + t, j] = remap[face_edges[o + t, j]]
        k += ln
        o = stop
        if a < na_f and ins_f[a] == o:
            s = add_f[a]
            e = s // 4
            i = s - 4 * e
            n_face_elem[k] = e
            n_face_local[k] = i
            n_face_body[k] = elem_body[e]
            for j in range(3):
                n_faces[k, j] = conn[e, local_faces[i, j]]
                n_face_edges[k, j] = _lower(n_edge_mesh, elem_edges[e, face_edges_local[i, j]])
            k += 1
            a += 1
        elif d < nd_f and del_f[d] == o:
            o += 1
            d += 1
        else:
            break
    # nodes (index order)
    nh_old = nodes.shape[0]
    nh = nh_old - nd_n + na_n
    n_nodes = np.empty(nh, np.int32)
    n_node_body = np.empty(nh, np.int32)
    o = 0
    h = 0
    a = 0
    d = 0
    while True:
        stop = _next_stop(del_n, nd_n, d, ins_n, na_n, a, nh_old)
        ln = stop - o
        n_nodes[h:h + ln] = nodes[o:stop]
        n_node_body[h:h + ln] = node_body[o:stop]
        h += ln
        o = stop
        if a < na_n and ins_n[a] == o:
            n_nodes[h] = add_n[a]
            n_node_body[h] = node_body_all[add_n[a]]
            h += 1
            a += 1
        elif d < nd_n and del_n[d] == o:
            o += 1
            d += 1
        else:
            break
    return (n_faces, n_face_elem, n_face_local, n_face_body, n_face_edges, n_edges,
            n_edge_mesh, n_edge_body, n_nodes, n_node_body)


class Surface:
    """Boundary faces, edges and nodes of all bodies of a tet mesh (see the module docstring).

    ``conn (e,4) int32`` positive tets; ``elem_body (e,) int32``; ``status (e,) int8``
    (elements with status ERODED are not part of the mesh); ``node_body (n,) int32`` (derived
    from the elements when None); ``n_node`` the number of nodes (max node + 1 when None).
    """

    # the compact arrays after a removal from the changes alone (``_compact_changes``); a
    # subclass whose compact arrays hold more than the tets' (contact/hexes.py) recomputes them
    incremental = True

    def __init__(self, conn, elem_body, status=None, node_body=None, n_node=None):
        self.conn = np.ascontiguousarray(conn, dtype=np.int32)
        self.elem_body = np.ascontiguousarray(elem_body, dtype=np.int32)
        n_elem = self.conn.shape[0]
        if n_node is None:
            n_node = int(self.conn.max()) + 1 if n_elem else 0
        self.n_node = int(n_node)
        if node_body is None:
            node_body = np.zeros(self.n_node, dtype=np.int32)
            node_body[self.conn.reshape(-1)] = np.repeat(self.elem_body, 4)
        self.node_body_all = np.ascontiguousarray(node_body, dtype=np.int32)
        self.mesh_edges, self.elem_edges = unique_edges(self.conn)
        self.adj = face_adjacency(self.conn)
        self.version = 0
        self._events = np.empty(0, dtype=np.int64)  # scratch of remove_elements
        self.rebuild(status)

    @classmethod
    def from_model(cls, model) -> "Surface":
        if getattr(model, "blocks", None):  # hexahedra too: their quads as triangles
            from impactsim.contact.hexes import HexSurface

            return HexSurface(model)
        return cls(model.conn, model.elem_body, model.status, model.node_body, model.n_node)

    # --- full and incremental updates -----------------------------------------------------
    def rebuild(self, status=None) -> None:
        """Recompute the flags and counts from scratch for the given element status."""
        n_elem = self.conn.shape[0]
        if status is None:
            self.alive = np.ones(n_elem, dtype=bool)
        else:
            self.alive = np.asarray(status) != ERODED
        nb_alive = np.where(self.adj >= 0, self.alive[np.maximum(self.adj, 0)], False)
        self.face_flag = (self.alive[:, None] & ~nb_alive).reshape(-1)
        ids = np.flatnonzero(self.face_flag)
        elem, local = ids // 4, ids % 4
        fe = self.elem_edges[elem[:, None], FACE_EDGES[local]]
        fn = self.conn[elem[:, None], LOCAL_FACES[local]]
        self.edge_count = np.bincount(fe.reshape(-1), minlength=self.mesh_edges.shape[0]).astype(
            np.int32)
        self.node_count = np.bincount(fn.reshape(-1), minlength=self.n_node).astype(np.int32)
        self._compact()

    def remove_elements(self, elem_ids) -> int:
        """Delete elements from the surface (erosion); returns how many were newly removed."""
        ids = np.ascontiguousarray(elem_ids, dtype=np.int64).reshape(-1)
        self._events = events_buffer(self._events, ids.shape[0])
        removed, m = _remove_elements_kernel(ids, self.conn, self.adj, self.elem_edges,
                                             self.alive, self.face_flag, self.edge_count,
                                             self.node_count, LOCAL_FACES, FACE_EDGES,
                                             self._events)
        if removed:
            if self.incremental:  # the compact arrays from the changes (_compact_changes)
                self._set_compact(_compact_changes(
                    self._events, m, self.face_flag, self.edge_count, self.node_count,
                    self.conn, self.elem_body, self.elem_edges, self.mesh_edges,
                    self.node_body_all, LOCAL_FACES, FACE_EDGES, self.faces, self.face_elem,
                    self.face_local, self.face_body, self.face_edges, self.edges, self.edge_mesh,
                    self.edge_body, self.nodes, self.node_body))
            else:
                self._compact()
        return int(removed)

    def reconnect(self, conn, changed) -> None:
        """Follow node separation (fracture/separation.py): the elements ``changed`` had corners
        repointed to new nodes in ``conn``. Only they and their face neighbours are touched: the
        faces a release opened become free faces of both sides, the edges of the new
        connectivity join ``mesh_edges`` (kept sorted, so the compact arrays come out in the
        order a rebuild gives; edges no element uses any more stay, with count 0, and are not
        on the surface), and the counts of the touched faces are redone. The compact arrays
        equal those of ``Surface.from_model`` on the new mesh (tests/unit/
        test_contact_surface.py) at a cost in proportion to the changed elements plus one
        O(mesh edges) remapping when edges are added."""
        changed = np.unique(np.asarray(changed, dtype=np.int64))
        if changed.shape[0] == 0:
            return
        nbs = self.adj[changed].reshape(-1)
        touched = np.unique(np.concatenate([changed, nbs[nbs >= 0]]))
        _face_counts(touched, self.conn, self.elem_edges, self.face_flag, self.edge_count,
                     self.node_count, LOCAL_FACES, FACE_EDGES, -1)
        self.conn[changed] = conn[changed]
        # the edges of the changed elements, merged into the sorted mesh edges
        pairs = self.conn[changed][:, LOCAL_EDGES].reshape(-1, 2).astype(np.int64)
        pairs.sort(axis=1)
        self.mesh_edges, pos, at = insert_edges(self.mesh_edges, pairs, self.n_node)
        if pos is not None:
            self.elem_edges = pos[self.elem_edges]
            count = np.zeros(self.mesh_edges.shape[0], np.int32)
            count[pos] = self.edge_count
            self.edge_count = count
        self.elem_edges[changed] = at.reshape(-1, 6)
        _open_faces(changed, self.conn, self.adj, LOCAL_FACES)
        _reflag(touched, self.adj, self.alive, self.face_flag)
        _face_counts(touched, self.conn, self.elem_edges, self.face_flag, self.edge_count,
                     self.node_count, LOCAL_FACES, FACE_EDGES, 1)
        self._compact()

    def sync(self, status) -> bool:
        """Follow ``status`` (elements eroded since the last call); True when the surface changed.
        An element that came back to life forces a full rebuild."""
        status = np.asarray(status)
        if status.shape == self.alive.shape and not alive_changed(status, self.alive):
            return False  # (one pass, no temporaries: every contact pass calls this each step)
        alive = status != ERODED
        if np.any(alive & ~self.alive):
            self.rebuild(status)
            return True
        return self.remove_elements(np.flatnonzero(self.alive & ~alive)) > 0

    def _compact(self) -> None:
        """The compact arrays from the flags and counts (module docstring), in one kernel
        pass (``_compact_kernel``): erosion calls this every step it removes elements."""
        if getattr(self, "_edge_index", None) is None or \
                self._edge_index.shape[0] != self.mesh_edges.shape[0]:
            self._edge_index = np.empty(self.mesh_edges.shape[0], dtype=np.int64)
        self._set_compact(_compact_kernel(self.face_flag, self.conn, self.elem_body,
                                          self.elem_edges, self.mesh_edges, self.edge_count,
                                          self.node_count, self.node_body_all, LOCAL_FACES,
                                          FACE_EDGES, self._edge_index))

    def _set_compact(self, arrays) -> None:
        (self.faces, self.face_elem, self.face_local, self.face_body, self.face_edges,
         self.edges, self.edge_mesh, self.edge_body, self.nodes, self.node_body) = arrays
        # the nodes the self-contact exclusion compares per face and edge (the entity's own;
        # a hex surface keys its triangles by their whole quad, contact/hexes.py)
        self.face_key, self.edge_key = self.faces, self.edges
        self.version += 1

    # --- sizes and measures ---------------------------------------------------------------
    @property
    def n_faces(self) -> int:
        return self.faces.shape[0]

    @property
    def n_edges(self) -> int:
        return self.edges.shape[0]

    @property
    def n_nodes(self) -> int:
        return self.nodes.shape[0]

    def mean_edge_length(self, x) -> float:
        """Mean length [m] of the boundary edges at positions x (0 when there are none)."""
        return float(mean_length(x, self.edges))

    def view(self) -> SurfaceView:
        """The compact arrays as they are now, for a reader in another thread."""
        return SurfaceView(self)


class SurfaceView:
    """A surface's compact arrays at one moment (``Surface.view``), with the sizes and the
    measure a reader takes of them: what the penetration measure reads in its own thread
    (contact/diagnostics.py) while the run goes on. A surface replaces its compact arrays when
    it changes (``_set_compact``) and never writes into them, so a view stays as it was taken.
    ``source`` is the surface, ``version`` its version then."""

    __slots__ = ("source", "version", "faces", "face_body", "edges", "edge_body", "nodes",
                 "node_body")

    def __init__(self, surface: Surface):
        self.source = surface
        self.version = surface.version
        self.faces, self.face_body = surface.faces, surface.face_body
        self.edges, self.edge_body = surface.edges, surface.edge_body
        self.nodes, self.node_body = surface.nodes, surface.node_body

    n_faces = Surface.n_faces
    n_edges = Surface.n_edges
    n_nodes = Surface.n_nodes
    mean_edge_length = Surface.mean_edge_length



@numba.njit(cache=True)
def alive_changed(status, alive):
    """True when some element's (status != ERODED) differs from ``alive``. A count without an
    early exit: the loop vectorises (15 us for 200,000 elements, against 100 us for numpy's
    compare and array_equal, and 350 us for the loop that stops at the first change)."""
    c = 0
    for e in range(status.shape[0]):
        c += np.int64((status[e] != ERODED) != alive[e])
    return c != 0


def insert_edges(mesh_edges, pairs, n_node):
    """(edges, pos, at): the sorted unique node pairs ``mesh_edges`` (m, 2) with those of
    ``pairs`` (k, 2) int64, smaller node first, that it lacks inserted in order (few: no sort
    of the whole list); ``pos`` (m,) the new index of each old edge, None when none was added;
    ``at`` (k,) the index of each pair. Edges already there keep their relative order, so
    arrays built from the list come out in the order a fresh unique gives (Surface.reconnect,
    HexSurface.reconnect)."""
    n = np.int64(max(n_node, 1))
    keys = pairs[:, 0] * n + pairs[:, 1]
    old = mesh_edges[:, 0].astype(np.int64) * n + mesh_edges[:, 1]
    at = np.searchsorted(old, keys)
    found = (at < old.shape[0]) & (old[np.minimum(at, max(old.shape[0] - 1, 0))] == keys) \
        if old.shape[0] else np.zeros(keys.shape[0], bool)
    if np.all(found):
        return mesh_edges, None, at
    add = np.unique(keys[~found])
    merged = np.insert(old, np.searchsorted(old, add), add)
    pos = np.arange(old.shape[0]) + np.searchsorted(add, old)
    edges = np.stack([merged // n, merged % n], axis=1).astype(np.int32)
    return edges, pos, np.searchsorted(merged, keys)


def events_buffer(buf, n_ids, faces: int = 4) -> np.ndarray:
    """A buffer for the ``events`` of ``free_face_changes`` for n_ids removed elements of
    ``faces`` faces each: ``buf`` when it is large enough, else one half as large again (no
    allocation while it suffices)."""
    need = faces * int(n_ids)
    if buf.shape[0] >= need:
        return buf
    return np.empty(max(need, 64, int(1.5 * buf.shape[0])), dtype=np.int64)
