"""Projected Gauss-Seidel rounds over the constraint rows of a step (contact energy, see
docs/physics.md "Contact energy" and the ``passes`` module docstring).

A row is a pair of the node-face or the edge-edge pass that got an impulse in the step, with the
geometry of its crossing (weights or alpha, beta, the unit normal n, a target velocity) and its
accumulated normal impulse lam >= 0. Both kinds have the same form: four nodes i with
coefficients c_i, the relative normal velocity u = sum c_i (v_i . n), which must be at least the
target t, and an impulse dlam that changes v_i by c_i dlam n / m_i:

- node-face (ALGORITHMS.md 3.1), node p on face (a, b, c) with weights w: nodes (p, a, b, c),
  c = (1, -w_a, -w_b, -w_c), n the face's outward normal, t = 0 at a crossing (equal normal
  velocities) or the restoring speed of a touching node;
- edge-edge (ALGORITHMS.md 3.2, [D19 eq. 11, 12]), edges [a, b] and [e, f]: nodes (a, b, e, f),
  c = (-(1 - alpha), -alpha, 1 - beta, beta), n from body 1 toward body 2, t = -gap / tau.

A round visits the rows in order (node-face rows, then edge-edge rows, each in the order of
their pairs) and sets each to its target, u = t, with lam >= 0: an impulse may be taken back down
to 0 (never a pull). Two rows that hold nearly the same nodes apart along nearly the same
direction (the mirror rows of the symmetric node-face pass at two coincident vertices; a
node-face row and an edge-edge row at a vertex) undo each other's updates, and scalar rounds
reduce their error only by a factor rho^2 per round, rho their normalised coupling; such rows
(mutual strongest partners with rho > RHO_BLOCK) are solved together, exactly, as a 2 x 2
complementarity problem (``_block``). Only helping couplings pair up (pushing one row opens the
other): two rows with opposite demands (a node of each body on the other's coplanar side face)
would get a pair of huge, cancelling impulses. Rounds are frictionless; with friction the
passes do not call them (``passes`` module docstring).

Prescribed velocity components (``lock (n_node, 3)``, 0.0 where prescribed, else 1.0; an empty
array when the case prescribes none, and then the plain code below runs): an impulse changes
node i's velocity only along its free axes, c_i dlam (lock_i * n) / m_i, so every inverse mass
1/m_i along a pair of directions (n_r, n_s) becomes sum_d lock_i,d n_r,d n_s,d / m_i, in the
diagonal D_r, the couplings C_rs (mirror rows included) and the update alike
(``impactsim.contact.impulse``).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from impactsim.contact.impulse import NO_LOCK, VEL_TOL

RHO_BLOCK = 0.5  # rows coupled more strongly than this (normalised, helping) are solved in pairs


@numba.njit(cache=True, inline="always")
def unchanged_since(stamp, since, i0, i1, i2, i3):
    """True when none of a pair's four nodes changed velocity in sweep ``since`` or later
    (``stamp (n_node,)``: the number of the sweep that last changed a node; numbers only
    grow): a repeated sweep may skip the pair, its answer would be the same."""
    return max(max(stamp[i0], stamp[i1]), max(stamp[i2], stamp[i3])) < since


@numba.njit(cache=True, inline="always")
def first_visit(J, active, k):
    """The result of testing pair k afresh (it was no row): an impulse J > 0 makes it a row
    (active[k] = 1, its geometry in row k of the pass's table); anything else counts as 0."""
    if J > 0.0:
        active[k] = 1
        return J
    return 0.0


@numba.njit(cache=True, inline="always")
def stamp_nodes(stamp, sweep, i0, i1, i2, i3):
    """A pair's four nodes changed velocity in sweep ``sweep``."""
    stamp[i0] = sweep
    stamp[i1] = sweep
    stamp[i2] = sweep
    stamp[i3] = sweep


@numba.njit(cache=True, inline="always")
def pushes_again(err, slack, scale):
    """A row's later visit pushes when its relative normal velocity falls short of its target
    by err > slack [m/s] and by more than VEL_TOL of the speeds in it (``scale``)."""
    return err > slack and err > VEL_TOL * scale


@numba.njit(cache=True)
def gather_node_face(rows, pairs, nodes, faces, geo, off, idx, coef, nrm, tgt, lam):
    """Rows ``rows`` (indices into the node-face pairs; geo columns lam, w_a, w_b, w_c, n, vmin)
    into rows off, off + 1, ... of the table."""
    for i in range(rows.shape[0]):
        k = rows[i]
        r = off + i
        f = pairs[k, 1]
        idx[r, 0] = nodes[pairs[k, 0]]
        idx[r, 1] = faces[f, 0]
        idx[r, 2] = faces[f, 1]
        idx[r, 3] = faces[f, 2]
        coef[r, 0] = 1.0
        coef[r, 1] = -geo[k, 1]
        coef[r, 2] = -geo[k, 2]
        coef[r, 3] = -geo[k, 3]
        nrm[r, 0] = geo[k, 4]
        nrm[r, 1] = geo[k, 5]
        nrm[r, 2] = geo[k, 6]
        tgt[r] = geo[k, 7]
        lam[r] = geo[k, 0]


@numba.njit(cache=True)
def gather_edge_edge(rows, pairs, edges, geo, off, idx, coef, nrm, tgt, lam):
    """Rows ``rows`` (indices into the edge-edge pairs; geo columns lam, alpha, beta, n,
    gap / tau) into rows off, off + 1, ... of the table."""
    for i in range(rows.shape[0]):
        k = rows[i]
        r = off + i
        al = geo[k, 1]
        be = geo[k, 2]
        idx[r, 0] = edges[pairs[k, 0], 0]
        idx[r, 1] = edges[pairs[k, 0], 1]
        idx[r, 2] = edges[pairs[k, 1], 0]
        idx[r, 3] = edges[pairs[k, 1], 1]
        coef[r, 0] = -(1.0 - al)
        coef[r, 1] = -al
        coef[r, 2] = 1.0 - be
        coef[r, 3] = be
        nrm[r, 0] = geo[k, 3]
        nrm[r, 1] = geo[k, 4]
        nrm[r, 2] = geo[k, 5]
        tgt[r] = -geo[k, 6]
        lam[r] = geo[k, 0]


@numba.njit(cache=True)
def _coupling(r, s, idx, coef, nrm, mass, lock):
    """G_r M^-1 G_s^T: the change of u_r per unit impulse of row s."""
    nd = nrm[r, 0] * nrm[s, 0] + nrm[r, 1] * nrm[s, 1] + nrm[r, 2] * nrm[s, 2]
    c = 0.0
    for a in range(4):
        for b in range(4):
            if idx[r, a] == idx[s, b]:
                i = idx[r, a]
                if lock.shape[0] == 0:
                    c += coef[r, a] * coef[s, b] * nd / mass[i]
                else:
                    ld = (lock[i, 0] * nrm[r, 0] * nrm[s, 0] + lock[i, 1] * nrm[r, 1] * nrm[s, 1]
                          + lock[i, 2] * nrm[r, 2] * nrm[s, 2])
                    c += coef[r, a] * coef[s, b] * ld / mass[i]
    return c


@numba.njit(cache=True)
def _stable_order(flat):
    """np.argsort(flat, kind="mergesort") for node indices >= 0, by a counting sort: the
    entries of one node in their order in ``flat`` (a few thousand rows a step: the merge sort
    cost more than the rest of ``row_partners``)."""
    m = flat.shape[0]
    order = np.empty(m, np.int64)
    if m == 0:
        return order
    start = np.zeros(flat.max() + 2, np.int64)
    for q in range(m):
        start[flat[q] + 1] += 1
    for i in range(1, start.shape[0]):
        start[i] += start[i - 1]
    for q in range(m):
        i = flat[q]
        order[start[i]] = q
        start[i] += 1
    return order


@numba.njit(cache=True)
def row_partners(idx, coef, nrm, mass, diag, partner, lock=NO_LOCK):
    """diag[r] = sum c_i^2 / m_i (with ``lock``: sum c_i^2 s_i / m_i, s_i = sum_d lock_i,d
    n_d^2); partner[r] = the row s solved together with r (mutual
    strongest helping coupling rho = C_rs / sqrt(D_r D_s) > RHO_BLOCK), else -1."""
    n = idx.shape[0]
    best = np.full(n, -1, np.int64)
    rho = np.full(n, RHO_BLOCK)
    for r in range(n):
        d = 0.0
        if lock.shape[0] == 0:
            for a in range(4):
                d += coef[r, a] * coef[r, a] / mass[idx[r, a]]
        else:
            for a in range(4):
                i = idx[r, a]
                d += coef[r, a] * coef[r, a] * (lock[i, 0] * nrm[r, 0] * nrm[r, 0]
                                                + lock[i, 1] * nrm[r, 1] * nrm[r, 1]
                                                + lock[i, 2] * nrm[r, 2] * nrm[r, 2]) / mass[i]
        diag[r] = d
    flat = idx.ravel()
    order = _stable_order(flat)
    i = 0
    while i < flat.shape[0]:
        j = i + 1
        while j < flat.shape[0] and flat[order[j]] == flat[order[i]]:
            j += 1
        for a in range(i, j):
            r = order[a] // 4
            for b in range(a + 1, j):
                s = order[b] // 4
                if r == s:
                    continue
                q = _coupling(r, s, idx, coef, nrm, mass, lock) / math.sqrt(diag[r] * diag[s])
                if q > rho[r] or (q == rho[r] and best[r] >= 0 and s < best[r]):
                    rho[r] = q
                    best[r] = s
                if q > rho[s] or (q == rho[s] and best[s] >= 0 and r < best[s]):
                    rho[s] = q
                    best[s] = r
        i = j
    for r in range(n):
        s = best[r]
        partner[r] = s if s >= 0 and best[s] == r else -1


@numba.njit(cache=True)
def _u(r, idx, coef, nrm, v):
    u = 0.0
    scale = 0.0
    for a in range(4):
        i = idx[r, a]
        vn = v[i, 0] * nrm[r, 0] + v[i, 1] * nrm[r, 1] + v[i, 2] * nrm[r, 2]
        u += coef[r, a] * vn
        scale += abs(coef[r, a] * vn)
    return u, scale


@numba.njit(cache=True)
def _apply(r, x, idx, coef, nrm, v, mass, stamp, sweep, lock):
    """Impulse x along row r; returns (the largest velocity change of its nodes, the change of
    their kinetic energy [J])."""
    jump = 0.0
    dke = 0.0
    for a in range(4):
        i = idx[r, a]
        m = mass[i]
        f = coef[r, a] * x / m
        dx = f * nrm[r, 0]
        dy = f * nrm[r, 1]
        dz = f * nrm[r, 2]
        if lock.shape[0] != 0:
            dx *= lock[i, 0]
            dy *= lock[i, 1]
            dz *= lock[i, 2]
        dke += m * (v[i, 0] * dx + v[i, 1] * dy + v[i, 2] * dz
                    + 0.5 * (dx * dx + dy * dy + dz * dz))
        v[i, 0] += dx
        v[i, 1] += dy
        v[i, 2] += dz
        stamp[i] = sweep
        jump = max(jump, abs(f))
    return jump, dke


@numba.njit(cache=True)
def _block(r, s, idx, coef, nrm, tgt, lam, diag, v, mass, lock):
    """Rows r, s together: lam + x >= 0, u + A x >= t, (lam + x) (u + A x - t) = 0 with
    A = [[D_r, C], [C, D_s]]. Returns (x_r, x_s); (0, 0) when no case fits (round-off)."""
    ur, sr = _u(r, idx, coef, nrm, v)
    us, ss = _u(s, idx, coef, nrm, v)
    er = tgt[r] - ur
    es = tgt[s] - us
    dr = diag[r]
    ds = diag[s]
    c = _coupling(r, s, idx, coef, nrm, mass, lock)
    lr = lam[r]
    ls = lam[s]
    tol = VEL_TOL * (sr + ss + abs(tgt[r]) + abs(tgt[s]))
    det = dr * ds - c * c
    if det > 1e-12 * dr * ds:  # both keep an impulse
        xr = (ds * er - c * es) / det
        xs = (dr * es - c * er) / det
        if lr + xr >= 0.0 and ls + xs >= 0.0:
            return xr, xs
    xs = -ls  # r only
    xr = (er - c * xs) / dr
    if lr + xr >= 0.0 and es - c * xr - ds * xs <= tol:
        return xr, xs
    xr = -lr  # s only
    xs = (es - c * xr) / ds
    if ls + xs >= 0.0 and er - dr * xr - c * xs <= tol:
        return xr, xs
    xr = -lr  # neither
    xs = -ls
    if er - dr * xr - c * xs <= tol and es - c * xr - ds * xs <= tol:
        return xr, xs
    return 0.0, 0.0


@numba.njit(cache=True)
def rows_round(idx, coef, nrm, tgt, lam, diag, partner, v, mass, stamp, sweep, lock=NO_LOCK):
    """One projected Gauss-Seidel round over all rows (module docstring; ``lock`` as in
    ``row_partners``, which made ``diag`` and ``partner``). Changed nodes get
    ``stamp = sweep``. Returns (rows changed, sum of the impulse changes [N s], largest velocity
    change of a node [m/s], change of the rounds' objective [J]). The objective, kinetic energy
    minus sum t_r lam_r, is what a round minimises row by row (its derivative along lam_r is
    u_r - t_r): it never grows, and its decrease per round measures convergence
    (``passes._project``)."""
    changed = 0
    total = 0.0
    jump = 0.0
    dphi = 0.0
    for r in range(idx.shape[0]):
        s = partner[r]
        if s >= 0:
            if s < r:
                continue
            xr, xs = _block(r, s, idx, coef, nrm, tgt, lam, diag, v, mass, lock)
            for q, x in ((r, xr), (s, xs)):
                if abs(x) > 1e-13 * max(lam[q], lam[q] + x):
                    jq, dk = _apply(q, x, idx, coef, nrm, v, mass, stamp, sweep, lock)
                    jump = max(jump, jq)
                    dphi += dk - tgt[q] * (max(lam[q] + x, 0.0) - lam[q])
                    lam[q] = max(lam[q] + x, 0.0)
                    changed += 1
                    total += x
            continue
        u, scale = _u(r, idx, coef, nrm, v)
        e = tgt[r] - u
        if not abs(e) > VEL_TOL * (scale + abs(tgt[r])):
            continue
        x = max(e / diag[r], -lam[r])
        if x == 0.0:
            continue
        jr, dk = _apply(r, x, idx, coef, nrm, v, mass, stamp, sweep, lock)
        jump = max(jump, jr)
        lam_new = lam[r] + x if x > -lam[r] else 0.0
        dphi += dk - tgt[r] * (lam_new - lam[r])
        lam[r] = lam_new
        changed += 1
        total += x
    return changed, total, jump, dphi
