"""Node-face pass (ALGORITHMS.md 3.1, the main contact pass of [D19]).

A boundary node p of one body and a boundary face (a, b, c) of another move linearly over the
step, x_k(t) = x_k^n + t U*_k. The node crosses the face's plane at a root of the cubic
det[x_b - x_a, x_c - x_a, x_p - x_a](t) = 0 in [0, tau]; the earliest root at which the node is
inside the triangle (barycentric weights w_i >= -eps) is the contact. There the impulse that makes
the node's normal velocity equal to the face point's (velocity interpolated with w_i) is applied
to all four nodes:

    N = (U*_n,node - sum w_i U*_n,i) / (tau (1/m_node + sum w_i^2 / m_i)),
    node: U -= tau N / m_node,   face node i: U += tau w_i N / m_i,

with n the unit normal of the face at the crossing pointing into the face's body (here written
with the outward normal and J = tau N). Compressive only: nothing is done for a separating pair.
Optional Coulomb friction: a tangential impulse along the relative sliding direction, at most the
one that stops sliding and at most mu times the normal impulse, with the same weights (momentum is
conserved). This algebra is ``point_face_impulse``, the pointwise law shared with the
particle-face contact (impactsim.fracture.particles: the same algebra with the particle's radius);
its sums and updates are those of ``impactsim.contact.impulse``, which the edge-edge pass uses too,
and its geometry (edges, normal, barycentric weights) that of ``impactsim.contact.geometry``.

Departure from the paper, for persistent contact: after a correction the node ends the step on
the face's plane only up to round-off and second-order terms (the face turns and slides during
the step), so at the next step it may start a little behind the plane, where the cubic has no
sign change. A node that starts at depth g <= ``band`` behind the plane, inside the triangle,
counts as touching at t = 0; it is held with a relative normal velocity of at least
restore * g / tau away from the face (restore = 1: back on the plane at the end of the step;
still a compressive impulse, never a pull). Deeper nodes are left alone (the penetration
diagnostic reports them).

A pair that gets an impulse keeps it as a constraint row (``geo``: the accumulated impulse,
weights, normal and target velocity of its crossing): later sweeps of the step push it again
through that row when it approaches again (``node_face_relax``), and the projected rounds of
``impactsim.contact.rows`` may take impulse back from it when corrections of other pairs have
pushed it apart (departure from [D19], see ``impactsim.contact.passes`` and docs/physics.md,
"Contact energy").

Prescribed velocity components (the boundary-conditions pass runs before contact): with a
``lock`` array (0.0 on prescribed components, 1.0 on free ones; ``passes.ContactContext.lock``)
a prescribed component is an infinite mass along its axis, and the impulses change node
velocities only along free axes with the matching effective mass (``point_face_impulse``,
``impactsim.contact.impulse``). Without prescribed components the plain sums run.
"""

from __future__ import annotations

import math

import numba

import numpy as np

from impactsim.contact.cubic import cubic_coefficients, cubic_roots_in
from impactsim.contact.geometry import (barycentric_numerators, clamped_weights, point_at,
                                        triangle_normal, unit_cross, unit_normal)
from impactsim.contact.impulse import NO_LOCK, inverse_mass, lock_row, push
from impactsim.contact.rows import first_visit, pushes_again, stamp_nodes, unchanged_since

GEO_COLS = 8  # a constraint row: lam, wa, wb, wc, nx, ny, nz, vmin
APART = 3  # node_face_sweep: a pair apart on a separating axis, kept in its row (still_apart)
FAR = 4  # node_face_sweep: a pair apart for as long as the candidate list is kept (far_apart)
APART_MARGIN = 1e-3  # node_face_apart: the margin beyond band, a share of the face's edges


