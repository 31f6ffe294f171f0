"""Discrete particles from fully fractured cells (ALGORITHMS.md 4.1) and their contacts.

``Particles`` owns the arrays (capacity grows by half when needed; rows [0, n) are live):
  x (cap,3) float64 [m] centres; v (cap,3) float64 [m/s]; m (cap,) float64 [kg];
  radius (cap,) float64 [m]; energy (cap,) float64 [J] internal energy carried (not specific);
  body (cap,) int32 body the particle came from.
Particles fly ballistically between contacts.

Particle-face contact (the node-face algebra of ALGORITHMS.md 3.1 with the particle's radius):
a particle p and a boundary face (a, b, c) with outward unit normal n, the particle's centre
projected inside the triangle at the end of the step (barycentric weights w_i >= -eps, positions
x + tau U*; clamped to [0, 1] and renormalised as in the node-face pass). A particle meets a face
from its outer side only: its centre must be in front of the face's plane at the start of the
step. (A centre behind the plane is inside the body or past the face; counting such pairs let a
particle larger than a thin cell press on its opposite faces at once and crush it between them.)
With the gap g = (x_p - x_a).n - r at the start of the step and the relative normal velocity
u = (U*_p - sum w_i U*_i).n, the gap must not close within the step: u >= -g / tau (or u >= 0
for a particle already overlapping, g < 0). When violated, the normal impulse
J = du / (1/m_p + sum w_i^2 / m_i) with du the missing relative velocity is applied:
U_p += J n / m_p, U_i -= w_i J n / m_i (compressive only; momentum conserved). The impulse is
``impactsim.contact.nodeface.point_face_impulse``, the one function both passes call (a face
with a massless node takes none). Pairs are corrected one after the other in sorted order
(Gauss-Seidel, as 3.2 asks); a screen over windows of pairs (``particle_screen``) spares the
exact test to the pairs that cannot take an impulse, without changing a correction.

Particle-particle contact (optional): the same with two spheres, n along the line of centres and
g = |x_j - x_i| - r_i - r_j.

Energy: the impulse does the work J . (U_before + U_after) / 2 on each node, with U_before the
node's velocity at the previous half step, U* - dtv F / m, exactly as the wall constraint
(impactsim.solver.constraints); for particles (no force) U_before is the velocity before the
impulse. The (negative) work is kinetic energy dissipated in the inelastic impact.

Rigid walls of the case stop particles the same way (``particle_walls``).
"""

from __future__ import annotations

import numba
import numpy as np

from impactsim.contact.geometry import (barycentric_numerators, clamped_weights, point_at,
                                        segment, triangle_normal, unit_normal)
from impactsim.contact.impulse import NO_LOCK
from impactsim.contact.nodeface import point_face_impulse
from impactsim.fracture import particle_screen as PS
from impactsim.fracture.particle_cells import touches_marked


class Particles:
    """Growable particle arrays (see the module docstring)."""

    def __init__(self, capacity: int = 256):
        self.n = 0
        self.grows = 0
        self._alloc(max(int(capacity), 16))

    def _alloc(self, cap: int) -> None:
        old = None if not hasattr(self, "x") else (self.x, self.v, self.m, self.radius,
                                                      self.energy, self.body)
        self.x = np.zeros((cap, 3))
        self.v = np.zeros((cap, 3))
        self.m = np.zeros(cap)
        self.radius = np.zeros(cap)
        self.energy = np.zeros(cap)
        self.body = np.zeros(cap, dtype=np.int32)
        self.ids = np.arange(cap, dtype=np.int64).reshape(-1, 1)
        self.no_body = np.full(cap, -1, dtype=np.int32)
        if old is not None:
            n = self.n
            for new, o in zip((self.x, self.v, self.m, self.radius, self.energy, self.body), old):
                new[:n] = o[:n]

    @property
    def capacity(self) -> int:
        return self.m.shape[0]

    def reserve(self, extra: int) -> None:
        """Make room for `extra` more particles (grows by at least half the capacity)."""
        need = self.n + int(extra)
        if need > self.capacity:
            self.grows += 1
            self._alloc(max(need, int(1.5 * self.capacity)))

    def sums(self) -> tuple:
        """(mass, kinetic energy, internal energy, momentum (3,)) of the live particles."""
        m, ke, ie, p0, p1, p2 = particle_sums(self.m, self.v, self.energy, self.n)
        return m, ke, ie, np.array([p0, p1, p2])

    def kinetic_energy(self) -> float:
        return float(self.sums()[1])

    def internal_energy(self) -> float:
        return float(self.sums()[2])

    def mass(self) -> float:
        return float(self.sums()[0])

    def momentum(self) -> np.ndarray:
        return self.sums()[3]


