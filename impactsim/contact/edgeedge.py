"""Edge-edge pass ([D19], ALGORITHMS.md 3.2, the paper's contribution).

Boundary edge [a, b] of body 1 and [e, f] of body 2, all points moving linearly over the step.
They can only cross when the four points are coplanar: det[x_b - x_a, x_e - x_a, x_f - x_a](t) = 0,
a cubic in t. At each root in [0, tau] (earliest first) the two lines meet; the root is kept when
the meeting point lies inside both segments (0 <= alpha, beta <= 1). There, with n the unit normal
of both lines (along the common perpendicular dc, d on [a,b], c on [e,f]) oriented from body 1
toward body 2 before the crossing, [D19 eq. 11]

    N_c = [(1-a) U*_na + a U*_nb - (1-b) U*_ne - b U*_nf]
          / (tau [(1-b)^2/m_e + b^2/m_f + (1-a)^2/m_a + a^2/m_b])      (a = alpha, b = beta)

and, only when N_c > 0 (approaching), [D19 eq. 12]

    U_ne += tau (1-b) N_c / m_e,  U_nf += tau b N_c / m_f,
    U_na -= tau (1-a) N_c / m_a,  U_nb -= tau a N_c / m_b   (m_b, not the paper's misprinted m_a).

The normal direction at the crossing is (b - a) x (f - e); "before the crossing" is decided by the
material points d and c (parameters alpha, beta) at t = 0: n points from d toward c.

Departure from the paper, for persistent contact (as in the node-face pass): edges that start the
step within ``band`` of each other, with the closest points inside both segments, count as
touching at t = 0. Their order "before the crossing" is then not reliable (they may have crossed
by round-off or by the second-order drift of turning edges), so n is oriented by the bodies'
outward normals at the edges instead (the sum of the unit normals of the boundary faces at each
edge): n . (nu_1 - nu_2) > 0; the same holds for a root whose material points d, c start at most
``band`` apart. Touching edges are held so that their gap g = (c - d) . n along that n does
not close beyond the end of the step: the numerator of N_c gets the extra term -g / tau, and
for an overlap (g < 0) -restore * g / tau (restore = 1: undone in one step; a compressive
impulse, never a pull).
Parallel edges (|(b-a) x (f-e)| <= 1e-6 |b-a| |f-e|) have no crossing point; they are skipped
(the node-face pass covers them).

A corrected pair keeps alpha, beta, n and its gap term as a constraint row with its accumulated
impulse, as in the node-face pass: later sweeps push it through that row
(``edge_edge_relax``), the projected rounds of ``impactsim.contact.rows`` may take impulse back.

The sum of eq. 11 and the corrections of eq. 12 (with friction, and with prescribed velocity
components) are ``impactsim.contact.impulse``, the algebra of the node-face pass too.
"""

from __future__ import annotations

import math

import numba

import numpy as np

from impactsim.contact.cubic import cubic_coefficients, cubic_roots_in
from impactsim.contact.geometry import point_at, triangle_normal, unit_cross
from impactsim.contact.impulse import NO_LOCK, inverse_mass, lock_row, push
from impactsim.contact.rows import first_visit, pushes_again, stamp_nodes, unchanged_since

PARALLEL_SIN = 1e-6  # edges closer to parallel than this (sine of the angle) are skipped
SEGMENT_EPS = 1e-9  # tolerance of 0 <= alpha, beta <= 1
NU_RELIABLE = 0.2  # nu orients n only when |n . nu| >= this * |nu|
GEO_COLS = 7  # a constraint row: lam, alpha, beta, nx, ny, nz, gap / tau
APART_MARGIN = 1e-3  # stay_apart: the margin beyond band, a share of the segments' half-lengths
HELD = -2.0  # edge_edge_test: touching edges that need no impulse (their row kept, no impulse)
APART = 3  # edge_edge_sweep: a pair apart on a separating axis, kept in its row (still_apart)
FAR = 4  # edge_edge_sweep: a pair apart for as long as the candidate list is kept (far_apart)


@numba.njit(cache=True)
def line_parameters(ax, ay, az, d1x, d1y, d1z, ex, ey, ez, d2x, d2y, d2z):
    """Closest points of the lines a + alpha d1 and e + beta d2: (alpha, beta, |d1 x d2|^2,
    |d1|^2 |d2|^2). alpha = |ad|/|ab|, beta = |ec|/|ef| of ALGORITHMS.md 3.2."""
    rx = ax - ex
    ry = ay - ey
    rz = az - ez
    A = d1x * d1x + d1y * d1y + d1z * d1z
    B = d1x * d2x + d1y * d2y + d1z * d2z
    E = d2x * d2x + d2y * d2y + d2z * d2z
    C = d1x * rx + d1y * ry + d1z * rz
    F = d2x * rx + d2y * ry + d2z * rz
    den = A * E - B * B
    if not den > 0.0:
        return 0.0, 0.0, 0.0, A * E
    return (B * F - C * E) / den, (A * F - B * C) / den, den, A * E


