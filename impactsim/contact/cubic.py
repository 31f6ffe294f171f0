"""Coplanarity in time: the cubic det[A + tB] = 0 and its roots in [0, tau].

Four points moving linearly, x_k(t) = x_k + t U_k, are coplanar when det[x_1-x_0, x_2-x_0,
x_3-x_0](t) = 0 ([D19], ALGORITHMS.md 3.2). With A the columns at t = 0 and B their velocities,
det(A + tB) = a t^3 + b t^2 + c t + d, where d = det A, a = det B, b the sum of the determinants
with two columns from B and one from A, c the sum with one column from B and two from A.

The root finder does not use companion-matrix eigenvalues (np.roots): it splits [0, tau] at the
critical points of the cubic (roots of the derivative, a stable quadratic formula), so the cubic
is monotone on each piece, and brackets each sign change with safeguarded Newton steps. It handles
a vanishing leading coefficient (quadratic, linear, constant), roots at either end, and double
roots (a critical point where the cubic is zero to round-off counts as a root).
"""

from __future__ import annotations

import math

import numba


@numba.njit(cache=True)
def det3(ux, uy, uz, vx, vy, vz, wx, wy, wz):
    """det[u, v, w] (columns) = u . (v x w) (ALGORITHMS.md 3.2, the coplanarity determinant)."""
    return ux * (vy * wz - vz * wy) + uy * (vz * wx - vx * wz) + uz * (vx * wy - vy * wx)


@numba.njit(cache=True)
def cubic_coefficients(a1x, a1y, a1z, a2x, a2y, a2z, a3x, a3y, a3z,
                       b1x, b1y, b1z, b2x, b2y, b2z, b3x, b3y, b3z):
    """Coefficients (a, b, c, d) of det[A1 + t B1, A2 + t B2, A3 + t B3] = a t^3 + b t^2 + c t + d
    ([D19] section 2, ALGORITHMS.md 3.2 "vector form")."""
    d = det3(a1x, a1y, a1z, a2x, a2y, a2z, a3x, a3y, a3z)
    a = det3(b1x, b1y, b1z, b2x, b2y, b2z, b3x, b3y, b3z)
    b = (det3(a1x, a1y, a1z, b2x, b2y, b2z, b3x, b3y, b3z)
         + det3(b1x, b1y, b1z, a2x, a2y, a2z, b3x, b3y, b3z)
         + det3(b1x, b1y, b1z, b2x, b2y, b2z, a3x, a3y, a3z))
    c = (det3(a1x, a1y, a1z, a2x, a2y, a2z, b3x, b3y, b3z)
         + det3(a1x, a1y, a1z, b2x, b2y, b2z, a3x, a3y, a3z)
         + det3(b1x, b1y, b1z, a2x, a2y, a2z, a3x, a3y, a3z))
    return a, b, c, d


@numba.njit(cache=True)
def _poly(A, B, C, D, s):
    """The cubic of ALGORITHMS.md 3.2 in s = t / tau, by Horner's rule."""
    return ((A * s + B) * s + C) * s + D


@numba.njit(cache=True)
def _push(n, r0, r1, r2, s):
    """Append s to the increasing root list (r0, r1, r2) of length n, skipping duplicates
    (ALGORITHMS.md 3.2, "take the roots in [0, tau]")."""
    last = r0 if n == 1 else (r1 if n == 2 else r2)
    if n > 0 and s <= last + 1e-14:
        return n, r0, r1, r2
    if n == 0:
        return 1, s, r1, r2
    if n == 1:
        return 2, r0, s, r2
    if n == 2:
        return 3, r0, r1, s
    return n, r0, r1, r2


@numba.njit(cache=True)
def _bracketed_root(A, B, C, D, lo, hi, plo):
    """Root of the cubic of ALGORITHMS.md 3.2 in [lo, hi] where it is monotone and changes sign
    (plo = p(lo)):
    Newton steps kept inside the shrinking bracket, bisection otherwise."""
    s = 0.5 * (lo + hi)
    for _ in range(200):
        p = _poly(A, B, C, D, s)
        if p == 0.0:
            return s
        if (p < 0.0) == (plo < 0.0):
            lo = s
        else:
            hi = s
        if hi - lo <= 4e-16:
            return 0.5 * (lo + hi)
        dp = (3.0 * A * s + 2.0 * B) * s + C
        if dp != 0.0:
            sn = s - p / dp
            if lo < sn < hi:
                if abs(sn - s) <= 1e-15:
                    return sn
                s = sn
                continue
        s = 0.5 * (lo + hi)
    return s