@numba.njit(cache=True)
def particle_face_sweep(pairs, px, pv, pm, pr, faces, x, v, mass, force, dtv, tau, eps_bary,
                        lock=NO_LOCK):
    """Gauss-Seidel particle-face corrections over sorted ``pairs (k,2)`` (particle, face row);
    the impulse is ``impactsim.contact.nodeface.point_face_impulse``, the node-face algebra.
    ``lock (n_node, 3)``: 0.0 on the face nodes' prescribed velocity components, else 1.0
    (empty: none), left alone by the impulse (``nodeface.point_face_impulse``); the geometry is
    ``impactsim.contact.geometry``'s, as in the node-face pass.
    Returns (pairs corrected, work of the impulses on nodes and particles [J]).
    ``particle_face_sweep_packed`` with a node table of its own."""
    xv = np.empty((x.shape[0], NODE_COLS))
    pack_face_nodes(faces, faces.shape[0], x, v, mass, xv)
    return particle_face_sweep_packed(pairs, px, pv, pm, pr, faces, xv, v, mass, force, dtv, tau,
                                      eps_bary, lock)


NODE_COLS = 8  # a face node's row in the sweep's table: x (0-2), U* (3-5), mass (6), unused


@numba.njit(cache=True)
def pack_face_nodes(faces, k, x, v, mass, xv):
    """The nodes of face rows [0, k) into the table ``xv (n_node, NODE_COLS)``: position,
    predicted velocity and mass of a node in one row (one cache line), so that the sweep reads
    a face's three nodes in three loads instead of nine (x, v and mass are arrays apart). Rows of
    other nodes are left as they are."""
    for f in range(k):
        for j in range(3):
            pack_node(faces[f, j], x, v, mass, xv)


@numba.njit(cache=True, inline="always")
def pack_node(i, x, v, mass, xv):
    """Node i's row of the sweep's table: position, predicted velocity, mass."""
    xv[i, 0] = x[i, 0]
    xv[i, 1] = x[i, 1]
    xv[i, 2] = x[i, 2]
    xv[i, 3] = v[i, 0]
    xv[i, 4] = v[i, 1]
    xv[i, 5] = v[i, 2]
    xv[i, 6] = mass[i]


@numba.njit(cache=True, inline="always")
def _end_of_step(xv, tau, i):
    """Node i's position at the end of the step from its row of the table: x + tau U*, the
    arithmetic of ``geometry.point_at``."""
    return xv[i, 0] + tau * xv[i, 3], xv[i, 1] + tau * xv[i, 4], xv[i, 2] + tau * xv[i, 5]


@numba.njit(cache=True)
def particle_face_sweep_packed(pairs, px, pv, pm, pr, faces, xv, v, mass, force, dtv, tau,
                               eps_bary, lock, screened=True):
    """``particle_face_sweep`` reading the face nodes' positions, predicted velocities and
    masses from the table ``xv`` of ``pack_face_nodes`` or ``faces_near`` (rows of every node
    of the faces the pairs name), the same arithmetic: the same impulses bit for bit. An
    impulse writes the nodes' new velocities to ``v`` and to their rows of the table.

    The pairs go in windows of ``particle_screen.LANES``: the screen flags those of a window
    that might take an impulse, and only they get the exact test (``_pair_impulse``); after an
    impulse the next window starts at the next pair. ``screened=False`` gives every pair the
    exact test (the reference the screen is tested against)."""
    applied = 0
    work = 0.0
    n_pair = pairs.shape[0]
    flags = np.ones(PS.LANES, np.uint8)
    buf = np.empty(PS.ROWS * PS.LANES)
    k0 = 0
    while k0 < n_pair:
        k1 = min(k0 + PS.LANES, n_pair)
        if screened:
            PS.screen_window(pairs, k0, k1, px, pv, pr, faces, xv, tau, eps_bary, flags, buf)
        nxt = k1
        for k in range(k0, k1):
            if flags[k - k0] == 0:
                continue
            took, work = _pair_impulse(pairs[k, 0], pairs[k, 1], px, pv, pm, pr, faces, xv, v,
                                       mass, force, dtv, tau, eps_bary, lock, work)
            if took:
                applied += 1
                nxt = k + 1  # the pairs after it are screened on the new velocities
                break
        k0 = nxt
    return applied, work