@numba.njit(cache=True, inline="always")
def _inverse_mass(al, be, nx, ny, nz, ia, ib, ie, jf, mass, lock):
    """The sum of the weighted inverse masses of [D19 eq. 11] along n,
    (1-b)^2/m_e + b^2/m_f + (1-a)^2/m_a + a^2/m_b, with prescribed velocity components
    (``lock``) each 1/m_k along n counting only its free axes (``impactsim.contact.impulse``:
    the points (e, f, a, b), coefficients (1 - beta, beta, -(1 - alpha), -alpha))."""
    le0, le1, le2 = lock_row(lock, ie)
    return inverse_mass(nx, ny, nz, 1.0 - be, mass[ie], le0, le1, le2, be, mass[jf], jf,
                        -(1.0 - al), mass[ia], ia, -al, mass[ib], ib, lock)


@numba.njit(cache=True)
def _apply(J, mu, S, al, be, nx, ny, nz, ia, ib, ie, jf, v, mass, lock):
    """The corrections of [D19 eq. 12] for the normal impulse J = tau N_c > 0 (m_b in the last
    one, ALGORITHMS.md 3.2 [note]), then optional Coulomb friction along the relative sliding
    velocity of body 1's point d over body 2's c after the normal correction: at most the
    impulse that stops sliding and at most mu J. S: the sum of the weighted inverse masses of
    [D19 eq. 11] (``_inverse_mass``). With prescribed velocity components (``lock``) each node's
    velocity changes only along its free axes (the constraint takes the rest of the impulse),
    friction with the effective mass along the sliding direction
    (``impactsim.contact.impulse``)."""
    ma = mass[ia]
    mb = mass[ib]
    me = mass[ie]
    mf = mass[jf]
    le0, le1, le2 = lock_row(lock, ie)
    # [D19 eq. 12], m_b in the last correction (ALGORITHMS.md 3.2 [note])
    push(J, nx, ny, nz, v, ie, 1.0 - be, me, le0, le1, le2, v, jf, be, mf, ia, -(1.0 - al), ma,
         ib, -al, mb, lock)
    if mu > 0.0:
        # Coulomb friction: relative tangential velocity of body 1's point d over body 2's c
        vx = ((1.0 - al) * v[ia, 0] + al * v[ib, 0]) - ((1.0 - be) * v[ie, 0] + be * v[jf, 0])
        vy = ((1.0 - al) * v[ia, 1] + al * v[ib, 1]) - ((1.0 - be) * v[ie, 1] + be * v[jf, 1])
        vz = ((1.0 - al) * v[ia, 2] + al * v[ib, 2]) - ((1.0 - be) * v[ie, 2] + be * v[jf, 2])
        vn = vx * nx + vy * ny + vz * nz
        vx -= vn * nx
        vy -= vn * ny
        vz -= vn * nz
        vt = math.sqrt(vx * vx + vy * vy + vz * vz)
        if vt > 0.0:
            tx = vx / vt
            ty = vy / vt
            tz = vz / vt
            St = S
            if lock.shape[0] > 0:
                St = _inverse_mass(al, be, tx, ty, tz, ia, ib, ie, jf, mass, lock)
            if St > 0.0:
                Jt = min(vt / St, mu * J)
                push(Jt, tx, ty, tz, v, ie, 1.0 - be, me, le0, le1, le2, v, jf, be, mf, ia,
                     -(1.0 - al), ma, ib, -al, mb, lock)


@numba.njit(cache=True)
def _edge_edge_at(t, force_nu, band, restore, ia, ib, ie, jf, x, v, mass, tau, mu, nu_x, nu_y,
                  nu_z, geo, k, lock):
    """Crossing of edges [ia, ib] (body 1) and [ie, jf] (body 2) at time t (ALGORITHMS.md 3.2).

    n is oriented by the material points d, c at t = 0 (d -> c), unless ``force_nu`` (edges
    touching at t = 0) or they are at most ``band`` apart along n: then by nu = nu_1 - nu_2
    (outward normals), if nu is not nearly perpendicular to n. Touching edges (``force_nu``) keep
    their gap g = (c - d) . n (or undo ``restore`` of an overlap) by the end of the step: N_c
    uses the approach speed minus g / tau (restore * g / tau for g < 0). Returns -1 when not a
    valid crossing, 0 when valid but needing no impulse, else tau N_c [N s], and then row k of
    ``geo`` holds the constraint (``edge_edge_relax``)."""
    ax, ay, az = point_at(x, v, t, ia)
    bx, by, bz = point_at(x, v, t, ib)
    ex, ey, ez = point_at(x, v, t, ie)
    fx, fy, fz = point_at(x, v, t, jf)
    d1x = bx - ax
    d1y = by - ay
    d1z = bz - az
    d2x = fx - ex
    d2y = fy - ey
    d2z = fz - ez
    al, be, den, ae = line_parameters(ax, ay, az, d1x, d1y, d1z, ex, ey, ez, d2x, d2y, d2z)
    return _crossing(al, be, den, ae, d1x, d1y, d1z, d2x, d2y, d2z, force_nu, band, restore,
                     ia, ib, ie, jf, x, v, mass, tau, mu, nu_x, nu_y, nu_z, geo, k, lock)


