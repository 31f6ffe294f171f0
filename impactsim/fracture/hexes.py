"""Fracture of hexahedral bodies (ALGORITHMS.md 4.1-4.2 on the hex blocks of Model.blocks).

The same criteria, removal and bookkeeping as the tets (criteria.py, removal.py), on each
ElementBlock's arrays, which have the tets' layout (status, sdev, pressure, vol, vol0, eps_p,
damage, ...):

- ``hex_fracture_criteria``: one numba pass over a block, the pointwise steps of the tets'
  kernel (``criteria.element_state``: spall, loosening, Johnson-Cook damage;
  ``criteria.element_action``: particle, melt, erosion) with the hex's own geometry: a hex is on
  the surface when one of its six quads is free, a one-cell fragment when all six are (and it
  had a neighbour), the patch pressure is the mean over its eight nodes of the nodal means over
  the live hexes (``criteria.patch_fields`` with 8 corners), the principal stretch is that of
  the Jacobian at the hex's centre against the reference one (``principal.stretch_of``: exact
  for a parallelepiped, the mean deformation of a distorted hex), and the distortion guard
  predicts the hex's exact trilinear volume (``hex_volume``) 1.1 and 2.2 steps ahead.
- Removal is ``removal.remove_elements``, which works on any corner count: an eroded hex's
  orphaned corners pass their mass and momentum equally to its remaining corners, a hex whose
  corners are all orphaned, or a fractured surface hex, becomes particles with the mass its
  corners give (m_e / 8 each, an orphan all it has), its momentum and energy. Mass is conserved
  to round-off, momentum exactly up to it. Before the removal, the corner forces the hex added
  at the last element update are taken off its nodes (``solver.blocks.hex_corner_forces``), so it
  no longer pushes them at the next predictor (what Simulation.refresh_forces does for tets).
- ``HexBoundary``: the free quads of a block, each as two triangles split along the diagonal
  through the quad's smallest node (the split of the contact surface, contact/hexes.py), in
  O(change) as hexes leave (``contact.surface.free_face_changes`` with six faces per element):
  the faces the particles hit, and the surface flags of the criteria. The contact surface
  (contact/hexes.py ``HexSurface``) follows the blocks' status by itself.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from impactsim.contact.surface import events_buffer, free_face_changes
from impactsim.fracture import criteria as C
from impactsim.fracture.principal import stretch_of
from impactsim.fracture.separation import HEX_FACES, face_adjacency_k
from impactsim.fracture.separation_refresh import _open_faces_k, move_node_elements
from impactsim.fracture.spall import SPALL_CELL, spall_pressure
from impactsim.materials import params as P
from impactsim.model import ERODED

# sign of xi, eta, zeta at each corner (VTK order): the centre Jacobian's weights
XI = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
               [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], dtype=np.float64)


@numba.njit(cache=True, inline="always")
def _triple(ax, ay, az, bx, by, bz, cx, cy, cz):
    return ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)


@numba.njit(cache=True, inline="always")
def _d(x, v, h, conn, e, a, b):
    """Corner a minus corner b of hex e at positions x + h v."""
    i, j = conn[e, a], conn[e, b]
    return ((x[i, 0] + h * v[i, 0]) - (x[j, 0] + h * v[j, 0]),
            (x[i, 1] + h * v[i, 1]) - (x[j, 1] + h * v[j, 1]),
            (x[i, 2] + h * v[i, 2]) - (x[j, 2] + h * v[j, 2]))


@numba.njit(cache=True)
def hex_volume(x, v, h, conn, e):
    """Exact (trilinear) volume of hex e at positions x + h v: the closed form of LULESH's
    CalcElemVolume, (1/12) [(d31 + d72) . (d63 x d20) + (d43 + d57) . (d64 x d70)
    + (d14 + d25) . (d61 x d50)], dij = corner i - corner j."""
    a31 = _d(x, v, h, conn, e, 3, 1)
    a72 = _d(x, v, h, conn, e, 7, 2)
    a63 = _d(x, v, h, conn, e, 6, 3)
    a20 = _d(x, v, h, conn, e, 2, 0)
    a43 = _d(x, v, h, conn, e, 4, 3)
    a57 = _d(x, v, h, conn, e, 5, 7)
    a64 = _d(x, v, h, conn, e, 6, 4)
    a70 = _d(x, v, h, conn, e, 7, 0)
    a14 = _d(x, v, h, conn, e, 1, 4)
    a25 = _d(x, v, h, conn, e, 2, 5)
    a61 = _d(x, v, h, conn, e, 6, 1)
    a50 = _d(x, v, h, conn, e, 5, 0)
    t = (_triple(a31[0] + a72[0], a31[1] + a72[1], a31[2] + a72[2], a63[0], a63[1], a63[2],
                 a20[0], a20[1], a20[2])
         + _triple(a43[0] + a57[0], a43[1] + a57[1], a43[2] + a57[2], a64[0], a64[1], a64[2],
                   a70[0], a70[1], a70[2])
         + _triple(a14[0] + a25[0], a14[1] + a25[1], a14[2] + a25[2], a61[0], a61[1], a61[2],
                   a50[0], a50[1], a50[2]))
    return t / 12.0


@numba.njit(cache=True, inline="always")
def _dx(x, conn, e, a, b):
    """Corner a minus corner b of hex e at positions x."""
    i, j = conn[e, a], conn[e, b]
    return x[i, 0] - x[j, 0], x[i, 1] - x[j, 1], x[i, 2] - x[j, 2]


@numba.njit(cache=True, inline="always")
def _norm(a):
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@numba.njit(cache=True, inline="always")
def _term_bound(p, q, s, reach):
    """(change bound, grown scale) of the triple product p . (q x s) when each corner
    difference moves by at most reach (p is a sum of two of them): by multilinearity and
    Hadamard's inequality (|p| + 2 reach)(|q| + reach)(|s| + reach) - |p||q||s|."""
    np_, nq, ns = _norm(p), _norm(q), _norm(s)
    big = (np_ + 2.0 * reach) * (nq + reach) * (ns + reach)
    return big - np_ * nq * ns, big


