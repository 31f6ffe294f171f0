"""Principal values of symmetric 3x3 tensors (pointwise laws for the fracture criteria).

Closed form of the eigenvalues of a symmetric matrix (Smith 1961, the trigonometric solution of
the characteristic cubic): with m = tr A / 3, B = A - m I, p2 = |B|^2 / 6, r = det(B) / (2 p^3),
the eigenvalues are m + 2 p cos(acos(r)/3 + 2 pi k / 3), k = 0, 1, 2; k = 0 gives the largest.
"""

from __future__ import annotations

import math

import numba


@numba.njit(cache=True, inline="always")
def max_principal(axx, ayy, azz, axy, ayz, azx):
    """Largest eigenvalue of the symmetric tensor with components xx, yy, zz, xy, yz, zx."""
    m = (axx + ayy + azz) / 3.0
    bxx, byy, bzz = axx - m, ayy - m, azz - m
    off = axy * axy + ayz * ayz + azx * azx
    p2 = (bxx * bxx + byy * byy + bzz * bzz + 2.0 * off) / 6.0
    if p2 <= 1e-30 * (m * m + 1e-300):
        return m
    p = math.sqrt(p2)
    det = (bxx * (byy * bzz - ayz * ayz) - axy * (axy * bzz - ayz * azx)
           + azx * (axy * ayz - byy * azx))
    r = det / (2.0 * p2 * p)
    if r > 1.0:
        r = 1.0
    elif r < -1.0:
        r = -1.0
    return m + 2.0 * p * math.cos(math.acos(r) / 3.0)


@numba.njit(cache=True, inline="always")
def max_principal_stretch(x, x0, i0, i1, i2, i3):
    """Largest principal stretch sqrt(max eig(F^T F)) of a linear tet, F = dx/dX from its
    reference (x0) and current (x) corners."""
    # reference edge matrix Dm and current Ds (columns: corner k - corner 0)
    m00, m10, m20 = x0[i1, 0] - x0[i0, 0], x0[i1, 1] - x0[i0, 1], x0[i1, 2] - x0[i0, 2]
    m01, m11, m21 = x0[i2, 0] - x0[i0, 0], x0[i2, 1] - x0[i0, 1], x0[i2, 2] - x0[i0, 2]
    m02, m12, m22 = x0[i3, 0] - x0[i0, 0], x0[i3, 1] - x0[i0, 1], x0[i3, 2] - x0[i0, 2]
    s00, s10, s20 = x[i1, 0] - x[i0, 0], x[i1, 1] - x[i0, 1], x[i1, 2] - x[i0, 2]
    s01, s11, s21 = x[i2, 0] - x[i0, 0], x[i2, 1] - x[i0, 1], x[i2, 2] - x[i0, 2]
    s02, s12, s22 = x[i3, 0] - x[i0, 0], x[i3, 1] - x[i0, 1], x[i3, 2] - x[i0, 2]
    return stretch_of(m00, m01, m02, m10, m11, m12, m20, m21, m22,
                      s00, s01, s02, s10, s11, s12, s20, s21, s22)


@numba.njit(cache=True, inline="always")
def stretch_of(m00, m01, m02, m10, m11, m12, m20, m21, m22,
               s00, s01, s02, s10, s11, s12, s20, s21, s22):
    """Largest principal stretch sqrt(max eig(F^T F)) of F = S M^{-1}, with M (m_rc) a frame of
    three material vectors at the reference state and S (s_rc) the same vectors now (a tet's
    edges; a hex's centre Jacobian, impactsim.fracture.hexes); 1 when M is singular."""
    det = (m00 * (m11 * m22 - m12 * m21) - m01 * (m10 * m22 - m12 * m20)
           + m02 * (m10 * m21 - m11 * m20))
    if det == 0.0:
        return 1.0
    inv = 1.0 / det
    # Dm^{-1}
    n00 = (m11 * m22 - m12 * m21) * inv
    n01 = (m02 * m21 - m01 * m22) * inv
    n02 = (m01 * m12 - m02 * m11) * inv
    n10 = (m12 * m20 - m10 * m22) * inv
    n11 = (m00 * m22 - m02 * m20) * inv
    n12 = (m02 * m10 - m00 * m12) * inv
    n20 = (m10 * m21 - m11 * m20) * inv
    n21 = (m01 * m20 - m00 * m21) * inv
    n22 = (m00 * m11 - m01 * m10) * inv
    # F = Ds Dm^{-1}
    f00 = s00 * n00 + s01 * n10 + s02 * n20
    f01 = s00 * n01 + s01 * n11 + s02 * n21
    f02 = s00 * n02 + s01 * n12 + s02 * n22
    f10 = s10 * n00 + s11 * n10 + s12 * n20
    f11 = s10 * n01 + s11 * n11 + s12 * n21
    f12 = s10 * n02 + s11 * n12 + s12 * n22
    f20 = s20 * n00 + s21 * n10 + s22 * n20
    f21 = s20 * n01 + s21 * n11 + s22 * n21
    f22 = s20 * n02 + s21 * n12 + s22 * n22
    # C = F^T F
    cxx = f00 * f00 + f10 * f10 + f20 * f20
    cyy = f01 * f01 + f11 * f11 + f21 * f21
    czz = f02 * f02 + f12 * f12 + f22 * f22
    cxy = f00 * f01 + f10 * f11 + f20 * f21
    cyz = f01 * f02 + f11 * f12 + f21 * f22
    czx = f02 * f00 + f12 * f10 + f22 * f20
    lam = max_principal(cxx, cyy, czz, cxy, cyz, czx)
    return math.sqrt(lam) if lam > 0.0 else 0.0