@numba.njit(cache=True)
def cubic_roots_in(a, b, c, d, tau):
    """Roots of a t^3 + b t^2 + c t + d in [0, tau], increasing, as (n, r0, r1, r2) (n <= 3).

    ALGORITHMS.md 3.2 ("take the roots in [0, tau]"). Works in s = t / tau; a cubic that vanishes
    identically (all coefficients zero) returns the single root 0. Double roots: a critical point
    where |p| <= 1e-12 * (|a'| + |b'| + |c'| + |d|) counts as a root."""
    A = a * tau * tau * tau
    B = b * tau * tau
    C = c * tau
    D = d
    scale = abs(A) + abs(B) + abs(C) + abs(D)
    n = 0
    r0 = 0.0
    r1 = 0.0
    r2 = 0.0
    if scale == 0.0 or not math.isfinite(scale):
        if scale == 0.0:
            return 1, 0.0, 0.0, 0.0
        return 0, 0.0, 0.0, 0.0
    ztol = 1e-12 * scale
    # no root when the Bernstein coefficients on [0, 1] all have one sign, clear of zero by
    # more than ztol and round-off: the cubic is their weighted mean, so the walk below would
    # find no sign change and no double root either (same answer, without the critical points)
    b1 = D + C / 3.0
    b2 = D + (2.0 * C + B) / 3.0
    b3 = D + C + B + A
    far = 4.0 * ztol
    if (min(min(D, b1), min(b2, b3)) > far) or (max(max(D, b1), max(b2, b3)) < -far):
        return 0, 0.0, 0.0, 0.0
    # critical points: 3A s^2 + 2B s + C = 0, inside (0, 1), increasing
    qa = 3.0 * A
    qb = 2.0 * B
    qc = C
    nc = 0
    c0 = 0.0
    c1 = 0.0
    if abs(qa) <= 1e-14 * (abs(qb) + abs(qc)):
        if qb != 0.0:
            c0 = -qc / qb
            nc = 1
    else:
        disc = qb * qb - 4.0 * qa * qc
        if disc >= 0.0:
            sq = math.sqrt(disc)
            q = -0.5 * (qb + sq) if qb >= 0.0 else -0.5 * (qb - sq)
            if q != 0.0:
                c0 = q / qa
                c1 = qc / q
                nc = 2
            else:
                c0 = 0.0
                nc = 1
            if nc == 2 and c1 < c0:
                c0, c1 = c1, c0
    # keep the critical points inside (0, 1)
    k0 = 0.0
    k1 = 0.0
    nk = 0
    if nc >= 1 and 0.0 < c0 < 1.0:
        k0 = c0
        nk = 1
    if nc == 2 and 0.0 < c1 < 1.0 and c1 != c0:
        if nk == 0:
            k0 = c1
        else:
            k1 = c1
        nk += 1
    # walk the monotone pieces [0, k0], [k0, k1], [k1, 1]
    lo = 0.0
    plo = D
    if plo == 0.0:
        n, r0, r1, r2 = _push(n, r0, r1, r2, 0.0)
    for piece in range(nk + 1):
        if piece < nk:
            hi = k0 if piece == 0 else k1
        else:
            hi = 1.0
        phi = _poly(A, B, C, D, hi)
        if piece < nk and abs(phi) <= ztol:
            phi = 0.0  # a double root at the critical point
        if plo != 0.0 and phi != 0.0 and (plo < 0.0) != (phi < 0.0):
            n, r0, r1, r2 = _push(n, r0, r1, r2, _bracketed_root(A, B, C, D, lo, hi, plo))
        if phi == 0.0:
            n, r0, r1, r2 = _push(n, r0, r1, r2, hi)
        lo = hi
        plo = phi
    return n, r0 * tau, r1 * tau, r2 * tau