@numba.njit(cache=True, inline="always")
def hex_clear(x, conn, e, reach, lim):
    """The hexes' counterpart of ``criteria.guard_clear``: True only when the full guard
    (``hex_volume`` at x + h v, h = 1.1 dt and 2.2 dt, below lim) cannot flag hex e, each
    corner difference moving by at most ``reach`` (``criteria.guard_reach`` for h = 2.2 dt).
    Bounds the change of each of the three triple products of LULESH's closed form
    (``_term_bound``); the rounding of both tests is covered by GUARD_ROUND_SLACK times the
    grown terms. Reads the corners' positions only."""
    a31 = _dx(x, conn, e, 3, 1)
    a72 = _dx(x, conn, e, 7, 2)
    a63 = _dx(x, conn, e, 6, 3)
    a20 = _dx(x, conn, e, 2, 0)
    a43 = _dx(x, conn, e, 4, 3)
    a57 = _dx(x, conn, e, 5, 7)
    a64 = _dx(x, conn, e, 6, 4)
    a70 = _dx(x, conn, e, 7, 0)
    a14 = _dx(x, conn, e, 1, 4)
    a25 = _dx(x, conn, e, 2, 5)
    a61 = _dx(x, conn, e, 6, 1)
    a50 = _dx(x, conn, e, 5, 0)
    p1 = (a31[0] + a72[0], a31[1] + a72[1], a31[2] + a72[2])
    p2 = (a43[0] + a57[0], a43[1] + a57[1], a43[2] + a57[2])
    p3 = (a14[0] + a25[0], a14[1] + a25[1], a14[2] + a25[2])
    t = (_triple(p1[0], p1[1], p1[2], a63[0], a63[1], a63[2], a20[0], a20[1], a20[2])
         + _triple(p2[0], p2[1], p2[2], a64[0], a64[1], a64[2], a70[0], a70[1], a70[2])
         + _triple(p3[0], p3[1], p3[2], a61[0], a61[1], a61[2], a50[0], a50[1], a50[2]))
    d1, b1 = _term_bound(p1, a63, a20, reach)
    d2, b2 = _term_bound(p2, a64, a70, reach)
    d3, b3 = _term_bound(p3, a61, a50, reach)
    return (t - (d1 + d2 + d3) - C.GUARD_ROUND_SLACK * (b1 + b2 + b3)) / 12.0 > lim


@numba.njit(cache=True, inline="always")
def _centre_jacobian(x, conn, e, xi):
    """dx/d(xi, eta, zeta) at the centre of hex e: column c = (1/8) sum_I xi_Ic x_I, returned
    row by row (j_rc, r the coordinate)."""
    j = np.zeros(9)
    for k in range(8):
        i = conn[e, k]
        for r in range(3):
            for c in range(3):
                j[3 * r + c] += 0.125 * xi[k, c] * x[i, r]
    return j