@numba.njit(cache=True)
def _node_face_at(t, p, ia, ib, ic, x, v, mass, mu, eps_bary, vmin, geo, k, lock):
    """Contact of node p with face (ia, ib, ic) at time t of the step (ALGORITHMS.md 3.1).

    The node's normal velocity relative to the face point must be at least ``vmin`` (0 at a
    crossing: equal normal velocities). Returns -1 when the node is not inside the triangle at t
    (or the face is degenerate), 0 when it is inside but needs no impulse, else the normal
    impulse J [N s] it applied to v, and then row k of ``geo`` holds the constraint (see
    ``node_face_relax``)."""
    ax, ay, az = point_at(x, v, t, ia)
    bx, by, bz = point_at(x, v, t, ib)
    cx, cy, cz = point_at(x, v, t, ic)
    e1x, e1y, e1z, e2x, e2y, e2z, nx, ny, nz, nn = triangle_normal(ax, ay, az, bx, by, bz, cx,
                                                                   cy, cz)
    if not nn > 0.0:
        return -1.0
    # barycentric weights of the node's projection
    qx, qy, qz = point_at(x, v, t, p)
    sb, sc = barycentric_numerators(qx - ax, qy - ay, qz - az, e1x, e1y, e1z, e2x, e2y, e2z, nx,
                                    ny, nz)
    wb = sb / nn
    wc = sc / nn
    wa = 1.0 - wb - wc
    if wa < -eps_bary or wb < -eps_bary or wc < -eps_bary:
        return -1.0
    wa, wb, wc = clamped_weights(wa, wb, wc)
    nx, ny, nz = unit_normal(nx, ny, nz, nn)
    lpx, lpy, lpz = lock_row(lock, p)
    J = point_face_impulse(v, p, mass[p], lpx, lpy, lpz, v, mass, lock, ia, ib, ic, wa, wb, wc,
                           nx, ny, nz, vmin, mu)
    if J > 0.0:
        geo[k, 0] = J
        geo[k, 1] = wa
        geo[k, 2] = wb
        geo[k, 3] = wc
        geo[k, 4] = nx
        geo[k, 5] = ny
        geo[k, 6] = nz
        geo[k, 7] = vmin
    return J


@numba.njit(cache=True, inline="always")
def relative_normal_velocity(vp, p, v, ia, ib, ic, wa, wb, wc, nx, ny, nz):
    """Velocity of point p (row p of vp) relative to the point of face (ia, ib, ic) with
    barycentric weights w (rows of v), and its component along n: (vrx, vry, vrz, u)."""
    vrx = vp[p, 0] - (wa * v[ia, 0] + wb * v[ib, 0] + wc * v[ic, 0])
    vry = vp[p, 1] - (wa * v[ia, 1] + wb * v[ib, 1] + wc * v[ic, 1])
    vrz = vp[p, 2] - (wa * v[ia, 2] + wb * v[ib, 2] + wc * v[ic, 2])
    return vrx, vry, vrz, vrx * nx + vry * ny + vrz * nz