@numba.njit(cache=True)
def _crossing(al, be, den, ae, d1x, d1y, d1z, d2x, d2y, d2z, force_nu, band, restore, ia, ib,
              ie, jf, x, v, mass, tau, mu, nu_x, nu_y, nu_z, geo, k, lock):
    """``_edge_edge_at`` from the lines' parameters at its time t (``line_parameters`` of the
    segments b - a = d1 and f - e = d2 there): the touching test at t = 0 has them already."""
    if not den > PARALLEL_SIN * PARALLEL_SIN * ae:
        return -1.0
    if al < -SEGMENT_EPS or al > 1.0 + SEGMENT_EPS or be < -SEGMENT_EPS or be > 1.0 + SEGMENT_EPS:
        return -1.0
    al = min(max(al, 0.0), 1.0)
    be = min(max(be, 0.0), 1.0)
    # n along the common perpendicular: (b - a) x (f - e)
    nx = d1y * d2z - d1z * d2y
    ny = d1z * d2x - d1x * d2z
    nz = d1x * d2y - d1y * d2x
    inv = 1.0 / math.sqrt(den)
    nx *= inv
    ny *= inv
    nz *= inv
    # from body 1 toward body 2 before the crossing: d -> c at t = 0
    s = ((1.0 - be) * x[ie, 0] + be * x[jf, 0] - (1.0 - al) * x[ia, 0] - al * x[ib, 0]) * nx \
        + ((1.0 - be) * x[ie, 1] + be * x[jf, 1] - (1.0 - al) * x[ia, 1] - al * x[ib, 1]) * ny \
        + ((1.0 - be) * x[ie, 2] + be * x[jf, 2] - (1.0 - al) * x[ia, 2] - al * x[ib, 2]) * nz
    o = s
    if force_nu or abs(s) <= band:
        o = nx * nu_x + ny * nu_y + nz * nu_z
        if abs(o) < NU_RELIABLE * math.sqrt(nu_x * nu_x + nu_y * nu_y + nu_z * nu_z):
            if force_nu:
                return -1.0
            o = s
    if o == 0.0:
        return -1.0
    if o < 0.0:
        nx = -nx
        ny = -ny
        nz = -nz
        s = -s
    gap = 0.0
    if force_nu:
        gap = s if s > 0.0 else restore * s
    una = v[ia, 0] * nx + v[ia, 1] * ny + v[ia, 2] * nz
    unb = v[ib, 0] * nx + v[ib, 1] * ny + v[ib, 2] * nz
    une = v[ie, 0] * nx + v[ie, 1] * ny + v[ie, 2] * nz
    unf = v[jf, 0] * nx + v[jf, 1] * ny + v[jf, 2] * nz
    ma = mass[ia]
    mb = mass[ib]
    me = mass[ie]
    mf = mass[jf]
    if not (ma > 0.0 and mb > 0.0 and me > 0.0 and mf > 0.0):
        return -1.0  # a massless node (orphaned by erosion) takes no impulse
    S = _inverse_mass(al, be, nx, ny, nz, ia, ib, ie, jf, mass, lock)
    if not S > 0.0:
        return 0.0  # every node is held along n: the constraints take it all
    # [D19 eq. 11] (with the gap term for touching edges, see the docstring)
    Nc = ((1.0 - al) * una + al * unb - (1.0 - be) * une - be * unf - gap / tau) / (tau * S)
    if not Nc > 0.0:
        if force_nu:  # touching, held apart already: its row kept without impulse (HELD)
            geo[k, 0] = 0.0
            geo[k, 1] = al
            geo[k, 2] = be
            geo[k, 3] = nx
            geo[k, 4] = ny
            geo[k, 5] = nz
            geo[k, 6] = gap / tau
            return HELD
        return 0.0
    J = tau * Nc
    _apply(J, mu, S, al, be, nx, ny, nz, ia, ib, ie, jf, v, mass, lock)
    geo[k, 0] = J
    geo[k, 1] = al
    geo[k, 2] = be
    geo[k, 3] = nx
    geo[k, 4] = ny
    geo[k, 5] = nz
    geo[k, 6] = gap / tau
    return J


@numba.njit(cache=True, inline="always")
def _side(p0, p1, p2, p3, q0, q1, q2, q3, tol):
    """1 when the interval [min p, max p] lies more than tol above [min q, max q], -1 when
    below, else 0."""
    if min(min(p0, p1), min(p2, p3)) > max(max(q0, q1), max(q2, q3)) + tol:
        return 1.0
    if min(min(q0, q1), min(q2, q3)) > max(max(p0, p1), max(p2, p3)) + tol:
        return -1.0
    return 0.0


