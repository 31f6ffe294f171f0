"""Writes impactsim/solver/hex8_block.py: the vector path of the hex kernel, its loops over the
8 corners and 4 hourglass modes written out as straight-line code (LLVM vectorises only the
innermost loop, the one over the B lanes of a block, and only if nothing inside it loops).

    python scripts/gen_hex8_block.py   # then review the diff of impactsim/solver/hex8_block.py
"""

from pathlib import Path

import numpy as np

GAMMA = [[1, 1, -1, -1, -1, -1, 1, 1], [1, -1, -1, 1, -1, 1, 1, -1],
         [1, -1, 1, -1, 1, -1, 1, -1], [-1, 1, -1, 1, 1, -1, 1, -1]]
VD = ((1, 2, 3, 4, 5, 7), (2, 3, 0, 5, 6, 4), (3, 0, 1, 6, 7, 5), (0, 1, 2, 7, 4, 6),
      (7, 6, 5, 0, 3, 1), (4, 7, 6, 1, 0, 2), (5, 4, 7, 2, 1, 3), (6, 5, 4, 3, 2, 0))
FACES = ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7))
XYZ = "xyz"


def row(base, k):
    return f"buf[({base} + {k}) * B + i]"


def lines_b(px, out):
    """b of corner n: out(d, n) = _vol_der(...) on coordinates px(d, n)."""
    L = []
    for n, a in enumerate(VD):
        args = ", ".join(px(d, k) for d in range(3) for k in a)
        L.append(f"{out(0, n)}, {out(1, n)}, {out(2, n)} = _vol_der({args})")
    return L


