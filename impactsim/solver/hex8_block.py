"""The vector path of the hex kernel (solver/hex8.py): a full block of B intact hexes of one
material, as loops over the B lanes that LLVM turns into SIMD instructions, like the tets'
vector path (element.py). WRITTEN BY scripts/gen_hex8_block.py: the loops over corners and
hourglass modes are written out there, since a loop inside the lane loop would stop its
vectorisation. The formulas are those of `hex8._hex_element` (tested equal to round-off).

The block buffer shares its rows with element.py's where the meaning is the same (stress,
strain rate, return-map rows: the Johnson-Cook vector return `element._jc_return_block` and
`element._return_block` run on it unchanged; R_DET holds 6 V as for a tet), and adds the hex
rows HX (x^{n+1}), HV (velocity), HB (b = dV/dx at n+1), HF (corner forces), HG (stiffness
hourglass resultants), HGV, HGS (hourglass coefficients), HGW (hourglass work), HC2 (c^2).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from impactsim.materials.laws import eos_linear_part
from impactsim.solver import vecmath as VM
from impactsim.solver.element import (B, FAST, R_D, R_DET, R_DTE, R_EN, R_EN1, R_LEN, R_MASS,
                                      R_PN, R_POLD, R_QN, R_QW, R_RATE, R_S0, R_SEQ, R_SN,
                                      R_TRD, R_VOLD, ROWS)

HX = ROWS  # 24 rows: x, y, z of corners 0..7
HV = HX + 24  # 24 rows: velocity
HB = HV + 24  # 24 rows: b at n+1
HF = HB + 24  # 24 rows: forces
HG = HF + 24  # 12 rows: stiffness hourglass resultants (in, updated)
HGV = HG + 12
HGS = HGV + 1
HGW = HGS + 1
HC2 = HGW + 1
HROWS = HC2 + 1


@numba.njit(cache=True, inline="always", error_model="numpy", fastmath=FAST)
def _vol_der(x0, x1, x2, x3, x4, x5, y0, y1, y2, y3, y4, y5, z0, z1, z2, z3, z4, z5):
    """One node's dV/dx, dV/dy, dV/dz from the six other nodes that enter it (Flanagan &
    Belytschko 1981's closed form of dV/dx, in the grouping of LULESH's `VoluDer`)."""
    dx = ((y1 + y2) * (z0 + z1) - (y0 + y1) * (z1 + z2) + (y0 + y4) * (z3 + z4)
          - (y3 + y4) * (z0 + z4) - (y2 + y5) * (z3 + z5) + (y3 + y5) * (z2 + z5))
    dy = (-(x1 + x2) * (z0 + z1) + (x0 + x1) * (z1 + z2) - (x0 + x4) * (z3 + z4)
          + (x3 + x4) * (z0 + z4) + (x2 + x5) * (z3 + z5) - (x3 + x5) * (z2 + z5))
    dz = (-(y1 + y2) * (x0 + x1) + (y0 + y1) * (x1 + x2) - (y0 + y4) * (x3 + x4)
          + (y3 + y4) * (x0 + x4) + (y2 + y5) * (x3 + x5) - (y3 + y5) * (x2 + x5))
    t = 1.0 / 12.0
    return dx * t, dy * t, dz * t


@numba.njit(cache=True, error_model="numpy")
def load_block(x, v, conn, sdev, pressure, energy, vol, elem_mass, hg, hg_visc, hg_stiff, e0,
               buf, stiff):
    """Copy the data of hexes e0 .. e0 + B - 1 into the block buffer (views of the block, as
    element._load_block); the stiffness resultants only when the block has the stiffness form
    (`stiff`), else those rows are zero (the viscous form, the default, then reads and writes
    192 bytes less per hex: the kernel is bound by memory traffic more than by arithmetic)."""
    cn = conn[e0:e0 + B]
    for i in range(B):
        for k in range(8):
            n = np.uint64(cn[i, k])
            for d in range(3):
                buf[(HX + 3 * k + d) * B + i] = x[n, d]
                buf[(HV + 3 * k + d) * B + i] = v[n, d]
    sd = sdev[e0:e0 + B]
    hgb = hg[e0:e0 + B]
    for i in range(B):
        for c in range(6):
            buf[(R_S0 + c) * B + i] = sd[i, c]
    if stiff:
        for i in range(B):
            for c in range(12):
                buf[(HG + c) * B + i] = hgb[i, c]
    else:
        for k in range(12 * B):
            buf[HG * B + k] = 0.0
    vo = vol[e0:e0 + B]
    ms = elem_mass[e0:e0 + B]
    en = energy[e0:e0 + B]
    pr = pressure[e0:e0 + B]
    hv = hg_visc[e0:e0 + B]
    hs = hg_stiff[e0:e0 + B]
    for i in range(B):
        buf[R_VOLD * B + i] = vo[i]
        buf[R_MASS * B + i] = ms[i]
        buf[R_EN * B + i] = en[i]
        buf[R_POLD * B + i] = pr[i]
        buf[HGV * B + i] = hv[i]
        buf[HGS * B + i] = hs[i]


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def kinematics_block(buf, half, dt, shear):
    """Velocity gradient on the mid-step geometry, b, volume and length at n+1, trial
    deviator (Jaumann), its von Mises equivalent and the effective strain rate."""
    for i in range(B):
        x0 = buf[(HX + 0) * B + i]
        ux0 = buf[(HV + 0) * B + i]
        y0 = buf[(HX + 1) * B + i]
        uy0 = buf[(HV + 1) * B + i]
        z0 = buf[(HX + 2) * B + i]
        uz0 = buf[(HV + 2) * B + i]
        x1 = buf[(HX + 3) * B + i]
        ux1 = buf[(HV + 3) * B + i]
        y1 = buf[(HX + 4) * B + i]
        uy1 = buf[(HV + 4) * B + i]
        z1 = buf[(HX + 5) * B + i]
        uz1 = buf[(HV + 5) * B + i]
        x2 = buf[(HX + 6) * B + i]
        ux2 = buf[(HV + 6) * B + i]
        y2 = buf[(HX + 7) * B + i]
        uy2 = buf[(HV + 7) * B + i]
        z2 = buf[(HX + 8) * B + i]
        uz2 = buf[(HV + 8) * B + i]
        x3 = buf[(HX + 9) * B + i]
        ux3 = buf[(HV + 9) * B + i]
        y3 = buf[(HX + 10) * B + i]
        uy3 = buf[(HV + 10) * B + i]
        z3 = buf[(HX + 11) * B + i]
        uz3 = buf[(HV + 11) * B + i]
        x4 = buf[(HX + 12) * B + i]
        ux4 = buf[(HV + 12) * B + i]
        y4 = buf[(HX + 13) * B + i]
        uy4 = buf[(HV + 13) * B + i]
        z4 = buf[(HX + 14) * B + i]
        uz4 = buf[(HV + 14) * B + i]
        x5 = buf[(HX + 15) * B + i]
        ux5 = buf[(HV + 15) * B + i]
        y5 = buf[(HX + 16) * B + i]
        uy5 = buf[(HV + 16) * B + i]
        z5 = buf[(HX + 17) * B + i]
        uz5 = buf[(HV + 17) * B + i]
        x6 = buf[(HX + 18) * B + i]
        ux6 = buf[(HV + 18) * B + i]
        y6 = buf[(HX + 19) * B + i]
        uy6 = buf[(HV + 19) * B + i]
        z6 = buf[(HX + 20) * B + i]
        uz6 = buf[(HV + 20) * B + i]
        x7 = buf[(HX + 21) * B + i]
        ux7 = buf[(HV + 21) * B + i]
        y7 = buf[(HX + 22) * B + i]
        uy7 = buf[(HV + 22) * B + i]
        z7 = buf[(HX + 23) * B + i]
        uz7 = buf[(HV + 23) * B + i]
        mx0 = x0 - half * ux0
        my0 = y0 - half * uy0
        mz0 = z0 - half * uz0
        mx1 = x1 - half * ux1
        my1 = y1 - half * uy1
        mz1 = z1 - half * uz1
        mx2 = x2 - half * ux2
        my2 = y2 - half * uy2
        mz2 = z2 - half * uz2
        mx3 = x3 - half * ux3
        my3 = y3 - half * uy3
        mz3 = z3 - half * uz3
        mx4 = x4 - half * ux4
        my4 = y4 - half * uy4
        mz4 = z4 - half * uz4
        mx5 = x5 - half * ux5
        my5 = y5 - half * uy5
        mz5 = z5 - half * uz5
        mx6 = x6 - half * ux6
        my6 = y6 - half * uy6
        mz6 = z6 - half * uz6
        mx7 = x7 - half * ux7
        my7 = y7 - half * uy7
        mz7 = z7 - half * uz7
        bx0, by0, bz0 = _vol_der(mx1, mx2, mx3, mx4, mx5, mx7, my1, my2, my3, my4, my5, my7, mz1, mz2, mz3, mz4, mz5, mz7)
        bx1, by1, bz1 = _vol_der(mx2, mx3, mx0, mx5, mx6, mx4, my2, my3, my0, my5, my6, my4, mz2, mz3, mz0, mz5, mz6, mz4)
        bx2, by2, bz2 = _vol_der(mx3, mx0, mx1, mx6, mx7, mx5, my3, my0, my1, my6, my7, my5, mz3, mz0, mz1, mz6, mz7, mz5)
        bx3, by3, bz3 = _vol_der(mx0, mx1, mx2, mx7, mx4, mx6, my0, my1, my2, my7, my4, my6, mz0, mz1, mz2, mz7, mz4, mz6)
        bx4, by4, bz4 = _vol_der(mx7, mx6, mx5, mx0, mx3, mx1, my7, my6, my5, my0, my3, my1, mz7, mz6, mz5, mz0, mz3, mz1)
        bx5, by5, bz5 = _vol_der(mx4, mx7, mx6, mx1, mx0, mx2, my4, my7, my6, my1, my0, my2, mz4, mz7, mz6, mz1, mz0, mz2)
        bx6, by6, bz6 = _vol_der(mx5, mx4, mx7, mx2, mx1, mx3, my5, my4, my7, my2, my1, my3, mz5, mz4, mz7, mz2, mz1, mz3)
        bx7, by7, bz7 = _vol_der(mx6, mx5, mx4, mx3, mx2, mx0, my6, my5, my4, my3, my2, my0, mz6, mz5, mz4, mz3, mz2, mz0)
        vmid = mx0 * bx0 + mx1 * bx1 + mx2 * bx2 + mx3 * bx3 + mx4 * bx4 + mx5 * bx5 + mx6 * bx6 + mx7 * bx7
        inv = 1.0 / vmid
        lxx = (ux0 * bx0 + ux1 * bx1 + ux2 * bx2 + ux3 * bx3 + ux4 * bx4 + ux5 * bx5 + ux6 * bx6 + ux7 * bx7) * inv
        lxy = (ux0 * by0 + ux1 * by1 + ux2 * by2 + ux3 * by3 + ux4 * by4 + ux5 * by5 + ux6 * by6 + ux7 * by7) * inv
        lxz = (ux0 * bz0 + ux1 * bz1 + ux2 * bz2 + ux3 * bz3 + ux4 * bz4 + ux5 * bz5 + ux6 * bz6 + ux7 * bz7) * inv
        lyx = (uy0 * bx0 + uy1 * bx1 + uy2 * bx2 + uy3 * bx3 + uy4 * bx4 + uy5 * bx5 + uy6 * bx6 + uy7 * bx7) * inv
        lyy = (uy0 * by0 + uy1 * by1 + uy2 * by2 + uy3 * by3 + uy4 * by4 + uy5 * by5 + uy6 * by6 + uy7 * by7) * inv
        lyz = (uy0 * bz0 + uy1 * bz1 + uy2 * bz2 + uy3 * bz3 + uy4 * bz4 + uy5 * bz5 + uy6 * bz6 + uy7 * bz7) * inv
        lzx = (uz0 * bx0 + uz1 * bx1 + uz2 * bx2 + uz3 * bx3 + uz4 * bx4 + uz5 * bx5 + uz6 * bx6 + uz7 * bx7) * inv
        lzy = (uz0 * by0 + uz1 * by1 + uz2 * by2 + uz3 * by3 + uz4 * by4 + uz5 * by5 + uz6 * by6 + uz7 * by7) * inv
        lzz = (uz0 * bz0 + uz1 * bz1 + uz2 * bz2 + uz3 * bz3 + uz4 * bz4 + uz5 * bz5 + uz6 * bz6 + uz7 * bz7) * inv
        trd = lxx + lyy + lzz
        third = trd * (1.0 / 3.0)
        exx, eyy, ezz = lxx - third, lyy - third, lzz - third
        dxy, dyz, dzx = 0.5 * (lxy + lyx), 0.5 * (lyz + lzy), 0.5 * (lzx + lxz)
        wxy, wyz, wzx = 0.5 * (lxy - lyx), 0.5 * (lyz - lzy), 0.5 * (lzx - lxz)
        cx0, cy0, cz0 = _vol_der(x1, x2, x3, x4, x5, x7, y1, y2, y3, y4, y5, y7, z1, z2, z3, z4, z5, z7)
        cx1, cy1, cz1 = _vol_der(x2, x3, x0, x5, x6, x4, y2, y3, y0, y5, y6, y4, z2, z3, z0, z5, z6, z4)
        cx2, cy2, cz2 = _vol_der(x3, x0, x1, x6, x7, x5, y3, y0, y1, y6, y7, y5, z3, z0, z1, z6, z7, z5)
        cx3, cy3, cz3 = _vol_der(x0, x1, x2, x7, x4, x6, y0, y1, y2, y7, y4, y6, z0, z1, z2, z7, z4, z6)
        cx4, cy4, cz4 = _vol_der(x7, x6, x5, x0, x3, x1, y7, y6, y5, y0, y3, y1, z7, z6, z5, z0, z3, z1)
        cx5, cy5, cz5 = _vol_der(x4, x7, x6, x1, x0, x2, y4, y7, y6, y1, y0, y2, z4, z7, z6, z1, z0, z2)
        cx6, cy6, cz6 = _vol_der(x5, x4, x7, x2, x1, x3, y5, y4, y7, y2, y1, y3, z5, z4, z7, z2, z1, z3)
        cx7, cy7, cz7 = _vol_der(x6, x5, x4, x3, x2, x0, y6, y5, y4, y3, y2, y0, z6, z5, z4, z3, z2, z0)
        vnew = x0 * cx0 + x1 * cx1 + x2 * cx2 + x3 * cx3 + x4 * cx4 + x5 * cx5 + x6 * cx6 + x7 * cx7
        buf[(HB + 0) * B + i] = cx0
        buf[(HB + 1) * B + i] = cy0
        buf[(HB + 2) * B + i] = cz0
        buf[(HB + 3) * B + i] = cx1
        buf[(HB + 4) * B + i] = cy1
        buf[(HB + 5) * B + i] = cz1
        buf[(HB + 6) * B + i] = cx2
        buf[(HB + 7) * B + i] = cy2
        buf[(HB + 8) * B + i] = cz2
        buf[(HB + 9) * B + i] = cx3
        buf[(HB + 10) * B + i] = cy3
        buf[(HB + 11) * B + i] = cz3
        buf[(HB + 12) * B + i] = cx4
        buf[(HB + 13) * B + i] = cy4
        buf[(HB + 14) * B + i] = cz4
        buf[(HB + 15) * B + i] = cx5
        buf[(HB + 16) * B + i] = cy5
        buf[(HB + 17) * B + i] = cz5
        buf[(HB + 18) * B + i] = cx6
        buf[(HB + 19) * B + i] = cy6
        buf[(HB + 20) * B + i] = cz6
        buf[(HB + 21) * B + i] = cx7
        buf[(HB + 22) * B + i] = cy7
        buf[(HB + 23) * B + i] = cz7
        buf[(R_DET + 0) * B + i] = 6.0 * vnew
        amax = 0.0
        ux, uy, uz = x2 - x0, y2 - y0, z2 - z0
        vx, vy, vz = x1 - x3, y1 - y3, z1 - z3
        qx, qy, qz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        amax = max(amax, 0.25 * (qx * qx + qy * qy + qz * qz))
        ux, uy, uz = x6 - x4, y6 - y4, z6 - z4
        vx, vy, vz = x7 - x5, y7 - y5, z7 - z5
        qx, qy, qz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        amax = max(amax, 0.25 * (qx * qx + qy * qy + qz * qz))
        ux, uy, uz = x5 - x0, y5 - y0, z5 - z0
        vx, vy, vz = x4 - x1, y4 - y1, z4 - z1
        qx, qy, qz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        amax = max(amax, 0.25 * (qx * qx + qy * qy + qz * qz))
        ux, uy, uz = x6 - x1, y6 - y1, z6 - z1
        vx, vy, vz = x5 - x2, y5 - y2, z5 - z2
        qx, qy, qz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        amax = max(amax, 0.25 * (qx * qx + qy * qy + qz * qz))
        ux, uy, uz = x7 - x2, y7 - y2, z7 - z2
        vx, vy, vz = x6 - x3, y6 - y3, z6 - z3
        qx, qy, qz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        amax = max(amax, 0.25 * (qx * qx + qy * qy + qz * qz))
        ux, uy, uz = x4 - x3, y4 - y3, z4 - z3
        vx, vy, vz = x7 - x0, y7 - y0, z7 - z0
        qx, qy, qz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        amax = max(amax, 0.25 * (qx * qx + qy * qy + qz * qz))
        buf[(R_LEN + 0) * B + i] = vnew / math.sqrt(max(amax, 1e-300))
        buf[(R_D + 0) * B + i] = exx
        buf[(R_D + 1) * B + i] = eyy
        buf[(R_D + 2) * B + i] = ezz
        buf[(R_D + 3) * B + i] = dxy
        buf[(R_D + 4) * B + i] = dyz
        buf[(R_D + 5) * B + i] = dzx
        buf[(R_TRD + 0) * B + i] = trd
        sxx, syy, szz = buf[(R_S0 + 0) * B + i], buf[(R_S0 + 1) * B + i], buf[(R_S0 + 2) * B + i]
        sxy, syz, szx = buf[(R_S0 + 3) * B + i], buf[(R_S0 + 4) * B + i], buf[(R_S0 + 5) * B + i]
        g2 = 2.0 * shear
        rxx = 2.0 * (wxy * sxy - wzx * szx)
        ryy = 2.0 * (wyz * syz - wxy * sxy)
        rzz = 2.0 * (wzx * szx - wyz * syz)
        rxy = wxy * (syy - sxx) + wzx * syz - wyz * szx
        ryz = wyz * (szz - syy) + wxy * szx - wzx * sxy
        rzx = wzx * (sxx - szz) + wyz * sxy - wxy * syz
        nxx = sxx + dt * (g2 * exx + rxx)
        nyy = syy + dt * (g2 * eyy + ryy)
        nzz = szz + dt * (g2 * ezz + rzz)
        nxy = sxy + dt * (g2 * dxy + rxy)
        nyz = syz + dt * (g2 * dyz + ryz)
        nzx = szx + dt * (g2 * dzx + rzx)
        buf[(R_SN + 0) * B + i] = nxx
        buf[(R_SN + 1) * B + i] = nyy
        buf[(R_SN + 2) * B + i] = nzz
        buf[(R_SN + 3) * B + i] = nxy
        buf[(R_SN + 4) * B + i] = nyz
        buf[(R_SN + 5) * B + i] = nzx
        buf[(R_RATE + 0) * B + i] = math.sqrt(max((2.0 / 3.0) * (exx * exx + eyy * eyy + ezz * ezz + 2.0 * (dxy * dxy + dyz * dyz + dzx * dzx)), 0.0))
        j2 = 0.5 * (nxx * nxx + nyy * nyy + nzz * nzz) + nxy * nxy + nyz * nyz + nzx * nzx
        buf[(R_SEQ + 0) * B + i] = math.sqrt(max(3.0 * j2, 0.0))


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def pressure_block(buf, dt, eos, rho0, bulk, c0, s, gamma0, shear, cq, cl):
    """Deviatoric work, EOS pressure with the energy implicit, bulk viscosity, stable dt and the
    stress forces f_I = -sigma b_I (as element._pressure_block, with the hex's volume)."""
    for i in range(B):
        vnew = buf[R_DET * B + i] * (1.0 / 6.0)
        vold = buf[R_VOLD * B + i]
        mass = buf[R_MASS * B + i]
        rho = mass / vnew
        exx = buf[(R_D + 0) * B + i]
        eyy = buf[(R_D + 1) * B + i]
        ezz = buf[(R_D + 2) * B + i]
        dxy = buf[(R_D + 3) * B + i]
        dyz = buf[(R_D + 4) * B + i]
        dzx = buf[(R_D + 5) * B + i]
        nxx = buf[(R_SN + 0) * B + i]
        nyy = buf[(R_SN + 1) * B + i]
        nzz = buf[(R_SN + 2) * B + i]
        nxy = buf[(R_SN + 3) * B + i]
        nyz = buf[(R_SN + 4) * B + i]
        nzx = buf[(R_SN + 5) * B + i]
        wdev = 0.25 * dt * (vold + vnew) * (
            (buf[(R_S0 + 0) * B + i] + nxx) * exx + (buf[(R_S0 + 1) * B + i] + nyy) * eyy
            + (buf[(R_S0 + 2) * B + i] + nzz) * ezz
            + 2.0 * ((buf[(R_S0 + 3) * B + i] + nxy) * dxy + (buf[(R_S0 + 4) * B + i] + nyz) * dyz
                     + (buf[(R_S0 + 5) * B + i] + nzx) * dzx))
        length = buf[R_LEN * B + i]
        trd = buf[R_TRD * B + i]
        pa, pb, c2a, c2b = eos_linear_part(eos, rho, rho0, bulk, c0, s, gamma0)
        pold = buf[R_POLD * B + i]
        dv = vnew - vold
        c = math.sqrt(max(c2a + c2b * max(pold, 0.0), 0.0))
        qn = rho * length * (cq * cq * length * trd * trd - cl * c * trd) if trd < 0.0 else 0.0
        base = buf[R_EN * B + i] + (wdev - dv * (0.5 * pold + qn)) / mass
        kk = 0.5 * dv / mass
        enew = (base - kk * pa) / (1.0 + kk * pb)
        pn = pa + pb * enew
        buf[R_EN1 * B + i] = enew
        buf[R_PN * B + i] = pn
        buf[R_QN * B + i] = qn
        buf[R_QW * B + i] = -qn * dv
        c2 = max(c2a + c2b * max(pn, 0.0), 0.0) + 4.0 * shear / (3.0 * rho)
        buf[HC2 * B + i] = c2
        qq = cl * math.sqrt(c2) - cq * cq * length * trd if trd < 0.0 else 0.0
        buf[R_DTE * B + i] = length / (qq + math.sqrt(max(qq * qq + c2, 0.0)))
        ptot = pn + qn
        txx, tyy, tzz = nxx - ptot, nyy - ptot, nzz - ptot
        bx, by, bz = buf[(HB + 0) * B + i], buf[(HB + 1) * B + i], buf[(HB + 2) * B + i]
        buf[(HF + 0) * B + i] = -(txx * bx + nxy * by + nzx * bz)
        buf[(HF + 1) * B + i] = -(nxy * bx + tyy * by + nyz * bz)
        buf[(HF + 2) * B + i] = -(nzx * bx + nyz * by + tzz * bz)
        bx, by, bz = buf[(HB + 3) * B + i], buf[(HB + 4) * B + i], buf[(HB + 5) * B + i]
        buf[(HF + 3) * B + i] = -(txx * bx + nxy * by + nzx * bz)
        buf[(HF + 4) * B + i] = -(nxy * bx + tyy * by + nyz * bz)
        buf[(HF + 5) * B + i] = -(nzx * bx + nyz * by + tzz * bz)
        bx, by, bz = buf[(HB + 6) * B + i], buf[(HB + 7) * B + i], buf[(HB + 8) * B + i]
        buf[(HF + 6) * B + i] = -(txx * bx + nxy * by + nzx * bz)
        buf[(HF + 7) * B + i] = -(nxy * bx + tyy * by + nyz * bz)
        buf[(HF + 8) * B + i] = -(nzx * bx + nyz * by + tzz * bz)
        bx, by, bz = buf[(HB + 9) * B + i], buf[(HB + 10) * B + i], buf[(HB + 11) * B + i]
        buf[(HF + 9) * B + i] = -(txx * bx + nxy * by + nzx * bz)
        buf[(HF + 10) * B + i] = -(nxy * bx + tyy * by + nyz * bz)
        buf[(HF + 11) * B + i] = -(nzx * bx + nyz * by + tzz * bz)
        bx, by, bz = buf[(HB + 12) * B + i], buf[(HB + 13) * B + i], buf[(HB + 14) * B + i]
        buf[(HF + 12) * B + i] = -(txx * bx + nxy * by + nzx * bz)
        buf[(HF + 13) * B + i] = -(nxy * bx + tyy * by + nyz * bz)
        buf[(HF + 14) * B + i] = -(nzx * bx + nyz * by + tzz * bz)
        bx, by, bz = buf[(HB + 15) * B + i], buf[(HB + 16) * B + i], buf[(HB + 17) * B + i]
        buf[(HF + 15) * B + i] = -(txx * bx + nxy * by + nzx * bz)
        buf[(HF + 16) * B + i] = -(nxy * bx + tyy * by + nyz * bz)
        buf[(HF + 17) * B + i] = -(nzx * bx + nyz * by + tzz * bz)
        bx, by, bz = buf[(HB + 18) * B + i], buf[(HB + 19) * B + i], buf[(HB + 20) * B + i]
        buf[(HF + 18) * B + i] = -(txx * bx + nxy * by + nzx * bz)
        buf[(HF + 19) * B + i] = -(nxy * bx + tyy * by + nyz * bz)
        buf[(HF + 20) * B + i] = -(nzx * bx + nyz * by + tzz * bz)
        bx, by, bz = buf[(HB + 21) * B + i], buf[(HB + 22) * B + i], buf[(HB + 23) * B + i]
        buf[(HF + 21) * B + i] = -(txx * bx + nxy * by + nzx * bz)
        buf[(HF + 22) * B + i] = -(nxy * bx + tyy * by + nyz * bz)
        buf[(HF + 23) * B + i] = -(nzx * bx + nyz * by + tzz * bz)


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def hourglass_block(buf, dt, bulk, shear):
    """Flanagan-Belytschko hourglass forces of the block (hex8._hex_element): gamma vectors,
    rates, viscous and stiffness resultants, their work; added to the HF rows."""
    for i in range(B):
        cv = buf[HGV * B + i]
        cs = buf[HGS * B + i]
        vnew = buf[R_DET * B + i] * (1.0 / 6.0)
        vinv = 1.0 / vnew
        rho = buf[R_MASS * B + i] * vinv
        x0 = buf[(HX + 0) * B + i]
        bx0 = buf[(HB + 0) * B + i]
        ux0 = buf[(HV + 0) * B + i]
        y0 = buf[(HX + 1) * B + i]
        by0 = buf[(HB + 1) * B + i]
        uy0 = buf[(HV + 1) * B + i]
        z0 = buf[(HX + 2) * B + i]
        bz0 = buf[(HB + 2) * B + i]
        uz0 = buf[(HV + 2) * B + i]
        x1 = buf[(HX + 3) * B + i]
        bx1 = buf[(HB + 3) * B + i]
        ux1 = buf[(HV + 3) * B + i]
        y1 = buf[(HX + 4) * B + i]
        by1 = buf[(HB + 4) * B + i]
        uy1 = buf[(HV + 4) * B + i]
        z1 = buf[(HX + 5) * B + i]
        bz1 = buf[(HB + 5) * B + i]
        uz1 = buf[(HV + 5) * B + i]
        x2 = buf[(HX + 6) * B + i]
        bx2 = buf[(HB + 6) * B + i]
        ux2 = buf[(HV + 6) * B + i]
        y2 = buf[(HX + 7) * B + i]
        by2 = buf[(HB + 7) * B + i]
        uy2 = buf[(HV + 7) * B + i]
        z2 = buf[(HX + 8) * B + i]
        bz2 = buf[(HB + 8) * B + i]
        uz2 = buf[(HV + 8) * B + i]
        x3 = buf[(HX + 9) * B + i]
        bx3 = buf[(HB + 9) * B + i]
        ux3 = buf[(HV + 9) * B + i]
        y3 = buf[(HX + 10) * B + i]
        by3 = buf[(HB + 10) * B + i]
        uy3 = buf[(HV + 10) * B + i]
        z3 = buf[(HX + 11) * B + i]
        bz3 = buf[(HB + 11) * B + i]
        uz3 = buf[(HV + 11) * B + i]
        x4 = buf[(HX + 12) * B + i]
        bx4 = buf[(HB + 12) * B + i]
        ux4 = buf[(HV + 12) * B + i]
        y4 = buf[(HX + 13) * B + i]
        by4 = buf[(HB + 13) * B + i]
        uy4 = buf[(HV + 13) * B + i]
        z4 = buf[(HX + 14) * B + i]
        bz4 = buf[(HB + 14) * B + i]
        uz4 = buf[(HV + 14) * B + i]
        x5 = buf[(HX + 15) * B + i]
        bx5 = buf[(HB + 15) * B + i]
        ux5 = buf[(HV + 15) * B + i]
        y5 = buf[(HX + 16) * B + i]
        by5 = buf[(HB + 16) * B + i]
        uy5 = buf[(HV + 16) * B + i]
        z5 = buf[(HX + 17) * B + i]
        bz5 = buf[(HB + 17) * B + i]
        uz5 = buf[(HV + 17) * B + i]
        x6 = buf[(HX + 18) * B + i]
        bx6 = buf[(HB + 18) * B + i]
        ux6 = buf[(HV + 18) * B + i]
        y6 = buf[(HX + 19) * B + i]
        by6 = buf[(HB + 19) * B + i]
        uy6 = buf[(HV + 19) * B + i]
        z6 = buf[(HX + 20) * B + i]
        bz6 = buf[(HB + 20) * B + i]
        uz6 = buf[(HV + 20) * B + i]
        x7 = buf[(HX + 21) * B + i]
        bx7 = buf[(HB + 21) * B + i]
        ux7 = buf[(HV + 21) * B + i]
        y7 = buf[(HX + 22) * B + i]
        by7 = buf[(HB + 22) * B + i]
        uy7 = buf[(HV + 22) * B + i]
        z7 = buf[(HX + 23) * B + i]
        bz7 = buf[(HB + 23) * B + i]
        uz7 = buf[(HV + 23) * B + i]
        bb = bx0 * bx0 + by0 * by0 + bz0 * bz0 + bx1 * bx1 + by1 * by1 + bz1 * bz1 + bx2 * bx2 + by2 * by2 + bz2 * bz2 + bx3 * bx3 + by3 * by3 + bz3 * bz3 + bx4 * bx4 + by4 * by4 + bz4 * bz4 + bx5 * bx5 + by5 * by5 + bz5 * bz5 + bx6 * bx6 + by6 * by6 + bz6 * bz6 + bx7 * bx7 + by7 * by7 + bz7 * bz7
        chg = math.sqrt(max(buf[HC2 * B + i], 0.0))
        kv = cv * rho * chg * VM.power(vnew, 2.0 / 3.0)
        ks = cs * dt * (bulk + 4.0 * shear / 3.0) * bb * vinv * (1.0 / 3.0)
        work = 0.0
        fx0 = 0.0
        fy0 = 0.0
        fz0 = 0.0
        fx1 = 0.0
        fy1 = 0.0
        fz1 = 0.0
        fx2 = 0.0
        fy2 = 0.0
        fz2 = 0.0
        fx3 = 0.0
        fy3 = 0.0
        fz3 = 0.0
        fx4 = 0.0
        fy4 = 0.0
        fz4 = 0.0
        fx5 = 0.0
        fy5 = 0.0
        fz5 = 0.0
        fx6 = 0.0
        fy6 = 0.0
        fz6 = 0.0
        fx7 = 0.0
        fy7 = 0.0
        fz7 = 0.0
        hx = (x0 + x1 - x2 - x3 - x4 - x5 + x6 + x7) * vinv
        hy = (y0 + y1 - y2 - y3 - y4 - y5 + y6 + y7) * vinv
        hz = (z0 + z1 - z2 - z3 - z4 - z5 + z6 + z7) * vinv
        g0 = 0.125 * (1.0 - (hx * bx0 + hy * by0 + hz * bz0))
        g1 = 0.125 * (1.0 - (hx * bx1 + hy * by1 + hz * bz1))
        g2 = 0.125 * (-1.0 - (hx * bx2 + hy * by2 + hz * bz2))
        g3 = 0.125 * (-1.0 - (hx * bx3 + hy * by3 + hz * bz3))
        g4 = 0.125 * (-1.0 - (hx * bx4 + hy * by4 + hz * bz4))
        g5 = 0.125 * (-1.0 - (hx * bx5 + hy * by5 + hz * bz5))
        g6 = 0.125 * (1.0 - (hx * bx6 + hy * by6 + hz * bz6))
        g7 = 0.125 * (1.0 - (hx * bx7 + hy * by7 + hz * bz7))
        rx = ux0 * g0 + ux1 * g1 + ux2 * g2 + ux3 * g3 + ux4 * g4 + ux5 * g5 + ux6 * g6 + ux7 * g7
        ry = uy0 * g0 + uy1 * g1 + uy2 * g2 + uy3 * g3 + uy4 * g4 + uy5 * g5 + uy6 * g6 + uy7 * g7
        rz = uz0 * g0 + uz1 * g1 + uz2 * g2 + uz3 * g3 + uz4 * g4 + uz5 * g5 + uz6 * g6 + uz7 * g7
        s0x = buf[(HG + 0) * B + i]
        s1x = s0x + ks * rx
        buf[(HG + 0) * B + i] = s1x
        qx = s1x + kv * rx
        work += dt * (0.5 * (s0x + s1x) + kv * rx) * rx
        s0y = buf[(HG + 1) * B + i]
        s1y = s0y + ks * ry
        buf[(HG + 1) * B + i] = s1y
        qy = s1y + kv * ry
        work += dt * (0.5 * (s0y + s1y) + kv * ry) * ry
        s0z = buf[(HG + 2) * B + i]
        s1z = s0z + ks * rz
        buf[(HG + 2) * B + i] = s1z
        qz = s1z + kv * rz
        work += dt * (0.5 * (s0z + s1z) + kv * rz) * rz
        fx0 -= qx * g0
        fy0 -= qy * g0
        fz0 -= qz * g0
        fx1 -= qx * g1
        fy1 -= qy * g1
        fz1 -= qz * g1
        fx2 -= qx * g2
        fy2 -= qy * g2
        fz2 -= qz * g2
        fx3 -= qx * g3
        fy3 -= qy * g3
        fz3 -= qz * g3
        fx4 -= qx * g4
        fy4 -= qy * g4
        fz4 -= qz * g4
        fx5 -= qx * g5
        fy5 -= qy * g5
        fz5 -= qz * g5
        fx6 -= qx * g6
        fy6 -= qy * g6
        fz6 -= qz * g6
        fx7 -= qx * g7
        fy7 -= qy * g7
        fz7 -= qz * g7
        hx = (x0 - x1 - x2 + x3 - x4 + x5 + x6 - x7) * vinv
        hy = (y0 - y1 - y2 + y3 - y4 + y5 + y6 - y7) * vinv
        hz = (z0 - z1 - z2 + z3 - z4 + z5 + z6 - z7) * vinv
        g0 = 0.125 * (1.0 - (hx * bx0 + hy * by0 + hz * bz0))
        g1 = 0.125 * (-1.0 - (hx * bx1 + hy * by1 + hz * bz1))
        g2 = 0.125 * (-1.0 - (hx * bx2 + hy * by2 + hz * bz2))
        g3 = 0.125 * (1.0 - (hx * bx3 + hy * by3 + hz * bz3))
        g4 = 0.125 * (-1.0 - (hx * bx4 + hy * by4 + hz * bz4))
        g5 = 0.125 * (1.0 - (hx * bx5 + hy * by5 + hz * bz5))
        g6 = 0.125 * (1.0 - (hx * bx6 + hy * by6 + hz * bz6))
        g7 = 0.125 * (-1.0 - (hx * bx7 + hy * by7 + hz * bz7))
        rx = ux0 * g0 + ux1 * g1 + ux2 * g2 + ux3 * g3 + ux4 * g4 + ux5 * g5 + ux6 * g6 + ux7 * g7
        ry = uy0 * g0 + uy1 * g1 + uy2 * g2 + uy3 * g3 + uy4 * g4 + uy5 * g5 + uy6 * g6 + uy7 * g7
        rz = uz0 * g0 + uz1 * g1 + uz2 * g2 + uz3 * g3 + uz4 * g4 + uz5 * g5 + uz6 * g6 + uz7 * g7
        s0x = buf[(HG + 3) * B + i]
        s1x = s0x + ks * rx
        buf[(HG + 3) * B + i] = s1x
        qx = s1x + kv * rx
        work += dt * (0.5 * (s0x + s1x) + kv * rx) * rx
        s0y = buf[(HG + 4) * B + i]
        s1y = s0y + ks * ry
        buf[(HG + 4) * B + i] = s1y
        qy = s1y + kv * ry
        work += dt * (0.5 * (s0y + s1y) + kv * ry) * ry
        s0z = buf[(HG + 5) * B + i]
        s1z = s0z + ks * rz
        buf[(HG + 5) * B + i] = s1z
        qz = s1z + kv * rz
        work += dt * (0.5 * (s0z + s1z) + kv * rz) * rz
        fx0 -= qx * g0
        fy0 -= qy * g0
        fz0 -= qz * g0
        fx1 -= qx * g1
        fy1 -= qy * g1
        fz1 -= qz * g1
        fx2 -= qx * g2
        fy2 -= qy * g2
        fz2 -= qz * g2
        fx3 -= qx * g3
        fy3 -= qy * g3
        fz3 -= qz * g3
        fx4 -= qx * g4
        fy4 -= qy * g4
        fz4 -= qz * g4
        fx5 -= qx * g5
        fy5 -= qy * g5
        fz5 -= qz * g5
        fx6 -= qx * g6
        fy6 -= qy * g6
        fz6 -= qz * g6
        fx7 -= qx * g7
        fy7 -= qy * g7
        fz7 -= qz * g7
        hx = (x0 - x1 + x2 - x3 + x4 - x5 + x6 - x7) * vinv
        hy = (y0 - y1 + y2 - y3 + y4 - y5 + y6 - y7) * vinv
        hz = (z0 - z1 + z2 - z3 + z4 - z5 + z6 - z7) * vinv
        g0 = 0.125 * (1.0 - (hx * bx0 + hy * by0 + hz * bz0))
        g1 = 0.125 * (-1.0 - (hx * bx1 + hy * by1 + hz * bz1))
        g2 = 0.125 * (1.0 - (hx * bx2 + hy * by2 + hz * bz2))
        g3 = 0.125 * (-1.0 - (hx * bx3 + hy * by3 + hz * bz3))
        g4 = 0.125 * (1.0 - (hx * bx4 + hy * by4 + hz * bz4))
        g5 = 0.125 * (-1.0 - (hx * bx5 + hy * by5 + hz * bz5))
        g6 = 0.125 * (1.0 - (hx * bx6 + hy * by6 + hz * bz6))
        g7 = 0.125 * (-1.0 - (hx * bx7 + hy * by7 + hz * bz7))
        rx = ux0 * g0 + ux1 * g1 + ux2 * g2 + ux3 * g3 + ux4 * g4 + ux5 * g5 + ux6 * g6 + ux7 * g7
        ry = uy0 * g0 + uy1 * g1 + uy2 * g2 + uy3 * g3 + uy4 * g4 + uy5 * g5 + uy6 * g6 + uy7 * g7
        rz = uz0 * g0 + uz1 * g1 + uz2 * g2 + uz3 * g3 + uz4 * g4 + uz5 * g5 + uz6 * g6 + uz7 * g7
        s0x = buf[(HG + 6) * B + i]
        s1x = s0x + ks * rx
        buf[(HG + 6) * B + i] = s1x
        qx = s1x + kv * rx
        work += dt * (0.5 * (s0x + s1x) + kv * rx) * rx
        s0y = buf[(HG + 7) * B + i]
        s1y = s0y + ks * ry
        buf[(HG + 7) * B + i] = s1y
        qy = s1y + kv * ry
        work += dt * (0.5 * (s0y + s1y) + kv * ry) * ry
        s0z = buf[(HG + 8) * B + i]
        s1z = s0z + ks * rz
        buf[(HG + 8) * B + i] = s1z
        qz = s1z + kv * rz
        work += dt * (0.5 * (s0z + s1z) + kv * rz) * rz
        fx0 -= qx * g0
        fy0 -= qy * g0
        fz0 -= qz * g0
        fx1 -= qx * g1
        fy1 -= qy * g1
        fz1 -= qz * g1
        fx2 -= qx * g2
        fy2 -= qy * g2
        fz2 -= qz * g2
        fx3 -= qx * g3
        fy3 -= qy * g3
        fz3 -= qz * g3
        fx4 -= qx * g4
        fy4 -= qy * g4
        fz4 -= qz * g4
        fx5 -= qx * g5
        fy5 -= qy * g5
        fz5 -= qz * g5
        fx6 -= qx * g6
        fy6 -= qy * g6
        fz6 -= qz * g6
        fx7 -= qx * g7
        fy7 -= qy * g7
        fz7 -= qz * g7
        hx = (- x0 + x1 - x2 + x3 + x4 - x5 + x6 - x7) * vinv
        hy = (- y0 + y1 - y2 + y3 + y4 - y5 + y6 - y7) * vinv
        hz = (- z0 + z1 - z2 + z3 + z4 - z5 + z6 - z7) * vinv
        g0 = 0.125 * (-1.0 - (hx * bx0 + hy * by0 + hz * bz0))
        g1 = 0.125 * (1.0 - (hx * bx1 + hy * by1 + hz * bz1))
        g2 = 0.125 * (-1.0 - (hx * bx2 + hy * by2 + hz * bz2))
        g3 = 0.125 * (1.0 - (hx * bx3 + hy * by3 + hz * bz3))
        g4 = 0.125 * (1.0 - (hx * bx4 + hy * by4 + hz * bz4))
        g5 = 0.125 * (-1.0 - (hx * bx5 + hy * by5 + hz * bz5))
        g6 = 0.125 * (1.0 - (hx * bx6 + hy * by6 + hz * bz6))
        g7 = 0.125 * (-1.0 - (hx * bx7 + hy * by7 + hz * bz7))
        rx = ux0 * g0 + ux1 * g1 + ux2 * g2 + ux3 * g3 + ux4 * g4 + ux5 * g5 + ux6 * g6 + ux7 * g7
        ry = uy0 * g0 + uy1 * g1 + uy2 * g2 + uy3 * g3 + uy4 * g4 + uy5 * g5 + uy6 * g6 + uy7 * g7
        rz = uz0 * g0 + uz1 * g1 + uz2 * g2 + uz3 * g3 + uz4 * g4 + uz5 * g5 + uz6 * g6 + uz7 * g7
        s0x = buf[(HG + 9) * B + i]
        s1x = s0x + ks * rx
        buf[(HG + 9) * B + i] = s1x
        qx = s1x + kv * rx
        work += dt * (0.5 * (s0x + s1x) + kv * rx) * rx
        s0y = buf[(HG + 10) * B + i]
        s1y = s0y + ks * ry
        buf[(HG + 10) * B + i] = s1y
        qy = s1y + kv * ry
        work += dt * (0.5 * (s0y + s1y) + kv * ry) * ry
        s0z = buf[(HG + 11) * B + i]
        s1z = s0z + ks * rz
        buf[(HG + 11) * B + i] = s1z
        qz = s1z + kv * rz
        work += dt * (0.5 * (s0z + s1z) + kv * rz) * rz
        fx0 -= qx * g0
        fy0 -= qy * g0
        fz0 -= qz * g0
        fx1 -= qx * g1
        fy1 -= qy * g1
        fz1 -= qz * g1
        fx2 -= qx * g2
        fy2 -= qy * g2
        fz2 -= qz * g2
        fx3 -= qx * g3
        fy3 -= qy * g3
        fz3 -= qz * g3
        fx4 -= qx * g4
        fy4 -= qy * g4
        fz4 -= qz * g4
        fx5 -= qx * g5
        fy5 -= qy * g5
        fz5 -= qz * g5
        fx6 -= qx * g6
        fy6 -= qy * g6
        fz6 -= qz * g6
        fx7 -= qx * g7
        fy7 -= qy * g7
        fz7 -= qz * g7
        buf[(HF + 0) * B + i] += fx0
        buf[(HF + 1) * B + i] += fy0
        buf[(HF + 2) * B + i] += fz0
        buf[(HF + 3) * B + i] += fx1
        buf[(HF + 4) * B + i] += fy1
        buf[(HF + 5) * B + i] += fz1
        buf[(HF + 6) * B + i] += fx2
        buf[(HF + 7) * B + i] += fy2
        buf[(HF + 8) * B + i] += fz2
        buf[(HF + 9) * B + i] += fx3
        buf[(HF + 10) * B + i] += fy3
        buf[(HF + 11) * B + i] += fz3
        buf[(HF + 12) * B + i] += fx4
        buf[(HF + 13) * B + i] += fy4
        buf[(HF + 14) * B + i] += fz4
        buf[(HF + 15) * B + i] += fx5
        buf[(HF + 16) * B + i] += fy5
        buf[(HF + 17) * B + i] += fz5
        buf[(HF + 18) * B + i] += fx6
        buf[(HF + 19) * B + i] += fy6
        buf[(HF + 20) * B + i] += fz6
        buf[(HF + 21) * B + i] += fx7
        buf[(HF + 22) * B + i] += fy7
        buf[(HF + 23) * B + i] += fz7
        buf[HGW * B + i] = work


@numba.njit(cache=True, error_model="numpy")
def store_block(rows, sdev, pressure, q, eps_rate, energy, vol, hg, fext, e0, buf, hourglass,
                stiff):
    """Copy the block's results back and add its forces to the corners' rows of fext (in lane
    order); returns (min dt, its element, viscous work, hourglass work) reduced in lane order."""
    sd = sdev[e0:e0 + B]
    hgb = hg[e0:e0 + B]
    for i in range(B):
        for c in range(6):
            sd[i, c] = buf[(R_SN + c) * B + i]
    if stiff:
        for i in range(B):
            for c in range(12):
                hgb[i, c] = buf[(HG + c) * B + i]
    pr = pressure[e0:e0 + B]
    qq = q[e0:e0 + B]
    en = energy[e0:e0 + B]
    er = eps_rate[e0:e0 + B]
    vo = vol[e0:e0 + B]
    for i in range(B):
        pr[i] = buf[R_PN * B + i]
        qq[i] = buf[R_QN * B + i]
        en[i] = buf[R_EN1 * B + i]
        er[i] = buf[R_RATE * B + i]
        vo[i] = buf[R_DET * B + i] * (1.0 / 6.0)
    rw = rows[e0:e0 + B]
    dt_min = math.inf
    worst = -1
    qwork = 0.0
    hgwork = 0.0
    for i in range(B):
        for k in range(8):
            r = np.uint64(rw[i, k])
            for d in range(3):
                fext[r, d] += buf[(HF + 3 * k + d) * B + i]
        qwork += buf[R_QW * B + i]
        if hourglass:
            hgwork += buf[HGW * B + i]
        dte = buf[R_DTE * B + i]
        if dte < dt_min:
            dt_min = dte
            worst = e0 + i
    return dt_min, worst, qwork, hgwork