@numba.njit(cache=True, inline="always")
def _pair_impulse(p, f, px, pv, pm, pr, faces, xv, v, mass, force, dtv, tau, eps_bary, lock,
                  work):
    """The exact test and correction of pair (particle p, face row f) (module docstring).
    Returns (True, ``work`` plus the work of the impulse [J], added term by term in the sweep's
    order), or (False, ``work``) when the pair takes none."""
    ia, ib, ic = faces[f, 0], faces[f, 1], faces[f, 2]
    if not (xv[ia, 6] > 0.0 and xv[ib, 6] > 0.0 and xv[ic, 6] > 0.0):
        return False, work
    # geometry at the end of the step (predicted positions)
    ax, ay, az = _end_of_step(xv, tau, ia)
    bx, by, bz = _end_of_step(xv, tau, ib)
    cx, cy, cz = _end_of_step(xv, tau, ic)
    e1x, e1y, e1z, e2x, e2y, e2z, nx, ny, nz, nn = triangle_normal(ax, ay, az, bx, by, bz,
                                                                   cx, cy, cz)
    if not nn > 0.0:
        return False, work
    qx, qy, qz = point_at(px, pv, tau, p)
    sb, sc = barycentric_numerators(qx - ax, qy - ay, qz - az, e1x, e1y, e1z, e2x, e2y, e2z,
                                    nx, ny, nz)
    wb = sb / nn
    wc = sc / nn
    wa = 1.0 - wb - wc
    if wa < -eps_bary or wb < -eps_bary or wc < -eps_bary:
        return False, work
    wa, wb, wc = clamped_weights(wa, wb, wc)
    nx, ny, nz = unit_normal(nx, ny, nz, nn)
    # the centre's distance from the face's plane at the start of the step: a particle meets
    # a face from its outer side only
    d0 = ((px[p, 0] - xv[ia, 0]) * nx + (px[p, 1] - xv[ia, 1]) * ny
          + (px[p, 2] - xv[ia, 2]) * nz)
    if not d0 > 0.0:
        return False, work
    g0 = d0 - pr[p]
    umin = -g0 / tau if g0 > 0.0 else 0.0
    p0, p1, p2 = pv[p, 0], pv[p, 1], pv[p, 2]
    a0, a1, a2 = v[ia, 0], v[ia, 1], v[ia, 2]
    b0, b1, b2 = v[ib, 0], v[ib, 1], v[ib, 2]
    c0, c1, c2 = v[ic, 0], v[ic, 1], v[ic, 2]
    jn = point_face_impulse(pv, p, pm[p], 1.0, 1.0, 1.0, v, mass, lock, ia, ib, ic, wa, wb, wc,
                            nx, ny, nz, umin, 0.0)
    if not jn > 0.0:
        return False, work
    work += 0.5 * pm[p] * ((pv[p, 0] - p0) * (pv[p, 0] + p0) + (pv[p, 1] - p1) * (pv[p, 1] + p1)
                          + (pv[p, 2] - p2) * (pv[p, 2] + p2))
    work += _node_work(v, mass, force, dtv, ia, a0, a1, a2)
    work += _node_work(v, mass, force, dtv, ib, b0, b1, b2)
    work += _node_work(v, mass, force, dtv, ic, c0, c1, c2)
    for j in range(3):
        i = faces[f, j]
        xv[i, 3] = v[i, 0]
        xv[i, 4] = v[i, 1]
        xv[i, 5] = v[i, 2]
    return True, work


