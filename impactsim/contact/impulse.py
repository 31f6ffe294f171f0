"""The impulse algebra of the contact passes (ALGORITHMS.md 3.1, [D19] eq. 11, 12): a normal (or
friction) impulse J along a unit direction d acting on four points k with coefficients c_k,

    1/m_eff = sum_k c_k^2 / m_k,        dU_k = c_k J d / m_k,

the node-face pair (node p on face (a, b, c) with weights w: c = (1, -w_a, -w_b, -w_c), also the
particle-face contact) and the edge-edge pair (edges [a, b], [e, f]: c = (1 - beta, beta,
-(1 - alpha), -alpha) for (e, f, a, b)) alike. One function serves both passes, with or without
prescribed velocity components.

Prescribed components (``lock (n_node, 3)``: 0.0 where the case prescribes a component, else
1.0; ``NO_LOCK``, an empty array, when it prescribes none): a prescribed component is a
kinematic constraint, an infinite mass along its axis, so the inverse mass of point k along d
becomes s_k / m_k with s_k = sum_i lock_k,i d_i^2 and dU_k = c_k J (lock_k * d) / m_k. The first
point's row is passed as three numbers (1, 1, 1 for a particle, which is never held). Without
prescribed components the sum is the plain sum c_k^2 / m_k (so a scene without boundary
conditions gets the bits it got when the two variants were separate functions), and the
factors of the update are 1.0, which changes no bit.

The order of the points is the order of the sums and updates: the node-face pass passes (p, a,
b, c), the edge-edge pass (e, f, a, b), as they summed and updated before the variants were
merged.
"""

from __future__ import annotations

import numba
import numpy as np

NO_LOCK = np.ones((0, 3))  # no prescribed velocity components
VEL_TOL = 1e-12  # a constraint row is satisfied when its velocity error is below this share of
#                  the speeds (node-face, edge-edge and the projected rounds of ``rows``)


@numba.njit(cache=True, inline="always")
def lock_row(lock, i):
    """Row i of ``lock`` as three numbers, (1, 1, 1) without prescribed components."""
    if lock.shape[0] == 0:
        return 1.0, 1.0, 1.0
    return lock[i, 0], lock[i, 1], lock[i, 2]


@numba.njit(cache=True, inline="always")
def inverse_mass(dx, dy, dz, c0, m0, l0x, l0y, l0z, c1, m1, i1, c2, m2, i2, c3, m3, i3, lock):
    """1/m_eff of the four points along the unit direction d (module docstring): point 0 of
    mass m0 with lock row (l0x, l0y, l0z), points 1-3 nodes i1-i3 of masses m1-m3."""
    if lock.shape[0] == 0:
        return c0 * c0 / m0 + c1 * c1 / m1 + c2 * c2 / m2 + c3 * c3 / m3
    qx = dx * dx
    qy = dy * dy
    qz = dz * dz
    return (c0 * c0 * (l0x * qx + l0y * qy + l0z * qz) / m0
            + c1 * c1 * (lock[i1, 0] * qx + lock[i1, 1] * qy + lock[i1, 2] * qz) / m1
            + c2 * c2 * (lock[i2, 0] * qx + lock[i2, 1] * qy + lock[i2, 2] * qz) / m2
            + c3 * c3 * (lock[i3, 0] * qx + lock[i3, 1] * qy + lock[i3, 2] * qz) / m3)


@numba.njit(cache=True, inline="always")
def push(J, dx, dy, dz, v0, i0, c0, m0, l0x, l0y, l0z, v, i1, c1, m1, i2, c2, m2, i3, c3, m3,
         lock):
    """dU_k = c_k J d / m_k along the free axes (module docstring): point 0 is row i0 of
    ``v0`` (the nodes' ``v`` itself, or the particles' velocities), points 1-3 rows of ``v``."""
    held = lock.shape[0] > 0
    for d in range(3):
        nd = dx if d == 0 else (dy if d == 1 else dz)
        f0 = 1.0
        f1 = 1.0
        f2 = 1.0
        f3 = 1.0
        if held:
            f0 = l0x if d == 0 else (l0y if d == 1 else l0z)
            f1 = lock[i1, d]
            f2 = lock[i2, d]
            f3 = lock[i3, d]
        v0[i0, d] += c0 * J / m0 * nd * f0
        v[i1, d] += c1 * J / m1 * nd * f1
        v[i2, d] += c2 * J / m2 * nd * f2
        v[i3, d] += c3 * J / m3 * nd * f3