@numba.njit(cache=True, inline="always")
def _kept_axis(s, mx, my, mz, pa, pb, qe, qf, tol):
    """What a repeated sweep needs of a separating axis m found apart on side s (``_side``):
    the axis turned so that segment 1 lies above, the projections of a, b at t = 0 on it and
    those of e, f plus tol (``still_apart``)."""
    return s * mx, s * my, s * mz, s * pa, s * pb, s * qe + tol, s * qf + tol


@numba.njit(cache=True)
def apart_axis(ia, ib, ie, jf, x, v, tau, band):
    """``stay_apart`` and the separating axis it found: (apart, mx, my, mz, pa, pb, qe, qf),
    the axis turned so that segment [ia, ib] lies above, pa, pb the projections of a and b at
    t = 0 on it and qe, qf those of e and f plus the tolerance (``still_apart``; zeros when not
    apart)."""
    ax = x[ia, 0]
    ay = x[ia, 1]
    az = x[ia, 2]
    bx = x[ib, 0]
    by = x[ib, 1]
    bz = x[ib, 2]
    ex = x[ie, 0]
    ey = x[ie, 1]
    ez = x[ie, 2]
    fx = x[jf, 0]
    fy = x[jf, 1]
    fz = x[jf, 2]
    # the end points at tau
    Ax, Ay, Az = point_at(x, v, tau, ia)
    Bx, By, Bz = point_at(x, v, tau, ib)
    Ex, Ey, Ez = point_at(x, v, tau, ie)
    Fx, Fy, Fz = point_at(x, v, tau, jf)
    d1x = bx - ax
    d1y = by - ay
    d1z = bz - az
    d2x = fx - ex
    d2y = fy - ey
    d2z = fz - ez
    ll = max(d1x * d1x + d1y * d1y + d1z * d1z, d2x * d2x + d2y * d2y + d2z * d2z)
    tol = band + APART_MARGIN * math.sqrt(ll)
    # x, y, z first: no square root
    s = _side(ax, bx, Ax, Bx, ex, fx, Ex, Fx, tol)
    if s != 0.0:
        return (True,) + _kept_axis(s, 1.0, 0.0, 0.0, ax, bx, ex, fx, tol)
    s = _side(ay, by, Ay, By, ey, fy, Ey, Fy, tol)
    if s != 0.0:
        return (True,) + _kept_axis(s, 0.0, 1.0, 0.0, ay, by, ey, fy, tol)
    s = _side(az, bz, Az, Bz, ez, fz, Ez, Fz, tol)
    if s != 0.0:
        return (True,) + _kept_axis(s, 0.0, 0.0, 1.0, az, bz, ez, fz, tol)
    nx, ny, nz, normal = unit_cross(d1x, d1y, d1z, d2x, d2y, d2z)
    if not normal:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    pa = ax * nx + ay * ny + az * nz
    pb = bx * nx + by * ny + bz * nz
    qe = ex * nx + ey * ny + ez * nz
    qf = fx * nx + fy * ny + fz * nz
    s = _side(pa, pb, Ax * nx + Ay * ny + Az * nz, Bx * nx + By * ny + Bz * nz,
              qe, qf, Ex * nx + Ey * ny + Ez * nz, Fx * nx + Fy * ny + Fz * nz, tol)
    if s != 0.0:
        return (True,) + _kept_axis(s, nx, ny, nz, pa, pb, qe, qf, tol)
    # in the plane of the two segments (a flat contact: coplanar segments that do not cross)
    for j in range(2):
        mx, my, mz, ok = unit_cross(nx, ny, nz, d1x if j == 0 else d2x,
                                    d1y if j == 0 else d2y, d1z if j == 0 else d2z)
        if ok:
            pa = ax * mx + ay * my + az * mz
            pb = bx * mx + by * my + bz * mz
            qe = ex * mx + ey * my + ez * mz
            qf = fx * mx + fy * my + fz * mz
            s = _side(pa, pb, Ax * mx + Ay * my + Az * mz, Bx * mx + By * my + Bz * mz,
                      qe, qf, Ex * mx + Ey * my + Ez * mz, Fx * mx + Fy * my + Fz * mz, tol)
            if s != 0.0:
                return (True,) + _kept_axis(s, mx, my, mz, pa, pb, qe, qf, tol)
    return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0


