"""Writes impactsim/solver/hex8_block.py: the vector path of the hex kernel, its loops over the
8 corners and 4 hourglass modes written out as straight-line code (LLVM vectorises only the
innermost loop, the one over the B lanes of a block, and only if nothing inside it loops).

    python scripts/gen_hex8_block.py   # then review the diff of impactsim/solver/hex8_block.py
"""

import hashlib
import re
from pathlib import Path

import numpy as np

GAMMA = [[1, 1, -1, -1, -1, -1, 1, 1], [1, -1, -1, 1, -1, 1, 1, -1],
         [1, -1, 1, -1, 1, -1, 1, -1], [-1, 1, -1, 1, 1, -1, 1, -1]]
VD = ((1, 2, 3, 4, 5, 7), (2, 3, 0, 5, 6, 4), (3, 0, 1, 6, 7, 5), (0, 1, 2, 7, 4, 6),
      (7, 6, 5, 0, 3, 1), (4, 7, 6, 1, 0, 2), (5, 4, 7, 2, 1, 3), (6, 5, 4, 3, 2, 0))
FACES = ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7))
XYZ = "xyz"
# column j of b = dV/dx: (sign, first coordinate, second coordinate), b_j = sign F(first,
# second) / 12 with F the dx of `_vol_der` (dy = -F(x, z), dz = -F(y, x))
COLS = {0: ("", "y", "z"), 1: ("-", "x", "z"), 2: ("-", "y", "x")}


def row(base, k):
    return f"buf[({base} + {k}) * B + i]"


def edge(c, p):
    lo, hi = sorted(p)
    return f"e{c}{lo}{hi}"


def pairs(a):
    P = [(a[1], a[2]), (a[0], a[1]), (a[0], a[4]), (a[3], a[4]), (a[2], a[5]), (a[3], a[5])]
    Q = [P[1], P[0], P[3], P[2], P[5], P[4]]
    return P, Q


def f_expr(c1, c2, a):
    """F: FB81's dV/dx of the node whose six neighbours are `a` (`_vol_der`'s dx, times 12),
    with y -> c1, z -> c2, from the edge sums e{c}{lo}{hi} (`edge_lines`)."""
    P, Q = pairs(a)
    sg = ["+", "-", "+", "-", "-", "+"]
    out = []
    for k in range(6):
        t = f"{edge(c1, P[k])} * {edge(c2, Q[k])}"
        out.append((sg[k] if k else ("" if sg[k] == "+" else "-")) + (" " if k else "") + t)
    return "(" + " ".join(out) + ")"


def edge_lines(c1, c2, ind):
    """The sums of coordinates c1 and c2 over the hex edges that enter F (each twice)."""
    need = set()
    for a in VD:
        P, Q = pairs(a)
        need |= {(c1, tuple(sorted(p))) for p in P} | {(c2, tuple(sorted(q))) for q in Q}
    return [f"{ind}{edge(c, p)} = {c}{p[0]} + {c}{p[1]}" for c, p in sorted(need)]