@numba.njit(cache=True)
def hex_stretch(x, x0, conn, e, xi):
    """Largest principal stretch of hex e: F = J J0^{-1} with J, J0 its centre Jacobians now
    and at the reference state (``principal.stretch_of``)."""
    m = _centre_jacobian(x0, conn, e, xi)
    s = _centre_jacobian(x, conn, e, xi)
    return stretch_of(m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7], m[8],
                      s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7], s[8])


@numba.njit(cache=True, parallel=True)
def hex_fracture_criteria(x, v, x0, conn, elem_mat, status, sdev, pressure, vol, vol0, eps_p,
                          eps_p_prev, damage, eps_rate, temperature, mat_params, face_flag, adj,
                          surface_only, dt, action, spall_mode, pnode, xi, spall_k, integrate,
                          reach):
    """``criteria.fracture_criteria`` on a hex block (module docstring): applies spall and
    loosening to ``status`` and decides ``action (n,) int8``. face_flag (6n,) free quads and adj
    (n, 6) quad neighbours at t = 0 (``HexBoundary``); pnode the nodal means of
    ``criteria.patch_fields`` over the block (read unless spall_mode is "cell"); spall_k, integrate
    the Tuler-Butcher accumulators and criterion (``spall.spalls``); reach, the guard's
    pre-test (``hex_clear``), as in ``criteria.fracture_criteria``. Returns (newly damaged,
    newly fractured, hexes with an action, newly damaged by the ductile criterion, hexes the
    guard tested, of them cleared by the pre-test)."""
    n_dam = 0
    n_frac = 0
    n_act = 0
    n_duct = 0
    n_guard = 0
    n_clear = 0
    pretest = reach < math.inf
    for e in numba.prange(conn.shape[0]):
        action[e] = C.NONE
        st = status[e]
        if st == ERODED:
            continue
        mk = elem_mat[e]
        p = pressure[e]
        if spall_mode != SPALL_CELL:
            pp = 0.0
            for k in range(8):
                pp += pnode[conn[e, k]]
            p = spall_pressure(spall_mode, p, 0.125 * pp)
        st, dam, frac = C.element_state(e, mk, st, p, sdev, vol, vol0, eps_p, eps_p_prev,
                                        damage, eps_rate, temperature, mat_params, dt, spall_k,
                                        integrate)
        n_dam += 1 if dam > 0 else 0
        n_duct += 1 if dam == 2 else 0
        n_frac += frac
        status[e] = st
        free = 0
        nb = 0
        for i in range(6):
            if face_flag[6 * e + i]:
                free += 1
            if adj[e, i] >= 0:
                nb += 1
        stretch = 1.0
        if int(mat_params[mk, P.EROSION]) == 3:
            stretch = hex_stretch(x, x0, conn, e, xi)
        act = C.element_action(e, mk, st, free > 0, free == 6 and nb > 0, surface_only, eps_p,
                               damage, temperature, mat_params, stretch)
        if act == C.NONE and C.failing_material(mat_params, mk):
            lim = C.GUARD_FRACTION * vol0[e]
            n_guard += 1
            if pretest and hex_clear(x, conn, e, reach, lim):
                n_clear += 1
            elif (hex_volume(x, v, 1.1 * dt, conn, e) < lim
                  or hex_volume(x, v, 2.2 * dt, conn, e) < lim):
                act = C.GUARD
        action[e] = act
        if act != C.NONE:
            n_act += 1
    return n_dam, n_frac, n_act, n_duct, n_guard, n_clear


