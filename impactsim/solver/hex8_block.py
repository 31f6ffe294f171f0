"""The vector path of the hex kernel (solver/hex8.py): a full block of B intact hexes of one
material, as loops over the B lanes that LLVM turns into SIMD instructions, like the tets'
vector path (element.py). WRITTEN BY scripts/gen_hex8_block.py: the loops over corners and
hourglass modes are written out there, since a loop inside the lane loop would stop its
vectorisation. The formulas are those of `hex8._hex_element` (tested equal to round-off).

The block buffer shares its rows with element.py's where the meaning is the same (stress,
strain rate, return-map rows: the Johnson-Cook vector return `element._jc_return_block` and
`element._return_block` run on it unchanged; R_DET holds 6 V as for a tet), and adds the hex
rows HX (x^{n+1}), HV (velocity), HB (b = dV/dx at n+1), HF (corner forces), HG (stiffness
hourglass resultants), HGV, HGS (hourglass coefficients), HGW (hourglass work).
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
HROWS = HGW + 1


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
def forces_block(buf, dt, eos, rho0, bulk, c0, s, gamma0, shear, cq, cl):
    """Deviatoric work, EOS pressure with the energy implicit, bulk viscosity, stable dt (as
    element._pressure_block, with the hex's volume), then the Flanagan-Belytschko hourglass
    resultants and their work, and the corner forces of stress and hourglass control together
    (hex8._hex_element's formulas, regrouped: see gen_hex8_block.hourglass_lines)."""
    for i in range(B):
        vnew = buf[R_DET * B + i] * (1.0 / 6.0)
        bx0 = buf[(HB + 0) * B + i]
        ux0 = buf[(HV + 0) * B + i]
        by0 = buf[(HB + 1) * B + i]
        uy0 = buf[(HV + 1) * B + i]
        bz0 = buf[(HB + 2) * B + i]
        uz0 = buf[(HV + 2) * B + i]
        bb = bx0 * bx0 + by0 * by0 + bz0 * bz0
        Wxx = ux0 * bx0
        Wxy = ux0 * by0
        Wxz = ux0 * bz0
        Wyx = uy0 * bx0
        Wyy = uy0 * by0
        Wyz = uy0 * bz0
        Wzx = uz0 * bx0
        Wzy = uz0 * by0
        Wzz = uz0 * bz0
        bx1 = buf[(HB + 3) * B + i]
        ux1 = buf[(HV + 3) * B + i]
        by1 = buf[(HB + 4) * B + i]
        uy1 = buf[(HV + 4) * B + i]
        bz1 = buf[(HB + 5) * B + i]
        uz1 = buf[(HV + 5) * B + i]
        bb += bx1 * bx1 + by1 * by1 + bz1 * bz1
        Wxx += ux1 * bx1
        Wxy += ux1 * by1
        Wxz += ux1 * bz1
        Wyx += uy1 * bx1
        Wyy += uy1 * by1
        Wyz += uy1 * bz1
        Wzx += uz1 * bx1
        Wzy += uz1 * by1
        Wzz += uz1 * bz1
        px = ux0 + ux1
        dx = ux0 - ux1
        Gu0x = px
        Gu1x = dx
        Gu2x = dx
        Gu3x = -dx
        py = uy0 + uy1
        dy = uy0 - uy1
        Gu0y = py
        Gu1y = dy
        Gu2y = dy
        Gu3y = -dy
        pz = uz0 + uz1
        dz = uz0 - uz1
        Gu0z = pz
        Gu1z = dz
        Gu2z = dz
        Gu3z = -dz
        bx2 = buf[(HB + 6) * B + i]
        ux2 = buf[(HV + 6) * B + i]
        by2 = buf[(HB + 7) * B + i]
        uy2 = buf[(HV + 7) * B + i]
        bz2 = buf[(HB + 8) * B + i]
        uz2 = buf[(HV + 8) * B + i]
        bb += bx2 * bx2 + by2 * by2 + bz2 * bz2
        Wxx += ux2 * bx2
        Wxy += ux2 * by2
        Wxz += ux2 * bz2
        Wyx += uy2 * bx2
        Wyy += uy2 * by2
        Wyz += uy2 * bz2
        Wzx += uz2 * bx2
        Wzy += uz2 * by2
        Wzz += uz2 * bz2
        bx3 = buf[(HB + 9) * B + i]
        ux3 = buf[(HV + 9) * B + i]
        by3 = buf[(HB + 10) * B + i]
        uy3 = buf[(HV + 10) * B + i]
        bz3 = buf[(HB + 11) * B + i]
        uz3 = buf[(HV + 11) * B + i]
        bb += bx3 * bx3 + by3 * by3 + bz3 * bz3
        Wxx += ux3 * bx3
        Wxy += ux3 * by3
        Wxz += ux3 * bz3
        Wyx += uy3 * bx3
        Wyy += uy3 * by3
        Wyz += uy3 * bz3
        Wzx += uz3 * bx3
        Wzy += uz3 * by3
        Wzz += uz3 * bz3
        px = ux2 + ux3
        dx = ux2 - ux3
        Gu0x -= px
        Gu1x -= dx
        Gu2x += dx
        Gu3x -= dx
        py = uy2 + uy3
        dy = uy2 - uy3
        Gu0y -= py
        Gu1y -= dy
        Gu2y += dy
        Gu3y -= dy
        pz = uz2 + uz3
        dz = uz2 - uz3
        Gu0z -= pz
        Gu1z -= dz
        Gu2z += dz
        Gu3z -= dz
        bx4 = buf[(HB + 12) * B + i]
        ux4 = buf[(HV + 12) * B + i]
        by4 = buf[(HB + 13) * B + i]
        uy4 = buf[(HV + 13) * B + i]
        bz4 = buf[(HB + 14) * B + i]
        uz4 = buf[(HV + 14) * B + i]
        bb += bx4 * bx4 + by4 * by4 + bz4 * bz4
        Wxx += ux4 * bx4
        Wxy += ux4 * by4
        Wxz += ux4 * bz4
        Wyx += uy4 * bx4
        Wyy += uy4 * by4
        Wyz += uy4 * bz4
        Wzx += uz4 * bx4
        Wzy += uz4 * by4
        Wzz += uz4 * bz4
        bx5 = buf[(HB + 15) * B + i]
        ux5 = buf[(HV + 15) * B + i]
        by5 = buf[(HB + 16) * B + i]
        uy5 = buf[(HV + 16) * B + i]
        bz5 = buf[(HB + 17) * B + i]
        uz5 = buf[(HV + 17) * B + i]
        bb += bx5 * bx5 + by5 * by5 + bz5 * bz5
        Wxx += ux5 * bx5
        Wxy += ux5 * by5
        Wxz += ux5 * bz5
        Wyx += uy5 * bx5
        Wyy += uy5 * by5
        Wyz += uy5 * bz5
        Wzx += uz5 * bx5
        Wzy += uz5 * by5
        Wzz += uz5 * bz5
        px = ux4 + ux5
        dx = ux4 - ux5
        Gu0x -= px
        Gu1x -= dx
        Gu2x += dx
        Gu3x += dx
        py = uy4 + uy5
        dy = uy4 - uy5
        Gu0y -= py
        Gu1y -= dy
        Gu2y += dy
        Gu3y += dy
        pz = uz4 + uz5
        dz = uz4 - uz5
        Gu0z -= pz
        Gu1z -= dz
        Gu2z += dz
        Gu3z += dz
        bx6 = buf[(HB + 18) * B + i]
        ux6 = buf[(HV + 18) * B + i]
        by6 = buf[(HB + 19) * B + i]
        uy6 = buf[(HV + 19) * B + i]
        bz6 = buf[(HB + 20) * B + i]
        uz6 = buf[(HV + 20) * B + i]
        bb += bx6 * bx6 + by6 * by6 + bz6 * bz6
        Wxx += ux6 * bx6
        Wxy += ux6 * by6
        Wxz += ux6 * bz6
        Wyx += uy6 * bx6
        Wyy += uy6 * by6
        Wyz += uy6 * bz6
        Wzx += uz6 * bx6
        Wzy += uz6 * by6
        Wzz += uz6 * bz6
        bx7 = buf[(HB + 21) * B + i]
        ux7 = buf[(HV + 21) * B + i]
        by7 = buf[(HB + 22) * B + i]
        uy7 = buf[(HV + 22) * B + i]
        bz7 = buf[(HB + 23) * B + i]
        uz7 = buf[(HV + 23) * B + i]
        bb += bx7 * bx7 + by7 * by7 + bz7 * bz7
        Wxx += ux7 * bx7
        Wxy += ux7 * by7
        Wxz += ux7 * bz7
        Wyx += uy7 * bx7
        Wyy += uy7 * by7
        Wyz += uy7 * bz7
        Wzx += uz7 * bx7
        Wzy += uz7 * by7
        Wzz += uz7 * bz7
        px = ux6 + ux7
        dx = ux6 - ux7
        Gu0x += px
        Gu1x += dx
        Gu2x += dx
        Gu3x += dx
        py = uy6 + uy7
        dy = uy6 - uy7
        Gu0y += py
        Gu1y += dy
        Gu2y += dy
        Gu3y += dy
        pz = uz6 + uz7
        dz = uz6 - uz7
        Gu0z += pz
        Gu1z += dz
        Gu2z += dz
        Gu3z += dz
        vinv = 1.0 / vnew
        xx0 = buf[(HX + 0) * B + i]
        xx1 = buf[(HX + 3) * B + i]
        xx2 = buf[(HX + 6) * B + i]
        xx3 = buf[(HX + 9) * B + i]
        xx4 = buf[(HX + 12) * B + i]
        xx5 = buf[(HX + 15) * B + i]
        xx6 = buf[(HX + 18) * B + i]
        xx7 = buf[(HX + 21) * B + i]
        p0 = xx0 + xx1
        d0 = xx0 - xx1
        p1 = xx2 + xx3
        d1 = xx2 - xx3
        p2 = xx4 + xx5
        d2 = xx4 - xx5
        p3 = xx6 + xx7
        d3 = xx6 - xx7
        Gx0x = p0 - p1 - p2 + p3
        Gx1x = d0 - d1 - d2 + d3
        Gx2x = d0 + d1 + d2 + d3
        Gx3x = -d0 - d1 + d2 + d3
        h0x = Gx0x * vinv
        h1x = Gx1x * vinv
        h2x = Gx2x * vinv
        h3x = Gx3x * vinv
        xy0 = buf[(HX + 1) * B + i]
        xy1 = buf[(HX + 4) * B + i]
        xy2 = buf[(HX + 7) * B + i]
        xy3 = buf[(HX + 10) * B + i]
        xy4 = buf[(HX + 13) * B + i]
        xy5 = buf[(HX + 16) * B + i]
        xy6 = buf[(HX + 19) * B + i]
        xy7 = buf[(HX + 22) * B + i]
        p0 = xy0 + xy1
        d0 = xy0 - xy1
        p1 = xy2 + xy3
        d1 = xy2 - xy3
        p2 = xy4 + xy5
        d2 = xy4 - xy5
        p3 = xy6 + xy7
        d3 = xy6 - xy7
        Gx0y = p0 - p1 - p2 + p3
        Gx1y = d0 - d1 - d2 + d3
        Gx2y = d0 + d1 + d2 + d3
        Gx3y = -d0 - d1 + d2 + d3
        h0y = Gx0y * vinv
        h1y = Gx1y * vinv
        h2y = Gx2y * vinv
        h3y = Gx3y * vinv
        xz0 = buf[(HX + 2) * B + i]
        xz1 = buf[(HX + 5) * B + i]
        xz2 = buf[(HX + 8) * B + i]
        xz3 = buf[(HX + 11) * B + i]
        xz4 = buf[(HX + 14) * B + i]
        xz5 = buf[(HX + 17) * B + i]
        xz6 = buf[(HX + 20) * B + i]
        xz7 = buf[(HX + 23) * B + i]
        p0 = xz0 + xz1
        d0 = xz0 - xz1
        p1 = xz2 + xz3
        d1 = xz2 - xz3
        p2 = xz4 + xz5
        d2 = xz4 - xz5
        p3 = xz6 + xz7
        d3 = xz6 - xz7
        Gx0z = p0 - p1 - p2 + p3
        Gx1z = d0 - d1 - d2 + d3
        Gx2z = d0 + d1 + d2 + d3
        Gx3z = -d0 - d1 + d2 + d3
        h0z = Gx0z * vinv
        h1z = Gx1z * vinv
        h2z = Gx2z * vinv
        h3z = Gx3z * vinv
        r0x = 0.125 * (Gu0x - (h0x * Wxx + h0y * Wxy + h0z * Wxz))
        r0y = 0.125 * (Gu0y - (h0x * Wyx + h0y * Wyy + h0z * Wyz))
        r0z = 0.125 * (Gu0z - (h0x * Wzx + h0y * Wzy + h0z * Wzz))
        r1x = 0.125 * (Gu1x - (h1x * Wxx + h1y * Wxy + h1z * Wxz))
        r1y = 0.125 * (Gu1y - (h1x * Wyx + h1y * Wyy + h1z * Wyz))
        r1z = 0.125 * (Gu1z - (h1x * Wzx + h1y * Wzy + h1z * Wzz))
        r2x = 0.125 * (Gu2x - (h2x * Wxx + h2y * Wxy + h2z * Wxz))
        r2y = 0.125 * (Gu2y - (h2x * Wyx + h2y * Wyy + h2z * Wyz))
        r2z = 0.125 * (Gu2z - (h2x * Wzx + h2y * Wzy + h2z * Wzz))
        r3x = 0.125 * (Gu3x - (h3x * Wxx + h3y * Wxy + h3z * Wxz))
        r3y = 0.125 * (Gu3y - (h3x * Wyx + h3y * Wyy + h3z * Wyz))
        r3z = 0.125 * (Gu3z - (h3x * Wzx + h3y * Wzy + h3z * Wzz))
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
        qq = cl * math.sqrt(c2) - cq * cq * length * trd if trd < 0.0 else 0.0
        buf[R_DTE * B + i] = length / (qq + math.sqrt(max(qq * qq + c2, 0.0)))
        ptot = pn + qn
        cv = buf[HGV * B + i]
        cs = buf[HGS * B + i]
        chg = math.sqrt(max(c2, 0.0))
        kv = cv * rho * chg * VM.power(vnew, 2.0 / 3.0)
        ks = cs * dt * (bulk + 4.0 * shear / 3.0) * bb * vinv * (1.0 / 3.0)
        work = 0.0
        s0 = buf[(HG + 0) * B + i]
        s1 = s0 + ks * r0x
        buf[(HG + 0) * B + i] = s1
        Q0x = s1 + kv * r0x
        work += dt * (0.5 * (s0 + s1) + kv * r0x) * r0x
        s0 = buf[(HG + 1) * B + i]
        s1 = s0 + ks * r0y
        buf[(HG + 1) * B + i] = s1
        Q0y = s1 + kv * r0y
        work += dt * (0.5 * (s0 + s1) + kv * r0y) * r0y
        s0 = buf[(HG + 2) * B + i]
        s1 = s0 + ks * r0z
        buf[(HG + 2) * B + i] = s1
        Q0z = s1 + kv * r0z
        work += dt * (0.5 * (s0 + s1) + kv * r0z) * r0z
        s0 = buf[(HG + 3) * B + i]
        s1 = s0 + ks * r1x
        buf[(HG + 3) * B + i] = s1
        Q1x = s1 + kv * r1x
        work += dt * (0.5 * (s0 + s1) + kv * r1x) * r1x
        s0 = buf[(HG + 4) * B + i]
        s1 = s0 + ks * r1y
        buf[(HG + 4) * B + i] = s1
        Q1y = s1 + kv * r1y
        work += dt * (0.5 * (s0 + s1) + kv * r1y) * r1y
        s0 = buf[(HG + 5) * B + i]
        s1 = s0 + ks * r1z
        buf[(HG + 5) * B + i] = s1
        Q1z = s1 + kv * r1z
        work += dt * (0.5 * (s0 + s1) + kv * r1z) * r1z
        s0 = buf[(HG + 6) * B + i]
        s1 = s0 + ks * r2x
        buf[(HG + 6) * B + i] = s1
        Q2x = s1 + kv * r2x
        work += dt * (0.5 * (s0 + s1) + kv * r2x) * r2x
        s0 = buf[(HG + 7) * B + i]
        s1 = s0 + ks * r2y
        buf[(HG + 7) * B + i] = s1
        Q2y = s1 + kv * r2y
        work += dt * (0.5 * (s0 + s1) + kv * r2y) * r2y
        s0 = buf[(HG + 8) * B + i]
        s1 = s0 + ks * r2z
        buf[(HG + 8) * B + i] = s1
        Q2z = s1 + kv * r2z
        work += dt * (0.5 * (s0 + s1) + kv * r2z) * r2z
        s0 = buf[(HG + 9) * B + i]
        s1 = s0 + ks * r3x
        buf[(HG + 9) * B + i] = s1
        Q3x = s1 + kv * r3x
        work += dt * (0.5 * (s0 + s1) + kv * r3x) * r3x
        s0 = buf[(HG + 10) * B + i]
        s1 = s0 + ks * r3y
        buf[(HG + 10) * B + i] = s1
        Q3y = s1 + kv * r3y
        work += dt * (0.5 * (s0 + s1) + kv * r3y) * r3y
        s0 = buf[(HG + 11) * B + i]
        s1 = s0 + ks * r3z
        buf[(HG + 11) * B + i] = s1
        Q3z = s1 + kv * r3z
        work += dt * (0.5 * (s0 + s1) + kv * r3z) * r3z
        buf[HGW * B + i] = work
        Txx = nxx - ptot - 0.125 * (Q0x * h0x + Q1x * h1x + Q2x * h2x + Q3x * h3x)
        Txy = nxy - 0.125 * (Q0x * h0y + Q1x * h1y + Q2x * h2y + Q3x * h3y)
        Txz = nzx - 0.125 * (Q0x * h0z + Q1x * h1z + Q2x * h2z + Q3x * h3z)
        Tyx = nxy - 0.125 * (Q0y * h0x + Q1y * h1x + Q2y * h2x + Q3y * h3x)
        Tyy = nyy - ptot - 0.125 * (Q0y * h0y + Q1y * h1y + Q2y * h2y + Q3y * h3y)
        Tyz = nyz - 0.125 * (Q0y * h0z + Q1y * h1z + Q2y * h2z + Q3y * h3z)
        Tzx = nzx - 0.125 * (Q0z * h0x + Q1z * h1x + Q2z * h2x + Q3z * h3x)
        Tzy = nyz - 0.125 * (Q0z * h0y + Q1z * h1y + Q2z * h2y + Q3z * h3y)
        Tzz = nzz - ptot - 0.125 * (Q0z * h0z + Q1z * h1z + Q2z * h2z + Q3z * h3z)
        Ax, Cx = 0.125 * (Q0x + Q1x), 0.125 * (Q2x + Q3x)
        Dx, Ex = 0.125 * (Q0x - Q1x), 0.125 * (Q2x - Q3x)
        Ay, Cy = 0.125 * (Q0y + Q1y), 0.125 * (Q2y + Q3y)
        Dy, Ey = 0.125 * (Q0y - Q1y), 0.125 * (Q2y - Q3y)
        Az, Cz = 0.125 * (Q0z + Q1z), 0.125 * (Q2z + Q3z)
        Dz, Ez = 0.125 * (Q0z - Q1z), 0.125 * (Q2z - Q3z)
        bx = buf[(HB + 0) * B + i]
        by = buf[(HB + 1) * B + i]
        bz = buf[(HB + 2) * B + i]
        buf[(HF + 0) * B + i] = -(Txx * bx + Txy * by + Txz * bz) - (Ax + Ex)
        buf[(HF + 1) * B + i] = -(Tyx * bx + Tyy * by + Tyz * bz) - (Ay + Ey)
        buf[(HF + 2) * B + i] = -(Tzx * bx + Tzy * by + Tzz * bz) - (Az + Ez)
        bx = buf[(HB + 3) * B + i]
        by = buf[(HB + 4) * B + i]
        bz = buf[(HB + 5) * B + i]
        buf[(HF + 3) * B + i] = -(Txx * bx + Txy * by + Txz * bz) - (Dx - Ex)
        buf[(HF + 4) * B + i] = -(Tyx * bx + Tyy * by + Tyz * bz) - (Dy - Ey)
        buf[(HF + 5) * B + i] = -(Tzx * bx + Tzy * by + Tzz * bz) - (Dz - Ez)
        bx = buf[(HB + 6) * B + i]
        by = buf[(HB + 7) * B + i]
        bz = buf[(HB + 8) * B + i]
        buf[(HF + 6) * B + i] = -(Txx * bx + Txy * by + Txz * bz) - (-Ax + Ex)
        buf[(HF + 7) * B + i] = -(Tyx * bx + Tyy * by + Tyz * bz) - (-Ay + Ey)
        buf[(HF + 8) * B + i] = -(Tzx * bx + Tzy * by + Tzz * bz) - (-Az + Ez)
        bx = buf[(HB + 9) * B + i]
        by = buf[(HB + 10) * B + i]
        bz = buf[(HB + 11) * B + i]
        buf[(HF + 9) * B + i] = -(Txx * bx + Txy * by + Txz * bz) - (-Dx - Ex)
        buf[(HF + 10) * B + i] = -(Tyx * bx + Tyy * by + Tyz * bz) - (-Dy - Ey)
        buf[(HF + 11) * B + i] = -(Tzx * bx + Tzy * by + Tzz * bz) - (-Dz - Ez)
        bx = buf[(HB + 12) * B + i]
        by = buf[(HB + 13) * B + i]
        bz = buf[(HB + 14) * B + i]
        buf[(HF + 12) * B + i] = -(Txx * bx + Txy * by + Txz * bz) - (-Ax + Cx)
        buf[(HF + 13) * B + i] = -(Tyx * bx + Tyy * by + Tyz * bz) - (-Ay + Cy)
        buf[(HF + 14) * B + i] = -(Tzx * bx + Tzy * by + Tzz * bz) - (-Az + Cz)
        bx = buf[(HB + 15) * B + i]
        by = buf[(HB + 16) * B + i]
        bz = buf[(HB + 17) * B + i]
        buf[(HF + 15) * B + i] = -(Txx * bx + Txy * by + Txz * bz) - (-Dx - Cx)
        buf[(HF + 16) * B + i] = -(Tyx * bx + Tyy * by + Tyz * bz) - (-Dy - Cy)
        buf[(HF + 17) * B + i] = -(Tzx * bx + Tzy * by + Tzz * bz) - (-Dz - Cz)
        bx = buf[(HB + 18) * B + i]
        by = buf[(HB + 19) * B + i]
        bz = buf[(HB + 20) * B + i]
        buf[(HF + 18) * B + i] = -(Txx * bx + Txy * by + Txz * bz) - (Ax + Cx)
        buf[(HF + 19) * B + i] = -(Tyx * bx + Tyy * by + Tyz * bz) - (Ay + Cy)
        buf[(HF + 20) * B + i] = -(Tzx * bx + Tzy * by + Tzz * bz) - (Az + Cz)
        bx = buf[(HB + 21) * B + i]
        by = buf[(HB + 22) * B + i]
        bz = buf[(HB + 23) * B + i]
        buf[(HF + 21) * B + i] = -(Txx * bx + Txy * by + Txz * bz) - (Dx - Cx)
        buf[(HF + 22) * B + i] = -(Tyx * bx + Tyy * by + Tyz * bz) - (Dy - Cy)
        buf[(HF + 23) * B + i] = -(Tzx * bx + Tzy * by + Tzz * bz) - (Dz - Cz)


@numba.njit(cache=True, error_model="numpy")
def store_block(rows, sdev, pressure, q, eps_rate, energy, vol, hg, fext, e0, buf, stiff):
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
        hgwork += buf[HGW * B + i]
        dte = buf[R_DTE * B + i]
        if dte < dt_min:
            dt_min = dte
            worst = e0 + i
    return dt_min, worst, qwork, hgwork