def kinematics_lines(ind):
    K = []
    A = K.append
    A('@numba.njit(cache=True, error_model="numpy", fastmath=FAST)')
    A('def kinematics_block(buf, half, dt, shear):')
    A('    """Velocity gradient on the mid-step geometry, b, volume and length at n+1, trial')
    A('    deviator (Jaumann), its von Mises equivalent and the effective strain rate. In several')
    A('    lane loops, each with fewer live values than the registers (a single loop keeps about')
    A('    100 values per lane alive and spills a third of its instructions): the mid-step')
    A('    coordinates (into the HF rows, free until forces_block), then one loop per column j of')
    A('    b = dV/dx at the mid-step (sums sum_I v_iI b_jI into HK) and at n+1 (into HB), '
      'each from')
    A('    the 24 edge sums of the two coordinates that enter it, the face areas, and the rest."""')
    # 1: mid-step coordinates
    A("    for i in range(B):")
    for n in range(8):
        for d in range(3):
            A(f"{ind}{row('HF', 3 * n + d)} = {row('HX', 3 * n + d)}"
              f" - half * {row('HV', 3 * n + d)}")
    # 2: mid-step columns
    for j in range(3):
        sg, c1, c2 = COLS[j]
        A("    for i in range(B):")
        for n in range(8):
            for c in (c1, c2):
                A(f"{ind}{c}{n} = {row('HF', 3 * n + XYZ.index(c))}")
        K.extend(edge_lines(c1, c2, ind))
        for n, a in enumerate(VD):
            A(f"{ind}b{n} = {sg}{f_expr(c1, c2, a)}")
        for d in range(3):
            A(f"{ind}{row('HK', 3 * d + j)} = " + " + ".join(
                f"{row('HV', 3 * n + d)} * b{n}" for n in range(8)))
        if j == 0:
            A(f"{ind}{row('HK', 9)} = "
              + " + ".join(f"{row('HF', 3 * n)} * b{n}" for n in range(8)))
    # 3: columns at n+1
    for j in range(3):
        sg, c1, c2 = COLS[j]
        A("    for i in range(B):")
        for n in range(8):
            for c in (c1, c2):
                A(f"{ind}{c}{n} = {row('HX', 3 * n + XYZ.index(c))}")
        K.extend(edge_lines(c1, c2, ind))
        for n, a in enumerate(VD):
            A(f"{ind}b{n} = {sg}{f_expr(c1, c2, a)} * (1.0 / 12.0)")
            A(f"{ind}{row('HB', 3 * n + j)} = b{n}")
        if j == 0:
            A(f"{ind}{row('HK', 10)} = "
              + " + ".join(f"{row('HX', 3 * n)} * b{n}" for n in range(8)))
    # 4: face areas
    A("    for i in range(B):")
    for n in range(8):
        for d in range(3):
            A(f"{ind}{XYZ[d]}{n} = {row('HX', 3 * n + d)}")
    A(ind + "amax = 0.0")
    for (a, b, c, d) in FACES:
        A(ind + f"ux, uy, uz = x{c} - x{a}, y{c} - y{a}, z{c} - z{a}")
        A(ind + f"vx, vy, vz = x{d} - x{b}, y{d} - y{b}, z{d} - z{b}")
        A(ind + "qx, qy, qz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx")
        A(ind + "amax = max(amax, qx * qx + qy * qy + qz * qz)")
    A(ind + f"{row('HK', 11)} = 0.25 * amax")
    # 5: the rest
    A("    for i in range(B):")
    A(ind + f"inv = 1.0 / {row('HK', 9)}")
    for a in range(3):
        for b in range(3):
            A(ind + f"l{XYZ[a]}{XYZ[b]} = {row('HK', 3 * a + b)} * inv")
    A(ind + f"vnew = {row('HK', 10)}")
    A(ind + f"{row('R_DET', 0)} = 6.0 * vnew")
    A(ind + f"{row('R_LEN', 0)} = vnew / math.sqrt(max({row('HK', 11)}, 1e-300))")
    A(ind + "trd = lxx + lyy + lzz")
    A(ind + "third = trd * (1.0 / 3.0)")
    A(ind + "exx, eyy, ezz = lxx - third, lyy - third, lzz - third")
    A(ind + "dxy, dyz, dzx = 0.5 * (lxy + lyx), 0.5 * (lyz + lzy), 0.5 * (lzx + lxz)")
    A(ind + "wxy, wyz, wzx = 0.5 * (lxy - lyx), 0.5 * (lyz - lzy), 0.5 * (lzx - lxz)")
    return K


