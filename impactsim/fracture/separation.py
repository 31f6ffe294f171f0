"""Node separation [Z] (ALGORITHMS.md 4.3 and 7.2): a body comes apart along element faces,
without deleting anything.

Design: node copies preallocated, families split on demand (the on-demand recipe of 7.2, after
Akantu's cohesive inserter, with the copies made at build time so that no node array ever grows).

- Build (solver/build.py, ``split_points``): every element of a body whose material has
  ``failure.fracture_strain`` gets its own copy of each of its nodes (node count x 8 for hexes,
  about x 20 for tets). The copies of one mesh node form a family. A tied (sub-)family is
  represented by one of its copies, its *rep* (the smallest copy index of the family part it
  stands for); the element connectivity points at the reps, so ``Model.conn`` is always the
  merged mesh as it currently is, and everything that reads it (element kernel, force rows,
  contact surface, free faces) sees a mesh whose nodes are shared exactly where the material
  still holds together. The rep carries the lumped mass of its part (sum of m_e / k over its
  corners, the same sum as the unsplit mesh); the other copies are dormant (zero mass: the
  predictor, energies, momentum and contact skip them).
- Release (``SeparationPass``, fracture stage, every step after the element update): an inner
  face fails when the effective plastic strain of its two elements (``[fracture]
  separation_measure`` = "mean" (default) or "max") reaches the fracture strain. Each node
  family touched by a newly failed face is split into the connected components of its star of
  live elements joined through the faces that have not failed (union-find, in copy order:
  deterministic). This is the partial release of the issue; ``separation_release = "nodes"``
  instead releases every copy of a family at once when the mean / max plastic strain of its
  star reaches the fracture strain. A part that leaves its rep gets a new rep (its smallest
  copy) with the parent's position and velocity and the parent's mass times the part's share of
  the lumped corner masses: mass and momentum are conserved to round-off through every release,
  and no force passes between the parts afterwards (they share no node). Each moved corner
  also takes its element's force of the last element update from the old rep to the new one
  (``SeparationPass.move_forces``: tets from the stored stress, hexes by the kernel re-run at
  dt = 0), so that every part enters the next predictor with the force of its own elements;
  left all on the old rep, whose mass shrank, that force over-accelerated it (momentum kept,
  energy gained: +4 % of the largest energy in the torn block of the tests, +100 % in the
  warm-up scene at 2 km/s).
- After a step with releases, what depends on the connectivity is refreshed, in place at the
  cost of the moved corners (``SeparationPass.refresh``, fracture/separation_refresh.py): the
  force rows of the element kernels (tets and the block runners), the fracture passes' free
  faces and live-node counts, the hexes' free quads (``hexes.reconnect_hex_boundary``), the
  node-to-element indices (the model's, a hex block's patch index: ``move_node_elements``) and
  the contact surface (``ContactContext.reconnect_surface``: only the moved tets and hexes and
  their neighbours, giving the arrays a rebuild gives: Surface.reconnect, HexSurface.reconnect).
  The faces exposed by a release are free faces of their bodies (contact with the other bodies,
  and self-contact of the fragments when ``contact.self_contact``) at the next velocity stage.
  ``SeparationPass.incremental = False`` rebuilds everything (the reference of the tests).
- Every step the stable step is lowered to that of the tets with a corner in a split family,
  from the masses their corners carry (``_released_step``, ``SeparationPass.limit_step``): the
  kernel's L / c holds for a connected mesh, not for a tet cut loose (its critical step is
  0.67 L / c), whose breathing mode otherwise rang up at cfl 0.6 until it inverted (issue 12).
- After every element update (and the release) the bulk-viscosity heat of the elements loose
  at the previous pass is booked with the mean of q at both ends of the step, the work their q
  forces do (``SeparationPass.centre_heat``): the kernels' -q^{n+1} dV over-booked a ringing
  lone tet's rebound (+10.9 % of the balance of the warm-up's block dragged at 2 km/s). An
  intact element whose EOS reads the energy takes the pressure of the re-booked energy, and
  that change's corner forces join the coming step's force (``consistent_pressure``).
"""

from __future__ import annotations

import numba
import numpy as np

import math

from impactsim.materials import params as P
from impactsim.materials.laws import eos_linear_part
from impactsim.materials.params import FRACTURE_STRAIN
from impactsim.fracture.separation_refresh import (move_node_elements, move_node_live,
                                                   reconnect_boundary, reconnect_rows)
from impactsim.solver.element import (FAST, _char_length, _tet_gradients,
                                      stored_corner_force)
from impactsim.solver.hex8 import _volume_gradient
from impactsim.mesh import buckets
from impactsim.mesh.topology import LOCAL_FACES as TET_FACES
from impactsim.model import ERODED, FRACTURED, INTACT