@numba.njit(cache=True)
def pass_orphan_forces(ids, conn, node_live, force):
    """After removing hexes ``ids``: the force left on each orphaned corner (the difference
    between what the hexes added at the last update and what ``hex_corner_forces`` took off:
    round-off, the yield caches' update, and the velocity impulses of the passes between the
    update and the removal) goes, shared equally, to the remaining corners of a removed hex, as
    its mass did (removal.py): a massless node's force would be lost and the momentum with it.
    A removed hex with no remaining corner passes its orphans' forces to the remaining corners
    of the nearest removed hex that has some, through the corners the removed hexes share (a
    cluster of hexes removed together; with none in the cluster the forces stay, and they sum
    to the round-off of the cluster's own forces). Returns how many orphans passed a force."""
    k = conn.shape[1]
    m = ids.shape[0]
    target = np.full(m, -1, np.int64)  # the removed hex whose remaining corners take q's forces
    n_rem = np.zeros(m, np.int64)
    for q in range(m):
        for j in range(k):
            if node_live[conn[ids[q], j]] > 0:
                n_rem[q] += 1
        if n_rem[q] > 0:
            target[q] = q
    node_target = np.full(force.shape[0], -1, np.int64)
    changed = True
    while changed:  # spread the targets through shared corners, in the order of ids
        changed = False
        for q in range(m):
            if target[q] >= 0:
                for j in range(k):
                    o = conn[ids[q], j]
                    if node_target[o] < 0:
                        node_target[o] = target[q]
        for q in range(m):
            if target[q] < 0:
                for j in range(k):
                    t = node_target[conn[ids[q], j]]
                    if t >= 0:
                        target[q] = t
                        changed = True
                        break
    n = 0
    for q in range(m):
        if target[q] < 0:
            continue
        e = ids[q]
        r_e = ids[target[q]]
        nr = n_rem[target[q]]
        for j in range(k):
            o = conn[e, j]
            if node_live[o] > 0 or (force[o, 0] == 0.0 and force[o, 1] == 0.0
                                    and force[o, 2] == 0.0):
                continue
            for jj in range(k):
                r = conn[r_e, jj]
                if node_live[r] > 0:
                    for d in range(3):
                        force[r, d] += force[o, d] / nr
            force[o, 0] = 0.0
            force[o, 1] = 0.0
            force[o, 2] = 0.0
            n += 1
    return n


# --- the free quads of a block, as triangles ------------------------------------------------
@numba.njit(cache=True)
def _append_quad(s, conn, elem_body, quads, faces, face_slot, face_body, pos, n):
    """Quad slot s = 6 hex + local becomes free: its two triangles at rows n, n + 1, split along
    the diagonal through its smallest node (contact.hexes.split_quads)."""
    e = s // 6
    i = s % 6
    a = conn[e, quads[i, 0]]
    b = conn[e, quads[i, 1]]
    c = conn[e, quads[i, 2]]
    d = conn[e, quads[i, 3]]
    low = min(min(a, b), min(c, d))
    if low == a or low == c:
        t = (a, b, c, a, c, d)
    else:
        t = (b, c, d, b, d, a)
    faces[n, 0], faces[n, 1], faces[n, 2] = t[0], t[1], t[2]
    faces[n + 1, 0], faces[n + 1, 1], faces[n + 1, 2] = t[3], t[4], t[5]
    face_slot[n] = s
    face_slot[n + 1] = s
    face_body[n] = elem_body[e]
    face_body[n + 1] = elem_body[e]
    pos[s] = n
    return n + 2


@numba.njit(cache=True)
def _drop_quad(s, faces, face_slot, face_body, pos, n):
    """Quad slot s stops being free: the last two rows take its place."""
    k = pos[s]
    last = n - 2
    if k != last:
        for r in range(2):
            for j in range(3):
                faces[k + r, j] = faces[last + r, j]
            face_slot[k + r] = face_slot[last + r]
            face_body[k + r] = face_body[last + r]
        pos[face_slot[k]] = k
    pos[s] = -1
    return last


@numba.njit(cache=True)
def remove_hex_cells(ids, conn, elem_body, adj, alive, face_flag, quads, faces, face_slot,
                     face_body, pos, n, events):
    """``boundary.remove_cells`` for a hex block: the quad changes of
    ``contact.surface.free_face_changes`` (six faces per hex), applied in their order. Returns
    (new row count, hexes removed)."""
    m, removed = free_face_changes(ids, adj, alive, face_flag, events)
    for k in range(m):
        s = events[k]
        if s < 0:
            n = _drop_quad(-1 - s, faces, face_slot, face_body, pos, n)
        else:
            n = _append_quad(s, conn, elem_body, quads, faces, face_slot, face_body, pos, n)
    return n, removed


@numba.njit(cache=True)
def _initial_quads(conn, elem_body, adj, alive, face_flag, quads, faces, face_slot, face_body,
                   pos):
    n = 0
    for e in range(conn.shape[0]):
        if not alive[e]:
            continue
        for i in range(6):
            nb = adj[e, i]
            if nb >= 0 and alive[nb]:
                continue
            s = 6 * e + i
            face_flag[s] = True
            n = _append_quad(s, conn, elem_body, quads, faces, face_slot, face_body, pos, n)
    return n