PRESSURE = """

@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def forces_block(buf, dt, eos, rho0, bulk, c0, s, gamma0, shear, cq, cl, stiff):
    \"\"\"Deviatoric work, EOS pressure with the energy implicit, bulk viscosity, stable dt (as
    element._pressure_block, with the hex's volume), then the Flanagan-Belytschko hourglass
    resultants and their work, and the corner forces of stress and hourglass control together
    (hex8._hex_element's formulas, regrouped: see gen_hex8_block.hourglass_lines). In five
    lane loops, each keeping fewer values alive than the registers, through the HK rows:
    W_ij = sum_n v_in b_jn, b.b and Gamma_a . v; h_a and the rates; the pressure part; the
    resultants Q, their work and T = sigma - M / 8 (with the stiffness resultants of the HG
    rows only when the block has the stiffness form, `stiff`: the viscous form, the default,
    neither reads nor writes them); the corner forces.\"\"\"
"""

PRESSURE_BODY = """        vold = buf[R_VOLD * B + i]
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
"""

# the sign of Gamma_a at node n, by pairs of nodes: with p = x_m + x_n, d = x_m - x_n for the
# pairs (0, 1), (2, 3), (4, 5), (6, 7), Gamma_a . x is a signed sum of the four p (a = 0) or
# the four d (a = 1, 2, 3); checked against GAMMA in gen()
HG_PAIRS = {0: ("p", (1, -1, -1, 1)), 1: ("d", (1, -1, -1, 1)), 2: ("d", (1, 1, 1, 1)),
            3: ("d", (-1, -1, 1, 1))}


def signed(terms):
    out = ""
    for sign, t in terms:
        out += (" + " if sign > 0 else " - ") + t
    return out[3:] if out.startswith(" + ") else "-" + out[3:]


def gamma_dot(v, d):
    """Lines computing G{v}{a}{d} = Gamma_a . v_d (a = 0..3) of the 8 corner values v{d}{n}."""
    L = []
    for k in range(4):
        m, n = 2 * k, 2 * k + 1
        L.append(f"p{k} = {v}{d}{m} + {v}{d}{n}")
        L.append(f"d{k} = {v}{d}{m} - {v}{d}{n}")
    for a in range(4):
        kind, sg = HG_PAIRS[a]
        L.append(f"G{v}{a}{d} = " + signed([(sg[k], f"{kind}{k}") for k in range(4)]))
    return L


# scratch rows of forces_block in HK: W (9), Gamma_a . v (12), b.b, h_a (12), rates (12), p + q,
# the viscous and stiffness coefficients; T (9) and the pair sums A, C, D, E (12) over W and Gu
K_W, K_GU, K_BB, K_H, K_R, K_PT, K_KV, K_KS = 0, 9, 21, 22, 34, 46, 47, 48
K_T, K_Q8 = 0, 9
N_HK = 49


def hk(k):
    return row("HK", k)