# the quad faces of a hex in VTK order, outward
HEX_FACES = np.array([[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6],
                      [3, 0, 4, 7]], dtype=np.int64)


def local_faces(corners: int) -> np.ndarray:
    return TET_FACES if corners == 4 else HEX_FACES


def face_adjacency_k(conn: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(n, f) int64 neighbour across each local face (faces (f, w) local corner lists), -1 on
    the boundary: faces matched by their sorted node tuples (lexsort, O(N log N); in linear
    time from KERNEL_MIN_ROWS element faces on, `mesh.buckets`)."""
    n, f = conn.shape[0], faces.shape[0]
    if n * f >= buckets.KERNEL_MIN_ROWS:
        adj = buckets.match_faces(conn, faces)
        if adj is None:
            raise ValueError("non-manifold mesh: a face is shared by more than two elements")
        return adj
    adj = np.full((n, f), -1, np.int64)
    if n == 0:
        return adj
    keys = np.sort(conn[:, faces].reshape(n * f, faces.shape[1]).astype(np.int64), axis=1)
    order = np.lexsort(keys.T[::-1])
    ks = keys[order]
    same = np.all(ks[1:] == ks[:-1], axis=1)
    a, b = order[:-1][same], order[1:][same]
    adj.reshape(-1)[a] = b // f
    adj.reshape(-1)[b] = a // f
    return adj


@numba.njit(cache=True)
def _find(parent, i):
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@numba.njit(cache=True)
def _fail_faces(conn, status, elem_mat, eps_p, mat_params, adj, faces, failed, sep, use_max,
                ecopy, fam, touched):
    """Mark the inner faces of separable elements whose plastic-strain measure reached the
    fracture strain (both sides) and flag the families of their nodes in ``touched``.
    Returns the number of newly failed faces."""
    n_new = 0
    nf, w = faces.shape[0], faces.shape[1]
    for e in range(conn.shape[0]):
        if not sep[e] or status[e] == ERODED:
            continue
        for i in range(nf):
            nb = adj[e, i]
            if nb < e or failed[e, i] or status[nb] == ERODED:
                continue  # each inner face once (from its lower element)
            a, b = eps_p[e], eps_p[nb]
            m = max(a, b) if use_max else 0.5 * (a + b)
            fs = min(mat_params[elem_mat[e], FRACTURE_STRAIN],
                     mat_params[elem_mat[nb], FRACTURE_STRAIN])
            if m < fs:
                continue
            failed[e, i] = True
            for jn in range(nf):
                if adj[nb, jn] == e:
                    failed[nb, jn] = True
            for q in range(w):
                touched[fam[ecopy[e, faces[i, q]]]] = True
            n_new += 1
    return n_new


@numba.njit(cache=True)
def _release_nodes(conn, status, elem_mat, eps_p, mat_params, use_max, fam_ptr, fam_mem,
                   copy_elem, copy_corner, released, touched):
    """``separation_release = "nodes"``: a family whose star (live elements) has a plastic
    strain mean / max at or above the fracture strain is released whole (all its copies apart).
    Returns the number of families released."""
    n = 0
    for f in range(fam_ptr.shape[0] - 1):
        if released[f]:
            continue
        s, cnt, mx, fs = 0.0, 0, 0.0, np.inf
        for k in range(fam_ptr[f], fam_ptr[f + 1]):
            e = copy_elem[fam_mem[k]]
            if status[e] == ERODED:
                continue
            s += eps_p[e]
            mx = max(mx, eps_p[e])
            cnt += 1
            fs = min(fs, mat_params[elem_mat[e], FRACTURE_STRAIN])
        if cnt == 0:
            continue
        m = mx if use_max else s / cnt
        if m >= fs:
            released[f] = True
            touched[f] = True
            n += 1
    return n


@numba.njit(cache=True)
def _split_families(conn, status, elem_mass, adj, faces, failed, corner_in_face, released,
                    fam_ptr, fam_mem, copy_elem, copy_corner, ecopy, fam, touched, x, x0, v,
                    mass, parent):
    """Split every touched family into the components of its live star joined through unfailed
    faces (module docstring). ``parent`` (n_copies,) scratch. Returns the new reps made."""
    k = conn.shape[1]
    nf = faces.shape[0]
    made = 0
    for f in range(fam_ptr.shape[0] - 1):
        if not touched[f]:
            continue
        touched[f] = False
        lo, hi = fam_ptr[f], fam_ptr[f + 1]
        for q in range(lo, hi):
            parent[fam_mem[q]] = fam_mem[q]
        if not released[f]:
            for q in range(lo, hi):
                c = fam_mem[q]
                e = copy_elem[c]
                if status[e] == ERODED:
                    continue
                j = copy_corner[c]
                for i in range(nf):
                    if not corner_in_face[j, i] or failed[e, i]:
                        continue
                    nb = adj[e, i]
                    if nb < 0 or status[nb] == ERODED:
                        continue
                    for jj in range(k):
                        c2 = ecopy[nb, jj]
                        if fam[c2] == f:
                            ra, rb = _find(parent, c), _find(parent, c2)
                            if ra != rb:  # the smaller index becomes the root
                                if ra < rb:
                                    parent[rb] = ra
                                else:
                                    parent[ra] = rb
                            break
        made += _apply_split(conn, status, elem_mass, fam_mem, lo, hi, copy_elem, copy_corner,
                             parent, x, x0, v, mass, k)
    return made


@numba.njit(cache=True)
def _apply_split(conn, status, elem_mass, fam_mem, lo, hi, copy_elem, copy_corner, parent, x,
                 x0, v, mass, k):
    """Move the components of the family members lo:hi that leave their group's rep to new
    reps (their roots), sharing the rep's mass by corner-mass weight. Returns reps made."""
    made = 0
    n = hi - lo
    # distinct groups (reps) and, per group, its kept root (smallest root among live members)
    reps = np.empty(n, np.int64)
    keep = np.empty(n, np.int64)
    wsum = np.zeros(n)
    ng = 0
    for q in range(lo, hi):
        c = fam_mem[q]
        e = copy_elem[c]
        if status[e] == ERODED:
            continue
        r = conn[e, copy_corner[c]]
        root = _find(parent, c)
        g = -1
        for t in range(ng):
            if reps[t] == r:
                g = t
                break
        if g < 0:
            g = ng
            reps[g] = r
            keep[g] = root
            ng += 1
        elif root < keep[g]:
            keep[g] = root
        wsum[g] += elem_mass[e] / k
    # per (group, leaving root): weights, then the new reps
    roots = np.empty(n, np.int64)
    rgrp = np.empty(n, np.int64)
    rw = np.zeros(n)
    nr = 0
    for q in range(lo, hi):
        c = fam_mem[q]
        e = copy_elem[c]
        if status[e] == ERODED:
            continue
        r = conn[e, copy_corner[c]]
        root = _find(parent, c)
        g = 0
        while reps[g] != r:
            g += 1
        if root == keep[g]:
            continue
        t = -1
        for u in range(nr):
            if roots[u] == root:
                t = u
                break
        if t < 0:
            t = nr
            roots[t] = root
            rgrp[t] = g
            nr += 1
        rw[t] += elem_mass[e] / k
    if nr == 0:
        return 0
    # masses: every leaving part takes its share of its group's current rep mass
    for t in range(nr):
        g = rgrp[t]
        r = reps[g]
        q_new = roots[t]
        share = mass[r] * (rw[t] / wsum[g])
        for d in range(3):
            x[q_new, d] = x[r, d]
            x0[q_new, d] = x0[r, d]
            v[q_new, d] = v[r, d]
        mass[q_new] = share
        made += 1
    for t in range(nr):  # the parents' remaining mass, after all shares were taken
        g = rgrp[t]
        mass[reps[g]] -= mass[roots[t]]
    # repoint the corners of the leaving parts
    for q in range(lo, hi):
        c = fam_mem[q]
        e = copy_elem[c]
        if status[e] == ERODED:
            continue
        r = conn[e, copy_corner[c]]
        root = _find(parent, c)
        g = 0
        while reps[g] != r:
            g += 1
        if root != keep[g]:
            conn[e, copy_corner[c]] = root
    return made


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def _tet_corner_forces(x, conn, status, sdev, pressure, q, e_ids, j_ids, out):
    """out[k] = the force corner j_ids[k] of tet e_ids[k] added to its node at the last element
    update (``element.stored_corner_force``, as ``element.node_forces``)."""
    for k in range(e_ids.shape[0]):
        out[k, 0], out[k, 1], out[k, 2] = stored_corner_force(
            e_ids[k], j_ids[k], x, conn, status, sdev, pressure, q)


@numba.njit(cache=True)
def _move_corner_forces(old, new, f, force):
    """The forces ``f`` of moved corners leave their old reps for their new ones, in corner
    order (deterministic): the new reps start from zero (dormant copies until now)."""
    for k in range(new.shape[0]):
        for d in range(3):
            force[new[k], d] = 0.0
    for k in range(new.shape[0]):
        for d in range(3):
            force[old[k], d] -= f[k, d]
            force[new[k], d] += f[k, d]


@numba.njit(cache=True)
def _centre_viscous_heat(ids, status, q, vol, q_prev, vol_prev, elem_mass, energy, pressure,
                         elem_mat, mat_params, consistent, dp):
    """Re-book the bulk-viscosity heat of the last element update of the elements ``ids`` with
    the mean of q at both ends of the step, -(q^n + q^{n+1}) / 2 dV, the work the q forces do
    (q^n acts over the first half of the step, q^{n+1} over the second), instead of the
    kernel's -q^{n+1} dV; ``q_prev``, ``vol_prev``: q and volume before the update.

    ``consistent``: an intact element whose EOS depends on the energy (p = a + b e, b > 0:
    Mie-Grueneisen) takes the energy and pressure the kernel's implicit update gives with the
    centred heat, e' = e + d / (1 + b dV / 2m), p' = p + b (e' - e) (d the heat change per
    mass; the kernel's trapezoid books -(p^n + p') dV / 2, so e' keeps the pressure work of
    the new pressure), and ``dp[k]`` = p' - p, whose corner forces the caller adds to the
    forces of the coming step. Otherwise (or when b = 0, or the element is damaged or
    fractured: the kernel's pressure branches there) e += d and dp[k] = 0.
    Returns the change of the booked viscous heat [J] (SeparationPass.centre_heat)."""
    total = 0.0
    for k in range(ids.shape[0]):
        e = ids[k]
        dp[k] = 0.0
        if status[e] == ERODED:
            continue
        dv = vol[e] - vol_prev[k]
        c = 0.5 * (q[e] - q_prev[k]) * dv
        total += c
        m = elem_mass[e]
        mk = elem_mat[e]
        b = 0.0
        if int(mat_params[mk, P.EOS]) == P.MIE_GRUNEISEN:
            b = mat_params[mk, P.GAMMA0] * mat_params[mk, P.RHO0]
        if consistent and b > 0.0 and status[e] == INTACT:
            de = (c / m) / (1.0 + 0.5 * dv * b / m)
            energy[e] += de
            dp[k] = b * de
            pressure[e] += dp[k]
        else:
            energy[e] += c / m
    return total


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def _tet_pressure_forces(x, conn, status, ids, dp, force):
    """The corner forces of the pressure changes ``dp`` of the tets ``ids`` added to ``force``
    (``element.stored_corner_force`` with the stress -dp I), in element and corner order."""
    z6 = np.zeros((1, 6))
    z1 = np.zeros(1)
    pe = np.zeros(1)
    st = np.zeros(1, np.int8)
    cn = np.zeros((1, 4), conn.dtype)
    for k in range(ids.shape[0]):
        if dp[k] == 0.0:
            continue
        e = ids[k]
        pe[0] = dp[k]
        st[0] = status[e]
        for a in range(4):
            cn[0, a] = conn[e, a]
        for a in range(4):
            fx, fy, fz = stored_corner_force(0, a, x, cn, st, z6, pe, z1)
            force[cn[0, a], 0] += fx
            force[cn[0, a], 1] += fy
            force[cn[0, a], 2] += fz


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def _hex_pressure_forces(x, conn, ids, dp, force):
    """The corner forces of the pressure changes ``dp`` of the hexes ``ids`` added to ``force``:
    dp times the volume gradient dV/dx_I at the current corners (the pressure part of the hex
    kernel's f_I = -sigma b_I), in element and corner order."""
    p = np.empty(24)
    b = np.empty(24)
    for k in range(ids.shape[0]):
        if dp[k] == 0.0:
            continue
        e = ids[k]
        for n in range(8):
            for d in range(3):
                p[3 * n + d] = x[conn[e, n], d]
        if not _volume_gradient(p, b) > 0.0:
            continue
        for n in range(8):
            for d in range(3):
                force[conn[e, n], d] += dp[k] * b[3 * n + d]


@numba.njit(cache=True, error_model="numpy")
def _released_step(x, v, conn, status, elem_mat, mat_params, pressure, elem_mass, mass, ids,
                   cq, cl):
    """(stable step, element) of the tets ``ids`` (those with a corner in a split family) with
    the masses their corners now carry: the element kernel's step L / (qq + sqrt(qq^2 + c^2))
    (element._element_scalar) with L replaced by min(L, l_m), l_m = 1 / sqrt(sum_a s_a
    |grad N_a|^2), s_a = (m_e / 4) / m_a the element's share of the mass of its corner a. With
    these masses the element alone has omega^2 <= c^2 rho V sum_a |grad N_a|^2 / m_a = 4 c^2 /
    l_m^2 (the Flanagan-Belytschko bound, weighted; checked on random tets and masses), so
    l_m / c is at most its critical step. In a connected mesh the corners are shared and the
    kernel's L / c binds (the 3 mm block of 1 mm Kuhn tets: min l_m = min L; its critical step
    is 0.94 L / c); a lone tet
    (s_a = 1) has l_m = 0.577 L (Kuhn tets; its critical step is 0.67 L / c), fragments of 2, 3,
    6, 12 tets 0.71 .. 0.93 L: critical step / (l_m / c) 0.94 .. 1.16, the connected mesh's
    margin (docs/fracture.md: time step of fragments)."""
    best, worst = np.inf, -1
    for k in range(ids.shape[0]):
        e = ids[k]
        st = status[e]
        if st == ERODED or st == FRACTURED:
            continue  # no stress, no force, no limit (as in the kernel)
        i0, i1, i2, i3 = conn[e, 0], conn[e, 1], conn[e, 2], conn[e, 3]
        det, b1x, b1y, b1z, b2x, b2y, b2z, b3x, b3y, b3z = _tet_gradients(
            x[i0, 0], x[i0, 1], x[i0, 2], x[i1, 0], x[i1, 1], x[i1, 2],
            x[i2, 0], x[i2, 1], x[i2, 2], x[i3, 0], x[i3, 1], x[i3, 2])
        if not det > 0.0:
            continue
        length = _char_length(det, b1x, b1y, b1z, b2x, b2y, b2z, b3x, b3y, b3z)
        b0x, b0y, b0z = -(b1x + b2x + b3x), -(b1y + b2y + b3y), -(b1z + b2z + b3z)
        share = 0.25 * elem_mass[e]
        s0 = 1.0 if not mass[i0] > share else share / mass[i0]
        s1 = 1.0 if not mass[i1] > share else share / mass[i1]
        s2 = 1.0 if not mass[i2] > share else share / mass[i2]
        s3 = 1.0 if not mass[i3] > share else share / mass[i3]
        g = (s0 * (b0x * b0x + b0y * b0y + b0z * b0z) + s1 * (b1x * b1x + b1y * b1y + b1z * b1z)
             + s2 * (b2x * b2x + b2y * b2y + b2z * b2z)
             + s3 * (b3x * b3x + b3y * b3y + b3z * b3z))
        lm = min(length, det / math.sqrt(g))
        mk = elem_mat[e]
        rho = 6.0 * elem_mass[e] / det
        _, _, c2a, c2b = eos_linear_part(int(mat_params[mk, P.EOS]), rho, mat_params[mk, P.RHO0],
                                         mat_params[mk, P.K], mat_params[mk, P.C0],
                                         mat_params[mk, P.S], mat_params[mk, P.GAMMA0])
        c2 = c2a + c2b * max(pressure[e], 0.0)
        if c2 < 0.0:
            c2 = 0.0
        if st == 0:  # intact (as the kernel): the shear modulus stiffens it
            c2 += 4.0 * mat_params[mk, P.G] / (3.0 * rho)
        # the volume rate of the corners' velocities (the kernel's on the mid-step geometry)
        trd = (b1x * (v[i1, 0] - v[i0, 0]) + b2x * (v[i2, 0] - v[i0, 0])
               + b3x * (v[i3, 0] - v[i0, 0])
               + b1y * (v[i1, 1] - v[i0, 1]) + b2y * (v[i2, 1] - v[i0, 1])
               + b3y * (v[i3, 1] - v[i0, 1])
               + b1z * (v[i1, 2] - v[i0, 2]) + b2z * (v[i2, 2] - v[i0, 2])
               + b3z * (v[i3, 2] - v[i0, 2]))
        trd /= det
        qq = cl * math.sqrt(c2) + cq * cq * length * (-trd) if trd < 0.0 else 0.0
        if not (c2 > 0.0 or qq > 0.0):
            continue
        dte = lm / (qq + math.sqrt(qq * qq + c2))
        if dte < best:
            best, worst = dte, e
    return best, worst


def _grow(fext: np.ndarray, add: int) -> np.ndarray:
    """``fext`` with ``add`` zero rows more (the force rows a release added)."""
    if not add:
        return fext
    return np.concatenate([fext, np.zeros((add, 3))])


class SeparableSet:
    """The separable elements of one element set (the tets, or a hex block) and their state."""

    def __init__(self, model, holder, sep_bodies, elem_start):
        self.holder = holder  # the Model (tets) or the ElementBlock
        conn = holder.conn
        n, k = conn.shape
        self.k = k
        self.faces = local_faces(k)
        nf = self.faces.shape[0]
        self.corner_in_face = np.zeros((k, nf), bool)
        for i in range(nf):
            self.corner_in_face[self.faces[i], i] = True
        self.sep = np.isin(holder.elem_body, sep_bodies)
        self.ecopy = np.full((n, k), -1, np.int64)
        nn = model.n_node
        self.copy_elem = np.full(nn, -1, np.int64)
        self.copy_corner = np.full(nn, -1, np.int64)
        for b in sep_bodies:
            e0, e1 = int(elem_start[b]), int(elem_start[b + 1])
            if e1 == e0:
                continue
            c0 = int(model.node_start[b])
            copies = c0 + np.arange((e1 - e0) * k, dtype=np.int64)
            self.ecopy[e0:e1] = copies.reshape(-1, k)
            self.copy_elem[copies] = np.repeat(np.arange(e0, e1), k)
            self.copy_corner[copies] = np.tile(np.arange(k), e1 - e0)
        self.adj = face_adjacency_k(conn, self.faces)
        self.failed = np.zeros((n, nf), bool)
        # the elements with a corner in a split family (their step: _released_step)
        self.loose = np.zeros(0, np.int64)
        # the loose elements at the end of the last pass and their q and volume then (the
        # centred viscous heat of the next element update: SeparationPass.centre_heat)
        self.q_ids = np.zeros(0, np.int64)
        self.q_prev = np.zeros(0)
        self.vol_prev = np.zeros(0)

    @property
    def n_sep(self) -> int:
        return int(np.count_nonzero(self.sep))


class Separation:
    """Node separation of a run: the separable sets, the families and the release (module
    docstring). ``model`` must come from build_model with separable bodies split."""

    def __init__(self, case, model):
        f = case.fracture
        self.use_max = f.separation_measure == "max"
        self.whole = f.separation_release == "nodes"
        self.bodies = np.flatnonzero(np.asarray(model.separable_bodies, bool)).astype(np.int64)
        self.sets = []
        if model.n_elem:
            self.sets.append(SeparableSet(model, model, self.bodies, model.elem_start))
        for blk in model.blocks:
            self.sets.append(SeparableSet(model, blk, self.bodies, blk.body_start))
        self.sets = [s for s in self.sets if s.n_sep]
        nn = model.n_node
        # families: the copies pointing at one rep at t = 0, numbered by that rep
        rep = np.full(nn, -1, np.int64)
        for s in self.sets:
            m = s.ecopy >= 0
            rep[s.ecopy[m]] = s.holder.conn[m]
        is_copy = rep >= 0
        reps = np.unique(rep[is_copy])
        self.fam = np.full(nn, -1, np.int64)
        self.fam[is_copy] = np.searchsorted(reps, rep[is_copy])
        members = np.flatnonzero(is_copy)
        order = np.argsort(self.fam[members], kind="stable")  # members ascending per family
        self.fam_mem = members[order].astype(np.int64)
        self.fam_ptr = np.zeros(reps.shape[0] + 1, np.int64)
        np.cumsum(np.bincount(self.fam[members], minlength=reps.shape[0]), out=self.fam_ptr[1:])
        self.released = np.zeros(reps.shape[0], bool)
        self.split = np.zeros(reps.shape[0], bool)  # families split at least once
        self.touched = np.zeros(reps.shape[0], bool)
        self.parent = np.zeros(nn, np.int64)
        dormant = is_copy & (model.mass == 0.0)
        model.v[dormant] = 0.0  # dormant copies stay where they are
        self.counts = {"failed_faces": 0, "released_families": 0, "new_nodes": 0,
                       "release_steps": 0}
        self.moved = []
        self.n_families = int(reps.shape[0])
        self.n_copies = int(members.shape[0])

    def release(self, model) -> bool:
        """Fail faces and split families (module docstring); True when the mesh changed."""
        changed = False
        self.moved = []  # (set, elements, corners, old reps, new reps) of the corners moved
        for s in self.sets:
            h = s.holder
            if self.whole:
                n = _release_nodes(h.conn, h.status, h.elem_mat, h.eps_p, model.mat_params,
                                   self.use_max, self.fam_ptr, self.fam_mem, s.copy_elem,
                                   s.copy_corner, self.released, self.touched)
                self.counts["released_families"] += int(n)
            else:
                n = _fail_faces(h.conn, h.status, h.elem_mat, h.eps_p, model.mat_params, s.adj,
                                s.faces, s.failed, s.sep, self.use_max, s.ecopy, self.fam,
                                self.touched)
                self.counts["failed_faces"] += int(n)
            if not n:
                continue
            before = h.conn.copy()
            made = _split_families(h.conn, h.status, h.elem_mass, s.adj, s.faces, s.failed,
                                   s.corner_in_face, self.released, self.fam_ptr, self.fam_mem,
                                   s.copy_elem, s.copy_corner, s.ecopy, self.fam, self.touched,
                                   model.x, model.x0, model.v, model.mass, self.parent)
            if made:
                self.counts["new_nodes"] += int(made)
                e, j = np.nonzero(before != h.conn)
                self.moved.append((s, e.astype(np.int64), j.astype(np.int64),
                                   before[e, j].astype(np.int64), h.conn[e, j].astype(np.int64)))
                self.split[self.fam[before[e, j]]] = True
                fam = np.where(s.ecopy >= 0, self.fam[s.ecopy], 0)
                s.loose = np.flatnonzero(s.sep & np.any(self.split[fam] & (s.ecopy >= 0),
                                                        axis=1)).astype(np.int64)
                h.conn = h.conn.copy()  # a new array: caches keyed on conn see the change
                changed = True
        if changed:
            self.counts["release_steps"] += 1
        return changed

    def summary(self, model) -> dict:
        return {"families": self.n_families, "copies": self.n_copies,
                "measure": "max" if self.use_max else "mean",
                "release": "nodes" if self.whole else "faces", **self.counts}


class SeparationPass:
    """Node separation after the element update (fracture stage, after the fracture pass):
    release, then the refresh of what depends on the connectivity (module docstring)."""

    name = "fracture.separation"
    stage = "fracture"

    def __init__(self, state, sep: Separation):
        self.s = state
        self.sep = sep
        self.sim = None
        # the contact surface follows a release in place (Surface.reconnect); False rebuilds
        # it (the reference of tests and benchmarks/bench_reconnect.py)
        self.incremental = True
        # the centred heat of loose elements also gives them the pressure of their EOS at the
        # re-booked energy, and its forces (centre_heat); False leaves the kernel's pressure
        self.consistent_pressure = True

    def attach(self, sim) -> None:
        self.sim = sim
        key = np.arange(sim.model.n_node, dtype=np.int64)
        copy = self.sep.fam >= 0
        key[copy] = sim.model.n_node + self.sep.fam[copy]  # the family, apart from any node
        for ctx in self.contexts():
            ctx.node_key = key

    def contexts(self):
        """The contact contexts of the run (one shared by the contact passes)."""
        if self.sim is None:
            return []
        return list({id(p.ctx): p.ctx for p in self.sim.velocity_passes
                     if hasattr(p, "ctx")}.values())

    def run(self, model, dt) -> None:
        # the release first: move_forces reads the stress of the forces the update added
        # (tets) or re-runs the kernel from the elements' energy (hexes), both as the update
        # left them, before centre_heat changes energy, pressure and forces
        if self.sep.release(model):
            self.move_forces(model)
            self.refresh(model)
        self.centre_heat(model)
        self.limit_step(model)
        for s in self.sep.sets:
            h = s.holder
            s.q_ids = s.loose
            s.q_prev = h.q[s.loose]
            s.vol_prev = h.vol[s.loose]

    def centre_heat(self, model) -> None:
        """Book the bulk-viscosity heat of the loose elements' last update with the mean of q
        at both ends of the step (``_centre_viscous_heat``). The element kernels book
        -q^{n+1} dV over the step whose volume change made q^{n+1}, while the force of q^{n+1}
        acts from the middle of that step to the middle of the next (Wilkins' booking: first
        order in the jump of q over a step, nothing in a resolved flow). A tet cut loose rings in
        its breathing mode at about six steps a period: its q jumps from 0 to ~25 GPa in one
        step of the rebound and the heat booked exceeded the work of its q forces by 4.3 J in
        the warm-up's dragged block at 2 km/s (+10.9 % of the balance; docs/fracture.md).

        With ``consistent_pressure`` an intact Mie-Grueneisen element also takes the pressure
        of its EOS at the re-booked energy (as the kernel's implicit update with the centred q
        gives it), and the corner forces of that pressure change are added to ``model.force``,
        which the next predictor reads: left as the kernel set it, the stored pressure was off
        the EOS by up to 1.2 |p| (tet4) until the next update (docs/fracture.md)."""
        terms = model.energy_terms
        for s in self.sep.sets:
            if not s.q_ids.shape[0]:
                continue
            h = s.holder
            dp = np.empty(s.q_ids.shape[0])
            terms["viscous"] += _centre_viscous_heat(
                s.q_ids, h.status, h.q, h.vol, s.q_prev, s.vol_prev, h.elem_mass, h.energy,
                h.pressure, h.elem_mat, model.mat_params, self.consistent_pressure, dp)
            if not self.consistent_pressure:
                continue
            if s.k == 4:
                _tet_pressure_forces(model.x, h.conn, h.status, s.q_ids, dp, model.force)
            else:
                _hex_pressure_forces(model.x, h.conn, s.q_ids, dp, model.force)

    def limit_step(self, model) -> None:
        """Lower the integrator's stable step (set by the element update just before) to that
        of the tets with a corner in a split family, with the masses their corners now carry
        (``_released_step``). The kernel's L / c assumes corners shared with neighbours; a tet
        cut loose has corners of a quarter of its own mass and its highest mode 1.5 times
        faster: at cfl 0.6 such tets rang in their breathing mode at 0.9 of their critical step,
        pumped by the bulk viscosity and by the step they set themselves (docs/fracture.md)."""
        sim = self.sim
        if sim is None:
            return
        for s in self.sep.sets:
            if s.k != 4 or not s.loose.shape[0]:
                continue
            h = s.holder
            dte, worst = _released_step(model.x, model.v, h.conn, h.status, h.elem_mat,
                                        model.mat_params, h.pressure, h.elem_mass, model.mass,
                                        s.loose, sim.cq, sim.cl)
            if dte < sim.dt_stable:
                sim.dt_stable, sim.worst_element = float(dte), int(worst)

    def move_forces(self, model) -> None:
        """Each moved corner takes the force its element added at the last element update from
        the old rep to the new one, so every part enters the next predictor with the force of
        its own elements (module docstring: leaving it all on the old rep, whose mass shrank,
        over-accelerated it: momentum kept, energy gained)."""
        for s, e, j, old, new in self.sep.moved:
            h = s.holder
            if s.k == 4:
                f = np.empty((e.shape[0], 3))
                _tet_corner_forces(model.x, h.conn, h.status, h.sdev, h.pressure, h.q, e, j, f)
            else:
                f = self._hex_forces(model, h, e, j)
            _move_corner_forces(old, new, f, model.force)

    def _hex_forces(self, model, blk, e, j) -> np.ndarray:
        """The corner forces (e, j) hexes added at the last element update (the hex kernel
        re-run at dt = 0 on copies of their state: solver.blocks.hex_corner_forces)."""
        from impactsim.solver.blocks import hex_corner_forces

        sim = self.sim
        if sim is None:
            raise RuntimeError("node separation of hexes needs the integrator (attach)")
        runner = sim.block_runners[[b is blk for b in model.blocks].index(True)]
        ids, inv = np.unique(e, return_inverse=True)
        f = hex_corner_forces(model, blk, runner, ids, sim.cq, sim.cl)
        return np.ascontiguousarray(f[inv, j])

    def refresh(self, model) -> None:
        """What depends on the connectivity, after a release: in place at the cost of the moved
        corners (fracture/separation_refresh.py, hexes.reconnect_hex_boundary, Surface.reconnect,
        HexSurface.reconnect) when ``incremental``, else rebuilt (the reference)."""
        from impactsim.solver.build import node_to_element
        from impactsim.solver.scatter import force_rows

        sim = self.sim
        moved = self.sep.moved
        blocks_changed = any(m[0].holder is not model for m in moved)
        if sim is not None:
            for s, e, j, old, new in moved:
                if s.holder is model:
                    if self.incremental:
                        sim.force_rows, add = reconnect_rows(sim.force_rows, model.conn, e, j,
                                                             new)
                        sim.fext = _grow(sim.fext, add)
                    continue
                r = sim.block_runners[[b is s.holder for b in model.blocks].index(True)]
                if self.incremental:
                    r.rows, add = reconnect_rows(r.rows, s.holder.conn, e, j, new)
                    r.fext = _grow(r.fext, add)
                else:
                    r.rows = force_rows(r.block.conn, model.n_node, r.rows.part_size)
                    r.fext = np.zeros((r.rows.n_rows, 3))
            if model.n_elem and not self.incremental:
                sim.set_parts(sim.force_rows.part_size)
            changed = [m[1] for m in moved if m[0].holder is model]
            changed = np.concatenate(changed) if changed else np.zeros(0, np.int64)
            hex_changed = np.zeros(0, np.int64)
            if blocks_changed:  # the moved hexes, numbered in the blocks' concatenation
                start = np.cumsum([0] + [b.conn.shape[0] for b in model.blocks])
                hex_changed = np.concatenate(
                    [start[[b is s.holder for b in model.blocks].index(True)] + e
                     for s, e, j, old, new in moved if s.holder is not model] + [hex_changed])
            for ctx in self.contexts():
                if self.incremental:
                    ctx.reconnect_surface(model, changed, hex_changed)
                else:
                    ctx.rebuild_surface(model)
        fs = self.s
        if not self.incremental:
            model.n2e_ptr, model.n2e = node_to_element(model.conn, model.n_node)
            fs.rebuild_mesh(model)
            return
        for s, e, j, old, new in moved:
            if s.holder is model:
                reconnect_boundary(fs.boundary, model.conn, e)
                move_node_elements(model.n2e_ptr, model.n2e, 4, e, j, old, new)
            else:
                next(h for h in fs.hexes if h.blk is s.holder).reconnect(e, j, old, new)
            move_node_live(fs.node_live, s.holder.status, e, old, new)

    def history(self, model) -> dict:
        return {"separated_nodes": float(self.sep.counts["new_nodes"])}

    def summary(self, model) -> dict:
        return {"fracture": {"separation": self.sep.summary(model)}}
