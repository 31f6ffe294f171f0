"""Hexahedral bodies in contact: their quad faces as two triangles, their true edges only.

Node-face contact (ALGORITHMS.md 3.1) works on triangles: its impulse algebra
(`impulse.py`, barycentric weights) and the time of impact (`cubic.py`, a cubic in t for a
node and a plane triangle) are exact for plane faces. A boundary quad of a hex is therefore
given to it as two triangles through the same four nodes, split along the diagonal through the
quad's smallest global node number (the same split seen from either side, whatever the node
order of the hexes): exact for a plane quad; a warped quad becomes a roof of two planes through
its corners, within its warping (the quality report gives it) of the bilinear face. A bilinear
face would need an iterative closest point and time of impact, and new impulse weights, for a
difference of the order of the warping.

Edge-edge contact (3.2) uses the edges of the elements (the four edges of each boundary quad)
and, with CREASES (on), the diagonal of each split: the contact surface of a quad is then a
roof of two planes, and its diagonal is a crease of that roof as real as an element edge. An
edge of the other body can cut through a warped quad across the crease while none of its nodes
crosses a triangle and it crosses no element edge: measured without the creases in the
two-cylinders scene with a hex striker, 37 um at 1 mm and 6 um at 2 mm (edge cuts at the
diagonals, none elsewhere); with them, below 1 um. The diagonal is not an edge of the element
(mesh quality, fracture and the hex kernel do not know it): it exists only in this surface.
Triangles of a split quad list -1 for their diagonal in `face_edges` when CREASES is off.

`HexSurface` extends the tets' `Surface` with these faces, edges and nodes, following the hex
blocks' status as hexes leave (fracture/hexes.py) in O(change), as the tets' surface does, and
node separation's releases in place (`HexSurface.reconnect`, `ProxyTets.reconnect`: the moved
hexes and their face neighbours only; the same arrays as a fresh build).

Self-contact: the broad phase excludes pairs that share a node (contact/broadphase.py). With
quads split in two, that would pair a node with the other triangle of its own quad and a split's
diagonal with the edges of the quads around it, none of which share a node with it. The surface
therefore gives each face and edge a key the exclusion compares (`face_key`, `edge_key`, (k, 4)):
a hex triangle and a diagonal stand for their whole quad, a tet face and every true edge for
their own nodes (padded by repetition). `ProxyTets` gives the penetration measure
(diagnostics.py, which tests nodes against tets) a tet cover of every hex: its 12 faces'
triangles (the same split as the contact faces) joined to the hex's centre, a point of its own
after the mesh's nodes; exact for the volume bounded by those triangles.
"""

from __future__ import annotations

import numba
import numpy as np

from impactsim.contact.surface import ERODED, Surface, insert_edges

CREASES = True  # the split diagonals take part in edge-edge contact (module docstring)

# the faces of the hex, outward (solver/hex8.py FACES) and its edges
QUADS = np.array([[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6],
                  [3, 0, 4, 7]], dtype=np.int64)


