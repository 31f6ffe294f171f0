"""The one-point 8-node hexahedron with Flanagan-Belytschko hourglass control.

Flanagan, D.P. & Belytschko, T. (1981), "A uniform strain hexahedron and quadrilateral with
orthogonal hourglass control", IJNME 17:679-706 [FB81]; ALGORITHMS.md 7.1. The formulas below
are FB81's in its notation (uniform strain B = (1/V) dV/dx with the exact volume, the
hourglass base and shape vectors, the viscous and stiffness resultants); the paper was not at
hand to check its equation numbers, so they are named by content, each tested
(tests/unit/test_hex8.py).

Nodes in the VTK / standard order: 0-3 the face zeta = -1 counter-clockwise seen from zeta > 0,
4-7 the face zeta = +1 above them.

Per element (`_hex_element`), with x^{n+1} and the step's velocity U^{n+1/2}:
- b_iI = dV/dx_iI, the gradient of the exact volume V = sum_I x_I b_xI (V is linear in the
  x-coordinates alone; FB81's closed form of dV/dx, grouped as in LULESH's `VoluDer`;
  `_volume_gradient`, tested against central differences of the Gauss-integrated volume);
  the uniform (mean) strain gradient is B_iI = b_iI / V;
- the velocity gradient L_ij = sum_I v_iI B_jI on the mid-step geometry x^{n+1} - dt/2 U
  (as the tet, ALGORITHMS.md 1), the Jaumann trial deviator, the radial return, the EOS with the
  energy integrated implicitly and the bulk viscosity: the same pointwise laws as the tets
  (materials/laws.py; `element._jaumann_trial`, `element._deviator`, the radial return of
  `element._return_map`, and `element._deviatoric_work`, shared with the tet's scalar path);
- nodal forces f_iI = -sigma_ij b_jI, at x^{n+1};
- hourglass control (FB81 section 4): base vectors Gamma_alpha, shape vectors
  gamma_alpha = (1/8) [Gamma_alpha - (1/V) (Gamma_alpha . x_i) b_i] (FB81's
  1/8 in front), orthogonal to every linear field (sum_I gamma_aI = 0, sum_I gamma_aI x_jI = 0);
  hourglass rates qdot_ia = sum_I v_iI gamma_aI and generalized forces Q_ia with nodal
  forces f_iI = -sum_a Q_ia gamma_aI. Viscous form:
  Q_ia = c_v rho c V^{2/3} qdot_ia; stiffness form: Q accumulated,
  dQ_ia = c_s dt (K + 4G/3) / (3 V) (sum_jI b_jI b_jI) qdot_ia. Both coefficients may be given
  (per element; from the body's `hourglass` / `hourglass_coefficient`). The hourglass power
  Q . qdot is integrated with the mid-step value of the stiffness part (trapezoid, as the
  deviatoric work of the tets) and booked in Model.energy_terms["hourglass"] (history column
  `hourglass_energy`, part of total_energy). The stiffness Q is kept in the global frame (not
  rotated with the element); for the small hourglass resultants of a controlled mesh the
  difference is of second order;
- the stable step L / (Q + sqrt(Q^2 + c^2)) with L = V / (largest face area), the
  characteristic length of the one-point hex of LS-DYNA and Hallquist's notes, c the EOS sound
  speed with 4G/3rho; the bulk viscosity uses the same L.

Determinism: the elements run in parts of `part_size` consecutive hexes, one thread per part,
each corner adding to its (node, part) row of an fext of the block's own
(`scatter.force_rows` with 8 corners); each node's rows are added to `force` in part order
after the tets' sum (at the end of `hex_update`). The result is the same on any number of threads.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from impactsim.materials import params as P
from impactsim.materials.laws import eos_linear_part
from impactsim.model import DAMAGED, ERODED, FRACTURED
from impactsim.solver import element as E
from impactsim.solver import hex8_block as HB
from impactsim.solver import vecmath as VM
from impactsim.solver.element import FAST, _deviator, _deviatoric_work, _jaumann_trial
from impactsim.solver.hex8_block import _vol_der
from impactsim.solver.scatter import take_node

B = E.B  # lanes of a block of the vector path (hex8_block.py)
CHUNK = 256  # hexes per reduction chunk (a multiple of B)
PART = 4 * CHUNK  # hexes per part (the unit of work of a thread)
OUT_DT, OUT_QWORK, OUT_INVERTED, OUT_WORST, OUT_HGWORK = 0, 1, 2, 3, 4
N_OUT = 5
SCRATCH = 8 * 3 * 4 + 8  # per-thread work space of `_hex_element`
# the digest of hex8_block.py, written by scripts/gen_hex8_block.py: numba keys the cache of a
# function by its own file's contents, and hex_update compiles the block functions into itself,
# so this line changes this file whenever they change (else a stale hex_update is loaded)
BLOCK_SOURCE = "6a9859e1f3a00d65"

#: the hourglass base vectors, rows alpha = 0..3, columns the 8 nodes
GAMMA = np.array([[1.0, 1.0, -1.0, -1.0, -1.0, -1.0, 1.0, 1.0],
                  [1.0, -1.0, -1.0, 1.0, -1.0, 1.0, 1.0, -1.0],
                  [1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0],
                  [-1.0, 1.0, -1.0, 1.0, 1.0, -1.0, 1.0, -1.0]])
# the faces of the hex, outward (counter-clockwise seen from outside), VTK numbering
FACES = np.array([[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6],
                  [3, 0, 4, 7]], dtype=np.int64)
# the 12 edges
EDGES = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4], [0, 4],
                  [1, 5], [2, 6], [3, 7]], dtype=np.int64)


def n_chunks(n_elem: int) -> int:
    return max(1, (n_elem + CHUNK - 1) // CHUNK)


# for node I: the six nodes whose coordinates enter dV/dx_I, in `_vol_der`'s order
_VD = ((1, 2, 3, 4, 5, 7), (2, 3, 0, 5, 6, 4), (3, 0, 1, 6, 7, 5), (0, 1, 2, 7, 4, 6),
       (7, 6, 5, 0, 3, 1), (4, 7, 6, 1, 0, 2), (5, 4, 7, 2, 1, 3), (6, 5, 4, 3, 2, 0))
VD = np.array(_VD, dtype=np.int64)


@numba.njit(cache=True, inline="always", error_model="numpy", fastmath=FAST)
def _volume_gradient(p, b):
    """b[3 I + i] = dV/dx_iI of the hex with corners p[3 I + i]; returns the exact
    volume V = sum_I x_I b_xI."""
    for n in range(8):
        a0, a1, a2, a3, a4, a5 = VD[n, 0], VD[n, 1], VD[n, 2], VD[n, 3], VD[n, 4], VD[n, 5]
        bx, by, bz = _vol_der(p[3 * a0], p[3 * a1], p[3 * a2], p[3 * a3], p[3 * a4], p[3 * a5],
                              p[3 * a0 + 1], p[3 * a1 + 1], p[3 * a2 + 1], p[3 * a3 + 1],
                              p[3 * a4 + 1], p[3 * a5 + 1],
                              p[3 * a0 + 2], p[3 * a1 + 2], p[3 * a2 + 2], p[3 * a3 + 2],
                              p[3 * a4 + 2], p[3 * a5 + 2])
        b[3 * n] = bx
        b[3 * n + 1] = by
        b[3 * n + 2] = bz
    vol = 0.0
    for n in range(8):
        vol += p[3 * n] * b[3 * n]
    return vol


@numba.njit(cache=True, inline="always", error_model="numpy", fastmath=FAST)
def _max_face_area2(p):
    """The largest (area vector)^2 of the six faces, each as half the cross product of its
    diagonals (exact for a plane quad, the projected area of a warped one)."""
    amax = 0.0
    for f in range(6):
        a, b, c, d = FACES[f, 0], FACES[f, 1], FACES[f, 2], FACES[f, 3]
        ux, uy, uz = p[3 * c] - p[3 * a], p[3 * c + 1] - p[3 * a + 1], p[3 * c + 2] - p[3 * a + 2]
        vx, vy, vz = p[3 * d] - p[3 * b], p[3 * d + 1] - p[3 * b + 1], p[3 * d + 2] - p[3 * b + 2]
        cx, cy, cz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        a2 = 0.25 * (cx * cx + cy * cy + cz * cz)
        amax = max(amax, a2)
    return amax


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def _hex_element(e, x, v, conn, elem_mat, status, sdev, pressure, q, eps_p, eps_rate,
                 temperature, hard, thermal, energy, vol, elem_mass, hg, hg_visc, hg_stiff,
                 mat_params, half, dt, cq, cl, rows, fext, w):
    """The whole update of hex e (module docstring); adds its 8 corner forces to its rows of
    fext. w: the thread's scratch (SCRATCH doubles). Returns (stable dt, viscous work -q dV,
    1 if inverted, hourglass work)."""
    st = status[e]
    if st == ERODED:
        return math.inf, 0.0, 0, 0.0
    p = w[0:24]  # x^{n+1}, then the mid-step geometry
    vv = w[24:48]
    b = w[48:72]
    f = w[72:96]
    gm = w[96:104]  # gamma_a of the current mode
    # --- mid-step geometry and the velocity gradient L = sum_I v_I (x) b_I / V
    for n in range(8):
        node = conn[e, n]
        for d in range(3):
            vv[3 * n + d] = v[node, d]
            p[3 * n + d] = x[node, d] - half * v[node, d]
    vh = _volume_gradient(p, b)
    inv = 1.0 / vh if vh > 0.0 else 0.0
    lxx = lxy = lxz = lyx = lyy = lyz = lzx = lzy = lzz = 0.0
    for n in range(8):
        bx, by, bz = b[3 * n], b[3 * n + 1], b[3 * n + 2]
        ux, uy, uz = vv[3 * n], vv[3 * n + 1], vv[3 * n + 2]
        lxx += ux * bx
        lxy += ux * by
        lxz += ux * bz
        lyx += uy * bx
        lyy += uy * by
        lyz += uy * bz
        lzx += uz * bx
        lzy += uz * by
        lzz += uz * bz
    lxx *= inv
    lxy *= inv
    lxz *= inv
    lyx *= inv
    lyy *= inv
    lyz *= inv
    lzx *= inv
    lzy *= inv
    lzz *= inv
    trd = lxx + lyy + lzz
    third = trd / 3.0
    exx, eyy, ezz = lxx - third, lyy - third, lzz - third
    dxy, dyz, dzx = 0.5 * (lxy + lyx), 0.5 * (lyz + lzy), 0.5 * (lzx + lxz)
    wxy, wyz, wzx = 0.5 * (lxy - lyx), 0.5 * (lyz - lzy), 0.5 * (lzx - lxz)
    # --- geometry at n+1
    for n in range(8):
        node = conn[e, n]
        for d in range(3):
            p[3 * n + d] = x[node, d]
    vnew = _volume_gradient(p, b)
    if not vnew > 0.0:
        return math.inf, 0.0, 1, 0.0
    length = vnew / math.sqrt(max(_max_face_area2(p), 1e-300))
    vold = vol[e]
    mk = elem_mat[e]
    mass = elem_mass[e]
    rho = mass / vnew
    rho0 = mat_params[mk, P.RHO0]
    shear = mat_params[mk, P.G]
    bulk = mat_params[mk, P.K]
    # --- deviatoric stress: Jaumann rate, radial return (as the tets)
    sxx, syy, szz = sdev[e, 0], sdev[e, 1], sdev[e, 2]
    sxy, syz, szx = sdev[e, 3], sdev[e, 4], sdev[e, 5]
    nxx, nyy, nzz, nxy, nyz, nzx = _jaumann_trial(sxx, syy, szz, sxy, syz, szx, exx, eyy, ezz,
                                                   dxy, dyz, dzx, wxy, wyz, wzx, 2.0 * shear, dt)
    rate = math.sqrt(max((2.0 / 3.0) * (exx * exx + eyy * eyy + ezz * ezz
                                        + 2.0 * (dxy * dxy + dyz * dyz + dzx * dzx)), 0.0))
    eps_rate[e] = rate
    code = int(mat_params[mk, P.STRENGTH])
    nxx, nyy, nzz, nxy, nyz, nzx = _deviator(st, code, mat_params, mk, shear, nxx, nyy, nzz,
                                             nxy, nyz, nzx, rate, eps_p, temperature, hard,
                                             thermal, e, rho)
    wdev = _deviatoric_work(dt, vold, vnew, sxx, syy, szz, sxy, syz, szx, nxx, nyy, nzz, nxy,
                            nyz, nzx, exx, eyy, ezz, dxy, dyz, dzx)
    sdev[e, 0], sdev[e, 1], sdev[e, 2] = nxx, nyy, nzz
    sdev[e, 3], sdev[e, 4], sdev[e, 5] = nxy, nyz, nzx
    # --- pressure: EOS with the energy integrated implicitly (p = a + b e), bulk viscosity
    pa, pb, c2a, c2b = eos_linear_part(int(mat_params[mk, P.EOS]), rho, rho0, bulk,
                                       mat_params[mk, P.C0], mat_params[mk, P.S],
                                       mat_params[mk, P.GAMMA0])
    pold = pressure[e]
    dv = vnew - vold
    c = math.sqrt(max(c2a + c2b * max(pold, 0.0), 0.0))
    qn = 0.0
    if trd < 0.0 and st != FRACTURED:
        qn = rho * length * (cq * cq * length * trd * trd - cl * c * trd)
    base = energy[e] + (wdev - dv * (0.5 * pold + qn)) / mass
    if st == FRACTURED:
        pn = 0.0
        enew = base
    else:
        k = 0.5 * dv / mass
        enew = (base - k * pa) / (1.0 + k * pb)
        pn = pa + pb * enew
        if st == DAMAGED and pn < 0.0:
            pn = 0.0
            enew = base
    energy[e] = enew
    pressure[e] = pn
    q[e] = qn
    vol[e] = vnew
    # --- stable step
    c2 = max(c2a + c2b * max(pn, 0.0), 0.0)
    if st == 0:
        c2 += 4.0 * shear / (3.0 * rho)
    c = math.sqrt(c2)
    qq = cl * c + cq * cq * length * (-trd) if trd < 0.0 else 0.0
    limits = st != FRACTURED and (c2 > 0.0 or qq > 0.0)
    dte = length / (qq + math.sqrt(qq * qq + c2)) if limits else math.inf
    # --- stress forces f_I = -sigma b_I
    ptot = pn + qn
    txx, tyy, tzz = nxx - ptot, nyy - ptot, nzz - ptot
    for n in range(8):
        bx, by, bz = b[3 * n], b[3 * n + 1], b[3 * n + 2]
        f[3 * n] = -(txx * bx + nxy * by + nzx * bz)
        f[3 * n + 1] = -(nxy * bx + tyy * by + nyz * bz)
        f[3 * n + 2] = -(nzx * bx + nyz * by + tzz * bz)
    # --- hourglass control (FB81 section 4)
    cv, cs = hg_visc[e], hg_stiff[e]
    hgwork = 0.0
    if cv > 0.0 or cs > 0.0:
        vinv = 1.0 / vnew
        bb = 0.0
        for n in range(24):
            bb += b[n] * b[n]
        # sound speed of the hourglass forms: the EOS one with 4G/3rho, also for damaged
        # elements (the mesh still needs its control there)
        chg = math.sqrt(max(c2a + c2b * max(pn, 0.0), 0.0) + 4.0 * shear / (3.0 * rho))
        kv = cv * rho * chg * VM.pow_two_thirds(vnew)
        ks = cs * dt * (bulk + 4.0 * shear / 3.0) * bb * vinv / 3.0
        for a in range(4):
            hx = hy = hz = 0.0  # Gamma_a . x_i
            for n in range(8):
                g = GAMMA[a, n]
                hx += g * p[3 * n]
                hy += g * p[3 * n + 1]
                hz += g * p[3 * n + 2]
            hx *= vinv
            hy *= vinv
            hz *= vinv
            rx = ry = rz = 0.0  # qdot_ia = sum_I v_iI gamma_aI
            for n in range(8):
                gam = 0.125 * (GAMMA[a, n] - (hx * b[3 * n] + hy * b[3 * n + 1]
                                              + hz * b[3 * n + 2]))
                gm[n] = gam
                rx += vv[3 * n] * gam
                ry += vv[3 * n + 1] * gam
                rz += vv[3 * n + 2] * gam
            s0x = s0y = s0z = 0.0  # the stiffness resultants exist with the stiffness form
            if cs > 0.0:
                s0x, s0y, s0z = hg[e, 3 * a], hg[e, 3 * a + 1], hg[e, 3 * a + 2]
            s1x, s1y, s1z = s0x + ks * rx, s0y + ks * ry, s0z + ks * rz
            if cs > 0.0:
                hg[e, 3 * a], hg[e, 3 * a + 1], hg[e, 3 * a + 2] = s1x, s1y, s1z
            qx, qy, qz = s1x + kv * rx, s1y + kv * ry, s1z + kv * rz
            hgwork += dt * ((0.5 * (s0x + s1x) + kv * rx) * rx + (0.5 * (s0y + s1y) + kv * ry) * ry
                            + (0.5 * (s0z + s1z) + kv * rz) * rz)
            for n in range(8):
                gam = gm[n]
                f[3 * n] -= qx * gam
                f[3 * n + 1] -= qy * gam
                f[3 * n + 2] -= qz * gam
    for n in range(8):
        r = rows[e, n]
        fext[r, 0] += f[3 * n]
        fext[r, 1] += f[3 * n + 1]
        fext[r, 2] += f[3 * n + 2]
    return dte, -qn * dv, 0, hgwork


@numba.njit(cache=True, inline="always", error_model="numpy")
def _vector_block(elem_mat, status, e0):
    """The block's material row if it can take the vector path (all intact, one material)."""
    mat = elem_mat[e0:e0 + B]
    st = status[e0:e0 + B]
    mk = mat[0]
    for i in range(B):
        if st[i] != 0 or mat[i] != mk:
            return -1
    return mk