@numba.njit(cache=True)
def stay_apart(ia, ib, ie, jf, x, v, tau, band):
    """True when segments [ia, ib] and [ie, jf], moving linearly over [0, tau], stay farther
    apart than ``band`` (plus a margin) the whole step: then ``edge_edge_detect`` finds neither a
    touching pair at t = 0 nor a crossing, and the cubic need not be solved.

    A separating axis: over the step each segment lies in the hull of its end points at 0 and
    tau, so two intervals of projections that are apart by more than the tolerance on some unit
    axis keep the segments apart. The axes tried: x, y, z (tighter than the broad phase's
    boxes, padded by BOX_PAD of h; no square root), the segments' common normal at t = 0, which
    separates the near-coplanar pairs of a flat contact that lie one above the other, then the
    two directions in the segments' plane across each segment (common normal x segment), which
    separate coplanar segments of a flat contact that do not cross. The tolerance is band
    plus APART_MARGIN of the longer segment: the segments extended by SEGMENT_EPS, and a root of
    the cubic accepted within round-off, whose lines miss by far less."""
    return apart_axis(ia, ib, ie, jf, x, v, tau, band)[0]


@numba.njit(cache=True, inline="always")
def still_apart(ia, ib, ie, jf, v, tau, geo, k):
    """A repeated sweep's test of a pair that ``apart_axis`` found apart earlier in the step,
    its axis in row k of ``geo`` (mx, my, mz, pa, pb, qe, qf): the velocities changed since,
    the positions at t = 0 did not, so only the end points at tau are projected again (from
    the velocities alone: neither x nor the other axes are read). True: still apart by more
    than the tolerance on that axis, a separating axis of its own (``stay_apart``)."""
    mx = geo[k, 0]
    my = geo[k, 1]
    mz = geo[k, 2]
    pa = geo[k, 3]
    pb = geo[k, 4]
    qe = geo[k, 5]
    qf = geo[k, 6]
    ua = tau * (v[ia, 0] * mx + v[ia, 1] * my + v[ia, 2] * mz)
    ub = tau * (v[ib, 0] * mx + v[ib, 1] * my + v[ib, 2] * mz)
    ue = tau * (v[ie, 0] * mx + v[ie, 1] * my + v[ie, 2] * mz)
    uf = tau * (v[jf, 0] * mx + v[jf, 1] * my + v[jf, 2] * mz)
    return (min(min(pa, pb), min(pa + ua, pb + ub))
            > max(max(qe, qf), max(qe + ue, qf + uf)))


@numba.njit(cache=True)
def far_apart(pairs, edges, x, band_max, reach, out):
    """For the kept candidate list (``contact.skin``), built at positions x: out[k] = FAR for
    each pair k (rows of ``edges``) that ``stay_apart`` would find apart at every step the list
    is kept, else 0. While it is kept, every surface node's positions at 0 and tau lie within
    the skin's reach of x along each axis, and the broad phase allows the corrections of a step
    its BOX_PAD: together at most ``reach`` (pad_b) per axis, so at most reach |m|_1 along a unit
    axis m. A pair whose segments are apart on m by more than the largest tolerance of those
    steps (``band_max``, band of the largest h those moves allow; the segments' lengths grown
    by as much) plus 2 reach |m|_1 therefore stays apart on m, and a test of it would find
    nothing: the sweep skips it. The axes: the segments' common normal and the two directions
    across the segments in their plane at x (x, y, z need no test: the per-step filter of the
    kept list already drops the pairs apart on them)."""
    grow = 2.0 * math.sqrt(3.0) * reach
    for k in range(pairs.shape[0]):
        out[k] = 0
        ia = edges[pairs[k, 0], 0]
        ib = edges[pairs[k, 0], 1]
        ie = edges[pairs[k, 1], 0]
        jf = edges[pairs[k, 1], 1]
        d1x = x[ib, 0] - x[ia, 0]
        d1y = x[ib, 1] - x[ia, 1]
        d1z = x[ib, 2] - x[ia, 2]
        d2x = x[jf, 0] - x[ie, 0]
        d2y = x[jf, 1] - x[ie, 1]
        d2z = x[jf, 2] - x[ie, 2]
        ll = max(d1x * d1x + d1y * d1y + d1z * d1z, d2x * d2x + d2y * d2y + d2z * d2z)
        tol = band_max + APART_MARGIN * (math.sqrt(ll) + grow)
        nx, ny, nz, normal = unit_cross(d1x, d1y, d1z, d2x, d2y, d2z)
        if not normal:
            continue
        for j in range(3):
            mx, my, mz, ok = nx, ny, nz, True
            if j > 0:
                mx, my, mz, ok = unit_cross(nx, ny, nz, d1x if j == 1 else d2x,
                                            d1y if j == 1 else d2y, d1z if j == 1 else d2z)
            if not ok:
                continue
            pa = x[ia, 0] * mx + x[ia, 1] * my + x[ia, 2] * mz
            pb = x[ib, 0] * mx + x[ib, 1] * my + x[ib, 2] * mz
            qe = x[ie, 0] * mx + x[ie, 1] * my + x[ie, 2] * mz
            qf = x[jf, 0] * mx + x[jf, 1] * my + x[jf, 2] * mz
            gap = max(min(pa, pb) - max(qe, qf), min(qe, qf) - max(pa, pb))
            if gap > tol + 2.0 * reach * (abs(mx) + abs(my) + abs(mz)):
                out[k] = FAR
                break