@numba.njit(cache=True)
def point_face_impulse(vp, p, mp, lpx, lpy, lpz, v, mass, lock, ia, ib, ic, wa, wb, wc, nx, ny,
                       nz, vmin, mu):
    """The impulse algebra of ALGORITHMS.md 3.1, pointwise: a point of mass mp (row p of vp: a
    boundary node, vp is v, or a particle of impactsim.fracture.particles) against the point of
    face (ia, ib, ic) with barycentric weights w (rows of v, masses in mass), along the face's
    unit outward normal n. The point's normal velocity relative to the face point,
    u = (U_p - sum w_i U_i) . n, must be at least ``vmin``; when it is not, the normal impulse

        J = (vmin - u) / (1/m_p + sum w_i^2 / m_i),   U_p += J n / m_p,   U_i -= w_i J n / m_i

    is applied (compressive only, momentum conserved), then, with mu > 0, Coulomb friction: a
    tangential impulse along the relative sliding velocity, at most the one that stops sliding
    and at most mu J, with the same weights. That is ``impactsim.contact.impulse`` for the four
    points (p, a, b, c) with coefficients (1, -w_a, -w_b, -w_c).

    Prescribed velocity components (``lock (n_node, 3)``, 0.0 on a prescribed component, else
    1.0; ``NO_LOCK`` when the case prescribes none; (lpx, lpy, lpz) the point's own row, 1, 1, 1
    for a particle): an infinite mass along that axis. Its share of the impulse goes to the
    constraint's reaction and a node's velocity changes only along its free axes,
    dU_k = +-c_k J (lock_k * n) / m_k, with the matching effective mass

        1/m_eff = s_p / m_p + sum w_i^2 s_i / m_i,   s_k = sum_d lock_k,d n_d^2,

    and no impulse when every node is held along n (the constraints take it all). Friction
    likewise with the tangent t: at most the impulse that stops sliding along t (effective mass
    with t_d^2) and at most mu J; without prescribed components the normal's effective mass, as
    above. Momentum is conserved along every free axis of all four nodes.
    Returns J [N s], 0 when nothing was needed, -1 when a massless node (orphaned by erosion)
    would take part (nothing is applied)."""
    vrx, vry, vrz, vn = relative_normal_velocity(vp, p, v, ia, ib, ic, wa, wb, wc, nx, ny, nz)
    if not vn < vmin:
        return 0.0
    ma = mass[ia]
    mb = mass[ib]
    mc = mass[ic]
    if not (mp > 0.0 and ma > 0.0 and mb > 0.0 and mc > 0.0):
        return -1.0  # a massless node (orphaned by erosion) takes no impulse
    minv = inverse_mass(nx, ny, nz, 1.0, mp, lpx, lpy, lpz, -wa, ma, ia, -wb, mb, ib, -wc, mc,
                        ic, lock)
    if not minv > 0.0:
        return 0.0  # every node is held along n
    J = (vmin - vn) / minv
    push(J, nx, ny, nz, vp, p, 1.0, mp, lpx, lpy, lpz, v, ia, -wa, ma, ib, -wb, mb, ic, -wc, mc,
         lock)
    if mu > 0.0:
        # Coulomb friction: relative tangential velocity before the normal correction
        vtx = vrx - vn * nx
        vty = vry - vn * ny
        vtz = vrz - vn * nz
        vt = math.sqrt(vtx * vtx + vty * vty + vtz * vtz)
        if vt > 0.0:
            tx = vtx / vt
            ty = vty / vt
            tz = vtz / vt
            tinv = minv
            if lock.shape[0] > 0:
                tinv = inverse_mass(tx, ty, tz, 1.0, mp, lpx, lpy, lpz, -wa, ma, ia, -wb, mb,
                                    ib, -wc, mc, ic, lock)
            if tinv > 0.0:
                Jt = min(vt / tinv, mu * J)
                push(-Jt, tx, ty, tz, vp, p, 1.0, mp, lpx, lpy, lpz, v, ia, -wa, ma, ib, -wb, mb,
                     ic, -wc, mc, lock)
    return J


@numba.njit(cache=True, inline="always")
def _side(p0, p1, q0, q1, q2, q3, q4, q5, tol):
    """1 when the interval [min p, max p] lies more than tol above [min q, max q], -1 when
    below, else 0."""
    qlo = min(min(min(q0, q1), min(q2, q3)), min(q4, q5))
    qhi = max(max(max(q0, q1), max(q2, q3)), max(q4, q5))
    if min(p0, p1) > qhi + tol:
        return 1.0
    if qlo > max(p0, p1) + tol:
        return -1.0
    return 0.0


@numba.njit(cache=True, inline="always")
def _kept_axis(s, mx, my, mz, pp, qa, qb, qc, tol):
    """A separating axis m found apart on side s (``_side``), as ``still_apart`` reads it: the
    axis turned so that the node lies above, the node's projection at t = 0 on it and the
    corners' plus tol."""
    return s * mx, s * my, s * mz, s * pp, s * qa + tol, s * qb + tol, s * qc + tol