def gen():
    ind = " " * 8
    src = []
    P = src.append
    P('''"""The vector path of the hex kernel (solver/hex8.py): a full block of B intact hexes of one
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
''')
    # ---- load
    P('''

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
''')
    # ---- kinematics
    K = []
    A = K.append
    A('@numba.njit(cache=True, error_model="numpy", fastmath=FAST)')
    A('def kinematics_block(buf, half, dt, shear):')
    A('    """Velocity gradient on the mid-step geometry, b, volume and length at n+1, trial')
    A('    deviator (Jaumann), its von Mises equivalent and the effective strain rate."""')
    A('    for i in range(B):')
    for n in range(8):
        for d in range(3):
            A(f"{ind}{XYZ[d]}{n} = {row('HX', 3 * n + d)}")
            A(f"{ind}u{XYZ[d]}{n} = {row('HV', 3 * n + d)}")
    for n in range(8):
        for d in range(3):
            A(f"{ind}m{XYZ[d]}{n} = {XYZ[d]}{n} - half * u{XYZ[d]}{n}")
    for ln in lines_b(lambda d, k: f"m{XYZ[d]}{k}", lambda d, n: f"b{XYZ[d]}{n}"):
        A(ind + ln)
    A(ind + "vmid = " + " + ".join(f"mx{n} * bx{n}" for n in range(8)))
    A(ind + "inv = 1.0 / vmid")
    for a in range(3):
        for b in range(3):
            A(ind + f"l{XYZ[a]}{XYZ[b]} = (" + " + ".join(
                f"u{XYZ[a]}{n} * b{XYZ[b]}{n}" for n in range(8)) + ") * inv")
    A(ind + "trd = lxx + lyy + lzz")
    A(ind + "third = trd * (1.0 / 3.0)")
    A(ind + "exx, eyy, ezz = lxx - third, lyy - third, lzz - third")
    A(ind + "dxy, dyz, dzx = 0.5 * (lxy + lyx), 0.5 * (lyz + lzy), 0.5 * (lzx + lxz)")
    A(ind + "wxy, wyz, wzx = 0.5 * (lxy - lyx), 0.5 * (lyz - lzy), 0.5 * (lzx - lxz)")
    for ln in lines_b(lambda d, k: f"{XYZ[d]}{k}", lambda d, n: f"c{XYZ[d]}{n}"):
        A(ind + ln)
    A(ind + "vnew = " + " + ".join(f"x{n} * cx{n}" for n in range(8)))
    for n in range(8):
        for d in range(3):
            A(ind + f"{row('HB', 3 * n + d)} = c{XYZ[d]}{n}")
    A(ind + f"{row('R_DET', 0)} = 6.0 * vnew")
    # face areas
    A(ind + "amax = 0.0")
    for (a, b, c, d) in FACES:
        A(ind + f"ux, uy, uz = x{c} - x{a}, y{c} - y{a}, z{c} - z{a}")
        A(ind + f"vx, vy, vz = x{d} - x{b}, y{d} - y{b}, z{d} - z{b}")
        A(ind + "qx, qy, qz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx")
        A(ind + "amax = max(amax, 0.25 * (qx * qx + qy * qy + qz * qz))")
    A(ind + f"{row('R_LEN', 0)} = vnew / math.sqrt(max(amax, 1e-300))")
    for k, nm in enumerate(["exx", "eyy", "ezz", "dxy", "dyz", "dzx"]):
        A(ind + f"{row('R_D', k)} = {nm}")
    A(ind + f"{row('R_TRD', 0)} = trd")
    A(ind + "sxx, syy, szz = " + ", ".join(row("R_S0", k) for k in range(3)))
    A(ind + "sxy, syz, szx = " + ", ".join(row("R_S0", k) for k in range(3, 6)))
    A(ind + "g2 = 2.0 * shear")
    A(ind + "rxx = 2.0 * (wxy * sxy - wzx * szx)")
    A(ind + "ryy = 2.0 * (wyz * syz - wxy * sxy)")
    A(ind + "rzz = 2.0 * (wzx * szx - wyz * syz)")
    A(ind + "rxy = wxy * (syy - sxx) + wzx * syz - wyz * szx")
    A(ind + "ryz = wyz * (szz - syy) + wxy * szx - wzx * sxy")
    A(ind + "rzx = wzx * (sxx - szz) + wyz * sxy - wxy * syz")
    A(ind + "nxx = sxx + dt * (g2 * exx + rxx)")
    A(ind + "nyy = syy + dt * (g2 * eyy + ryy)")
    A(ind + "nzz = szz + dt * (g2 * ezz + rzz)")
    A(ind + "nxy = sxy + dt * (g2 * dxy + rxy)")
    A(ind + "nyz = syz + dt * (g2 * dyz + ryz)")
    A(ind + "nzx = szx + dt * (g2 * dzx + rzx)")
    for k, nm in enumerate(["nxx", "nyy", "nzz", "nxy", "nyz", "nzx"]):
        A(ind + f"{row('R_SN', k)} = {nm}")
    A(ind + f"{row('R_RATE', 0)} = math.sqrt(max((2.0 / 3.0) * (exx * exx + eyy * eyy + ezz * ezz"
      " + 2.0 * (dxy * dxy + dyz * dyz + dzx * dzx)), 0.0))")
    A(ind + "j2 = 0.5 * (nxx * nxx + nyy * nyy + nzz * nzz) + nxy * nxy + nyz * nyz + nzx * nzx")
    A(ind + f"{row('R_SEQ', 0)} = math.sqrt(max(3.0 * j2, 0.0))")
    P("\n\n" + "\n".join(K) + "\n")
    # ---- pressure, stress forces
    P('''

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
''')
    F = []
    for n in range(8):
        F.append(ind + f"bx, by, bz = {row('HB', 3 * n)}, {row('HB', 3 * n + 1)}, "
                 f"{row('HB', 3 * n + 2)}")
        F.append(ind + f"{row('HF', 3 * n)} = -(txx * bx + nxy * by + nzx * bz)")
        F.append(ind + f"{row('HF', 3 * n + 1)} = -(nxy * bx + tyy * by + nyz * bz)")
        F.append(ind + f"{row('HF', 3 * n + 2)} = -(nzx * bx + nyz * by + tzz * bz)")
    P("\n".join(F) + "\n")
    # ---- hourglass
    Hh = []
    A = Hh.append
    A('@numba.njit(cache=True, error_model="numpy", fastmath=FAST)')
    A('def hourglass_block(buf, dt, bulk, shear):')
    A('    """Flanagan-Belytschko hourglass forces of the block (hex8._hex_element): gamma vectors,')
    A('    rates, viscous and stiffness resultants, their work; added to the HF rows."""')
    A('    for i in range(B):')
    A(ind + "cv = buf[HGV * B + i]")
    A(ind + "cs = buf[HGS * B + i]")
    A(ind + "vnew = buf[R_DET * B + i] * (1.0 / 6.0)")
    A(ind + "vinv = 1.0 / vnew")
    A(ind + "rho = buf[R_MASS * B + i] * vinv")
    for n in range(8):
        for d in range(3):
            A(f"{ind}{XYZ[d]}{n} = {row('HX', 3 * n + d)}")
            A(f"{ind}b{XYZ[d]}{n} = {row('HB', 3 * n + d)}")
            A(f"{ind}u{XYZ[d]}{n} = {row('HV', 3 * n + d)}")
    A(ind + "bb = " + " + ".join(f"b{XYZ[d]}{n} * b{XYZ[d]}{n}" for n in range(8) for d in range(3)))
    A(ind + "chg = math.sqrt(max(buf[HC2 * B + i], 0.0))")
    A(ind + "kv = cv * rho * chg * VM.power(vnew, 2.0 / 3.0)")
    A(ind + "ks = cs * dt * (bulk + 4.0 * shear / 3.0) * bb * vinv * (1.0 / 3.0)")
    A(ind + "work = 0.0")
    for n in range(8):
        for d in range(3):
            A(ind + f"f{XYZ[d]}{n} = 0.0")
    for a, G in enumerate(GAMMA):
        def gsum(d):
            terms = [("+" if g > 0 else "-") + f" {XYZ[d]}{n}" for n, g in enumerate(G)]
            t = " ".join(terms)
            return t[2:] if t.startswith("+") else t
        for d in range(3):
            A(ind + f"h{XYZ[d]} = ({gsum(d)}) * vinv")
        for n, g in enumerate(G):
            A(ind + f"g{n} = 0.125 * ({float(g)} - (hx * bx{n} + hy * by{n} + hz * bz{n}))")
        for d in range(3):
            A(ind + f"r{XYZ[d]} = " + " + ".join(f"u{XYZ[d]}{n} * g{n}" for n in range(8)))
        for d in range(3):
            k = 3 * a + d
            A(ind + f"s0{XYZ[d]} = {row('HG', k)}")
            A(ind + f"s1{XYZ[d]} = s0{XYZ[d]} + ks * r{XYZ[d]}")
            A(ind + f"{row('HG', k)} = s1{XYZ[d]}")
            A(ind + f"q{XYZ[d]} = s1{XYZ[d]} + kv * r{XYZ[d]}")
            A(ind + f"work += dt * (0.5 * (s0{XYZ[d]} + s1{XYZ[d]}) + kv * r{XYZ[d]}) * r{XYZ[d]}")
        for n in range(8):
            for d in range(3):
                A(ind + f"f{XYZ[d]}{n} -= q{XYZ[d]} * g{n}")
    for n in range(8):
        for d in range(3):
            A(ind + f"{row('HF', 3 * n + d)} += f{XYZ[d]}{n}")
    A(ind + "buf[HGW * B + i] = work")
    P("\n\n" + "\n".join(Hh) + "\n")
    P('''

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
''')
    return "".join(src)


if __name__ == "__main__":
    out = Path(__file__).resolve().parents[1] / "impactsim" / "solver" / "hex8_block.py"
    out.write_text(gen())
    print(f"wrote {out}")
