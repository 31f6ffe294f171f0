"""Elements leaving the mesh: erosion with mass-conserving orphan handling (ALGORITHMS.md 4.2)
and conversion of fully fractured boundary cells into particles (4.1).

Lumped masses: node k carries m_k = sum over its elements of m_e / 4 (tets) or m_e / 8
(hexes) at t = 0. Two ways out:

- Erosion [R20]: the element is deleted, its mass stays on its nodes. A node of the element that
  no longer belongs to any live element (an orphan) passes its mass and momentum, shared equally,
  to the element's remaining nodes: m_r += m_o / R, m_r v_r += m_o v_o / R. The element's internal
  energy m_e e_e and the kinetic energy lost in that inelastic merge leave the model:
  ``eroded`` energy. An element whose nodes are all orphaned has no remaining node: it
  becomes a particle instead (the only place its mass can go).
- Particle conversion [D19]: each corner gives the particle(s) m_e / k of its mass (k = 4
  corners for tets, 8 for hexes; an orphaned corner gives all it has left) together with the
  matching momentum. The n particles of one cell share mass M equally; particle j sits at
  corner weights w_j (n = 1: the centroid; otherwise (1 - a)/k + a on corner j mod k,
  a = 1 / (2 (1 + j // k))) and takes the velocity
  of the linear field there, shifted so that the particles carry exactly the momentum taken.
  Radius: the cell's inscribed sphere, r = 3 V / (sum of face areas), times n^(-1/3) for several
  particles (equal total volume of the spheres). Internal energy of the particles: the cell's
  m_e e_e plus the nodal kinetic energy taken minus the particles' kinetic energy, shared
  equally, so the total energy is unchanged by the conversion.
Both keep the total mass (nodes plus particles) to round-off and the momentum exactly up to it.
Elements are removed one after the other in the given (ascending) order: deterministic.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from impactsim.model import ERODED


@numba.njit(cache=True)
def _face_area2(x, a, b, c):
    ux, uy, uz = x[b, 0] - x[a, 0], x[b, 1] - x[a, 1], x[b, 2] - x[a, 2]
    wx, wy, wz = x[c, 0] - x[a, 0], x[c, 1] - x[a, 1], x[c, 2] - x[a, 2]
    nx, ny, nz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
    return math.sqrt(nx * nx + ny * ny + nz * nz)  # twice the area


@numba.njit(cache=True)
def _tet_size(x, conn, e):
    """(volume [m^3], surface area [m^2]) of tet e."""
    i0, i1, i2, i3 = conn[e, 0], conn[e, 1], conn[e, 2], conn[e, 3]
    ax, ay, az = x[i1, 0] - x[i0, 0], x[i1, 1] - x[i0, 1], x[i1, 2] - x[i0, 2]
    bx, by, bz = x[i2, 0] - x[i0, 0], x[i2, 1] - x[i0, 1], x[i2, 2] - x[i0, 2]
    cx, cy, cz = x[i3, 0] - x[i0, 0], x[i3, 1] - x[i0, 1], x[i3, 2] - x[i0, 2]
    vol = abs(ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)) / 6.0
    area = 0.5 * (_face_area2(x, i1, i2, i3) + _face_area2(x, i0, i3, i2)
                  + _face_area2(x, i0, i1, i3) + _face_area2(x, i0, i2, i1))
    return vol, area


# the hex's faces (VTK order, outward) and a split of the hex into five tets (its volume)
_HEX_FACES = np.array([[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6],
                       [3, 0, 4, 7]], dtype=np.int64)
_HEX_TETS = np.array([[0, 1, 3, 4], [1, 2, 3, 6], [1, 6, 4, 5], [3, 4, 6, 7], [1, 3, 4, 6]],
                     dtype=np.int64)


@numba.njit(cache=True)
def _hex_size(x, conn, e):
    """(volume [m^3], surface area [m^2]) of hex e: the five tets of a split, and each face's
    area as half the cross product of its diagonals (the particle radius only)."""
    vol = 0.0
    for t in range(5):
        i0 = conn[e, _HEX_TETS[t, 0]]
        i1 = conn[e, _HEX_TETS[t, 1]]
        i2 = conn[e, _HEX_TETS[t, 2]]
        i3 = conn[e, _HEX_TETS[t, 3]]
        ax, ay, az = x[i1, 0] - x[i0, 0], x[i1, 1] - x[i0, 1], x[i1, 2] - x[i0, 2]
        bx, by, bz = x[i2, 0] - x[i0, 0], x[i2, 1] - x[i0, 1], x[i2, 2] - x[i0, 2]
        cx, cy, cz = x[i3, 0] - x[i0, 0], x[i3, 1] - x[i0, 1], x[i3, 2] - x[i0, 2]
        vol += abs(ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx))
    area = 0.0
    for f in range(6):
        a = conn[e, _HEX_FACES[f, 0]]
        b = conn[e, _HEX_FACES[f, 1]]
        c = conn[e, _HEX_FACES[f, 2]]
        d = conn[e, _HEX_FACES[f, 3]]
        ux, uy, uz = x[c, 0] - x[a, 0], x[c, 1] - x[a, 1], x[c, 2] - x[a, 2]
        wx, wy, wz = x[d, 0] - x[b, 0], x[d, 1] - x[b, 1], x[d, 2] - x[b, 2]
        nx, ny, nz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
        area += 0.5 * math.sqrt(nx * nx + ny * ny + nz * nz)
    return vol / 6.0, area


@numba.njit(cache=True)
def _to_particles(e, conn, elem_mass, energy, elem_body, x, v, mass, node_live, n_per,
                  px, pv, pm, pr, pe, pbody, n_p):
    """Convert element e (already marked eroded, node_live already decremented) into n_per
    particles starting at slot n_p; returns the new particle count."""
    me = elem_mass[e]
    big_m = 0.0
    mom0 = 0.0
    mom1 = 0.0
    mom2 = 0.0
    ke_nodes = 0.0
    kc = conn.shape[1]
    inv = 1.0 / kc  # a quarter (tets) or an eighth (hexes): exact
    share = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    for k in range(kc):
        i = conn[e, k]
        s = mass[i] if node_live[i] == 0 else min(inv * me, mass[i])
        share[k] = s
        big_m += s
        mom0 += s * v[i, 0]
        mom1 += s * v[i, 1]
        mom2 += s * v[i, 2]
        ke_nodes += 0.5 * s * (v[i, 0] ** 2 + v[i, 1] ** 2 + v[i, 2] ** 2)
    if kc == 4:
        vol, area = _tet_size(x, conn, e)
    else:
        vol, area = _hex_size(x, conn, e)
    r_in = 3.0 * vol / area if area > 0.0 else 0.0
    radius = r_in * (1.0 / n_per) ** (1.0 / 3.0)
    mp = big_m / n_per
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    for j in range(n_per):
        slot = n_p + j
        if n_per == 1:
            a = 0.0
        else:
            a = 0.5 / (1.0 + j // kc)
        for d in range(3):
            px[slot, d] = 0.0
            pv[slot, d] = 0.0
        for k in range(kc):
            w = inv * (1.0 - a) + (a if k == j % kc else 0.0)
            i = conn[e, k]
            for d in range(3):
                px[slot, d] += w * x[i, d]
                pv[slot, d] += w * v[i, d]
        s0 += mp * pv[slot, 0]
        s1 += mp * pv[slot, 1]
        s2 += mp * pv[slot, 2]
    c0 = (mom0 - s0) / big_m if big_m > 0.0 else 0.0
    c1 = (mom1 - s1) / big_m if big_m > 0.0 else 0.0
    c2 = (mom2 - s2) / big_m if big_m > 0.0 else 0.0
    ke_p = 0.0
    for j in range(n_per):
        slot = n_p + j
        pv[slot, 0] += c0
        pv[slot, 1] += c1
        pv[slot, 2] += c2
        ke_p += 0.5 * mp * (pv[slot, 0] ** 2 + pv[slot, 1] ** 2 + pv[slot, 2] ** 2)
    eint = (me * energy[e] + ke_nodes - ke_p) / n_per
    for j in range(n_per):
        slot = n_p + j
        pm[slot] = mp
        pr[slot] = radius
        pe[slot] = eint
        pbody[slot] = elem_body[e]
    for k in range(kc):
        i = conn[e, k]
        if node_live[i] == 0:
            mass[i] = 0.0
            v[i, 0] = 0.0
            v[i, 1] = 0.0
            v[i, 2] = 0.0
        else:
            mass[i] -= share[k]
    return n_p + n_per


@numba.njit(cache=True)
def _erode(e, conn, elem_mass, energy, v, mass, node_live):
    """Delete element e [R20]: orphans pass mass and momentum equally to the remaining corners.
    Returns the energy that leaves the model [J] (internal + kinetic lost in the merge)."""
    out = elem_mass[e] * energy[e]
    kc = conn.shape[1]
    n_rem = 0
    for k in range(kc):
        if node_live[conn[e, k]] > 0:
            n_rem += 1
    for k in range(kc):
        o = conn[e, k]
        if node_live[o] > 0 or mass[o] == 0.0:
            continue
        mo = mass[o]
        give = mo / n_rem
        ke_before = 0.5 * mo * (v[o, 0] ** 2 + v[o, 1] ** 2 + v[o, 2] ** 2)
        ke_after = 0.0
        for q in range(kc):
            r = conn[e, q]
            if node_live[r] == 0:
                continue
            mr = mass[r]
            ke_before += 0.5 * mr * (v[r, 0] ** 2 + v[r, 1] ** 2 + v[r, 2] ** 2)
            mn = mr + give
            for d in range(3):
                v[r, d] = (mr * v[r, d] + give * v[o, d]) / mn
            mass[r] = mn
            ke_after += 0.5 * mn * (v[r, 0] ** 2 + v[r, 1] ** 2 + v[r, 2] ** 2)
        out += ke_before - ke_after
        mass[o] = 0.0
        v[o, 0] = 0.0
        v[o, 1] = 0.0
        v[o, 2] = 0.0
    return out


@numba.njit(cache=True)
def remove_elements(ids, to_particle, conn, status, elem_mass, energy, elem_body, x, v, mass,
                    node_live, n_per, px, pv, pm, pr, pe, pbody, n_p):
    """Remove elements ``ids`` in order; ``to_particle[k]`` True converts ids[k] into particles,
    False erodes it. The particle arrays need room for n_per more particles per id.
    Returns (new particle count, eroded energy [J], elements eroded, elements converted)."""
    eroded_energy = 0.0
    n_eroded = 0
    n_conv = 0
    kc = conn.shape[1]
    for k in range(ids.shape[0]):
        e = ids[k]
        if status[e] == ERODED:
            continue
        status[e] = ERODED
        orphans = 0
        for q in range(kc):
            i = conn[e, q]
            node_live[i] -= 1
            if node_live[i] == 0:
                orphans += 1
        if to_particle[k] or orphans == kc:
            n_p = _to_particles(e, conn, elem_mass, energy, elem_body, x, v, mass, node_live,
                                n_per, px, pv, pm, pr, pe, pbody, n_p)
            n_conv += 1
        else:
            eroded_energy += _erode(e, conn, elem_mass, energy, v, mass, node_live)
            n_eroded += 1
    return n_p, eroded_energy, n_eroded, n_conv