@numba.njit(cache=True, inline="always")
def apart_axis(p, ia, ib, ic, x, v, tau, band):
    """``node_face_apart`` and the separating axis it found: (apart, mx, my, mz, pp, qa, qb,
    qc), the axis turned so that the node lies above, pp its projection at t = 0 on it and qa,
    qb, qc those of the corners plus the tolerance (``still_apart``; zeros when not apart)."""
    px = x[p, 0]
    py = x[p, 1]
    pz = x[p, 2]
    ax = x[ia, 0]
    ay = x[ia, 1]
    az = x[ia, 2]
    bx = x[ib, 0]
    by = x[ib, 1]
    bz = x[ib, 2]
    cx = x[ic, 0]
    cy = x[ic, 1]
    cz = x[ic, 2]
    Px, Py, Pz = point_at(x, v, tau, p)
    Ax, Ay, Az = point_at(x, v, tau, ia)
    Bx, By, Bz = point_at(x, v, tau, ib)
    Cx, Cy, Cz = point_at(x, v, tau, ic)
    e1x, e1y, e1z, e2x, e2y, e2z, nx, ny, nz, nn = triangle_normal(ax, ay, az, bx, by, bz,
                                                                    cx, cy, cz)
    ll = max(e1x * e1x + e1y * e1y + e1z * e1z, e2x * e2x + e2y * e2y + e2z * e2z)
    tol = band + APART_MARGIN * math.sqrt(ll)
    s = _side(px, Px, ax, bx, cx, Ax, Bx, Cx, tol)
    if s != 0.0:
        return (True,) + _kept_axis(s, 1.0, 0.0, 0.0, px, ax, bx, cx, tol)
    s = _side(py, Py, ay, by, cy, Ay, By, Cy, tol)
    if s != 0.0:
        return (True,) + _kept_axis(s, 0.0, 1.0, 0.0, py, ay, by, cy, tol)
    s = _side(pz, Pz, az, bz, cz, Az, Bz, Cz, tol)
    if s != 0.0:
        return (True,) + _kept_axis(s, 0.0, 0.0, 1.0, pz, az, bz, cz, tol)
    if not nn > 0.0:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    inv = 1.0 / math.sqrt(nn)
    nx *= inv
    ny *= inv
    nz *= inv
    pp = px * nx + py * ny + pz * nz
    qa = ax * nx + ay * ny + az * nz
    qb = bx * nx + by * ny + bz * nz
    qc = cx * nx + cy * ny + cz * nz
    s = _side(pp, Px * nx + Py * ny + Pz * nz, qa, qb, qc, Ax * nx + Ay * ny + Az * nz,
              Bx * nx + By * ny + Bz * nz, Cx * nx + Cy * ny + Cz * nz, tol)
    if s != 0.0:
        return (True,) + _kept_axis(s, nx, ny, nz, pp, qa, qb, qc, tol)
    # in the face's plane across each edge (a flat contact: a node beside the triangle)
    for j in range(3):
        mx, my, mz, ok = unit_cross(nx, ny, nz,
                                    e1x if j == 0 else (e2x if j == 1 else cx - bx),
                                    e1y if j == 0 else (e2y if j == 1 else cy - by),
                                    e1z if j == 0 else (e2z if j == 1 else cz - bz))
        if ok:
            pp = px * mx + py * my + pz * mz
            qa = ax * mx + ay * my + az * mz
            qb = bx * mx + by * my + bz * mz
            qc = cx * mx + cy * my + cz * mz
            s = _side(pp, Px * mx + Py * my + Pz * mz, qa, qb, qc, Ax * mx + Ay * my + Az * mz,
                      Bx * mx + By * my + Bz * mz, Cx * mx + Cy * my + Cz * mz, tol)
            if s != 0.0:
                return (True,) + _kept_axis(s, mx, my, mz, pp, qa, qb, qc, tol)
    return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0


@numba.njit(cache=True)
def node_face_apart(p, ia, ib, ic, x, v, tau, band):
    """True when node p and face (ia, ib, ic), moving linearly over [0, tau], stay farther apart
    than ``band`` (plus a margin) the whole step: then ``node_face_detect`` finds neither a
    touching node at t = 0 nor a crossing inside the triangle, and the cubic need not be solved
    (the edge-edge pass's ``stay_apart``). A separating axis: over the step the node lies on the
    segment of its positions at 0 and tau and the face in the hull of its corners' positions at
    0 and tau; the axes tried are x, y, z (tighter than the broad phase's padded boxes), the
    face's normal at t = 0 (nodes in front of a face that they do not reach in the step) and
    the three directions in the face's plane across its edges (nodes of a flat contact beside
    the triangle). The
    tolerance is band plus APART_MARGIN of the face's longer edge from a: the triangle test's
    eps_bary, and a root of the cubic accepted within round-off."""
    return apart_axis(p, ia, ib, ic, x, v, tau, band)[0]


