"""The free faces of the mesh as the fracture passes see them, updated in proportion to what
changes (ALGORITHMS.md 4.2: "its inner faces shared with neighbours become new boundary
triangles").

State (``Boundary``):
  adj (e,4) int64 face adjacency at t = 0 (impactsim.mesh.topology.face_adjacency);
  alive (e,) bool; face_flag (4e,) bool slot ``4*elem + local`` is a free face (alive element,
  neighbour across it missing or removed), as ``impactsim.contact.surface.Surface.face_flag``;
  faces (cap,3) int32 outward-oriented node triples, face_slot (cap,) int64 their slots and
  face_body (cap,) int32 their bodies, rows [0, n) live; pos (4e,) int64 row of a slot, -1 if
  the slot is not a free face.

Removing an element touches only its four faces: a free face of it leaves the list (the last row
takes its place), an inner face becomes a free face of the neighbour (appended, with the
neighbour's local numbering and orientation); which faces change is
``impactsim.contact.surface.free_face_changes``, the update of the contact surface too. The cost
is O(removed elements), nothing is regenerated. Row order is that history: deterministic (same
input, same order), not the canonical order of ``Surface`` (which also keeps the edges and
nodes the contact passes need and regenerates its compact arrays on every change).
"""

from __future__ import annotations

import numba
import numpy as np

from impactsim.contact.surface import events_buffer, free_face_changes
from impactsim.mesh.topology import LOCAL_FACES, face_adjacency


@numba.njit(cache=True)
def _append(s, conn, elem_body, local_faces, faces, face_slot, face_body, pos, n):
    e = s // 4
    i = s % 4
    for j in range(3):
        faces[n, j] = conn[e, local_faces[i, j]]
    face_slot[n] = s
    face_body[n] = elem_body[e]
    pos[s] = n
    return n + 1


@numba.njit(cache=True)
def _drop(s, faces, face_slot, face_body, pos, n):
    k = pos[s]
    last = n - 1
    if k != last:
        for j in range(3):
            faces[k, j] = faces[last, j]
        face_slot[k] = face_slot[last]
        face_body[k] = face_body[last]
        pos[face_slot[k]] = k
    pos[s] = -1
    return last


@numba.njit(cache=True)
def remove_cells(ids, conn, elem_body, adj, alive, face_flag, local_faces, faces, face_slot,
                 face_body, pos, n, events):
    """Remove elements ``ids`` in order (already removed ones are skipped) and update the free
    faces (module docstring): the face changes of
    ``impactsim.contact.surface.free_face_changes`` (``events``: room for 4 per id), applied in
    their order. The face arrays need room for 4 more rows per id.
    Returns (new row count, elements removed)."""
    m, removed = free_face_changes(ids, adj, alive, face_flag, events)
    for k in range(m):
        s = events[k]
        if s < 0:
            n = _drop(-1 - s, faces, face_slot, face_body, pos, n)
        else:
            n = _append(s, conn, elem_body, local_faces, faces, face_slot, face_body, pos, n)
    return n, removed


@numba.njit(cache=True)
def _initial(conn, elem_body, adj, alive, face_flag, local_faces, faces, face_slot, face_body,
             pos):
    n = 0
    for e in range(conn.shape[0]):
        if not alive[e]:
            continue
        for i in range(4):
            nb = adj[e, i]
            if nb >= 0 and alive[nb]:
                continue
            s = 4 * e + i
            face_flag[s] = True
            n = _append(s, conn, elem_body, local_faces, faces, face_slot, face_body, pos, n)
    return n


class Boundary:
    """Free faces of a tet mesh, updatable in O(change) (see the module docstring).

    ``conn (e,4) int32`` positive tets; ``elem_body (e,) int32``; ``alive (e,) bool`` (all alive
    when None).
    """

    def __init__(self, conn, elem_body, alive=None):
        self.conn = np.ascontiguousarray(conn, dtype=np.int32)
        self.elem_body = np.ascontiguousarray(elem_body, dtype=np.int32)
        n_elem = self.conn.shape[0]
        self.adj = face_adjacency(self.conn)
        self.alive = (np.ones(n_elem, dtype=bool) if alive is None
                      else np.array(alive, dtype=bool))
        self.face_flag = np.zeros(4 * n_elem, dtype=bool)
        self.pos = np.full(4 * n_elem, -1, dtype=np.int64)
        self.grows = 0
        self.n = 0
        self._events = np.empty(0, dtype=np.int64)  # scratch of remove
        nb_alive = np.where(self.adj >= 0, self.alive[np.maximum(self.adj, 0)], False)
        self._alloc(2 * int(np.count_nonzero(self.alive[:, None] & ~nb_alive)))
        self.n = int(_initial(self.conn, self.elem_body, self.adj, self.alive, self.face_flag,
                              LOCAL_FACES, self.faces, self.face_slot, self.face_body, self.pos))

    @classmethod
    def from_model(cls, model) -> "Boundary":
        from impactsim.model import ERODED

        return cls(model.conn, model.elem_body, model.status != ERODED)

    def _alloc(self, cap: int) -> None:
        cap = max(int(cap), 16)
        old = getattr(self, "faces", None)
        faces = np.zeros((cap, 3), dtype=np.int32)
        slot = np.zeros(cap, dtype=np.int64)
        body = np.zeros(cap, dtype=np.int32)
        if old is not None:
            faces[:self.n] = self.faces[:self.n]
            slot[:self.n] = self.face_slot[:self.n]
            body[:self.n] = self.face_body[:self.n]
        self.faces, self.face_slot, self.face_body = faces, slot, body

    @property
    def capacity(self) -> int:
        return self.faces.shape[0]

    def remove(self, elem_ids) -> int:
        """Remove elements (ascending ids give a deterministic order); returns how many were
        newly removed."""
        ids = np.ascontiguousarray(elem_ids, dtype=np.int64).reshape(-1)
        need = self.n + 4 * ids.shape[0]
        if need > self.capacity:
            self.grows += 1
            self._alloc(max(need, int(1.5 * self.capacity)))
        self._events = events_buffer(self._events, ids.shape[0])
        self.n, removed = remove_cells(ids, self.conn, self.elem_body, self.adj, self.alive,
                                       self.face_flag, LOCAL_FACES, self.faces, self.face_slot,
                                       self.face_body, self.pos, self.n, self._events)
        return int(removed)