@numba.njit(cache=True)
def edge_edge_correct(ia, ib, ie, jf, x, v, mass, tau, mu, band, restore, nu_x, nu_y, nu_z,
                      lock=NO_LOCK):
    """One edge-edge pair, see ``edge_edge_detect`` (the constraint row is not kept)."""
    return edge_edge_detect(ia, ib, ie, jf, x, v, mass, tau, mu, band, restore, nu_x, nu_y,
                            nu_z, np.empty((1, GEO_COLS)), 0, lock)


@numba.njit(cache=True)
def edge_edge_detect(ia, ib, ie, jf, x, v, mass, tau, mu, band, restore, nu_x, nu_y, nu_z, geo,
                     k, lock):
    """``edge_edge_test`` without the HELD answer (0 instead)."""
    J = edge_edge_test(ia, ib, ie, jf, x, v, mass, tau, mu, band, restore, nu_x, nu_y, nu_z,
                       geo, k, lock)
    return J if J > 0.0 else 0.0


@numba.njit(cache=True, inline="always")
def edge_edge_test(ia, ib, ie, jf, x, v, mass, tau, mu, band, restore, nu_x, nu_y, nu_z, geo,
                   k, lock):
    """One edge-edge pair (ALGORITHMS.md 3.2): the cubic, root selection in [0, tau], segment
    test, alpha, beta, the normal, N_c [D19 eq. 11] and the corrections [D19 eq. 12]. Corrects v
    in place; returns the normal impulse tau N_c [N s] (0 when nothing was done).
    (nu_x, nu_y, nu_z) = nu_1 - nu_2, the difference of the bodies' outward normals at the two
    edges, orients n only for touching edges (``band``, ``restore``: see the module
    docstring). An applied impulse leaves its constraint row in row k of ``geo (*, GEO_COLS)``.
    ``lock``: prescribed velocity components, left alone by the impulse (``_apply``; an
    empty array when there are none). Returns HELD (< 0) instead of 0 for edges touching at
    t = 0 that need no impulse and whose cubic finds none either: their touching row (alpha,
    beta, n, gap / tau, no impulse) is then in row k of ``geo`` (``edge_edge_held``)."""
    held = False
    ax = x[ia, 0]
    ay = x[ia, 1]
    az = x[ia, 2]
    if band > 0.0:
        d1x = x[ib, 0] - ax
        d1y = x[ib, 1] - ay
        d1z = x[ib, 2] - az
        d2x = x[jf, 0] - x[ie, 0]
        d2y = x[jf, 1] - x[ie, 1]
        d2z = x[jf, 2] - x[ie, 2]
        al, be, den, ae = line_parameters(ax, ay, az, d1x, d1y, d1z, x[ie, 0], x[ie, 1],
                                          x[ie, 2], d2x, d2y, d2z)
        if (den > PARALLEL_SIN * PARALLEL_SIN * ae and -SEGMENT_EPS <= al <= 1.0 + SEGMENT_EPS
                and -SEGMENT_EPS <= be <= 1.0 + SEGMENT_EPS):
            gx = x[ie, 0] + be * d2x - ax - al * d1x
            gy = x[ie, 1] + be * d2y - ay - al * d1y
            gz = x[ie, 2] + be * d2z - az - al * d1z
            if gx * gx + gy * gy + gz * gz <= band * band:
                # _edge_edge_at(0.0, True, ...), its line parameters being those just computed
                J = _crossing(al, be, den, ae, d1x, d1y, d1z, d2x, d2y, d2z, True, band, restore,
                              ia, ib, ie, jf, x, v, mass, tau, mu, nu_x, nu_y, nu_z, geo, k,
                              lock)
                if J > 0.0:
                    return J
                held = J == HELD
    a, b, c, d = cubic_coefficients(
        x[ib, 0] - ax, x[ib, 1] - ay, x[ib, 2] - az,
        x[ie, 0] - ax, x[ie, 1] - ay, x[ie, 2] - az,
        x[jf, 0] - ax, x[jf, 1] - ay, x[jf, 2] - az,
        v[ib, 0] - v[ia, 0], v[ib, 1] - v[ia, 1], v[ib, 2] - v[ia, 2],
        v[ie, 0] - v[ia, 0], v[ie, 1] - v[ia, 1], v[ie, 2] - v[ia, 2],
        v[jf, 0] - v[ia, 0], v[jf, 1] - v[ia, 1], v[jf, 2] - v[ia, 2])
    n, r0, r1, r2 = cubic_roots_in(a, b, c, d, tau)
    for i in range(n):
        t = r0 if i == 0 else (r1 if i == 1 else r2)
        J = _edge_edge_at(t, False, band, restore, ia, ib, ie, jf, x, v, mass, tau, mu, nu_x,
                          nu_y, nu_z, geo, k, lock)
        if J > 0.0:
            return J
    return HELD if held else 0.0