@numba.njit(cache=True, inline="always")
def still_apart(p, ia, ib, ic, v, tau, geo, k):
    """A repeated sweep's test of a pair that ``apart_axis`` found apart earlier in the step,
    its axis in row k of ``geo`` (mx, my, mz, pp, qa, qb, qc): the velocities changed since,
    the positions at t = 0 did not, so only the end points at tau are projected again (from
    the velocities alone). True: still apart by more than the tolerance on that axis, a
    separating axis of its own (``node_face_apart``)."""
    mx = geo[k, 0]
    my = geo[k, 1]
    mz = geo[k, 2]
    pp = geo[k, 3]
    qa = geo[k, 4]
    qb = geo[k, 5]
    qc = geo[k, 6]
    up = tau * (v[p, 0] * mx + v[p, 1] * my + v[p, 2] * mz)
    ua = tau * (v[ia, 0] * mx + v[ia, 1] * my + v[ia, 2] * mz)
    ub = tau * (v[ib, 0] * mx + v[ib, 1] * my + v[ib, 2] * mz)
    uc = tau * (v[ic, 0] * mx + v[ic, 1] * my + v[ic, 2] * mz)
    return (min(pp, pp + up) > max(max(max(qa, qb), max(qc, qa + ua)),
                                   max(qb + ub, qc + uc)))


@numba.njit(cache=True)
def far_apart(pairs, nodes, faces, x, band_max, reach, out):
    """For the kept candidate list (``contact.skin``), built at positions x: out[k] = FAR for
    each pair k (row of ``nodes``, row of ``faces``) that ``node_face_apart`` would find apart
    at every step the list is kept, else 0: apart on the face's normal or on a direction across
    one of its edges in its plane at x by more than the largest tolerance of those steps plus
    2 reach |m|_1 (the edge-edge pass's ``far_apart``, which gives the reasons)."""
    grow = 2.0 * math.sqrt(3.0) * reach
    for k in range(pairs.shape[0]):
        out[k] = 0
        p = nodes[pairs[k, 0]]
        ia = faces[pairs[k, 1], 0]
        ib = faces[pairs[k, 1], 1]
        ic = faces[pairs[k, 1], 2]
        e1x, e1y, e1z, e2x, e2y, e2z, nx, ny, nz, nn = triangle_normal(
            x[ia, 0], x[ia, 1], x[ia, 2], x[ib, 0], x[ib, 1], x[ib, 2], x[ic, 0], x[ic, 1],
            x[ic, 2])
        if not nn > 0.0:
            continue
        ll = max(e1x * e1x + e1y * e1y + e1z * e1z, e2x * e2x + e2y * e2y + e2z * e2z)
        tol = band_max + APART_MARGIN * (math.sqrt(ll) + grow)
        nx, ny, nz = unit_normal(nx, ny, nz, nn)
        for j in range(4):
            mx, my, mz, ok = nx, ny, nz, True
            if j > 0:
                mx, my, mz, ok = unit_cross(
                    nx, ny, nz, e1x if j == 1 else (e2x if j == 2 else x[ic, 0] - x[ib, 0]),
                    e1y if j == 1 else (e2y if j == 2 else x[ic, 1] - x[ib, 1]),
                    e1z if j == 1 else (e2z if j == 2 else x[ic, 2] - x[ib, 2]))
            if not ok:
                continue
            pp = x[p, 0] * mx + x[p, 1] * my + x[p, 2] * mz
            qa = x[ia, 0] * mx + x[ia, 1] * my + x[ia, 2] * mz
            qb = x[ib, 0] * mx + x[ib, 1] * my + x[ib, 2] * mz
            qc = x[ic, 0] * mx + x[ic, 1] * my + x[ic, 2] * mz
            gap = max(pp - max(max(qa, qb), qc), min(min(qa, qb), qc) - pp)
            if gap > tol + 2.0 * reach * (abs(mx) + abs(my) + abs(mz)):
                out[k] = FAR
                break