@numba.njit(cache=True, inline="always")
def _node_work(v, mass, force, dtv, i, u0, u1, u2):
    """Work of the impulse that changed node i's velocity from (u0, u1, u2) to v[i]: the node
    moves with the mean of U^{n-1/2} = U - dtv F / m (before the impulse) and U^{n+1/2}."""
    m = mass[i]
    w = 0.0
    for d in range(3):
        u = u0 if d == 0 else (u1 if d == 1 else u2)
        w += m * (v[i, d] - u) * 0.5 * (u - dtv * force[i, d] / m + v[i, d])
    return w


@numba.njit(cache=True)
def particle_particle_sweep(pairs, px, pv, pm, pr, tau):
    """Gauss-Seidel sphere-sphere corrections over sorted ``pairs (k,2)`` (i < j).
    Returns (pairs corrected, change of the particles' kinetic energy [J])."""
    applied = 0
    dke = 0.0
    for k in range(pairs.shape[0]):
        i = pairs[k, 0]
        j = pairs[k, 1]
        dx, dy, dz, dist = segment(px, i, px, j)
        if not dist > 0.0:
            continue
        nx, ny, nz = dx / dist, dy / dist, dz / dist
        g0 = dist - pr[i] - pr[j]
        un = ((pv[j, 0] - pv[i, 0]) * nx + (pv[j, 1] - pv[i, 1]) * ny
              + (pv[j, 2] - pv[i, 2]) * nz)
        umin = -g0 / tau if g0 > 0.0 else 0.0
        if un >= umin:
            continue
        mi, mj = pm[i], pm[j]
        jn = (umin - un) / (1.0 / mi + 1.0 / mj)
        ke0 = 0.5 * (mi * (pv[i, 0] ** 2 + pv[i, 1] ** 2 + pv[i, 2] ** 2)
                     + mj * (pv[j, 0] ** 2 + pv[j, 1] ** 2 + pv[j, 2] ** 2))
        pv[i, 0] -= jn * nx / mi
        pv[i, 1] -= jn * ny / mi
        pv[i, 2] -= jn * nz / mi
        pv[j, 0] += jn * nx / mj
        pv[j, 1] += jn * ny / mj
        pv[j, 2] += jn * nz / mj
        ke1 = 0.5 * (mi * (pv[i, 0] ** 2 + pv[i, 1] ** 2 + pv[i, 2] ** 2)
                     + mj * (pv[j, 0] ** 2 + pv[j, 1] ** 2 + pv[j, 2] ** 2))
        dke += ke1 - ke0
        applied += 1
    return applied, dke


@numba.njit(cache=True)
def particle_boxes(px, pv, pr, n, tau, pad, lo, hi, bounds):
    """Boxes of the particles' spheres swept over the step, padded. Writes lo, hi (n, 3) and
    their overall bounds (2, 3) (lowest corner, highest corner); returns the largest radius."""
    r_max = 0.0
    for d in range(3):
        bounds[0, d] = np.inf
        bounds[1, d] = -np.inf
    for p in range(n):
        r_max = max(r_max, pr[p])
        for d in range(3):
            a = px[p, d]
            b = a + tau * pv[p, d]
            r = pr[p] + pad
            lo[p, d] = min(a, b) - r
            hi[p, d] = max(a, b) + r
            bounds[0, d] = min(bounds[0, d], lo[p, d])
            bounds[1, d] = max(bounds[1, d], hi[p, d])
    return r_max


