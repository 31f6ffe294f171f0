"""The particle-face sweep's screen: which pairs of a window might take an impulse.

``particles.particle_face_sweep_packed`` corrects its pairs one after the other (Gauss-Seidel),
and most of them take nothing: on oblique-sphere about 70 % of a step's 35,000-55,000 pairs
project outside their triangle, 5 % more lie behind its plane, and 2 % need an impulse. The
exact test of every pair cost the sweep 42 ns a pair (scalar code: two divisions, a square
root, branches taken at random). So the sweep screens a window of ``LANES`` pairs at a time
with the tests below, without division or branch: the window's face nodes and particles are
copied into a buffer, and the tests run as one vector loop over it; the exact test runs only
on the pairs flagged. After an impulse the next window starts at the next pair, so every flag
is computed from the velocities the exact test would read. The flags are a superset of the
pairs the exact test accepts: each test is the sweep's, multiplied through by the positive
denominators and widened by ``SLACK`` of the magnitude of its terms (rounding is 1e-16 of it),
so the corrections, their order and their arithmetic are the unscreened sweep's bit for bit
(tests/unit/test_particle_screen.py).

With the face's normal n = e1 x e2 (|n|^2 = nn), r = x_p - x_a at the start of the step, the
barycentric numerators s_a, s_b, s_c (``geometry.barycentric_numerators``, s_a = nn - s_b - s_c)
and c_i = max(s_i, 0), a pair is flagged when every node has mass, nn > 0 and

    s_i >= -(eps_bary + SLACK) nn                          (inside the triangle, i = a, b, c)
    r . n > -SLACK sum_d |r_d n_d|                          (in front of the face's plane)
    tau ((sum c) U_p - sum_i c_i U_i) . n < (sum c) min(radius |n| - r . n, 0) + SLACK scale

the last being u < u_min of the exact test (u the relative normal velocity with the clamped,
renormalised weights c_i / sum c, u_min = min(-g0 / tau, 0) with the gap g0 = r . n / |n| -
radius) times tau |n| sum c. It reads the face nodes' velocities from the sweep's table, which
holds the nodes' U* (``particles.pack_node``; the sweep writes a node's row after each impulse).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from impactsim.contact.geometry import barycentric_numerators, triangle_normal

LANES = 16  # pairs per window: 8 compiled to scalar code (35 ns a pair), 32 screened more
#            pairs again after each impulse (oblique-sphere's sweeps, one thread: 17.7-17.9 ns
#            a pair at 16, 18.3-21.2 at 32; docs/performance.md, session 17)
SLACK = 1e-9  # relative widening of each test (rounding is about 1e-16 of its terms)
ROWS = 28  # buffer rows: three face nodes (x, U*, mass) and the particle (x, U, radius)


@numba.njit(cache=True, inline="always")
def screen_window(pairs, k0, k1, px, pv, pr, faces, xv, tau, eps_bary, flags, buf):
    """flags[k - k0] = 1 for the pairs k in [k0, k1) (k1 - k0 <= LANES) that might take an
    impulse, 0 for those that cannot (module docstring). ``buf (ROWS * LANES,)`` scratch; the
    lanes past k1 - k0 repeat the last pair. ``xv`` the sweep's node table."""
    lim = -(eps_bary + SLACK)
    n = k1 - k0
    for i in range(LANES):  # gather the window's rows (scalar loads)
        k = k0 + min(i, n - 1)
        p = np.uint64(pairs[k, 0])
        f = np.uint64(pairs[k, 1])
        for j in range(3):
            a = np.uint64(faces[f, j])
            for c in range(7):
                buf[(7 * j + c) * LANES + i] = xv[a, c]
        for c in range(3):
            buf[(21 + c) * LANES + i] = px[p, c]
            buf[(24 + c) * LANES + i] = pv[p, c]
        buf[27 * LANES + i] = pr[p]
    for i in range(LANES):  # the tests, one vector loop
        xa, ya, za = buf[0 * LANES + i], buf[1 * LANES + i], buf[2 * LANES + i]
        ua, va, wa = buf[3 * LANES + i], buf[4 * LANES + i], buf[5 * LANES + i]
        ub, vb, wb = buf[10 * LANES + i], buf[11 * LANES + i], buf[12 * LANES + i]
        uc, vc, wc = buf[17 * LANES + i], buf[18 * LANES + i], buf[19 * LANES + i]
        ax, ay, az = xa + tau * ua, ya + tau * va, za + tau * wa
        bx = buf[7 * LANES + i] + tau * ub
        by = buf[8 * LANES + i] + tau * vb
        bz = buf[9 * LANES + i] + tau * wb
        cx = buf[14 * LANES + i] + tau * uc
        cy = buf[15 * LANES + i] + tau * vc
        cz = buf[16 * LANES + i] + tau * wc
        e1x, e1y, e1z, e2x, e2y, e2z, nx, ny, nz, nn = triangle_normal(ax, ay, az, bx, by, bz,
                                                                       cx, cy, cz)
        pxx, pxy, pxz = buf[21 * LANES + i], buf[22 * LANES + i], buf[23 * LANES + i]
        pvx, pvy, pvz = buf[24 * LANES + i], buf[25 * LANES + i], buf[26 * LANES + i]
        sb, sc = barycentric_numerators(pxx + tau * pvx - ax, pxy + tau * pvy - ay,
                                        pxz + tau * pvz - az, e1x, e1y, e1z, e2x, e2y, e2z,
                                        nx, ny, nz)
        sa = nn - sb - sc
        ca, cb, cc = max(sa, 0.0), max(sb, 0.0), max(sc, 0.0)
        cs = ca + cb + cc
        rx, ry, rz = pxx - xa, pxy - ya, pxz - za
        dn = rx * nx + ry * ny + rz * nz
        dscale = abs(rx * nx) + abs(ry * ny) + abs(rz * nz)
        rn = buf[27 * LANES + i] * math.sqrt(max(nn, 0.0))
        ux = pvx * cs - (ca * ua + cb * ub + cc * uc)
        uy = pvy * cs - (ca * va + cb * vb + cc * vc)
        uz = pvz * cs - (ca * wa + cb * wb + cc * wc)
        lhs = tau * (ux * nx + uy * ny + uz * nz)
        rhs = cs * min(rn - dn, 0.0)
        scale = (tau * cs * (abs(pvx) + abs(pvy) + abs(pvz) + abs(ua) + abs(va) + abs(wa)
                             + abs(ub) + abs(vb) + abs(wb) + abs(uc) + abs(vc) + abs(wc))
                 * (abs(nx) + abs(ny) + abs(nz)) + cs * (dscale + rn))
        flags[i] = ((buf[6 * LANES + i] > 0.0) & (buf[13 * LANES + i] > 0.0)
                    & (buf[20 * LANES + i] > 0.0) & (nn > 0.0)
                    & (sa >= lim * nn) & (sb >= lim * nn) & (sc >= lim * nn)
                    & (dn > -SLACK * dscale) & (lhs < rhs + SLACK * scale))