@numba.njit(cache=True)
def _reflag_quads(elems, changed_mask, conn, elem_body, adj, alive, face_flag, quads, faces,
                  face_slot, face_body, pos, n):
    """``_reflag_faces`` for a hex block's free quads: a quad that became free is appended (two
    triangles), a free quad of a moved hex is written again with its new nodes (and the split
    through its new smallest node). Returns the new row count (room for 12 rows per hex)."""
    for k in range(elems.shape[0]):
        e = elems[k]
        for i in range(6):
            s = 6 * e + i
            nb = adj[e, i]
            free = alive[e] and not (nb >= 0 and alive[nb])
            if free and not face_flag[s]:
                face_flag[s] = True
                n = _append_quad(s, conn, elem_body, quads, faces, face_slot, face_body, pos, n)
            elif free and changed_mask[e]:
                _append_quad(s, conn, elem_body, quads, faces, face_slot, face_body, pos, pos[s])
    return n


def reconnect_hex_boundary(b, conn: np.ndarray, changed: np.ndarray) -> None:
    """Follow a node-separation release in a hex block's free quads ``b`` (a HexBoundary), as
    ``separation_refresh.reconnect_boundary`` does for the tets: ``changed`` the hexes whose
    corners were repointed in ``conn``. The faces the release opened become free quads of both
    sides, the free quads of the moved hexes take their new nodes, and the rows end in slot
    order: the arrays of a HexBoundary built afresh."""
    changed = np.unique(np.asarray(changed, dtype=np.int64))
    if changed.shape[0] == 0:
        return
    b.conn[changed] = conn[changed]
    nbs = b.adj[changed].reshape(-1)
    touched = np.unique(np.concatenate([changed, nbs[nbs >= 0]]))
    _open_faces_k(changed, b.conn, b.adj, HEX_FACES)
    need = b.n + 12 * touched.shape[0]
    if need > b.faces.shape[0]:
        b.grows += 1
        b._alloc(max(need, int(1.5 * b.faces.shape[0])))
    mask = np.zeros(b.conn.shape[0], np.bool_)
    mask[changed] = True
    n = b.n = int(_reflag_quads(touched, mask, b.conn, b.elem_body, b.adj, b.alive,
                                b.face_flag, HEX_FACES, b.faces, b.face_slot, b.face_body,
                                b.pos, b.n))
    order = np.argsort(b.face_slot[:n], kind="stable")  # a quad's two rows keep their order
    b.faces[:n] = b.faces[:n][order]
    b.face_slot[:n] = b.face_slot[:n][order]
    b.face_body[:n] = b.face_body[:n][order]
    b.pos[b.face_slot[:n:2]] = np.arange(0, n, 2)


class HexBoundary:
    """The free quads of a hex block as triangles, updatable in O(change) (the hexes' version of
    ``impactsim.fracture.boundary.Boundary``: adj (n, 6), alive (n,), face_flag (6n,) slot
    ``6*hex + local``; faces (cap, 3) int32, face_slot (cap,) the quad slot of each triangle,
    face_body (cap,), rows [0, n) live, two per free quad; pos (6n,) the first row of a free
    quad, -1 otherwise)."""

    def __init__(self, conn, elem_body, alive=None):
        self.conn = np.ascontiguousarray(conn, dtype=np.int32)
        self.elem_body = np.ascontiguousarray(elem_body, dtype=np.int32)
        n_elem = self.conn.shape[0]
        self.adj = face_adjacency_k(self.conn, HEX_FACES)
        self.alive = (np.ones(n_elem, dtype=bool) if alive is None
                      else np.array(alive, dtype=bool))
        self.face_flag = np.zeros(6 * n_elem, dtype=bool)
        self.pos = np.full(6 * n_elem, -1, dtype=np.int64)
        self.grows = 0
        self.n = 0
        self._events = np.empty(0, dtype=np.int64)
        nb_alive = np.where(self.adj >= 0, self.alive[np.maximum(self.adj, 0)], False)
        self._alloc(4 * int(np.count_nonzero(self.alive[:, None] & ~nb_alive)))
        self.n = int(_initial_quads(self.conn, self.elem_body, self.adj, self.alive,
                                    self.face_flag, HEX_FACES, self.faces, self.face_slot,
                                    self.face_body, self.pos))

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

    def remove(self, elem_ids) -> int:
        """Remove hexes (ascending ids: a deterministic order); returns how many were newly
        removed."""
        ids = np.ascontiguousarray(elem_ids, dtype=np.int64).reshape(-1)
        need = self.n + 12 * ids.shape[0]
        if need > self.faces.shape[0]:
            self.grows += 1
            self._alloc(max(need, int(1.5 * self.faces.shape[0])))
        self._events = events_buffer(self._events, ids.shape[0], 6)
        self.n, removed = remove_hex_cells(ids, self.conn, self.elem_body, self.adj, self.alive,
                                           self.face_flag, HEX_FACES, self.faces,
                                           self.face_slot, self.face_body, self.pos, self.n,
                                           self._events)
        return int(removed)