@numba.njit(cache=True)
def node_face_correct(p, ia, ib, ic, x, v, mass, tau, mu, band, eps_bary, restore,
                      lock=NO_LOCK):
    """One node-face pair (ALGORITHMS.md 3.1): continuous crossing test over [0, tau] (cubic in
    time, then inside the triangle), then the velocity-equalising normal impulse, compressive
    only, with optional Coulomb friction. Corrects v in place; returns the normal impulse [N s]
    (0 when nothing was done). ``band`` [m]: a node at most this far behind the face's plane at
    t = 0 is treated as touching, and ``restore`` of its depth is undone in the step (see the
    module docstring). ``lock``: prescribed velocity components (``point_face_impulse``;
    an empty array when there are none)."""
    return node_face_detect(p, ia, ib, ic, x, v, mass, tau, mu, band, eps_bary, restore,
                            np.empty((1, GEO_COLS)), 0, lock)


@numba.njit(cache=True)
def node_face_detect(p, ia, ib, ic, x, v, mass, tau, mu, band, eps_bary, restore, geo, k,
                     lock):
    """``node_face_correct`` that also stores the constraint row of an applied impulse in row k
    of ``geo (*, GEO_COLS)``: accumulated impulse, weights, unit normal, target velocity."""
    e1x, e1y, e1z, e2x, e2y, e2z, nx, ny, nz, nn = triangle_normal(
        x[ia, 0], x[ia, 1], x[ia, 2], x[ib, 0], x[ib, 1], x[ib, 2], x[ic, 0], x[ic, 1], x[ic, 2])
    a, b, c, d = cubic_coefficients(
        e1x, e1y, e1z, e2x, e2y, e2z, x[p, 0] - x[ia, 0], x[p, 1] - x[ia, 1], x[p, 2] - x[ia, 2],
        v[ib, 0] - v[ia, 0], v[ib, 1] - v[ia, 1], v[ib, 2] - v[ia, 2],
        v[ic, 0] - v[ia, 0], v[ic, 1] - v[ia, 1], v[ic, 2] - v[ia, 2],
        v[p, 0] - v[ia, 0], v[p, 1] - v[ia, 1], v[p, 2] - v[ia, 2])
    area2 = math.sqrt(nn)
    if not area2 > 0.0:
        return 0.0
    dist0 = d / area2  # signed distance of the node from the face's plane at t = 0 (+ outside)
    if dist0 < -band:
        return 0.0
    if dist0 < 0.0:
        J = _node_face_at(0.0, p, ia, ib, ic, x, v, mass, mu, eps_bary, -restore * dist0 / tau,
                          geo, k, lock)
        if J > 0.0:
            return J
    n, r0, r1, r2 = cubic_roots_in(a, b, c, d, tau)
    for i in range(n):
        t = r0 if i == 0 else (r1 if i == 1 else r2)
        J = _node_face_at(t, p, ia, ib, ic, x, v, mass, mu, eps_bary, 0.0, geo, k, lock)
        if J > 0.0:
            return J
    return 0.0


@numba.njit(cache=True)
def node_face_relax(p, ia, ib, ic, v, mass, mu, geo, k, slack, lock):
    """A later visit of a pair that got an impulse earlier in the step (row k of ``geo``): with
    its stored weights, normal and target vmin, the push that brings the node's relative normal
    velocity u back to vmin through ``point_face_impulse`` (with friction), added to the row's
    impulse, when u falls short of vmin by more than ``slack`` [m/s]. Never a release (that is
    ``impactsim.contact.rows``). Returns the impulse [N s] (0 when nothing was done)."""
    lam = geo[k, 0]
    wa = geo[k, 1]
    wb = geo[k, 2]
    wc = geo[k, 3]
    nx = geo[k, 4]
    ny = geo[k, 5]
    nz = geo[k, 6]
    vmin = geo[k, 7]
    up = v[p, 0] * nx + v[p, 1] * ny + v[p, 2] * nz
    ua = v[ia, 0] * nx + v[ia, 1] * ny + v[ia, 2] * nz
    ub = v[ib, 0] * nx + v[ib, 1] * ny + v[ib, 2] * nz
    uc = v[ic, 0] * nx + v[ic, 1] * ny + v[ic, 2] * nz
    err = vmin - (up - wa * ua - wb * ub - wc * uc)
    if not pushes_again(err, slack, abs(up) + wa * abs(ua) + wb * abs(ub) + wc * abs(uc)
                        + abs(vmin)):
        return 0.0
    lpx, lpy, lpz = lock_row(lock, p)
    J = point_face_impulse(v, p, mass[p], lpx, lpy, lpz, v, mass, lock, ia, ib, ic, wa, wb, wc,
                           nx, ny, nz, vmin, mu)
    if J > 0.0:
        geo[k, 0] = lam + J
        return J
    return 0.0