@numba.njit(cache=True)
def faces_near(x, v, mass, tau, faces, face_body, n_faces, pad, cloud, origin, inv_c, dims, bits,
               lo, hi, sel, sel_body, bounds, xv):
    """The faces whose swept, padded boxes meet the box ``cloud (2, 3)`` of all particle boxes
    and touch a cell of a particle box (``particle_cells``: origin, inv_c, dims, bits): only
    they can meet a particle this step. Writes their rows (in order) to ``sel (k, 3)``,
    bodies to ``sel_body``, boxes to ``lo, hi``, widens ``bounds (2, 3)`` to cover them and
    packs their nodes into the sweep's table ``xv`` (``pack_face_nodes``, here while the
    nodes are at hand: a second pass over the selected faces cost 0.36 ms a step in
    oblique-sphere); returns k. Linear in the number of faces, no allocation."""
    k = 0
    for f in range(n_faces):
        if not (face_box(x, v, tau, faces, f, pad, cloud, lo, hi, k)
                and touches_marked(lo, hi, k, origin, inv_c, dims, bits)):
            continue
        for j in range(3):
            sel[k, j] = faces[f, j]
            pack_node(faces[f, j], x, v, mass, xv)
        sel_body[k] = face_body[f]
        for d in range(3):
            bounds[0, d] = min(bounds[0, d], lo[k, d])
            bounds[1, d] = max(bounds[1, d], hi[k, d])
        k += 1
    return k


@numba.njit(cache=True, inline="always")
def face_box(x, v, tau, faces, f, pad, cloud, lo, hi, k):
    """Face f's box swept over the step ([x, x + tau v] of its nodes), padded, into row k of
    lo, hi; True when it meets the box ``cloud (2, 3)``."""
    inside = True
    for d in range(3):
        a = np.inf
        b = -np.inf
        for j in range(3):
            c0 = x[faces[f, j], d]
            c1 = c0 + tau * v[faces[f, j], d]
            a = min(a, min(c0, c1))
            b = max(b, max(c0, c1))
        lo[k, d] = a - pad
        hi[k, d] = b + pad
        if lo[k, d] > cloud[1, d] or hi[k, d] < cloud[0, d]:
            inside = False
    return inside


@numba.njit(cache=True)
def particle_sums(pm, pv, pe, n):
    """(mass [kg], kinetic energy [J], internal energy [J], momentum x, y, z [kg m/s]) of the
    first n particles."""
    mass = 0.0
    ke = 0.0
    ie = 0.0
    p0 = 0.0
    p1 = 0.0
    p2 = 0.0
    for p in range(n):
        m = pm[p]
        mass += m
        ke += 0.5 * m * (pv[p, 0] * pv[p, 0] + pv[p, 1] * pv[p, 1] + pv[p, 2] * pv[p, 2])
        ie += pe[p]
        p0 += m * pv[p, 0]
        p1 += m * pv[p, 1]
        p2 += m * pv[p, 2]
    return mass, ke, ie, p0, p1, p2


@numba.njit(cache=True)
def move_particles(px, pv, n, tau):
    for p in range(n):
        px[p, 0] += tau * pv[p, 0]
        px[p, 1] += tau * pv[p, 1]
        px[p, 2] += tau * pv[p, 2]


@numba.njit(cache=True)
def particle_walls(px, pv, pm, pr, n, walls, tau):
    """Rigid planar walls (n_wall, 7: point, unit normal, friction) for particles: the sphere
    must not cross the wall within the step (u >= -g / tau, or u >= 0 when overlapping), the
    normal velocity is raised to that bound; frictionless. Returns the work done [J] (<= 0)."""
    work = 0.0
    for w in range(walls.shape[0]):
        nx, ny, nz = walls[w, 3], walls[w, 4], walls[w, 5]
        for p in range(n):
            g = ((px[p, 0] - walls[w, 0]) * nx + (px[p, 1] - walls[w, 1]) * ny
                 + (px[p, 2] - walls[w, 2]) * nz) - pr[p]
            un = pv[p, 0] * nx + pv[p, 1] * ny + pv[p, 2] * nz
            umin = -g / tau if g > 0.0 else 0.0
            if un >= umin:
                continue
            ke0 = pv[p, 0] ** 2 + pv[p, 1] ** 2 + pv[p, 2] ** 2
            du = umin - un
            pv[p, 0] += du * nx
            pv[p, 1] += du * ny
            pv[p, 2] += du * nz
            work += 0.5 * pm[p] * (pv[p, 0] ** 2 + pv[p, 1] ** 2 + pv[p, 2] ** 2 - ke0)
    return work