class HexFracture:
    """The fracture state of one hex block: its free quads, the criteria's per-hex scratch and
    the patch pressure's node index (module docstring)."""

    def __init__(self, model, blk):
        self.blk = blk
        self.boundary = HexBoundary(blk.conn, blk.elem_body, blk.status != ERODED)
        self.action = np.zeros(blk.n_elem, dtype=np.int8)
        self.ids = np.zeros(blk.n_elem, dtype=np.int64)
        self.eps_p_prev = blk.eps_p.copy()
        self.spall_k = np.zeros(blk.n_elem)  # [s] Tuler-Butcher accumulators (spall.py)
        self.ductile = 0  # cells the ductile criterion damaged (fracture/ductile.py)
        self.status_before = blk.status.copy()  # before the criteria of the step
        self.pnode = np.zeros(model.n_node)
        self.jnode = np.ones(model.n_node)
        self._n2e = None

    def rebuild(self, model) -> None:
        """The free quads afresh from the block's conn (after node separation repointed
        corners)."""
        blk = self.blk
        self.boundary = HexBoundary(blk.conn, blk.elem_body, blk.status != ERODED)

    def reconnect(self, e, j, old, new) -> None:
        """Follow a node-separation release in place (the corners (e, j) of the block moved from
        the nodes ``old`` to ``new``): the free quads (``reconnect_hex_boundary``) and the patch
        pressure's node index (``separation_refresh.move_node_elements``), the arrays
        ``rebuild`` and a fresh index give."""
        blk = self.blk
        reconnect_hex_boundary(self.boundary, blk.conn, e)
        if self._n2e is not None:
            ptr, n2e, _ = self._n2e
            move_node_elements(ptr, n2e, 8, e, j, old, new)
            self._n2e = (ptr, n2e, blk.conn)

    def criteria(self, model, dt: float, surface_only: bool, spall_mode: int, integrate: bool,
                 guard=None):
        """Run the criteria on the block; returns (newly damaged, newly fractured, ascending ids
        of the hexes with an action); adds the ductile criterion's share to self.ductile.
        ``guard``: the pre-test's ``criteria.GuardPretest`` (None: always the full guard)."""
        b, blk = self.boundary, self.blk
        np.copyto(self.status_before, blk.status)  # what the element update saw
        if spall_mode != SPALL_CELL:
            if self._n2e is None or self._n2e[2] is not blk.conn:
                from impactsim.solver.build import node_to_element

                self._n2e = (*node_to_element(blk.conn, model.n_node), blk.conn)
            C.patch_fields(blk.vol, blk.vol0, blk.pressure, blk.status, self._n2e[0],
                           self._n2e[1], self.pnode, self.jnode, 8)
        reach = math.inf if guard is None else guard.reach(model, dt)
        n_dam, n_frac, n_act, n_duct, n_guard, n_clear = hex_fracture_criteria(
            model.x, model.v, model.x0, blk.conn, blk.elem_mat, blk.status, blk.sdev,
            blk.pressure, blk.vol, blk.vol0, blk.eps_p, self.eps_p_prev, blk.damage,
            blk.eps_rate, blk.temperature, model.mat_params, b.face_flag, b.adj, surface_only,
            dt, self.action, spall_mode, self.pnode, XI, self.spall_k, integrate, reach)
        if guard is not None:
            guard.count(n_guard, n_clear)
        ids = self.ids[:C.action_ids(self.action, self.ids)] if n_act else self.ids[:0]
        self.ductile += int(n_duct)
        return int(n_dam), int(n_frac), ids