@numba.njit(cache=True)
def node_face_sweep(pairs, nodes, faces, x, v, mass, tau, mu, band, eps_bary, restore, active,
                    stamp, sweep, since, geo, slack, lock=NO_LOCK):
    """Gauss-Seidel sweep over candidate pairs (ALGORITHMS.md 3.1 with the sequential rule of
    3.2): pair after pair in the given (sorted) order, each seeing the velocities corrected by the
    previous ones. ``pairs (k, 2)`` rows (index into nodes, index into faces); ``active (k,)``
    uint8 is set to 1 for every pair that got an impulse, and then row k of ``geo (k, GEO_COLS)``
    is its constraint row: later visits (of this sweep's repetitions in the same step) do not
    test the crossing again but update the row (``node_face_relax``: projected Gauss-Seidel,
    the accumulated impulse geo[k, 0] stays >= 0 but can shrink). The caller zeroes ``active``
    at the start of each step.

    ``stamp (n_node,)`` int64 holds the number of the sweep that last changed each node's
    velocity (numbers only grow); corrected nodes get ``sweep``. Pairs none of whose nodes has a
    stamp >= ``since`` are skipped: a repeated sweep passes the previous sweep's number, and a
    pair whose nodes did not change since then would repeat its last answer (no impulse), so the
    result is the same as visiting it. The first sweep passes since = 0 and visits every pair.
    ``lock (n_node, 3)``: 0.0 on prescribed velocity components, else 1.0 (an empty array
    when the case prescribes none): the impulses leave prescribed components alone
    (``point_face_impulse``).
    Returns (pairs corrected in this sweep, sum of the normal impulse changes [N s], largest
    velocity change of a corrected node |dJ| / m_node [m/s])."""
    applied = 0
    total = 0.0
    jump = 0.0
    for k in range(pairs.shape[0]):
        if active[k] == FAR:
            continue  # apart while the candidate list is kept (far_apart)
        p = nodes[pairs[k, 0]]
        f = pairs[k, 1]
        a = faces[f, 0]
        b = faces[f, 1]
        c = faces[f, 2]
        if unchanged_since(stamp, since, p, a, b, c):
            continue
        if active[k] == APART:
            if still_apart(p, a, b, c, v, tau, geo, k):
                continue  # what node_face_detect would find, without the cubic
            active[k] = 0
        if active[k] == 1:
            J = node_face_relax(p, a, b, c, v, mass, mu, geo, k, slack, lock)
        else:
            apart, mx, my, mz, pp, qa, qb, qc = apart_axis(p, a, b, c, x, v, tau, band)
            if apart:  # what node_face_detect would find, without the cubic
                geo[k, 0] = mx
                geo[k, 1] = my
                geo[k, 2] = mz
                geo[k, 3] = pp
                geo[k, 4] = qa
                geo[k, 5] = qb
                geo[k, 6] = qc
                active[k] = APART
                continue
            J = first_visit(node_face_detect(p, a, b, c, x, v, mass, tau, mu, band, eps_bary,
                                             restore, geo, k, lock), active, k)
        if J != 0.0:
            applied += 1
            total += J
            stamp_nodes(stamp, sweep, p, a, b, c)
            if abs(J) / mass[p] > jump:
                jump = abs(J) / mass[p]
    return applied, total, jump