def boundary_quads(conn: np.ndarray, status=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(quads (q, 4) outward node numbers, their hex (q,), their local face (q,)): the faces of
    the live hexes of conn (n, 8) that no other live hex shares, in the order hex, local face."""
    alive = np.ones(len(conn), bool) if status is None else np.asarray(status) != 3
    ids = np.flatnonzero(alive)
    faces = conn[ids][:, QUADS].reshape(-1, 4).astype(np.int64)
    key = np.sort(faces, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    single = counts[inverse.ravel()] == 1
    slot = np.flatnonzero(single)
    return faces[slot], ids[slot // 6], (slot % 6).astype(np.int8)


def split_quads(quads: np.ndarray) -> np.ndarray:
    """Two outward triangles (2q, 3) per quad (a, b, c, d), split along the diagonal through
    its smallest node number: (a, b, c), (a, c, d) or (b, c, d), (b, d, a)."""
    q = np.asarray(quads, np.int64)
    at_ac = np.argmin(q, axis=1) % 2 == 0
    a, b, c, d = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    t1 = np.where(at_ac[:, None], np.column_stack([a, b, c]), np.column_stack([b, c, d]))
    t2 = np.where(at_ac[:, None], np.column_stack([a, c, d]), np.column_stack([b, d, a]))
    return np.stack([t1, t2], axis=1).reshape(-1, 3)


def _quad_edge_table(conn: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(edges (m, 2) int32 smaller node first, unique; quad_edges (6n, 5) int64): the four true
    edges of every quad of every hex (in the quad's order a-b, b-c, c-d, d-a) and the diagonal
    of its split (column 4), as indices into ``edges``."""
    q = conn[:, QUADS].reshape(-1, 4).astype(np.int64)
    t = split_quads(q).reshape(-1, 2, 3)
    diag = np.stack([t[:, 0, 0], t[:, 0, 2]], axis=1)  # (a, c) or (b, d)
    e = np.concatenate([np.stack([q, np.roll(q, -1, axis=1)], axis=-1), diag[:, None, :]],
                       axis=1)  # (6n, 5, 2)
    e = np.sort(e, axis=2)
    edges, inverse = np.unique(e.reshape(-1, 2), axis=0, return_inverse=True)
    return edges.astype(np.int32), inverse.reshape(-1, 5).astype(np.int64)


@numba.njit(cache=True)
def _quad_counts(events, m, quad_edges, conn, quads, edge_count, node_count, creases):
    """Reference counts of the hex surface's edges and nodes after the quad changes ``events``
    (``surface.free_face_changes`` with six faces per hex)."""
    for k in range(m):
        s = events[k]
        step = 1
        if s < 0:
            s = -1 - s
            step = -1
        for j in range(5 if creases else 4):
            edge_count[quad_edges[s, j]] += step
        e = s // 6
        i = s % 6
        for j in range(4):
            node_count[conn[e, quads[i, j]]] += step


@numba.njit(cache=True)
def _quad_compact(face_flag, conn, elem_body, quads, quad_edges, edges, edge_count, n_tet,
                  edge_offset, creases, edge_index):
    """The free quads' triangles in slot order (two per quad, split through its smallest node),
    their element (n_tet + hex), local quad, body and edges (surface edge indices from
    ``edge_offset`` on; -1 for a diagonal without ``creases``), and the surface's hex edges
    (count > 0, index order) with their mesh-edge index. ``edge_index`` is scratch."""
    nf = 0
    for s in range(face_flag.shape[0]):
        if face_flag[s]:
            nf += 1
    ng = 0
    for g in range(edge_count.shape[0]):
        edge_index[g] = -1
        if edge_count[g] > 0:
            edge_index[g] = edge_offset + ng
            ng += 1
    out_edges = np.empty((ng, 2), dtype=np.int32)
    edge_mesh = np.empty(ng, dtype=np.int64)
    g2 = 0
    for g in range(edge_count.shape[0]):
        if edge_count[g] > 0:
            out_edges[g2, 0] = edges[g, 0]
            out_edges[g2, 1] = edges[g, 1]
            edge_mesh[g2] = g
            g2 += 1
    faces = np.empty((2 * nf, 3), dtype=np.int32)
    face_elem = np.empty(2 * nf, dtype=np.int64)
    face_local = np.empty(2 * nf, dtype=np.int8)
    face_body = np.empty(2 * nf, dtype=np.int32)
    face_edges = np.empty((2 * nf, 3), dtype=np.int64)
    k = 0
    for s in range(face_flag.shape[0]):
        if not face_flag[s]:
            continue
        e = s // 6
        i = s % 6
        a = conn[e, quads[i, 0]]
        b = conn[e, quads[i, 1]]
        c = conn[e, quads[i, 2]]
        d = conn[e, quads[i, 3]]
        g0 = edge_index[quad_edges[s, 0]]
        g1 = edge_index[quad_edges[s, 1]]
        g2 = edge_index[quad_edges[s, 2]]
        g3 = edge_index[quad_edges[s, 3]]
        gd = edge_index[quad_edges[s, 4]] if creases else -1
        low = min(min(a, b), min(c, d))
        if low == a or low == c:  # (a, b, c), (a, c, d)
            faces[k, 0], faces[k, 1], faces[k, 2] = a, b, c
            faces[k + 1, 0], faces[k + 1, 1], faces[k + 1, 2] = a, c, d
            face_edges[k, 0], face_edges[k, 1], face_edges[k, 2] = g0, g1, gd
            face_edges[k + 1, 0], face_edges[k + 1, 1], face_edges[k + 1, 2] = gd, g2, g3
        else:  # (b, c, d), (b, d, a)
            faces[k, 0], faces[k, 1], faces[k, 2] = b, c, d
            faces[k + 1, 0], faces[k + 1, 1], faces[k + 1, 2] = b, d, a
            face_edges[k, 0], face_edges[k, 1], face_edges[k, 2] = g1, g2, gd
            face_edges[k + 1, 0], face_edges[k + 1, 1], face_edges[k + 1, 2] = gd, g3, g0
        for r in range(2):
            face_elem[k + r] = n_tet + e
            face_local[k + r] = i
            face_body[k + r] = elem_body[e]
        k += 2
    return faces, face_elem, face_local, face_body, face_edges, out_edges, edge_mesh


class HexSurface(Surface):
    """The contact surface of a model with hex blocks: the tets' surface (Surface, updated as
    tets erode) followed by the triangles, edges and nodes of the hexes' free quads, updated as
    hexes erode (``sync`` follows the blocks' status too, in O(change) as the tets' surface:
    ``surface.free_face_changes`` with six faces per hex, reference counts of the quads' edges
    and nodes; the compact arrays are regenerated in slot order).

    ``face_key``, ``edge_key`` (module docstring, self-contact): the nodes the self-contact
    exclusion compares for each face and edge."""

    # the compact arrays hold the hexes' triangles after the tets': recomputed after a removal
    # (Surface.incremental)
    incremental = False

    def __init__(self, model):
        self.hex_conn = np.ascontiguousarray(
            np.concatenate([b.conn for b in model.blocks]), np.int32)
        self.hex_body = np.concatenate([b.elem_body for b in model.blocks]).astype(np.int32)
        self._hex_status = [b.status for b in model.blocks]
        self.n_tet = int(model.conn.shape[0])
        from impactsim.fracture.separation import face_adjacency_k

        self.hex_adj = face_adjacency_k(self.hex_conn, QUADS)
        self.hex_mesh_edges, self.quad_edges = _quad_edge_table(self.hex_conn)
        self._hex_events = np.empty(0, np.int64)
        self._hex_edge_index = np.empty(len(self.hex_mesh_edges), np.int64)
        super().__init__(model.conn, model.elem_body, model.status, model.node_body,
                         model.n_node)

    def _hex_alive(self) -> np.ndarray:
        return np.concatenate([st != ERODED for st in self._hex_status])

    def rebuild(self, status=None) -> None:
        """The tets' flags afresh (Surface.rebuild), and the hexes' from their blocks."""
        alive = self._hex_alive()
        self.hex_alive = alive.copy()
        nb_alive = np.where(self.hex_adj >= 0, alive[np.maximum(self.hex_adj, 0)], False)
        self.hex_face_flag = (alive[:, None] & ~nb_alive).reshape(-1)
        slots = np.flatnonzero(self.hex_face_flag)
        cols = 5 if CREASES else 4
        self.hex_edge_count = np.bincount(self.quad_edges[slots, :cols].reshape(-1),
                                          minlength=len(self.hex_mesh_edges)).astype(np.int32)
        q = self.hex_conn[slots // 6][np.arange(len(slots))[:, None], QUADS[slots % 6]]
        self.hex_node_count = np.bincount(q.reshape(-1), minlength=self.n_node).astype(np.int32)
        super().rebuild(status)

    def sync(self, status) -> bool:
        """Follow the tets' ``status`` and the hex blocks' (hexes eroded since the last call);
        True when the surface changed."""
        alive = self._hex_alive()
        hex_changed = not np.array_equal(alive, self.hex_alive)
        if hex_changed and np.any(alive & ~self.hex_alive):
            self.rebuild(status)
            return True
        if not hex_changed:
            return super().sync(status)
        ids = np.flatnonzero(self.hex_alive & ~alive)
        from impactsim.contact.surface import events_buffer, free_face_changes

        self._hex_events = events_buffer(self._hex_events, len(ids), 6)
        m, _ = free_face_changes(ids, self.hex_adj, self.hex_alive, self.hex_face_flag,
                                 self._hex_events)
        _quad_counts(self._hex_events, m, self.quad_edges, self.hex_conn, QUADS,
                     self.hex_edge_count, self.hex_node_count, CREASES)
        if not super().sync(status):
            self._compact()
        return True

    def reconnect(self, conn, changed, hex_changed=None, hex_rows=None) -> None:
        """Follow node separation: the tets ``changed`` had corners repointed in ``conn``
        (Surface.reconnect), the hexes ``hex_changed`` (sorted unique indices into the blocks'
        concatenated hexes; ``hex_rows`` their new corners). Only the changed hexes and their face
        neighbours are touched, as for the tets: their free quads' counts are withdrawn, their
        new corners and quad edges (the split diagonal follows the smallest node, so it can
        move) taken, the quads a release opened cut in the adjacency, and the counts of their
        free quads added back. The hex mesh edges stay sorted (new ones inserted; unused ones
        stay, with count 0), so the compact arrays equal those of a surface built afresh
        (tests/unit/test_contact_surface.py)."""
        hc = np.asarray(hex_changed if hex_changed is not None else [], np.int64)
        if hc.shape[0]:
            self._reconnect_hexes(hex_rows, hc)
        tc = np.asarray(changed, np.int64).reshape(-1)
        if tc.shape[0]:
            super().reconnect(conn, tc)  # compacts both
        elif hc.shape[0]:
            self._compact()

    def _reconnect_hexes(self, rows, changed) -> None:
        from impactsim.fracture.separation_refresh import _open_faces_k

        nbs = self.hex_adj[changed].reshape(-1)
        touched = np.unique(np.concatenate([changed, nbs[nbs >= 0]]))
        slots = (6 * touched[:, None] + np.arange(6)).reshape(-1)
        slots = slots[self.hex_face_flag[slots]]
        events = -1 - slots  # withdraw the touched free quads' counts
        _quad_counts(events, events.shape[0], self.quad_edges, self.hex_conn, QUADS,
                     self.hex_edge_count, self.hex_node_count, CREASES)
        self.hex_conn[changed] = rows
        # the changed hexes' quad edges (true edges and split diagonal), merged into the sorted
        # hex mesh edges as Surface.reconnect merges the tets' edges
        q = self.hex_conn[changed][:, QUADS].reshape(-1, 4).astype(np.int64)
        t = split_quads(q).reshape(-1, 2, 3)
        diag = np.stack([t[:, 0, 0], t[:, 0, 2]], axis=1)
        e = np.concatenate([np.stack([q, np.roll(q, -1, axis=1)], axis=-1), diag[:, None, :]],
                           axis=1)
        e.sort(axis=2)
        self.hex_mesh_edges, pos, at = insert_edges(self.hex_mesh_edges, e.reshape(-1, 2),
                                                    self.n_node)
        if pos is not None:
            self.quad_edges = pos[self.quad_edges]
            count = np.zeros(self.hex_mesh_edges.shape[0], np.int32)
            count[pos] = self.hex_edge_count
            self.hex_edge_count = count
            self._hex_edge_index = np.empty(self.hex_mesh_edges.shape[0], np.int64)
        rows = (6 * changed[:, None] + np.arange(6)).reshape(-1)
        self.quad_edges[rows] = at.reshape(-1, 5)
        _open_faces_k(changed, self.hex_conn, self.hex_adj, QUADS)
        nb = self.hex_adj[touched]
        alive = self.hex_alive
        flag = alive[touched][:, None] & ~((nb >= 0) & alive[np.maximum(nb, 0)])
        self.hex_face_flag.reshape(-1, 6)[touched] = flag
        slots = (6 * touched[:, None] + np.arange(6)).reshape(-1)
        slots = slots[self.hex_face_flag[slots]]
        _quad_counts(slots, slots.shape[0], self.quad_edges, self.hex_conn, QUADS,
                     self.hex_edge_count, self.hex_node_count, CREASES)

    def _compact(self) -> None:
        super()._compact()
        (faces, face_elem, face_local, face_body, face_edges, edges, edge_mesh) = _quad_compact(
            self.hex_face_flag, self.hex_conn, self.hex_body, QUADS, self.quad_edges,
            self.hex_mesh_edges, self.hex_edge_count, self.n_tet, self.edges.shape[0], CREASES,
            self._hex_edge_index)
        n_tet_faces = self.faces.shape[0]
        self.faces = np.ascontiguousarray(np.vstack([self.faces, faces]), np.int32)
        self.face_elem = np.concatenate([self.face_elem, face_elem])
        self.face_local = np.concatenate([self.face_local, face_local])
        self.face_body = np.concatenate([self.face_body, face_body])
        self.face_edges = np.ascontiguousarray(np.vstack([self.face_edges, face_edges]), np.int64)
        self.edges = np.ascontiguousarray(np.vstack([self.edges, edges]), np.int32)
        self.edge_mesh = np.concatenate([self.edge_mesh, self.mesh_edges.shape[0] + edge_mesh])
        hex_nodes = np.flatnonzero(self.hex_node_count > 0)
        self.nodes = np.union1d(self.nodes, hex_nodes).astype(np.int32)
        self.node_body = self.node_body_all[self.nodes]
        self.edge_body = (self.node_body_all[self.edges[:, 0]] if self.edges.shape[0]
                          else np.zeros(0, dtype=np.int32))
        # the self-contact exclusion's keys: a hex triangle and a split's diagonal stand for
        # their whole quad, a tet face and every true edge for their own nodes
        fk = np.empty((self.faces.shape[0], 4), np.int32)
        fk[:, :3] = self.faces
        fk[:n_tet_faces, 3] = self.faces[:n_tet_faces, 0]
        quad = self.hex_conn[face_elem - self.n_tet][np.arange(len(face_elem))[:, None],
                                                     QUADS[face_local]] if len(face_elem) \
            else np.zeros((0, 4), np.int32)
        fk[n_tet_faces:] = quad
        self.face_key = fk
        ek = np.empty((self.edges.shape[0], 4), np.int32)
        ek[:, :2] = self.edges
        ek[:, 2] = self.edges[:, 0]
        ek[:, 3] = self.edges[:, 1]
        if CREASES and len(face_elem):
            # a diagonal: the third edge of a split's first triangle; its key is the quad
            diag = face_edges[0::2, 2]
            ek[diag] = quad[0::2]
        self.edge_key = ek
class ProxyTets:
    """A tet cover of the model's tets and hexes for the penetration measure (module
    docstring): conn (tets, then 12 per hex), elem_body, status (a hex's for its 12), and the
    positions of the nodes followed by the hexes' centres (`positions`)."""

    def __init__(self, model):
        hconn = np.concatenate([b.conn for b in model.blocks]).astype(np.int64)
        self.hconn = hconn
        n_hex = len(hconn)
        self.n_node = model.n_node
        tets = self._tets(np.arange(n_hex))
        self.conn = np.ascontiguousarray(np.vstack([model.conn, tets.reshape(-1, 4)]), np.int32)
        self.elem_body = np.concatenate(
            [model.elem_body] + [np.repeat(b.elem_body, 12) for b in model.blocks]).astype(np.int32)
        self.status = np.zeros(len(self.conn), np.int8)
        self.x = np.zeros((model.n_node + n_hex, 3))

    def _tets(self, ids) -> np.ndarray:
        """(len(ids), 12, 4) the cover tets of hexes ``ids``."""
        centre = self.n_node + ids
        faces = self.hconn[ids][:, QUADS].reshape(-1, 4)  # every face of every hex, outward
        tris = split_quads(faces).reshape(len(ids), 12, 3)
        # outward triangle (a, b, c) with the centre g inside: (a, c, b, g) is positive
        return np.concatenate([tris[:, :, [0, 2, 1]],
                               np.broadcast_to(centre[:, None, None], (len(ids), 12, 1))],
                              axis=2)

    def reconnect(self, model, changed, hex_changed, hex_rows) -> None:
        """After node separation repointed the corners of the tets ``changed`` and the hexes
        ``hex_changed`` (sorted unique, into the blocks' concatenation; ``hex_rows`` their new
        corners): their cover tets, in place."""
        changed = np.asarray(changed, np.int64)
        self.conn[changed] = model.conn[changed]
        ids = np.asarray(hex_changed, np.int64)
        if ids.shape[0]:
            self.hconn[ids] = hex_rows
            rows = (model.conn.shape[0] + 12 * ids[:, None] + np.arange(12)).reshape(-1)
            self.conn[rows] = self._tets(ids).reshape(-1, 4)

    def update(self, model) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(positions, conn, elem_body, status) at the model's current state."""
        n = model.n_node
        self.x[:n] = model.x
        self.x[n:] = model.x[self.hconn].mean(axis=1)
        nt = model.conn.shape[0]
        self.status[:nt] = model.status
        self.status[nt:] = np.repeat(np.concatenate([b.status for b in model.blocks]), 12)
        return self.x, self.conn, self.elem_body, self.status