def hourglass_lines():
    """The loops of forces_block around the pressure part: (the two loops before it, the lines
    ending the pressure loop, the resultant loop in its stiffness and its viscous form, the
    corner-force loop), each a list of lines inside its lane loop.

    FB81's shape vectors g_an = (1/8) [Gamma_an - h_a . b_n] with h_a = (Gamma_a . x) / V are
    not formed. The rates are qdot_ia = sum_n v_in g_an = (1/8) [Gamma_a . v_i - h_a . W_i]
    with W_ij = sum_n v_in b_jn, and the forces -sum_a Q_ia g_an =
    -(1/8) sum_a Q_ia Gamma_an + (1/8) M_ij b_jn with M_ij = sum_a Q_ia h_aj, so stress and
    hourglass forces together are f_in = -(sigma_ij - M_ij / 8) b_jn - (1/8) sum_a Q_ia
    Gamma_an: the same sums in another order (equal to round-off), with far fewer operations
    and fewer values alive at once."""
    loops = []
    # loop 1: W_ij = sum_n v_in b_jn, sum b.b and Gamma_a . v, by pairs of nodes (2k, 2k + 1)
    L = []
    A = L.append
    for k in range(4):
        for m in (2 * k, 2 * k + 1):
            for d in XYZ:
                A(f"b{d}{m} = {row('HB', 3 * m + XYZ.index(d))}")
                A(f"u{d}{m} = {row('HV', 3 * m + XYZ.index(d))}")
            A(("bb = " if m == 0 else "bb += ") + f"bx{m} * bx{m} + by{m} * by{m} + bz{m} * bz{m}")
            for di in XYZ:
                for dj in XYZ:
                    A(f"W{di}{dj} {'=' if m == 0 else '+='} u{di}{m} * b{dj}{m}")
        for d in XYZ:
            A(f"p{d} = u{d}{2 * k} + u{d}{2 * k + 1}")
            A(f"d{d} = u{d}{2 * k} - u{d}{2 * k + 1}")
            for a in range(4):
                kind, sg = HG_PAIRS[a]
                term = f"{kind}{d}"
                if k == 0:
                    A(f"Gu{a}{d} = {'' if sg[k] > 0 else '-'}{term}")
                else:
                    A(f"Gu{a}{d} {'+=' if sg[k] > 0 else '-='} {term}")
    for i, di in enumerate(XYZ):
        for j, dj in enumerate(XYZ):
            A(f"{hk(K_W + 3 * i + j)} = W{di}{dj}")
    for a in range(4):
        for i, di in enumerate(XYZ):
            A(f"{hk(K_GU + 3 * a + i)} = Gu{a}{di}")
    A(f"{hk(K_BB)} = bb")
    loops.append(L)
    # loop 2: h_a = (Gamma_a . x) / V and the rates
    L = []
    A = L.append
    A("vinv = 6.0 / buf[R_DET * B + i]")
    for d in XYZ:
        for n in range(8):
            A(f"x{d}{n} = {row('HX', 3 * n + XYZ.index(d))}")
        L.extend(gamma_dot("x", d))
        for a in range(4):
            A(f"h{a}{d} = Gx{a}{d} * vinv")
            A(f"{hk(K_H + 3 * a + XYZ.index(d))} = h{a}{d}")
    for i, di in enumerate(XYZ):
        for j, dj in enumerate(XYZ):
            A(f"W{di}{dj} = {hk(K_W + 3 * i + j)}")
    for a in range(4):
        for i, di in enumerate(XYZ):
            A(f"{hk(K_R + 3 * a + i)} = 0.125 * ({hk(K_GU + 3 * a + i)} - (h{a}x * W{di}x"
              f" + h{a}y * W{di}y + h{a}z * W{di}z))")
    loops.append(L)
    # the end of the pressure loop: the hourglass coefficients
    L = []
    A = L.append
    A(f"{hk(K_PT)} = ptot")
    A("cv = buf[HGV * B + i]")
    A("cs = buf[HGS * B + i]")
    A("chg = math.sqrt(max(c2, 0.0))")
    A(f"{hk(K_KV)} = cv * rho * chg * VM.pow_two_thirds(vnew)")
    A(f"{hk(K_KS)} = cs * dt * (bulk + 4.0 * shear / 3.0) * {hk(K_BB)} / vnew * (1.0 / 3.0)")
    loops.append(L)
    # loop 4: resultants, their work, T = sigma - M / 8 (M_ij = sum_a Q_ia h_aj), the pair sums;
    # in two forms: with the stiffness resultants (HG rows, read and updated), and the viscous
    # form alone (Q = kv qdot; the same values as the first with ks = 0 and zero resultants,
    # bit for bit, without the 12 rows read and written and their zeroing in load_block)
    loops.append(_resultant_loop(True))
    loops.append(_resultant_loop(False))
    # loop 5: f_in = -T_ij b_jn - (1/8) sum_a Q_ia Gamma_an
    L = []
    A = L.append
    for i, di in enumerate(XYZ):
        for j, dj in enumerate(XYZ):
            A(f"T{di}{dj} = {hk(K_T + 3 * i + j)}")
        q8 = K_Q8 + 4 * i
        A(f"A{di}, C{di}, D{di}, E{di} = {hk(q8)}, {hk(q8 + 1)}, {hk(q8 + 2)}, {hk(q8 + 3)}")
    for n in range(8):
        for d in XYZ:
            A(f"b{d} = {row('HB', 3 * n + XYZ.index(d))}")
        for di in XYZ:
            A(f"{row('HF', 3 * n + XYZ.index(di))} = -(T{di}x * bx + T{di}y * by + T{di}z * bz)"
              f" - ({qgamma(n, di)})")
    loops.append(L)
    return loops


