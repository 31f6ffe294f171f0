"""Pointwise geometry of the contact tests (ALGORITHMS.md 3.1, 3.2): a node's position in the step,
a triangle's edges and normal, the barycentric weights of a point's projection onto its plane, a
segment's length.

One formula for every place that needs it: the node-face pass at a root of its cubic and at
t = 0 (``nodeface``), the particle-face contact at the end of the step
(``impactsim.fracture.particles``), the edge normals of the edge-edge pass (``edgeedge``), the
penetration measure (``diagnostics``) and the hash cell size (``broadphase.mean_length``). The
callers pass the corner positions (at the time they need) as scalars.

Inline numba functions of straight-line code: no branch, no early return, no division (a caller
divides by |n|^2 after it has tested it), so inlining them costs nothing. (An inlined
function that returned early with a flag cost the particle sweep 30 %: the caller branched a
second time on the flag.)
"""

from __future__ import annotations

import math

import numba


@numba.njit(cache=True, inline="always")
def point_at(x, v, t, i):
    """Position of node i at time t of the step, moving linearly: x_i + t v_i."""
    return x[i, 0] + t * v[i, 0], x[i, 1] + t * v[i, 1], x[i, 2] + t * v[i, 2]


@numba.njit(cache=True, inline="always")
def triangle_normal(ax, ay, az, bx, by, bz, cx, cy, cz):
    """Triangle (a, b, c): edges e1 = b - a, e2 = c - a and the normal n = e1 x e2 (not unit:
    |n| is twice the area; outward for the outward-oriented boundary faces of
    ``impactsim.mesh.topology``). Returns (e1x, e1y, e1z, e2x, e2y, e2z, nx, ny, nz, |n|^2)."""
    e1x = bx - ax
    e1y = by - ay
    e1z = bz - az
    e2x = cx - ax
    e2y = cy - ay
    e2z = cz - az
    nx = e1y * e2z - e1z * e2y
    ny = e1z * e2x - e1x * e2z
    nz = e1x * e2y - e1y * e2x
    return e1x, e1y, e1z, e2x, e2y, e2z, nx, ny, nz, nx * nx + ny * ny + nz * nz


@numba.njit(cache=True, inline="always")
def barycentric_numerators(rx, ry, rz, e1x, e1y, e1z, e2x, e2y, e2z, nx, ny, nz):
    """For r = p - a and a triangle from ``triangle_normal``: ((r x e2) . n, (e1 x r) . n),
    |n|^2 times the barycentric weights w_b, w_c of the projection of p onto the triangle's
    plane (w_a = 1 - w_b - w_c)."""
    sb = ((ry * e2z - rz * e2y) * nx + (rz * e2x - rx * e2z) * ny
          + (rx * e2y - ry * e2x) * nz)
    sc = ((e1y * rz - e1z * ry) * nx + (e1z * rx - e1x * rz) * ny
          + (e1x * ry - e1y * rx) * nz)
    return sb, sc


@numba.njit(cache=True, inline="always")
def clamped_weights(wa, wb, wc):
    """Weights of a projection accepted within a tolerance outside the triangle, clamped to
    [0, 1] and renormalised to sum 1 (the node-face and particle-face contacts)."""
    wa = max(wa, 0.0)
    wb = max(wb, 0.0)
    wc = max(wc, 0.0)
    ws = wa + wb + wc
    return wa / ws, wb / ws, wc / ws


@numba.njit(cache=True, inline="always")
def unit_normal(nx, ny, nz, nn):
    """n / |n| for nn = |n|^2 > 0."""
    inv = 1.0 / math.sqrt(nn)
    return nx * inv, ny * inv, nz * inv


@numba.njit(cache=True, inline="always")
def segment(x, i, y, j):
    """The vector y[j] - x[i] and its length: (dx, dy, dz, length)."""
    dx = y[j, 0] - x[i, 0]
    dy = y[j, 1] - x[i, 1]
    dz = y[j, 2] - x[i, 2]
    return dx, dy, dz, math.sqrt(dx * dx + dy * dy + dz * dz)


@numba.njit(cache=True, inline="always")
def unit_cross(ax, ay, az, bx, by, bz):
    """a x b normalised, and False (with zeros) when a x b = 0: a separating axis across a
    segment in a contact plane (contact/edgeedge.py, nodeface.py)."""
    mx = ay * bz - az * by
    my = az * bx - ax * bz
    mz = ax * by - ay * bx
    mm = mx * mx + my * my + mz * mz
    if not mm > 0.0:
        return 0.0, 0.0, 0.0, False
    inv = 1.0 / math.sqrt(mm)
    return mx * inv, my * inv, mz * inv, True