@numba.njit(cache=True, inline="always")
def edge_edge_held(ia, ib, ie, jf, v, mass, tau, mu, geo, k, lock):
    """A later visit of touching edges whose test found no impulse (``edge_edge_test``: HELD,
    their touching row in row k of ``geo``): the touching branch of that test again, from the
    stored alpha, beta, n and gap / tau, which depend on the positions at t = 0 alone, so the
    same arithmetic as a new test's; the cubic is not solved again (``edge_edge_sweep``).
    Returns the impulse tau N_c [N s] (0 when nothing was done); an impulse makes the row an
    ordinary one (geo[k, 0] = the impulse)."""
    al = geo[k, 1]
    be = geo[k, 2]
    nx = geo[k, 3]
    ny = geo[k, 4]
    nz = geo[k, 5]
    una = v[ia, 0] * nx + v[ia, 1] * ny + v[ia, 2] * nz
    unb = v[ib, 0] * nx + v[ib, 1] * ny + v[ib, 2] * nz
    une = v[ie, 0] * nx + v[ie, 1] * ny + v[ie, 2] * nz
    unf = v[jf, 0] * nx + v[jf, 1] * ny + v[jf, 2] * nz
    S = _inverse_mass(al, be, nx, ny, nz, ia, ib, ie, jf, mass, lock)
    if not S > 0.0:
        return 0.0
    Nc = ((1.0 - al) * una + al * unb - (1.0 - be) * une - be * unf - geo[k, 6]) / (tau * S)
    if not Nc > 0.0:
        return 0.0
    J = tau * Nc
    _apply(J, mu, S, al, be, nx, ny, nz, ia, ib, ie, jf, v, mass, lock)
    geo[k, 0] = J
    return J


@numba.njit(cache=True, inline="always")
def edge_edge_relax(ia, ib, ie, jf, v, mass, mu, geo, k, slack, lock):
    """A later visit of an edge pair that got an impulse earlier in the step (row k of ``geo``):
    with its stored alpha, beta, n and gap term, the push tau N_c of [D19 eq. 11, 12] (with
    friction), added to the row's impulse, when the approach exceeds its target by more than
    ``slack`` [m/s]. Never a release (that is ``impactsim.contact.rows``). Returns the impulse
    [N s] (0 when nothing was done)."""
    lam = geo[k, 0]
    al = geo[k, 1]
    be = geo[k, 2]
    nx = geo[k, 3]
    ny = geo[k, 4]
    nz = geo[k, 5]
    gt = geo[k, 6]
    una = v[ia, 0] * nx + v[ia, 1] * ny + v[ia, 2] * nz
    unb = v[ib, 0] * nx + v[ib, 1] * ny + v[ib, 2] * nz
    une = v[ie, 0] * nx + v[ie, 1] * ny + v[ie, 2] * nz
    unf = v[jf, 0] * nx + v[jf, 1] * ny + v[jf, 2] * nz
    err = (1.0 - al) * una + al * unb - (1.0 - be) * une - be * unf - gt
    scale = ((1.0 - al) * abs(una) + al * abs(unb) + (1.0 - be) * abs(une) + be * abs(unf)
             + abs(gt))
    if not pushes_again(err, slack, scale):
        return 0.0
    S = _inverse_mass(al, be, nx, ny, nz, ia, ib, ie, jf, mass, lock)
    if not S > 0.0:
        return 0.0
    J = err / S
    _apply(J, mu, S, al, be, nx, ny, nz, ia, ib, ie, jf, v, mass, lock)
    geo[k, 0] = lam + J
    return J


@numba.njit(cache=True)
def edge_normals(x, faces, face_edges, out):
    """Outward normal at each boundary edge: the sum of the unit normals of its boundary faces
    (used only to orient touching edge pairs, the departure from ALGORITHMS.md 3.2 described in
    the module docstring). out (g, 3)."""
    out[:] = 0.0
    edge_normals_of(x, faces, face_edges, np.arange(faces.shape[0]), out)


@numba.njit(cache=True)
def edge_normals_of(x, faces, face_edges, fsel, out):
    """``edge_normals`` for the edges of the faces ``fsel`` (increasing) alone: their rows of
    out are those ``edge_normals`` gives (the same sums, in the same order) when ``fsel`` holds
    every face of each of them; other rows are left as they are."""
    for q in range(fsel.shape[0]):
        for j in range(3):
            g = face_edges[fsel[q], j]
            if g >= 0:
                out[g, 0] = 0.0
                out[g, 1] = 0.0
                out[g, 2] = 0.0
    for q in range(fsel.shape[0]):
        f = fsel[q]
        a = faces[f, 0]
        b = faces[f, 1]
        c = faces[f, 2]
        nx, ny, nz, nn = triangle_normal(x[a, 0], x[a, 1], x[a, 2], x[b, 0], x[b, 1], x[b, 2],
                                         x[c, 0], x[c, 1], x[c, 2])[6:]
        nn = math.sqrt(nn)
        if nn > 0.0:
            for j in range(3):
                g = face_edges[f, j]
                if g >= 0:
                    out[g, 0] += nx / nn
                    out[g, 1] += ny / nn
                    out[g, 2] += nz / nn