def _resultant_loop(stiff):
    """Loop 4 of forces_block: the hourglass resultants Q_ia (viscous part kv qdot plus, with
    `stiff`, the accumulated stiffness part in the HG rows), their work, T = sigma - M / 8 and
    the pair sums of Q for the corner forces."""
    L = []
    A = L.append
    A(f"kv = {hk(K_KV)}")
    if stiff:
        A(f"ks = {hk(K_KS)}")
    A("work = 0.0")
    for a in range(4):
        for di in XYZ:
            k = 3 * a + XYZ.index(di)
            r = f"r{a}{di}"
            A(f"{r} = {hk(K_R + k)}")
            if stiff:
                A(f"s0 = {row('HG', k)}")
                A(f"s1 = s0 + ks * {r}")
                A(f"{row('HG', k)} = s1")
                A(f"Q{a}{di} = s1 + kv * {r}")
                A(f"work += dt * (0.5 * (s0 + s1) + kv * {r}) * {r}")
            else:
                A(f"Q{a}{di} = kv * {r}")
                A(f"work += dt * Q{a}{di} * {r}")
    A("buf[HGW * B + i] = work")
    A(f"ptot = {hk(K_PT)}")
    for k, nm in enumerate(["nxx", "nyy", "nzz", "nxy", "nyz", "nzx"]):
        A(f"{nm} = {row('R_SN', k)}")
    for a in range(4):
        for d in XYZ:
            A(f"h{a}{d} = {hk(K_H + 3 * a + XYZ.index(d))}")
    sig = {"xx": "nxx - ptot", "yy": "nyy - ptot", "zz": "nzz - ptot", "xy": "nxy", "yx": "nxy",
           "yz": "nyz", "zy": "nyz", "zx": "nzx", "xz": "nzx"}
    for i, di in enumerate(XYZ):
        for j, dj in enumerate(XYZ):
            A(f"{hk(K_T + 3 * i + j)} = {sig[di + dj]} - 0.125 * ("
              + " + ".join(f"Q{a}{di} * h{a}{dj}" for a in range(4)) + ")")
    for i, di in enumerate(XYZ):
        q8 = K_Q8 + 4 * i
        A(f"{hk(q8)}, {hk(q8 + 1)} = 0.125 * (Q0{di} + Q1{di}), 0.125 * (Q2{di} + Q3{di})")
        A(f"{hk(q8 + 2)}, {hk(q8 + 3)} = 0.125 * (Q0{di} - Q1{di}), 0.125 * (Q2{di} - Q3{di})")
    return L


def qgamma(n, d):
    """(1/8) sum_a Q_ia Gamma_an from the pair sums A = (Q0 + Q1) / 8, D = (Q0 - Q1) / 8,
    C = (Q2 + Q3) / 8, E = (Q2 - Q3) / 8."""
    g = [GAMMA[a][n] for a in range(4)]
    first = ("A" if g[0] == g[1] else "D", g[0])
    second = ("C" if g[2] == g[3] else "E", g[2])
    return signed([(first[1], first[0] + d), (second[1], second[0] + d)])


