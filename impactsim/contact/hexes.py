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

`HexSurface` extends the tets' `Surface` with these faces, edges and nodes (hex faces never
change: fracture of hexes is not available yet). `ProxyTets` gives the penetration measure
(diagnostics.py, which tests nodes against tets) a tet cover of every hex: its 12 faces'
triangles (the same split as the contact faces) joined to the hex's centre, a point of its own
after the mesh's nodes; exact for the volume bounded by those triangles.
"""

from __future__ import annotations

import numpy as np

from impactsim.contact.surface import Surface

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


class HexSurface(Surface):
    """The contact surface of a model with hex blocks: the tets' surface (Surface, updated as
    tets erode) followed by the triangles, edges and nodes of the hexes' boundary quads."""

    def __init__(self, model):
        self.hex_conn = np.concatenate([b.conn for b in model.blocks]).astype(np.int64)
        self.hex_body = np.concatenate([b.elem_body for b in model.blocks]).astype(np.int32)
        self.n_tet = int(model.conn.shape[0])
        quads, qelem, qlocal = boundary_quads(self.hex_conn)
        self.hex_tris = split_quads(quads).astype(np.int32)
        self.hex_tri_elem = self.n_tet + np.repeat(qelem, 2)
        self.hex_tri_local = np.repeat(qlocal, 2)
        self.hex_tri_body = np.repeat(self.hex_body[qelem], 2)
        # the quads' true edges, smaller node first, unique; with CREASES the split's diagonals
        e = np.stack([quads, np.roll(quads, -1, axis=1)], axis=-1).reshape(-1, 2)
        if CREASES:
            t = self.hex_tris.reshape(-1, 2, 3)
            diag = np.stack([t[:, 0, 0], t[:, 0, 2]], axis=1)  # (a, c) or (b, d)
            e = np.vstack([e, diag])
        self.hex_edges = np.unique(np.sort(e, axis=1), axis=0).astype(np.int32)
        self.hex_nodes = np.unique(quads).astype(np.int32)
        super().__init__(model.conn, model.elem_body, model.status, model.node_body,
                         model.n_node)

    def _compact(self) -> None:
        super()._compact()
        nt_edges = self.edges.shape[0]
        self.faces = np.ascontiguousarray(np.vstack([self.faces, self.hex_tris]), np.int32)
        self.face_elem = np.concatenate([self.face_elem, self.hex_tri_elem]).astype(np.int64)
        self.face_local = np.concatenate([self.face_local, self.hex_tri_local]).astype(np.int8)
        self.face_body = np.concatenate([self.face_body, self.hex_tri_body]).astype(np.int32)
        self.edges = np.ascontiguousarray(np.vstack([self.edges, self.hex_edges]), np.int32)
        self.edge_mesh = np.concatenate([self.edge_mesh, self.mesh_edges.shape[0]
                                         + np.arange(len(self.hex_edges))]).astype(np.int64)
        # the triangles' edges: a true edge's index, -1 for the split's diagonal
        key = self.hex_edges[:, 0].astype(np.int64) * (self.n_node + 1) + self.hex_edges[:, 1]
        t = self.hex_tris.astype(np.int64)
        fe = np.full((len(t), 3), -1, np.int64)
        for j in range(3):
            lo = np.minimum(t[:, j], t[:, (j + 1) % 3])
            hi = np.maximum(t[:, j], t[:, (j + 1) % 3])
            k = lo * (self.n_node + 1) + hi
            pos = np.clip(np.searchsorted(key, k), 0, max(len(key) - 1, 0))
            found = key[pos] == k if len(key) else np.zeros(len(k), bool)
            fe[:, j] = np.where(found, nt_edges + pos, -1)
        self.face_edges = np.ascontiguousarray(np.vstack([self.face_edges, fe]), np.int64)
        self.nodes = np.union1d(self.nodes, self.hex_nodes).astype(np.int32)
        self.node_body = self.node_body_all[self.nodes]
        self.edge_body = (self.node_body_all[self.edges[:, 0]] if self.edges.shape[0]
                          else np.zeros(0, dtype=np.int32))


class ProxyTets:
    """A tet cover of the model's tets and hexes for the penetration measure (module
    docstring): conn (tets, then 12 per hex), elem_body, status (a hex's for its 12), and the
    positions of the nodes followed by the hexes' centres (`positions`)."""

    def __init__(self, model):
        hconn = np.concatenate([b.conn for b in model.blocks]).astype(np.int64)
        self.hconn = hconn
        n_hex = len(hconn)
        centre = model.n_node + np.arange(n_hex)
        faces = hconn[:, QUADS].reshape(-1, 4)  # every face of every hex, outward
        tris = split_quads(faces).reshape(n_hex, 12, 3)
        # outward triangle (a, b, c) with the centre g inside: (a, c, b, g) is positive
        tets = np.concatenate([tris[:, :, [0, 2, 1]],
                               np.broadcast_to(centre[:, None, None], (n_hex, 12, 1))], axis=2)
        self.conn = np.ascontiguousarray(np.vstack([model.conn, tets.reshape(-1, 4)]), np.int32)
        self.elem_body = np.concatenate(
            [model.elem_body] + [np.repeat(b.elem_body, 12) for b in model.blocks]).astype(np.int32)
        self.status = np.zeros(len(self.conn), np.int8)
        self.x = np.zeros((model.n_node + n_hex, 3))

    def update(self, model) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(positions, conn, elem_body, status) at the model's current state."""
        n = model.n_node
        self.x[:n] = model.x
        self.x[n:] = model.x[self.hconn].mean(axis=1)
        nt = model.conn.shape[0]
        self.status[:nt] = model.status
        self.status[nt:] = np.repeat(np.concatenate([b.status for b in model.blocks]), 12)
        return self.x, self.conn, self.elem_body, self.status