# nogil: the frame writer's thread runs while the kernel does (as element.element_update)
@numba.njit(cache=True, parallel=True, nogil=True, error_model="numpy", fastmath=FAST)
def hex_update(x, v, conn, elem_mat, status, sdev, pressure, q, eps_p, eps_rate, temperature,
               hard, thermal, energy, vol, elem_mass, hg, hg_visc, hg_stiff, mat_params, dt, cq,
               cl, force, rows, fext, extra_ptr, extra_rows, part_chunks, chunk_out, threads,
               assign):
    """Advance every hex of a block from n to n+1 and ADD its nodal forces to `force` (after
    the tets' element update has written it; with `assign` they are written instead, for the
    first block of a model without tets). fext must be zero on entry and is left zero. Per chunk of CHUNK hexes, chunk_out holds
    [min stable dt, viscous work, inverted count, element of min dt, hourglass work].
    Parts of `part_chunks` chunks run one per thread (part t, t + T, ... on thread t of
    T = `threads`), every corner adds to its row of `fext` (`scatter.force_rows(conn, n_node,
    part_chunks * CHUNK)` for the (n, 8) conn), and each node's rows are added to force in part
    order: the same bits on any
    number of threads."""
    n_elem = conn.shape[0]
    half = 0.5 * dt
    n_ch = (n_elem + CHUNK - 1) // CHUNK
    n_parts = (n_ch + part_chunks - 1) // part_chunks
    for t in numba.prange(threads):
        w = np.empty(SCRATCH)
        buf = E.aligned_empty(HB.HROWS * B)  # the block buffer of the vector path
        for part in range(t, n_parts, threads):
            for ch in range(part * part_chunks, min(n_ch, (part + 1) * part_chunks)):
                dt_min = math.inf
                worst = -1
                qwork = 0.0
                hgwork = 0.0
                inverted = 0
                e_end = min(n_elem, (ch + 1) * CHUNK)
                for e0 in range(ch * CHUNK, e_end, B):
                    mk = _vector_block(elem_mat, status, e0) if e0 + B <= e_end else -1
                    # the vector path (hex8_block.py), its steps called from here: called
                    # through a function of their own, which took the arrays and called the
                    # block functions, each block paid an NRT incref and decref of about 20
                    # arrays (numba cannot prune them across the calls)
                    if mk >= 0:
                        # arrays of the block E.PF_AHEAD blocks on that the hardware
                        # prefetchers miss: the yield-floor caches, read after the kinematics,
                        # and q, eps_rate, written without being read (4 ns per hex); and the
                        # other one-value-per-hex arrays, into L2 only (into L1 they evicted
                        # the block buffer's rows: slower; into L2 5 ns per hex faster; sdev,
                        # conn and rows gained nothing: the hardware follows those)
                        for o in range(0, B, 8):  # a cache line each
                            ahead = min(e0 + E.PF_AHEAD * B + o, n_elem - 1)
                            VM.prefetch(hard, ahead)
                            VM.prefetch(thermal, ahead)
                            VM.prefetch_write(q, ahead)
                            VM.prefetch_write(eps_rate, ahead)
                            VM.prefetch_l2(pressure, ahead)
                            VM.prefetch_l2(energy, ahead)
                            VM.prefetch_l2(vol, ahead)
                            VM.prefetch_l2(elem_mass, ahead)
                            VM.prefetch_l2(hg_visc, ahead)
                            VM.prefetch_l2(hg_stiff, ahead)
                            VM.prefetch_l2(eps_p, ahead)
                            VM.prefetch_l2(temperature, ahead)
                        stiff = False
                        for i in range(B):
                            if hg_stiff[e0 + i] > 0.0:
                                stiff = True
                        HB.load_block(x, v, conn, sdev, pressure, energy, vol, elem_mass, hg,
                                      hg_visc, hg_stiff, e0, buf, stiff)
                        shear = mat_params[mk, P.G]
                        HB.kinematics_block(buf, half, dt, shear)
                        intact = True
                        for i in range(B):
                            if not buf[E.R_DET * B + i] > 0.0:
                                intact = False
                        if intact:  # else the scalar path redoes the block and counts it
                            code = int(mat_params[mk, P.STRENGTH])
                            if code == P.JOHNSON_COOK and mat_params[mk, P.JC_C] >= 0.0:
                                # `element._jc_return_block`'s three parts called from here,
                                # as the tets' `_chunk` does: through that function each
                                # block paid an NRT incref and decref of its six arrays
                                if E._jc_load(buf, eps_p, temperature, hard, thermal, e0):
                                    if E._jc_lanes(buf, mat_params, mk, shear):
                                        E._jc_store(buf, eps_p, temperature, hard, thermal, e0)
                            elif code != P.ELASTIC:
                                E._return_block(buf, code, mat_params, mk, shear, eps_p,
                                                temperature, hard, thermal, e0)
                            HB.forces_block(buf, dt, int(mat_params[mk, P.EOS]),
                                            mat_params[mk, P.RHO0], mat_params[mk, P.K],
                                            mat_params[mk, P.C0], mat_params[mk, P.S],
                                            mat_params[mk, P.GAMMA0], shear, cq, cl,
                                            stiff)
                            bdt, bworst, bq, bhg = HB.store_block(
                                rows, sdev, pressure, q, eps_rate, energy, vol, hg, fext, e0,
                                buf, stiff)
                            qwork += bq
                            hgwork += bhg
                            if bdt < dt_min:
                                dt_min = bdt
                                worst = bworst
                            continue
                    for e in range(e0, min(e0 + B, e_end)):
                        dte, qw, inv, hw = _hex_element(
                            e, x, v, conn, elem_mat, status, sdev, pressure, q, eps_p,
                            eps_rate, temperature, hard, thermal, energy, vol, elem_mass, hg,
                            hg_visc, hg_stiff, mat_params, half, dt, cq, cl, rows, fext, w)
                        qwork += qw
                        hgwork += hw
                        inverted += inv
                        if dte < dt_min:
                            dt_min = dte
                            worst = e
                chunk_out[ch, OUT_DT] = dt_min
                chunk_out[ch, OUT_QWORK] = qwork
                chunk_out[ch, OUT_INVERTED] = inverted
                chunk_out[ch, OUT_WORST] = worst
                chunk_out[ch, OUT_HGWORK] = hgwork
    for i in numba.prange(force.shape[0]):
        fx, fy, fz = take_node(i, fext, extra_ptr, extra_rows)
        if assign:
            force[i, 0] = fx
            force[i, 1] = fy
            force[i, 2] = fz
        else:
            force[i, 0] += fx
            force[i, 1] += fy
            force[i, 2] += fz


def hex_volume_gradient(points: np.ndarray) -> tuple[np.ndarray, float]:
    """b (8, 3) = dV/dx and the exact volume V of one hex (corners (8, 3)), for tests and the
    mesh tools."""
    p = np.ascontiguousarray(points, dtype=np.float64).reshape(24)
    b = np.empty(24)
    vol = _volume_gradient_py(p, b)
    return b.reshape(8, 3), vol


@numba.njit(cache=True)
def _volume_gradient_py(p, b):
    return _volume_gradient(p, b)


@numba.njit(cache=True)
def hex_volumes(x, conn):
    """Exact volumes of hexes (n, 8) at positions x [m^3]."""
    out = np.empty(conn.shape[0])
    p = np.empty(24)
    b = np.empty(24)
    for e in range(conn.shape[0]):
        for n in range(8):
            for d in range(3):
                p[3 * n + d] = x[conn[e, n], d]
        out[e] = _volume_gradient(p, b)
    return out