def check_pairs():
    """HG_PAIRS and qgamma against GAMMA, numerically."""
    rng = np.random.default_rng(0)
    G = np.array(GAMMA, dtype=float)
    x = rng.normal(size=8)
    p = [x[2 * k] + x[2 * k + 1] for k in range(4)]
    d = [x[2 * k] - x[2 * k + 1] for k in range(4)]
    for a in range(4):
        kind, sg = HG_PAIRS[a]
        got = sum(sg[k] * (p if kind == "p" else d)[k] for k in range(4))
        assert abs(got - G[a] @ x) < 1e-12, a
    q = rng.normal(size=4)
    env = {"Ax": (q[0] + q[1]) / 8, "Dx": (q[0] - q[1]) / 8, "Cx": (q[2] + q[3]) / 8,
           "Ex": (q[2] - q[3]) / 8}
    for n in range(8):
        assert abs(eval(qgamma(n, "x"), {}, env) - q @ G[:, n] / 8) < 1e-12, n


def gen():
    check_pairs()
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
HK = HGW + 1  # 49 rows: scratch of kinematics_block (12) and forces_block (49)
HROWS = HK + 49


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

# inlined into the caller (hex8.hex_update): called, each call passed its dozen arrays as
# about 100 scalar arguments, twice per block (3 ns per hex, session 9)
@numba.njit(cache=True, inline="always", error_model="numpy")
def load_block(x, v, conn, sdev, pressure, energy, vol, elem_mass, hg, hg_visc, hg_stiff, e0,
               buf, stiff):
    """Copy the data of hexes e0 .. e0 + B - 1 into the block buffer (views of the block, as
    element._load_block); the stiffness resultants only when the block has the stiffness form
    (`stiff`), else those rows are left as they are: forces_block's viscous form neither reads
    nor writes them (the viscous form, the default, thus moves 192 bytes less per hex, and
    does not zero 12 rows per block either: 2-4 ns per hex, session 9)."""
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
    K = kinematics_lines(ind)
    A = K.append
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
    # ---- pressure, stress and hourglass forces, in one loop
    w_loop, rate_loop, coef, q_stiff, q_visc, f_loop = hourglass_lines()
    P(PRESSURE)
    for lp in (w_loop, rate_loop):
        P("    for i in range(B):\n" + "\n".join(ind + ln for ln in lp) + "\n")
    P("    for i in range(B):\n" + ind + "vnew = buf[R_DET * B + i] * (1.0 / 6.0)\n")
    P(PRESSURE_BODY)
    P("\n".join(ind + ln for ln in coef) + "\n")
    P("    if stiff:\n        for i in range(B):\n"
      + "\n".join(ind + "    " + ln for ln in q_stiff) + "\n")
    P("    else:\n        for i in range(B):\n"
      + "\n".join(ind + "    " + ln for ln in q_visc) + "\n")
    P("    for i in range(B):\n" + "\n".join(ind + ln for ln in f_loop) + "\n")
    P('''

# inlined into the caller (hex8.hex_update): called, each call passed its dozen arrays as
# about 100 scalar arguments, twice per block (3 ns per hex, session 9)
@numba.njit(cache=True, inline="always", error_model="numpy")
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
''')
    return "".join(src)


STAMPED = ("impactsim/solver/hex8.py", "benchmarks/hex_parts.py")


def stamp(text: str) -> None:
    """Write the digest of the new hex8_block.py into the BLOCK_SOURCE line of the files that
    compile its functions into their own (STAMPED): numba keys a cached function by its own
    file's contents only, so without it hex8.hex_update would load its old machine code from
    the cache after hex8_block.py changed."""
    root = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    for name in STAMPED:
        path = root / name
        src = path.read_text()
        if not re.search(r'^BLOCK_SOURCE = "[0-9a-f]*"', src, flags=re.M):
            raise SystemExit(f"{name} has no BLOCK_SOURCE line")
        path.write_text(re.sub(r'^BLOCK_SOURCE = "[0-9a-f]*"', f'BLOCK_SOURCE = "{digest}"',
                               src, count=1, flags=re.M))


if __name__ == "__main__":
    out = Path(__file__).resolve().parents[1] / "impactsim" / "solver" / "hex8_block.py"
    text = gen()
    out.write_text(text)
    stamp(text)
    print(f"wrote {out} (and the BLOCK_SOURCE lines of {', '.join(STAMPED)})")