@numba.njit(cache=True)
def faces_at_edges(pairs, face_edges, mark, fsel):
    """The faces (increasing, into ``fsel``) with an edge in ``pairs (k, 2)`` of edge rows:
    every face of each such edge, so that ``edge_normals_of`` over them gives those edges the
    normals ``edge_normals`` would. ``mark (g,) bool`` all False on entry and on return.
    Returns how many faces. One pass over the pairs and one over the faces' edge rows, where
    ``edge_normals`` over every face also reads three nodes and takes a root per face."""
    for k in range(pairs.shape[0]):
        mark[pairs[k, 0]] = True
        mark[pairs[k, 1]] = True
    n = 0
    for f in range(face_edges.shape[0]):
        hit = False
        for j in range(3):
            g = face_edges[f, j]
            if g >= 0 and mark[g]:
                hit = True
        if hit:
            fsel[n] = f
            n += 1
    for k in range(pairs.shape[0]):
        mark[pairs[k, 0]] = False
        mark[pairs[k, 1]] = False
    return n


@numba.njit(cache=True)
def edge_edge_sweep(pairs, edges, normals, x, v, mass, tau, mu, band, restore, active, stamp,
                    sweep, since, geo, slack, lock=NO_LOCK):
    """Gauss-Seidel sweep over candidate edge pairs (ALGORITHMS.md 3.2): sequentially, in the
    given (sorted) order, each pair seeing the velocities already corrected. ``pairs (k, 2)``
    rows of indices into ``edges`` (body 1 edge, body 2 edge); ``normals (g, 3)`` from
    ``edge_normals``; ``active (k,)`` uint8 set to 1 for every pair that got an impulse, whose
    constraint row is then row k of ``geo (k, GEO_COLS)``: later visits in the same step update
    that row (``edge_edge_relax``, projected Gauss-Seidel) instead of testing the crossing again.
    ``stamp``, ``sweep``, ``since``: the skipping of unchanged pairs in repeated sweeps, as in
    ``nodeface.node_face_sweep``; ``lock``: prescribed velocity components, as there. Returns
    (pairs corrected in this sweep, sum of the normal impulse changes [N s], largest velocity
    change of a corrected node [m/s])."""
    applied = 0
    total = 0.0
    jump = 0.0
    for k in range(pairs.shape[0]):
        if active[k] == FAR:
            continue  # apart while the candidate list is kept (far_apart)
        g1 = pairs[k, 0]
        g2 = pairs[k, 1]
        ia = edges[g1, 0]
        ib = edges[g1, 1]
        ie = edges[g2, 0]
        jf = edges[g2, 1]
        if unchanged_since(stamp, since, ia, ib, ie, jf):
            continue
        if active[k] == APART:
            if still_apart(ia, ib, ie, jf, v, tau, geo, k):
                continue  # what edge_edge_detect would find, without the cubic
            active[k] = 0
        if active[k] == 1:
            J = edge_edge_relax(ia, ib, ie, jf, v, mass, mu, geo, k, slack, lock)
        elif active[k] == 2:
            J = edge_edge_held(ia, ib, ie, jf, v, mass, tau, mu, geo, k, lock)
            if J > 0.0:
                active[k] = 1
        else:
            apart, mx, my, mz, pa, pb, qe, qf = apart_axis(ia, ib, ie, jf, x, v, tau, band)
            if apart:  # what edge_edge_detect would find, without the cubic
                geo[k, 0] = mx
                geo[k, 1] = my
                geo[k, 2] = mz
                geo[k, 3] = pa
                geo[k, 4] = pb
                geo[k, 5] = qe
                geo[k, 6] = qf
                active[k] = APART
                continue
            J = edge_edge_test(ia, ib, ie, jf, x, v, mass, tau, mu, band, restore,
                               normals[g1, 0] - normals[g2, 0], normals[g1, 1] - normals[g2, 1],
                               normals[g1, 2] - normals[g2, 2], geo, k, lock)
            if J == HELD:
                active[k] = 2
                J = 0.0
            else:
                J = first_visit(J, active, k)
        if J != 0.0:
            applied += 1
            total += J
            stamp_nodes(stamp, sweep, ia, ib, ie, jf)
            for m in (mass[ia], mass[ib], mass[ie], mass[jf]):
                if abs(J) / m > jump:
                    jump = abs(J) / m
    return applied, total, jump
