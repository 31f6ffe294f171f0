"""The element update of the explicit scheme (ALGORITHMS.md 1-2) for 4-node tetrahedra.

Per element: geometry at x^{n+1}, velocity gradient on the mid-step configuration
x^{n+1/2} = x^{n+1} - dt/2 U^{n+1}, hypoelastic Jaumann update of the deviator, radial return,
EOS pressure with the per-element internal energy integrated implicitly in e, bulk artificial
viscosity, the element's nodal forces and its stable time step. Each element adds its corner
forces to the rows of its nodes (`scatter.py`).

Elements are processed in chunks of CHUNK (the unit of the reductions: time step, viscous work,
inverted elements, summed in chunk order so that results do not depend on the number of
threads), and the chunks in parts of PART elements, the unit of work of a thread. Every
(node, part) pair has a force row of its own, each part runs on one thread in element order,
and each node's rows are summed in part order at the end: no two threads add to one row, and
every node sums its elements in the same order whatever the number of threads. Inside a chunk,
blocks of B elements go down one of two paths:

- the vector path, for a full block of intact elements of one material (nearly every block of a
  real mesh): the block's node and element data are copied into a (rows x B) buffer
  (`_load_block`), the arithmetic runs as loops over the B lanes that LLVM turns into packed
  SIMD instructions (`_kinematics_block`: velocity gradient, geometry, trial stress;
  `_pressure_block`: EOS, energy, viscosity, time step, forces); the radial return runs for
  Johnson-Cook as vector loops too (`_jc_return_block`, with the lane functions ln and exp of
  `vecmath`, so each Newton iteration is one loop), for other strength models as a scalar loop
  (`_return_block`), and in both only for lanes whose trial stress exceeds the
  rate-independent lower bound of their yield stress, cached per element; the results are
  copied back and the forces added to the nodes (`_store_block`);
- the scalar path (`_element_scalar`), one element at a time with every branch: damaged,
  fractured and eroded elements, blocks that mix materials, the partial block at the end of
  the mesh, and a block with an inverted element.
Both paths compute the same formulas (equal to round-off, tested); which one an element takes
depends only on its block's content, never on the thread count.

The vector loops are separate small functions on purpose: LLVM vectorises a loop whose only
memory is the block buffer with a constant trip count B (no aliasing to check at run time), and
does not vectorise the same loop inside the big parallel function. `math.sqrt` gets an argument
LLVM can prove non-negative (`max(x, 0.0)`) where it is not obviously so, else it stays a libm
call. See docs/performance.md.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from impactsim.materials import params as P
from impactsim.materials.laws import (eos_linear_part, hardening, newton_start,
                                      newton_step_converged, power_near, radial_return,
                                      rate_independent_floor, thermal_factor)
from impactsim.model import DAMAGED, ERODED, FRACTURED
from impactsim.solver import guard as G
from impactsim.solver import vecmath as VM
from impactsim.solver.scatter import take_node
from impactsim.solver.workqueue import fetch_add

DAMAGED_F, FRACTURED_F = float(DAMAGED), float(FRACTURED)  # as row R_STAT holds them

CHUNK = 512
PART = 4 * CHUNK  # elements of a part (scatter.py), the unit of work of a thread
B = G.LANES  # 32 lanes of a block; the buffer (ROWS x B doubles, 23 kB) stays in the L1 cache
# IEEE semantics are kept (no nnan/ninf: inf marks "no limit"); numpy's error model drops the
# zero-division checks that Python semantics would put on every division.
FAST = G.FAST  # {"nsz", "arcp", "contract", "afn", "reassoc"}
# columns of the per-chunk reduction array
OUT_DT, OUT_QWORK, OUT_INVERTED, OUT_WORST = 0, 1, 2, 3
OUT_DEFERRED = 4  # the chunk's blocks left to `_deferred_chunk`, a bit mask (block b: 2^b)
N_OUT = 5

# rows of the block buffer: row r of lane i is buf[r * B + i]
R_X = 0  # 12 rows: x^{n+1} of corners 0..3 (x, y, z each)
R_V = 12  # 12 rows: U^{n+1} of corners 0..3
R_S0 = 24  # 6 rows: deviatoric stress at n (xx, yy, zz, xy, yz, zx)
R_VOLD = 30  # volume at n
# row 31 unused (the EOS volume at n was copied here and never read)
R_MASS = 32
R_EN = 33  # specific internal energy at n
R_POLD = 34  # pressure at n
R_VEOS = 35  # ANP: the mean of the corners' nodal volume ratios times V0
R_B = 36  # 9 rows: b_1, b_2, b_3 = 6 V grad N_1..3 at n+1
R_DET = 45  # 6 V at n+1
R_D = 46  # 6 rows: deviatoric strain rate xx, yy, zz and D xy, yz, zx
R_TRD = 52  # tr D
R_LEN = 53  # characteristic length 3V / max face area
R_SN = 54  # 6 rows: deviatoric stress at n+1 (trial, then returned)
R_SEQ = 60  # von Mises equivalent of the trial stress
R_RATE = 61  # effective deviatoric strain rate
R_PN = 62  # pressure at n+1
R_QN = 63  # bulk viscosity at n+1
R_EN1 = 64  # specific internal energy at n+1
R_DTE = 65  # stable time step
R_F = 66  # 12 rows: forces on corners 0..3
R_QW = 78  # viscous work of the step
# rows of the vector Johnson-Cook return (`_jc_return_block`)
R_EP = 79  # plastic strain (in), updated
R_TEMP = 80  # temperature (in), updated
R_HARD = 81  # hardening term A + B eps_p^n (in), updated
R_THERM = 82  # thermal factor 1 - T*^m (in), updated
R_ACT = 83  # 1 where the trial stress exceeds the yield stress at the step's rate
R_RT = 84  # rate factor x thermal factor
R_DEPS = 85  # plastic strain increment (Newton iterate)
R_LO = 86  # bracket of the increment
R_HI = 87
R_DONE = 88  # ITERATING, FINISHED (converged, or elastic), STALLED (see _jc_newton) or FIRST
#             (first yield, eps_p = 0: the scalar return takes it, `laws.first_yield_return`)
R_SY = 89  # yield stress at the end of the return
R_HN = 90  # hardening term at the end of the return
ROWS = 91  # the rows the hex kernel's buffer shares (hex8_block.py starts its own at ROWS)
# rows of the tet kernel's buffer only (`_block`'s masked passes)
R_STAT = ROWS  # status of the lane as a float: 0 intact, DAMAGED, FRACTURED (`_pressure_block`)
R_LIVE = ROWS + 1  # 1 for the lanes a masked pass computes and stores, else 0
TET_ROWS = ROWS + 2
# states of a lane in the vector return (row R_DONE)
ITERATING, FINISHED, STALLED, FIRST = 0.0, 1.0, 2.0, 3.0
# Newton iterations of the vector return; a lane not converged by then (a few per thousand
# yielding elements) is redone by the scalar return, so that one slow lane does not make the
# whole block iterate
VECTOR_ITERATIONS = 5
# lanes of a group in the vector return's loops (`_jc_start`, `_jc_newton`, `_jc_finish`): a
# group with no lane to work on is skipped (two 4-wide vectors with AVX2, one with AVX-512)
JG = 8
# blocks ahead that `_chunk` and hex8.hex_update prefetch: into every cache level the
# yield-floor caches (hard, thermal, read after the kinematics) and the write-only arrays (q,
# eps_rate; vol_eos for tets), into L2 the other one-value-per-element arrays (`vecmath`)
PF_AHEAD = 4


def n_chunks(n_elem: int) -> int:
    return max(1, (n_elem + CHUNK - 1) // CHUNK)


@numba.njit(cache=True, inline="always")
def aligned_empty(n):
    """An empty array of n doubles starting on a 64-byte boundary (a cache line), for the
    block buffers: their rows are 256 bytes, so every 64-byte vector load and store of a lane
    loop then stays inside one cache line (numba's np.empty aligns to 32 bytes only, and a load
    straddling two lines costs two)."""
    raw = np.empty(n + 8)
    off = ((64 - raw.ctypes.data % 64) % 64) // 8
    return raw[off:off + n]


@numba.njit(cache=True, inline="always", error_model="numpy", fastmath=FAST)
def _tet_gradients(x0, y0, z0, x1, y1, z1, x2, y2, z2, x3, y3, z3):
    """Shape-function gradients of a linear tet and six times its volume.

    With J = [x1-x0, x2-x0, x3-x0] (columns), grad N_i (i = 1..3) are the rows of J^{-1}:
    (d2 x d3, d3 x d1, d1 x d2) / det J, and grad N_0 = -(grad N_1 + grad N_2 + grad N_3).
    Returns det J (= 6 V) and the 9 components of grad N_1..3 (not yet divided by det J).
    """
    ax, ay, az = x1 - x0, y1 - y0, z1 - z0
    bx, by, bz = x2 - x0, y2 - y0, z2 - z0
    cx, cy, cz = x3 - x0, y3 - y0, z3 - z0
    # rows of adj(J): b x c, c x a, a x b
    g1x, g1y, g1z = by * cz - bz * cy, bz * cx - bx * cz, bx * cy - by * cx
    g2x, g2y, g2z = cy * az - cz * ay, cz * ax - cx * az, cx * ay - cy * ax
    g3x, g3y, g3z = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    det = ax * g1x + ay * g1y + az * g1z
    return det, g1x, g1y, g1z, g2x, g2y, g2z, g3x, g3y, g3z


@numba.njit(cache=True, inline="always", error_model="numpy", fastmath=FAST)
def _velocity_gradient(p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z, p3x, p3y, p3z,
                       v0x, v0y, v0z, v1x, v1y, v1z, v2x, v2y, v2z, v3x, v3y, v3z, half):
    """L = dv/dx on the mid-step geometry x^{n+1} - dt/2 U^{n+1}, split into the deviatoric
    strain rate D' (xx, yy, zz), D (xy, yz, zx), the spin W = (L - L^T)/2 (xy, yz, zx) and tr D.
    L_ij = sum_a (v_a - v_0)_i dN_a/dx_j over corners a = 1..3."""
    det, a1x, a1y, a1z, a2x, a2y, a2z, a3x, a3y, a3z = _tet_gradients(
        p0x - half * v0x, p0y - half * v0y, p0z - half * v0z,
        p1x - half * v1x, p1y - half * v1y, p1z - half * v1z,
        p2x - half * v2x, p2y - half * v2y, p2z - half * v2z,
        p3x - half * v3x, p3y - half * v3y, p3z - half * v3z)
    w1x, w1y, w1z = v1x - v0x, v1y - v0y, v1z - v0z
    w2x, w2y, w2z = v2x - v0x, v2y - v0y, v2z - v0z
    w3x, w3y, w3z = v3x - v0x, v3y - v0y, v3z - v0z
    inv = 1.0 / det if det != 0.0 else 0.0
    lxx = (w1x * a1x + w2x * a2x + w3x * a3x) * inv
    lxy = (w1x * a1y + w2x * a2y + w3x * a3y) * inv
    lxz = (w1x * a1z + w2x * a2z + w3x * a3z) * inv
    lyx = (w1y * a1x + w2y * a2x + w3y * a3x) * inv
    lyy = (w1y * a1y + w2y * a2y + w3y * a3y) * inv
    lyz = (w1y * a1z + w2y * a2z + w3y * a3z) * inv
    lzx = (w1z * a1x + w2z * a2x + w3z * a3x) * inv
    lzy = (w1z * a1y + w2z * a2y + w3z * a3y) * inv
    lzz = (w1z * a1z + w2z * a2z + w3z * a3z) * inv
    trd = lxx + lyy + lzz
    third = trd / 3.0
    return (lxx - third, lyy - third, lzz - third,
            0.5 * (lxy + lyx), 0.5 * (lyz + lzy), 0.5 * (lzx + lxz),
            0.5 * (lxy - lyx), 0.5 * (lyz - lzy), 0.5 * (lzx - lxz), trd)


@numba.njit(cache=True, inline="always", error_model="numpy", fastmath=FAST)
def _char_length(det1, b1x, b1y, b1z, b2x, b2y, b2z, b3x, b3y, b3z):
    """L = 3V / max face area (the smallest altitude): |grad N_a| det = 2 (area opposite a),
    so L = det / max_a |b_a| with b_0 = -(b_1 + b_2 + b_3)."""
    f1 = b1x * b1x + b1y * b1y + b1z * b1z
    f2 = b2x * b2x + b2y * b2y + b2z * b2z
    f3 = b3x * b3x + b3y * b3y + b3z * b3z
    s0x, s0y, s0z = b1x + b2x + b3x, b1y + b2y + b3y, b1z + b2z + b3z
    f0 = s0x * s0x + s0y * s0y + s0z * s0z
    return det1 / math.sqrt(max(max(f0, f1), max(f2, f3)))


@numba.njit(cache=True, inline="always", error_model="numpy", fastmath=FAST)
def _jaumann_trial(sxx, syy, szz, sxy, syz, szx, exx, eyy, ezz, dxy, dyz, dzx, wxy, wyz, wzx,
                   g2, dt):
    """Trial deviator s + dt (2G D' + W s - s W) (Jaumann rate; W skew with W_xy = wxy,
    W_yz = wyz, W_zx = wzx)."""
    rxx = 2.0 * (wxy * sxy - wzx * szx)
    ryy = 2.0 * (wyz * syz - wxy * sxy)
    rzz = 2.0 * (wzx * szx - wyz * syz)
    rxy = wxy * (syy - sxx) + wzx * syz - wyz * szx
    ryz = wyz * (szz - syy) + wxy * szx - wzx * sxy
    rzx = wzx * (sxx - szz) + wyz * sxy - wxy * syz
    return (sxx + dt * (g2 * exx + rxx), syy + dt * (g2 * eyy + ryy),
            szz + dt * (g2 * ezz + rzz), sxy + dt * (g2 * dxy + rxy),
            syz + dt * (g2 * dyz + ryz), szx + dt * (g2 * dzx + rzx))


@numba.njit(cache=True, inline="always", error_model="numpy", fastmath=FAST)
def _corner_forces(txx, tyy, tzz, txy, tyz, tzx, b1x, b1y, b1z, b2x, b2y, b2z, b3x, b3y, b3z):
    """Forces f_a = -V sigma grad N_a = -sigma b_a / 6 on corners 1..3 (V grad N_a = b_a / 6;
    corner 0 takes minus their sum)."""
    s6 = -1.0 / 6.0
    return (s6 * (txx * b1x + txy * b1y + tzx * b1z), s6 * (txy * b1x + tyy * b1y + tyz * b1z),
            s6 * (tzx * b1x + tyz * b1y + tzz * b1z),
            s6 * (txx * b2x + txy * b2y + tzx * b2z), s6 * (txy * b2x + tyy * b2y + tyz * b2z),
            s6 * (tzx * b2x + tyz * b2y + tzz * b2z),
            s6 * (txx * b3x + txy * b3y + tzx * b3z), s6 * (txy * b3x + tyy * b3y + tyz * b3z),
            s6 * (tzx * b3x + tyz * b3y + tzz * b3z))


@numba.njit(cache=True, inline="always", error_model="numpy", fastmath=FAST)
def _return_map(code, mat_params, mk, shear, seq, rate, eps_p, temperature, hard, thermal, e,
                rho):
    """Radial return of element e with its trial stress seq; updates eps_p, temperature and the
    element's cached hardening term and thermal factor. Returns (d eps_p, yield stress); d eps_p
    = 0 when elastic.

    hard x thermal is a rate-independent lower bound of the yield stress (the rate factor is
    >= 1): a trial stress at or below it is elastic, and the return (a log and a power for
    Johnson-Cook) is skipped. The caches change only here, with eps_p and the temperature.
    """
    if seq <= hard[e] * thermal[e] and rate_independent_floor(code, mat_params, mk):
        return 0.0, 0.0
    deps, sy, hnew = radial_return(code, mat_params, mk, shear, seq, eps_p[e], rate, hard[e],
                                   thermal[e])
    if deps > 0.0:
        eps_p[e] += deps
        temperature[e] += mat_params[mk, P.TQ] * sy * deps / (rho * mat_params[mk, P.CV])
        hard[e] = hnew
        thermal[e] = thermal_factor(code, mat_params, mk, temperature[e])
    return deps, sy


@numba.njit(cache=True, inline="always", error_model="numpy", fastmath=FAST)
def _deviator(st, code, mat_params, mk, shear, nxx, nyy, nzz, nxy, nyz, nzx, rate, eps_p,
              temperature, hard, thermal, e, rho):
    """The deviator at n+1 of one element from its Jaumann trial n..: zero for a damaged or
    fractured element (ALGORITHMS.md 4.1), the radial return of `_return_map` (which updates
    eps_p, temperature and the yield caches) for a plastic one. Shared by the tet's scalar
    path and the hex (solver/hex8.py)."""
    if st != 0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    if code != P.ELASTIC:
        j2 = 0.5 * (nxx * nxx + nyy * nyy + nzz * nzz) + nxy * nxy + nyz * nyz + nzx * nzx
        seq = math.sqrt(3.0 * j2)
        deps, sy = _return_map(code, mat_params, mk, shear, seq, rate, eps_p, temperature,
                               hard, thermal, e, rho)
        if deps > 0.0:
            scale = sy / seq if seq > 0.0 else 0.0
            return (nxx * scale, nyy * scale, nzz * scale, nxy * scale, nyz * scale,
                    nzx * scale)
    return nxx, nyy, nzz, nxy, nyz, nzx


@numba.njit(cache=True, inline="always", error_model="numpy", fastmath=FAST)
def _deviatoric_work(dt, vold, vnew, sxx, syy, szz, sxy, syz, szx, nxx, nyy, nzz, nxy, nyz, nzx,
                     exx, eyy, ezz, dxy, dyz, dzx):
    """Deviatoric work [J] over the step with the mid-step stress (s^n + s^{n+1}) / 2 and the
    mid-step volume."""
    return 0.5 * dt * (vold + vnew) * 0.5 * (
        (sxx + nxx) * exx + (syy + nyy) * eyy + (szz + nzz) * ezz
        + 2.0 * ((sxy + nxy) * dxy + (syz + nyz) * dyz + (szx + nzx) * dzx))


@numba.njit(cache=True, parallel=True)
def yield_cache(elem_mat, mat_params, eps_p, temperature, hard, thermal):
    """Fill the element kernel's caches: hardening term and thermal factor of every element at
    its plastic strain and temperature (`laws.hardening`, `laws.thermal_factor`)."""
    for e in numba.prange(elem_mat.shape[0]):
        mk = elem_mat[e]
        code = int(mat_params[mk, P.STRENGTH])
        hard[e] = hardening(code, mat_params, mk, eps_p[e])
        thermal[e] = thermal_factor(code, mat_params, mk, temperature[e])


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def _element_scalar(e, x, v, conn, elem_mat, status, sdev, pressure, q, eps_p, eps_rate,
                    temperature, hard, thermal, energy, vol, vol_eos, vol0, elem_mass, mat_params,
                    jnode, use_anp, half, dt, cq, cl, rows, fext):
    """The whole update of element e with every branch (the scalar path); adds its nodal forces
    to its rows `rows[e]` of `fext` (`scatter.force_rows`). Called, not inlined: inlined into
    the parallel loop it doubled the cold compile (time to the first step 22 -> 34 s).

    Returns (stable dt, viscous work -q dV, 1 if the element inverted else 0). An eroded or
    inverted element adds no force.
    """
    st = status[e]
    if st == ERODED:
        return math.inf, 0.0, 0
    i0, i1, i2, i3 = conn[e, 0], conn[e, 1], conn[e, 2], conn[e, 3]
    # --- velocities and the mid-step geometry: velocity gradient L = dv/dx^{n+1/2}
    v0x, v0y, v0z = v[i0, 0], v[i0, 1], v[i0, 2]
    v1x, v1y, v1z = v[i1, 0], v[i1, 1], v[i1, 2]
    v2x, v2y, v2z = v[i2, 0], v[i2, 1], v[i2, 2]
    v3x, v3y, v3z = v[i3, 0], v[i3, 1], v[i3, 2]
    p0x, p0y, p0z = x[i0, 0], x[i0, 1], x[i0, 2]
    p1x, p1y, p1z = x[i1, 0], x[i1, 1], x[i1, 2]
    p2x, p2y, p2z = x[i2, 0], x[i2, 1], x[i2, 2]
    p3x, p3y, p3z = x[i3, 0], x[i3, 1], x[i3, 2]
    exx, eyy, ezz, dxy, dyz, dzx, wxy, wyz, wzx, trd = _velocity_gradient(
        p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z, p3x, p3y, p3z,
        v0x, v0y, v0z, v1x, v1y, v1z, v2x, v2y, v2z, v3x, v3y, v3z, half)
    # --- geometry at n+1: volume and force gradients
    det1, b1x, b1y, b1z, b2x, b2y, b2z, b3x, b3y, b3z = _tet_gradients(
        p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z, p3x, p3y, p3z)
    vnew = det1 / 6.0
    if vnew <= 0.0:
        return math.inf, 0.0, 1
    vold = vol[e]
    mk = elem_mat[e]
    mass = elem_mass[e]
    rho = mass / vnew
    rho0 = mat_params[mk, P.RHO0]
    shear = mat_params[mk, P.G]
    # --- deviatoric stress: Jaumann rate s' = 2G D' + W s - s W
    sxx, syy, szz = sdev[e, 0], sdev[e, 1], sdev[e, 2]
    sxy, syz, szx = sdev[e, 3], sdev[e, 4], sdev[e, 5]
    nxx, nyy, nzz, nxy, nyz, nzx = _jaumann_trial(sxx, syy, szz, sxy, syz, szx, exx, eyy, ezz,
                                                   dxy, dyz, dzx, wxy, wyz, wzx, 2.0 * shear, dt)
    # effective deviatoric strain rate sqrt(2/3 D':D')
    rate = math.sqrt((2.0 / 3.0) * (exx * exx + eyy * eyy + ezz * ezz
                                    + 2.0 * (dxy * dxy + dyz * dyz + dzx * dzx)))
    eps_rate[e] = rate
    code = int(mat_params[mk, P.STRENGTH])
    nxx, nyy, nzz, nxy, nyz, nzx = _deviator(st, code, mat_params, mk, shear, nxx, nyy, nzz,
                                             nxy, nyz, nzx, rate, eps_p, temperature, hard,
                                             thermal, e, rho)
    wdev = _deviatoric_work(dt, vold, vnew, sxx, syy, szz, sxy, syz, szx, nxx, nyy, nzz, nxy,
                            nyz, nzx, exx, eyy, ezz, dxy, dyz, dzx)
    sdev[e, 0], sdev[e, 1], sdev[e, 2] = nxx, nyy, nzz
    sdev[e, 3], sdev[e, 4], sdev[e, 5] = nxy, nyz, nzx
    length = _char_length(det1, b1x, b1y, b1z, b2x, b2y, b2z, b3x, b3y, b3z)
    # --- pressure: EOS with the energy integrated implicitly (p = a + b e); the ANP tet
    # feeds the EOS the averaged nodal volume ratio. The energy takes the work the forces do,
    # -(p + q) dV with the element's own volume change, for both formulations: booked with the
    # averaged volume's change instead, it was not the work of any force, and it created
    # energy where the averaging set or the neighbours' pressures jump (fracture, removal:
    # +11.7 % on a fracturing 6061 bar, issue 17)
    if use_anp:
        veos = 0.25 * (jnode[i0] + jnode[i1] + jnode[i2] + jnode[i3]) * vol0[e]
    else:
        veos = vnew
    pa, pb, c2a, c2b = eos_linear_part(int(mat_params[mk, P.EOS]), mass / veos, rho0,
                                       mat_params[mk, P.K], mat_params[mk, P.C0],
                                       mat_params[mk, P.S], mat_params[mk, P.GAMMA0])
    pold = pressure[e]
    dv = vnew - vold
    c2 = c2a + c2b * max(pold, 0.0)
    if c2 < 0.0:
        c2 = 0.0
    c = math.sqrt(c2)
    qn = 0.0
    if trd < 0.0 and st != FRACTURED:
        qn = rho * length * (cq * cq * length * trd * trd - cl * c * trd)
    ecur = energy[e]
    base = ecur + (wdev - dv * (0.5 * pold + qn)) / mass
    if st == FRACTURED:
        pn = 0.0
        enew = base
    else:
        # e_new = base - dv/(2 mass) * (pa + pb e_new)
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
    vol_eos[e] = veos
    # --- stable time step; a fractured element carries no stress (no deviator, pressure or
    # viscosity), adds no force, and so sets no limit
    c2 = c2a + c2b * max(pn, 0.0)
    if c2 < 0.0:
        c2 = 0.0
    if st == 0:
        c2 += 4.0 * shear / (3.0 * rho)
    c = math.sqrt(c2)
    qq = 0.0
    if trd < 0.0:
        qq = cl * c + cq * cq * length * (-trd)
    limits = st != FRACTURED and (c2 > 0.0 or qq > 0.0)
    dte = length / (qq + math.sqrt(qq * qq + c2)) if limits else math.inf
    # --- nodal forces f_a = -V sigma grad N_a, sigma = s - (p + q) I
    ptot = pn + qn
    txx, tyy, tzz = nxx - ptot, nyy - ptot, nzz - ptot
    f1x, f1y, f1z, f2x, f2y, f2z, f3x, f3y, f3z = _corner_forces(
        txx, tyy, tzz, nxy, nyz, nzx, b1x, b1y, b1z, b2x, b2y, b2z, b3x, b3y, b3z)
    r0, r1, r2, r3 = rows[e, 0], rows[e, 1], rows[e, 2], rows[e, 3]
    fext[r0, 0] -= f1x + f2x + f3x
    fext[r0, 1] -= f1y + f2y + f3y
    fext[r0, 2] -= f1z + f2z + f3z
    fext[r1, 0] += f1x
    fext[r1, 1] += f1y
    fext[r1, 2] += f1z
    fext[r2, 0] += f2x
    fext[r2, 1] += f2y
    fext[r2, 2] += f2z
    fext[r3, 0] += f3x
    fext[r3, 1] += f3y
    fext[r3, 2] += f3z
    return dte, -qn * dv, 0


@numba.njit(cache=True, error_model="numpy")
def _load_block(x, v, conn, sdev, pressure, energy, vol, vol_eos, vol0, elem_mass, jnode,
                use_anp, e0, buf):
    """Copy the data of elements e0 .. e0 + B - 1 into the block buffer.

    Element arrays are read through views of the block (`sdev[e0:e0 + B]`...), indexed by the
    lane: an index e0 + i that LLVM cannot prove non-negative gets numba's negative-index
    wraparound, and the copy then compiles to gathers, several times slower."""
    cn = conn[e0:e0 + B]
    for i in range(B):
        for k in range(4):
            n = np.uint64(cn[i, k])  # unsigned: no wraparound test on the node index
            for d in range(3):
                buf[(R_X + 3 * k + d) * B + i] = x[n, d]
                buf[(R_V + 3 * k + d) * B + i] = v[n, d]
    sd = sdev[e0:e0 + B]
    for i in range(B):
        for c in range(6):
            buf[(R_S0 + c) * B + i] = sd[i, c]
    _copy_in(vol[e0:e0 + B], buf, R_VOLD)
    _copy_in(elem_mass[e0:e0 + B], buf, R_MASS)
    _copy_in(energy[e0:e0 + B], buf, R_EN)
    _copy_in(pressure[e0:e0 + B], buf, R_POLD)
    if use_anp:
        v0 = vol0[e0:e0 + B]
        for i in range(B):
            buf[R_VEOS * B + i] = 0.25 * (jnode[cn[i, 0]] + jnode[cn[i, 1]] + jnode[cn[i, 2]]
                                         + jnode[cn[i, 3]]) * v0[i]


@numba.njit(cache=True, inline="always")
def _copy_in(src, buf, row):
    """buf row `row` = src (a view of B lanes)."""
    for i in range(B):
        buf[row * B + i] = src[i]


@numba.njit(cache=True, inline="always")
def _copy_out(buf, row, dst):
    """dst (a view of B lanes) = buf row `row`."""
    for i in range(B):
        dst[i] = buf[row * B + i]


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def _kinematics_block(buf, half, dt, shear):
    """Velocity gradient on the mid-step geometry, gradients and length at n+1, trial stress."""
    for i in range(B):
        p0x = buf[(R_X + 0) * B + i]
        p0y = buf[(R_X + 1) * B + i]
        p0z = buf[(R_X + 2) * B + i]
        p1x = buf[(R_X + 3) * B + i]
        p1y = buf[(R_X + 4) * B + i]
        p1z = buf[(R_X + 5) * B + i]
        p2x = buf[(R_X + 6) * B + i]
        p2y = buf[(R_X + 7) * B + i]
        p2z = buf[(R_X + 8) * B + i]
        p3x = buf[(R_X + 9) * B + i]
        p3y = buf[(R_X + 10) * B + i]
        p3z = buf[(R_X + 11) * B + i]
        v0x = buf[(R_V + 0) * B + i]
        v0y = buf[(R_V + 1) * B + i]
        v0z = buf[(R_V + 2) * B + i]
        v1x = buf[(R_V + 3) * B + i]
        v1y = buf[(R_V + 4) * B + i]
        v1z = buf[(R_V + 5) * B + i]
        v2x = buf[(R_V + 6) * B + i]
        v2y = buf[(R_V + 7) * B + i]
        v2z = buf[(R_V + 8) * B + i]
        v3x = buf[(R_V + 9) * B + i]
        v3y = buf[(R_V + 10) * B + i]
        v3z = buf[(R_V + 11) * B + i]
        exx, eyy, ezz, dxy, dyz, dzx, wxy, wyz, wzx, trd = _velocity_gradient(
            p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z, p3x, p3y, p3z,
            v0x, v0y, v0z, v1x, v1y, v1z, v2x, v2y, v2z, v3x, v3y, v3z, half)
        det1, b1x, b1y, b1z, b2x, b2y, b2z, b3x, b3y, b3z = _tet_gradients(
            p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z, p3x, p3y, p3z)
        buf[R_LEN * B + i] = _char_length(det1, b1x, b1y, b1z, b2x, b2y, b2z, b3x, b3y, b3z)
        buf[(R_B + 0) * B + i] = b1x
        buf[(R_B + 1) * B + i] = b1y
        buf[(R_B + 2) * B + i] = b1z
        buf[(R_B + 3) * B + i] = b2x
        buf[(R_B + 4) * B + i] = b2y
        buf[(R_B + 5) * B + i] = b2z
        buf[(R_B + 6) * B + i] = b3x
        buf[(R_B + 7) * B + i] = b3y
        buf[(R_B + 8) * B + i] = b3z
        buf[R_DET * B + i] = det1
        buf[(R_D + 0) * B + i] = exx
        buf[(R_D + 1) * B + i] = eyy
        buf[(R_D + 2) * B + i] = ezz
        buf[(R_D + 3) * B + i] = dxy
        buf[(R_D + 4) * B + i] = dyz
        buf[(R_D + 5) * B + i] = dzx
        buf[R_TRD * B + i] = trd
        # trial deviatoric stress: Jaumann rate s' = 2G D' + W s - s W
        sxx = buf[(R_S0 + 0) * B + i]
        syy = buf[(R_S0 + 1) * B + i]
        szz = buf[(R_S0 + 2) * B + i]
        sxy = buf[(R_S0 + 3) * B + i]
        syz = buf[(R_S0 + 4) * B + i]
        szx = buf[(R_S0 + 5) * B + i]
        nxx, nyy, nzz, nxy, nyz, nzx = _jaumann_trial(
            sxx, syy, szz, sxy, syz, szx, exx, eyy, ezz, dxy, dyz, dzx, wxy, wyz, wzx,
            2.0 * shear, dt)
        buf[(R_SN + 0) * B + i] = nxx
        buf[(R_SN + 1) * B + i] = nyy
        buf[(R_SN + 2) * B + i] = nzz
        buf[(R_SN + 3) * B + i] = nxy
        buf[(R_SN + 4) * B + i] = nyz
        buf[(R_SN + 5) * B + i] = nzx
        buf[R_RATE * B + i] = math.sqrt(max((2.0 / 3.0) * (exx * exx + eyy * eyy + ezz * ezz
                                        + 2.0 * (dxy * dxy + dyz * dyz + dzx * dzx)), 0.0))
        j2 = 0.5 * (nxx * nxx + nyy * nyy + nzz * nzz) + nxy * nxy + nyz * nyz + nzx * nzx
        buf[R_SEQ * B + i] = math.sqrt(max(3.0 * j2, 0.0))



@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def _return_block(buf, code, mat_params, mk, shear, eps_p, temperature, hard, thermal, e0):
    """Radial return of the lanes whose trial stress exceeds their yield floor (scalar)."""
    for i in range(B):
        seq = buf[R_SEQ * B + i]
        rho = buf[R_MASS * B + i] / (buf[R_DET * B + i] * (1.0 / 6.0))
        deps, sy = _return_map(code, mat_params, mk, shear, seq, buf[R_RATE * B + i], eps_p,
                               temperature, hard, thermal, e0 + i, rho)
        if deps > 0.0:
            scale = sy / seq if seq > 0.0 else 0.0
            for c in range(6):
                buf[(R_SN + c) * B + i] *= scale


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def _jc_start(buf, a0, n, c, g3, inv_rate0):
    """Rate factor 1 + C ln(max(rate/rate0, 1)), the trial check at the step's rate and the
    Newton start of `laws.radial_return` (`laws.newton_start`, bracket [0, (seq - sy)/3G]); a
    lane at its first yield (eps_p = 0) is marked FIRST, for the scalar return
    (`laws.first_yield_return`: iterating such lanes in vector form made whole blocks iterate
    up to eight times, which cost more than it saved). Returns the number of yielding lanes
    (ITERATING or FIRST): a block above its yield floor may still be elastic at the step's
    rate, and then needs no Newton iteration and no update.

    The lanes go in groups of JG: a group with no lane above its yield floor (hard x thermal,
    below the yield stress at any rate when C >= 0) is elastic at any rate and only gets the
    rows the later steps read (not yielding, FINISHED, no increment), without the logarithm."""
    active = 0
    for g in range(0, B, JG):
        above = False
        for i in range(g, g + JG):
            above |= buf[R_SEQ * B + i] > buf[R_HARD * B + i] * buf[R_THERM * B + i]
        if not above:
            for i in range(g, g + JG):
                buf[R_ACT * B + i] = 0.0
                buf[R_DONE * B + i] = FINISHED
                buf[R_DEPS * B + i] = 0.0
            continue
        for i in range(g, g + JG):
            seq = buf[R_SEQ * B + i]
            ep = buf[R_EP * B + i]
            hard = buf[R_HARD * B + i]
            rt = (1.0 + c * VM.ln(max(buf[R_RATE * B + i] * inv_rate0, 1.0))) * buf[R_THERM * B + i]
            sy = hard * rt
            act = seq > sy
            hi = (seq - sy) / g3
            d = newton_start(seq, sy, hard, a0, rt, n, g3, ep) if ep > 0.0 else hi
            buf[R_RT * B + i] = rt
            buf[R_ACT * B + i] = 1.0 if act else 0.0
            buf[R_DONE * B + i] = (ITERATING if ep > 0.0 else FIRST) if act else FINISHED
            buf[R_DEPS * B + i] = d if act else 0.0
            buf[R_LO * B + i] = 0.0
            buf[R_HI * B + i] = hi if act else 0.0
            buf[R_SY * B + i] = sy
            buf[R_HN * B + i] = hard
            active += 1 if act else 0
    return active


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def _jc_newton(buf, a0, b0, n, g3):
    """One safeguarded Newton iteration of `laws.radial_return` on every lane still iterating,
    (eps_p + d)^n from `vecmath.power`. A lane whose Newton step is bounded to land within the
    tolerance (`laws.newton_step_converged`) takes it and finishes; a lane whose bracket has
    shrunk to round-off finishes at the next call with the yield stress at its last iterate, as
    the scalar return does. FIRST lanes are left to the scalar return. Returns the number of
    lanes still iterating here. A group of JG lanes none of which is iterating (or STALLED) is
    skipped: it would change nothing."""
    curv = b0 * n * abs(1.0 - n)
    left = 0
    for g in range(0, B, JG):
        busy = False
        for i in range(g, g + JG):
            dn = buf[R_DONE * B + i]
            busy |= dn == ITERATING or dn == STALLED
        if not busy:
            continue
        for i in range(g, g + JG):
            done = buf[R_DONE * B + i]
            seq = buf[R_SEQ * B + i]
            ep0 = buf[R_EP * B + i]
            rt = buf[R_RT * B + i]
            d = buf[R_DEPS * B + i]
            lo = buf[R_LO * B + i]
            hi = buf[R_HI * B + i]
            iterating = done == ITERATING
            final = done == STALLED
            ep = ep0 + d if iterating or final else 1.0
            pw = VM.power(ep, n)
            a = a0 * rt
            b = b0 * rt
            sy = a + b * pw
            f = seq - g3 * d - sy
            tol = 1e-12 * seq
            conv = abs(f) <= tol
            lo2 = d if f > 0.0 else lo
            hi2 = hi if f > 0.0 else d
            step = f / (g3 + b * n * pw / ep)
            dn = d + step
            accept = (newton_step_converged(step, ep, rt * curv * pw / (ep * ep), tol)
                      and dn > lo2 and dn < hi2 and not conv)
            pw = power_near(pw, step / ep, n) if accept else pw
            dn = 0.5 * (lo2 + hi2) if (dn <= lo2 or dn >= hi2) else dn
            stall = hi2 - lo2 <= 1e-15 * (1.0 + ep0)
            finish = final or (iterating and (conv or accept))
            going = iterating and not (conv or accept)
            new = FINISHED if finish else (STALLED if going and stall else done)
            buf[R_DONE * B + i] = new
            buf[R_SY * B + i] = a + b * pw if finish else buf[R_SY * B + i]
            buf[R_HN * B + i] = a0 + b0 * pw if finish else buf[R_HN * B + i]
            buf[R_LO * B + i] = lo2 if going else lo
            buf[R_HI * B + i] = hi2 if going else hi
            buf[R_DEPS * B + i] = dn if going or (iterating and accept) else d
            left += 1 if new == ITERATING or new == STALLED else 0
    return left


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def _jc_finish(buf, tq_cv, t_room, inv_t_range, m):
    """Plastic strain, adiabatic heating, the thermal factor 1 - T*^m (`laws.thermal_factor`)
    and the returned deviator of the yielded lanes (in groups of JG lanes: a group with none
    is left as it is)."""
    for g in range(0, B, JG):
        any_upd = False
        for i in range(g, g + JG):
            any_upd |= buf[R_ACT * B + i] > 0.0 and buf[R_DEPS * B + i] > 0.0
        if not any_upd:
            continue
        for i in range(g, g + JG):
            upd = buf[R_ACT * B + i] > 0.0 and buf[R_DEPS * B + i] > 0.0
            deps = buf[R_DEPS * B + i]
            sy = buf[R_SY * B + i]
            seq = buf[R_SEQ * B + i]
            rho = buf[R_MASS * B + i] / (buf[R_DET * B + i] * (1.0 / 6.0))
            temp = buf[R_TEMP * B + i] + tq_cv * sy * deps / rho
            scale = sy / seq if upd else 1.0
            for c in range(6):
                buf[(R_SN + c) * B + i] *= scale
            t_star = (temp - t_room) * inv_t_range
            tm = VM.power(t_star if (t_star > 0.0 and t_star < 1.0) else 0.5, m)
            th = 0.0 if t_star >= 1.0 else (1.0 - tm if t_star > 0.0 else 1.0)
            buf[R_EP * B + i] = buf[R_EP * B + i] + deps if upd else buf[R_EP * B + i]
            buf[R_TEMP * B + i] = temp if upd else buf[R_TEMP * B + i]
            buf[R_HARD * B + i] = buf[R_HN * B + i] if upd else buf[R_HARD * B + i]
            buf[R_THERM * B + i] = th if upd else buf[R_THERM * B + i]


@numba.njit(cache=True, error_model="numpy")
def _jc_return_block(buf, mat_params, mk, shear, eps_p, temperature, hard, thermal, e0):
    """The Johnson-Cook radial return of a block as vector loops: `laws.radial_return` and the
    caches' update of `_return_map`, lane by lane the same iteration (ln and exp from
    `vecmath`); a lane not finished after VECTOR_ITERATIONS is redone by the scalar return.
    Requires C >= 0 (hard x thermal is then a lower bound: lanes below it skip, and a block
    with no lane above it costs one comparison per lane).

    `_chunk` does the same with the three parts written out: numba keeps an NRT incref and
    decref of every array argument of a function that calls another (12 atomic counts per
    block for this one; docs/performance.md, "The tet kernel, session 9")."""
    if _jc_load(buf, eps_p, temperature, hard, thermal, e0):
        if _jc_lanes(buf, mat_params, mk, shear):
            _jc_store(buf, eps_p, temperature, hard, thermal, e0)


@numba.njit(cache=True, error_model="numpy")
def _jc_load(buf, eps_p, temperature, hard, thermal, e0):
    """False if no lane of the block is above its yield floor (hard x thermal); else copies
    the lanes' plastic strain, temperature and caches into rows R_EP .. R_THERM and returns
    True. The arrays are indexed by unsigned integers (no wraparound test), not through views
    of the block as in `_load_block`: a view is an array of its own, with its reference count."""
    any_active = False
    for i in range(B):
        j = np.uint64(e0 + i)
        if buf[R_SEQ * B + i] > hard[j] * thermal[j]:
            any_active = True
            break
    if any_active:
        for i in range(B):
            j = np.uint64(e0 + i)
            buf[R_EP * B + i] = eps_p[j]
            buf[R_TEMP * B + i] = temperature[j]
            buf[R_HARD * B + i] = hard[j]
            buf[R_THERM * B + i] = thermal[j]
    return any_active


@numba.njit(cache=True, error_model="numpy")
def _jc_store(buf, eps_p, temperature, hard, thermal, e0):
    """Rows R_EP .. R_THERM back to the element arrays (see `_jc_load`)."""
    for i in range(B):
        j = np.uint64(e0 + i)
        eps_p[j] = buf[R_EP * B + i]
        temperature[j] = buf[R_TEMP * B + i]
        hard[j] = buf[R_HARD * B + i]
        thermal[j] = buf[R_THERM * B + i]


@numba.njit(cache=True, error_model="numpy")
def _jc_lanes(buf, mat_params, mk, shear):
    """`_jc_return_block`'s iteration on the block's rows R_EP .. R_THERM; False when no lane
    yields at the step's rate (nothing changes)."""
    a0, b0, n = mat_params[mk, P.JC_A], mat_params[mk, P.JC_B], mat_params[mk, P.JC_N]
    g3 = 3.0 * shear
    if _jc_start(buf, a0, n, mat_params[mk, P.JC_C], g3, 1.0 / mat_params[mk, P.EPSDOT0]) == 0:
        return False  # elastic at the step's rate: nothing changes
    for _ in range(VECTOR_ITERATIONS):
        if _jc_newton(buf, a0, b0, n, g3) == 0:
            break
    for i in range(B):
        if buf[R_DONE * B + i] != FINISHED:  # first yield or slow: the scalar return
            deps, sy, hnew = radial_return(P.JOHNSON_COOK, mat_params, mk, shear,
                                           buf[R_SEQ * B + i], buf[R_EP * B + i],
                                           buf[R_RATE * B + i], buf[R_HARD * B + i],
                                           buf[R_THERM * B + i])
            buf[R_DEPS * B + i] = deps
            buf[R_SY * B + i] = sy
            buf[R_HN * B + i] = hnew
    t_room = mat_params[mk, P.T_ROOM]
    _jc_finish(buf, mat_params[mk, P.TQ] / mat_params[mk, P.CV], t_room,
               1.0 / (mat_params[mk, P.T_MELT] - t_room), mat_params[mk, P.JC_M])
    return True


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def _pressure_block(buf, dt, anp, eos, rho0, bulk, c0, s, gamma0, shear, cq, cl, stat):
    """Deviatoric work, EOS pressure with the energy implicit, bulk viscosity, stable dt, forces.

    The EOS (`laws.eos_linear_part`, code `eos`) is the same for all lanes; the Hugoniot's two
    branches (compression, tension) are selects, and so are the damaged and fractured lanes'
    rules (row R_STAT, as in `_element_scalar`) when `stat` is not None; with `stat` None (a
    block of intact elements) they are left out at compile time: the selects cost 10 % of the
    loop's time.
    """
    for i in range(B):
        det1 = buf[R_DET * B + i]
        vnew = det1 * (1.0 / 6.0)
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
        veos = buf[R_VEOS * B + i] if anp else vnew
        rho_e = mass / veos
        pa, pb, c2a, c2b = eos_linear_part(eos, rho_e, rho0, bulk, c0, s, gamma0)
        pold = buf[R_POLD * B + i]
        dv = vnew - vold
        if stat is None:
            st = 0.0
        else:
            st = buf[R_STAT * B + i]
        frac = st == FRACTURED_F
        c = math.sqrt(max(c2a + c2b * max(pold, 0.0), 0.0))
        qn = (rho * length * (cq * cq * length * trd * trd - cl * c * trd)
              if trd < 0.0 and not frac else 0.0)
        base = buf[R_EN * B + i] + (wdev - dv * (0.5 * pold + qn)) / mass
        kk = 0.5 * dv / mass
        enew = (base - kk * pa) / (1.0 + kk * pb)
        pn = pa + pb * enew
        # a fractured element carries no pressure, a damaged one no tension (ALGORITHMS.md 4.1)
        cut = frac or (st == DAMAGED_F and pn < 0.0)
        pn = 0.0 if cut else pn
        enew = base if cut else enew
        buf[R_EN1 * B + i] = enew
        buf[R_PN * B + i] = pn
        buf[R_QN * B + i] = qn
        buf[R_QW * B + i] = -qn * dv
        c2 = (max(c2a + c2b * max(pn, 0.0), 0.0)
              + (4.0 * shear / (3.0 * rho) if st == 0.0 else 0.0))
        qq = cl * math.sqrt(c2) - cq * cq * length * trd if trd < 0.0 else 0.0
        # no limit (inf) from a fractured element, nor from a damaged one with c = q = 0
        dte = length / (qq + math.sqrt(max(qq * qq + c2, 0.0)))
        buf[R_DTE * B + i] = math.inf if frac else dte
        ptot = pn + qn
        txx, tyy, tzz = nxx - ptot, nyy - ptot, nzz - ptot
        b1x = buf[(R_B + 0) * B + i]
        b1y = buf[(R_B + 1) * B + i]
        b1z = buf[(R_B + 2) * B + i]
        b2x = buf[(R_B + 3) * B + i]
        b2y = buf[(R_B + 4) * B + i]
        b2z = buf[(R_B + 5) * B + i]
        b3x = buf[(R_B + 6) * B + i]
        b3y = buf[(R_B + 7) * B + i]
        b3z = buf[(R_B + 8) * B + i]
        f1x, f1y, f1z, f2x, f2y, f2z, f3x, f3y, f3z = _corner_forces(
            txx, tyy, tzz, nxy, nyz, nzx, b1x, b1y, b1z, b2x, b2y, b2z, b3x, b3y, b3z)
        buf[(R_F + 0) * B + i] = -(f1x + f2x + f3x)
        buf[(R_F + 1) * B + i] = -(f1y + f2y + f3y)
        buf[(R_F + 2) * B + i] = -(f1z + f2z + f3z)
        buf[(R_F + 3) * B + i] = f1x
        buf[(R_F + 4) * B + i] = f1y
        buf[(R_F + 5) * B + i] = f1z
        buf[(R_F + 6) * B + i] = f2x
        buf[(R_F + 7) * B + i] = f2y
        buf[(R_F + 8) * B + i] = f2z
        buf[(R_F + 9) * B + i] = f3x
        buf[(R_F + 10) * B + i] = f3y
        buf[(R_F + 11) * B + i] = f3z



@numba.njit(cache=True, error_model="numpy")
def _store_block(rows, sdev, pressure, q, eps_rate, energy, vol, vol_eos, fext, use_anp, e0,
                 buf):
    """Copy the block's results back to the element arrays (through views of the block, see
    `_load_block`) and add its forces to the corners' rows of fext (in lane order); returns
    (min dt, its element, viscous work), reduced in lane order."""
    sd = sdev[e0:e0 + B]
    for i in range(B):
        for c in range(6):
            sd[i, c] = buf[(R_SN + c) * B + i]
    _copy_out(buf, R_PN, pressure[e0:e0 + B])
    _copy_out(buf, R_QN, q[e0:e0 + B])
    _copy_out(buf, R_EN1, energy[e0:e0 + B])
    _copy_out(buf, R_RATE, eps_rate[e0:e0 + B])
    vo = vol[e0:e0 + B]
    ve = vol_eos[e0:e0 + B]
    for i in range(B):
        vnew = buf[R_DET * B + i] * (1.0 / 6.0)
        vo[i] = vnew
        ve[i] = buf[R_VEOS * B + i] if use_anp else vnew
    rw = rows[e0:e0 + B]
    dt_min = math.inf
    worst = -1
    qwork = 0.0
    for i in range(B):
        for k in range(4):
            r = np.uint64(rw[i, k])
            for d in range(3):
                fext[r, d] += buf[(R_F + 3 * k + d) * B + i]
        qwork += buf[R_QW * B + i]
        dte = buf[R_DTE * B + i]
        if dte < dt_min:
            dt_min = dte
            worst = e0 + i
    return dt_min, worst, qwork


@numba.njit(cache=True, inline="always", error_model="numpy")
def _vector_block(elem_mat, status, e0):
    """The block's material row if it is a full block of intact elements of one material, else
    -1."""
    mat = elem_mat[e0:e0 + B]
    st = status[e0:e0 + B]
    mk = mat[0]
    for i in range(B):
        if st[i] != 0 or mat[i] != mk:
            return -1
    return mk


@numba.njit(cache=True, error_model="numpy")
def _store_masked(rows, sdev, pressure, q, eps_rate, energy, vol, vol_eos, fext, use_anp, e0,
                  buf):
    """`_store_block` for the lanes of row R_LIVE only (a masked pass of `_block`).

    The element arrays are written through views of the block as in `_store_block`, every lane
    with a select: a lane not in the pass gets its own value back, so the copy needs no branch
    (lane by lane with a branch, indexed e0 + i, it cost the masked blocks 1.5 ns per element
    more, docs/performance.md, session 18). The forces and the reductions take the pass's lanes
    only."""
    sd = sdev[e0:e0 + B]
    pr = pressure[e0:e0 + B]
    qq = q[e0:e0 + B]
    en = energy[e0:e0 + B]
    er = eps_rate[e0:e0 + B]
    vo = vol[e0:e0 + B]
    ve = vol_eos[e0:e0 + B]
    for i in range(B):
        live = buf[R_LIVE * B + i] != 0.0
        for c in range(6):
            sd[i, c] = buf[(R_SN + c) * B + i] if live else sd[i, c]
        pr[i] = buf[R_PN * B + i] if live else pr[i]
        qq[i] = buf[R_QN * B + i] if live else qq[i]
        en[i] = buf[R_EN1 * B + i] if live else en[i]
        er[i] = buf[R_RATE * B + i] if live else er[i]
    for i in range(B):  # vol_eos is vol itself without the averaged nodal pressure
        live = buf[R_LIVE * B + i] != 0.0
        vnew = buf[R_DET * B + i] * (1.0 / 6.0)
        vo[i] = vnew if live else vo[i]
        ve[i] = (buf[R_VEOS * B + i] if use_anp else vnew) if live else ve[i]
    rw = rows[e0:e0 + B]
    dt_min = math.inf
    worst = -1
    qwork = 0.0
    for i in range(B):
        if buf[R_LIVE * B + i] == 0.0:
            continue
        for k in range(4):
            r = np.uint64(rw[i, k])
            for d in range(3):
                fext[r, d] += buf[(R_F + 3 * k + d) * B + i]
        qwork += buf[R_QW * B + i]
        dte = buf[R_DTE * B + i]
        if dte < dt_min:
            dt_min = dte
            worst = e0 + i
    return dt_min, worst, qwork


@numba.njit(cache=True, inline="always", error_model="numpy")
def _return(buf, mat_params, mk, shear, eps_p, temperature, hard, thermal, e0):
    """The radial return of the block's lanes for material row mk: Johnson-Cook with C >= 0 as
    vector loops, other strength models lane by lane, none for an elastic material."""
    code = int(mat_params[mk, P.STRENGTH])
    if code == P.JOHNSON_COOK and mat_params[mk, P.JC_C] >= 0.0:
        _jc_return_block(buf, mat_params, mk, shear, eps_p, temperature, hard, thermal, e0)
    elif code != P.ELASTIC:
        _return_block(buf, code, mat_params, mk, shear, eps_p, temperature, hard, thermal, e0)


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def _masked_blocks(e_first, mask, x, v, conn, elem_mat, status, sdev, pressure, q, eps_p,
                   eps_rate, temperature, hard, thermal, energy, vol, vol_eos, vol0, elem_mass,
                   mat_params, jnode, use_anp, half, dt, cq, cl, rows, fext, buf, plastic,
                   guard, dt_min, worst, qwork, inverted):
    """The blocks e0 = e_first + b B for the set bits b of ``mask``, blocks that are not full
    blocks of intact elements of one material, through the vector path in masked passes, in
    order; returns (min stable dt, its element, viscous work, inverted elements) reduced over
    them from the given ones (the chunk's so far: the sums in the order of the blocks).

    All of a chunk's blocks in one call, not one call per block: numba passes each array as its
    data pointer, shape, strides and owner, and a call with these 20 arrays cost the masked
    blocks about 5 ns per tet (docs/performance.md, session 18).

    One masked pass runs per material among the block's elements that are not eroded: the other
    lanes get a copy of the pass's first lane's data (so that they compute finite numbers), the
    yield check of the return never fires for them (R_SEQ = 0), and `_store_masked` stores only
    the pass's lanes (row R_LIVE). Damaged and fractured lanes take no return and zero deviator,
    and `_pressure_block` applies their rules (row R_STAT); an eroded or inverted element is
    stored nowhere and adds no force, as in `_element_scalar`. With `plastic` None (a model
    whose tets are all elastic, `plastic_kernel`) the radial return is left out at compile
    time. ``guard`` (n_elem,) int8, or empty: the distortion guard's verdicts on the block's
    cells, each pass's on its lanes (those that invert included), PASSED on the eroded ones
    (the criteria pass them by), with the spall marks of the lanes it stores; only in the
    plastic specialisation, as in `_chunk`."""
    verdicts = guard.shape[0] != 0
    for blk in range(CHUNK // B):
        if (mask >> blk) & 1 == 0:
            continue
        e0 = e_first + blk * B
        mat = elem_mat[e0:e0 + B]
        st = status[e0:e0 + B]
        if plastic is not None and verdicts:
            for i in range(B):
                if st[i] == ERODED:
                    guard[np.uint64(e0 + i)] = G.PASSED
        bdt = math.inf  # the block's least stable step and its element
        bworst = -1
        bq = 0.0  # its viscous work
        for d in range(B):  # lane d starts the pass of its material if no lane before has it
            if st[d] == ERODED:
                continue
            mk = mat[d]
            first = True
            for j in range(d):
                if st[j] != ERODED and mat[j] == mk:
                    first = False
                    break
            if not first:
                continue
            _load_block(x, v, conn, sdev, pressure, energy, vol, vol_eos, vol0, elem_mass,
                        jnode, use_anp, e0, buf)
            for i in range(B):
                live = st[i] != ERODED and mat[i] == mk
                buf[R_LIVE * B + i] = 1.0 if live else 0.0
                buf[R_STAT * B + i] = float(st[i]) if live else 0.0
                if not live:
                    for r in range(R_VEOS + 1):
                        buf[r * B + i] = buf[r * B + d]
            if plastic is not None and verdicts:  # the pass's corners at hand
                G.masked_verdicts(buf, vol0, e0, dt, guard, R_LIVE)
            shear = mat_params[mk, P.G]
            _kinematics_block(buf, half, dt, shear)
            for i in range(B):
                # inverted as in `_element_scalar` (V <= 0): a NaN volume is not, and goes on,
                # so that the run's non-finite check names the node (the full block's test, not
                # V > 0, sends such a block here)
                if buf[R_LIVE * B + i] != 0.0 and buf[R_DET * B + i] <= 0.0:
                    inverted += 1
                    buf[R_LIVE * B + i] = 0.0
                if buf[R_LIVE * B + i] == 0.0 or buf[R_STAT * B + i] != 0.0:
                    buf[R_SEQ * B + i] = 0.0  # no return
            if plastic is not None:
                _return(buf, mat_params, mk, shear, eps_p, temperature, hard, thermal, e0)
            for i in range(B):
                if buf[R_STAT * B + i] != 0.0:  # damaged or fractured: no deviator
                    for c in range(6):
                        buf[(R_SN + c) * B + i] = 0.0
            _pressure_block(buf, dt, use_anp, int(mat_params[mk, P.EOS]),
                            mat_params[mk, P.RHO0], mat_params[mk, P.K], mat_params[mk, P.C0],
                            mat_params[mk, P.S], mat_params[mk, P.GAMMA0], shear, cq, cl, True)
            pdt, pworst, pq = _store_masked(rows, sdev, pressure, q, eps_rate, energy, vol,
                                            vol_eos, fext, use_anp, e0, buf)
            if plastic is not None and verdicts:
                G.spall_marks(buf, R_SN, R_PN, mat_params[mk, P.SPALL], e0, guard, R_LIVE)
            bq += pq
            if pdt < bdt:
                bdt = pdt
                bworst = pworst
        qwork += bq  # the block's sums into the chunk's, as block by block before
        if bdt < dt_min:
            dt_min = bdt
            worst = bworst
    return dt_min, worst, qwork, inverted


@numba.njit(cache=True)
def _lanes(a, e0, n):
    """A block of B lanes: a[e0 .. e0 + n - 1] (1-D), then copies of a[e0] (element by element:
    numpy's fancy indexing, or a row assignment, cost seconds of compile)."""
    out = np.empty(B, a.dtype)
    for i in range(B):
        out[i] = a[e0 + (i if i < n else 0)]
    return out


@numba.njit(cache=True)
def _lanes2(a, e0, n):
    """`_lanes` of a 2-D array (its rows)."""
    out = np.empty((B, a.shape[1]), a.dtype)
    for i in range(B):
        j = e0 + (i if i < n else 0)
        for c in range(a.shape[1]):
            out[i, c] = a[j, c]
    return out


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def _chunk(ch0, ch1, x, v, conn, elem_mat, status, sdev, pressure, q, eps_p, eps_rate,
           temperature, hard, thermal, energy, vol, vol_eos, vol0, elem_mass, mat_params, jnode,
           use_anp, half, dt, cq, cl, rows, fext, chunk_out, buf, plastic, guard):
    """The full blocks of intact elements of one material of chunks ch0 .. ch1 - 1 (the vector
    path, written out in this function: called as a function of its own, it took the kernel 62
    -> 66 ns per element); any other block is left to `_deferred_chunk`, marked in its chunk's
    OUT_DEFERRED. `buf` the block buffer (TET_ROWS * B) of the calling thread. A range of
    chunks (a part, or all of them on one thread), not one: numba increfs and decrefs every
    array argument at each call of a function that calls others (about 70 atomic counts).
    ``guard`` (n_elem,) int8, or empty: the distortion guard's verdicts on the cells of each
    full block (solver/guard.py), with the spall marks of the stress stored
    (``guard.spall_marks``); `_deferred_chunk` gives them on the blocks it leaves. Only in the
    plastic specialisation (element_update)."""
    n_elem = conn.shape[0]
    verdicts = guard.shape[0] != 0
    for ch in range(ch0, ch1):
        dt_min = math.inf
        worst = -1
        qwork = 0.0
        inverted = 0
        deferred = 0
        e_end = min(n_elem, (ch + 1) * CHUNK)
        for e0 in range(ch * CHUNK, e_end, B):
            if e0 + B <= e_end:
                mk = _vector_block(elem_mat, status, e0)
                if mk >= 0:
                    for o in range(0, B, 8):  # the block PF_AHEAD on: lines the hardware misses
                        ahead = min(e0 + PF_AHEAD * B + o, n_elem - 1)
                        VM.prefetch_write(q, ahead)
                        VM.prefetch_write(eps_rate, ahead)
                        VM.prefetch_write(vol_eos, ahead)
                        if plastic is not None:
                            VM.prefetch(hard, ahead)
                            VM.prefetch(thermal, ahead)
                            VM.prefetch_l2(eps_p, ahead)
                            VM.prefetch_l2(temperature, ahead)
                        VM.prefetch_l2(pressure, ahead)
                        VM.prefetch_l2(energy, ahead)
                        VM.prefetch_l2(vol, ahead)
                        VM.prefetch_l2(elem_mass, ahead)
                    _load_block(x, v, conn, sdev, pressure, energy, vol, vol_eos, vol0, elem_mass,
                                jnode, use_anp, e0, buf)
                    shear = mat_params[mk, P.G]
                    _kinematics_block(buf, half, dt, shear)
                    for i in range(B):
                        if not buf[R_DET * B + i] > 0.0:
                            mk = -1
                    if mk >= 0 and plastic is not None and verdicts:  # the corners at hand
                        G.block_verdicts(buf, vol0, e0, dt, guard)
                if mk >= 0:
                    if plastic is not None:  # `_return` written out (its inlining kept increfs)
                        code = int(mat_params[mk, P.STRENGTH])
                        if code == P.JOHNSON_COOK and mat_params[mk, P.JC_C] >= 0.0:
                            if _jc_load(buf, eps_p, temperature, hard, thermal, e0):
                                if _jc_lanes(buf, mat_params, mk, shear):
                                    _jc_store(buf, eps_p, temperature, hard, thermal, e0)
                        elif code != P.ELASTIC:
                            _return_block(buf, code, mat_params, mk, shear, eps_p, temperature,
                                          hard, thermal, e0)
                    _pressure_block(buf, dt, use_anp, int(mat_params[mk, P.EOS]),
                                    mat_params[mk, P.RHO0], mat_params[mk, P.K],
                                    mat_params[mk, P.C0], mat_params[mk, P.S],
                                    mat_params[mk, P.GAMMA0], shear, cq, cl, None)
                    bdt, bworst, bq = _store_block(rows, sdev, pressure, q, eps_rate, energy, vol,
                                                   vol_eos, fext, use_anp, e0, buf)
                    if plastic is not None and verdicts:  # the new stress at hand
                        G.spall_marks(buf, R_SN, R_PN, mat_params[mk, P.SPALL], e0, guard, -1)
                    binv = 0
                else:
                    deferred |= 1 << ((e0 - ch * CHUNK) // B)
                    continue
            else:
                deferred |= 1 << ((e0 - ch * CHUNK) // B)
                continue
            qwork += bq
            inverted += binv
            if bdt < dt_min:
                dt_min = bdt
                worst = bworst
        chunk_out[ch, OUT_DT] = dt_min
        chunk_out[ch, OUT_QWORK] = qwork
        chunk_out[ch, OUT_INVERTED] = inverted
        chunk_out[ch, OUT_WORST] = worst
        chunk_out[ch, OUT_DEFERRED] = deferred


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def _deferred_chunk(ch, x, v, conn, elem_mat, status, sdev, pressure, q, eps_p, eps_rate,
                    temperature, hard, thermal, energy, vol, vol_eos, vol0, elem_mass, mat_params,
                    jnode, use_anp, half, dt, cq, cl, rows, fext, chunk_out, buf, plastic, guard):
    """The blocks of chunk ch that `_chunk` left (OUT_DEFERRED): masked passes
    (`_masked_blocks`), the last block of the mesh on copies of its lanes; their results merged
    into the chunk's. A kernel of its own, called only when a chunk has such blocks, so that a
    case without any (the demo) does not compile it. ``guard`` as in `_chunk`: the verdicts of
    the full blocks' cells (`_masked_blocks`), none on the mesh's last block."""
    n_elem = conn.shape[0]
    mask = int(chunk_out[ch, OUT_DEFERRED])
    e_end = min(n_elem, (ch + 1) * CHUNK)
    n_full = (e_end - ch * CHUNK) // B  # the chunk's full blocks; a partial one is the last
    dt_min, worst, qwork, inverted = _masked_blocks(
        ch * CHUNK, mask & ((1 << n_full) - 1), x, v, conn, elem_mat, status, sdev, pressure, q,
        eps_p, eps_rate, temperature, hard, thermal, energy, vol, vol_eos, vol0, elem_mass,
        mat_params, jnode, use_anp, half, dt, cq, cl, rows, fext, buf, plastic, guard,
        chunk_out[ch, OUT_DT], int(chunk_out[ch, OUT_WORST]), chunk_out[ch, OUT_QWORK],
        int(chunk_out[ch, OUT_INVERTED]))
    e0 = ch * CHUNK + n_full * B
    if e0 < e_end and (mask >> n_full) & 1:
        # the last block of the mesh, n < B elements: copied into arrays of one full block
        # whose other lanes are eroded copies of its first element, run in masked passes,
        # copied back (its first lane is passed as e0 - e0, its mask as mask - mask + 1: a
        # literal would compile `_masked_blocks` again; and this code is here, not in a
        # function of its own: numba links a called kernel's code into its caller and
        # optimises it again there, so every level of calls costs compile time)
        n = e_end - e0
        t_st = _lanes(status, e0, n)
        for i in range(n, B):
            t_st[i] = ERODED
        t_sdev, t_p, t_q = _lanes2(sdev, e0, n), _lanes(pressure, e0, n), _lanes(q, e0, n)
        t_ep, t_rate = _lanes(eps_p, e0, n), _lanes(eps_rate, e0, n)
        t_temp, t_hard, t_th = (_lanes(temperature, e0, n), _lanes(hard, e0, n),
                                _lanes(thermal, e0, n))
        t_en, t_vol, t_veos = _lanes(energy, e0, n), _lanes(vol, e0, n), _lanes(vol_eos, e0, n)
        # (its worst element counted from e0 there, as its lanes are)
        dt_min, worst, qwork, inverted = _masked_blocks(
            e0 - e0, mask - mask + 1, x, v, _lanes2(conn, e0, n), _lanes(elem_mat, e0, n), t_st,
            t_sdev, t_p, t_q, t_ep, t_rate, t_temp, t_hard, t_th, t_en, t_vol, t_veos,
            _lanes(vol0, e0, n), _lanes(elem_mass, e0, n), mat_params, jnode, use_anp, half, dt,
            cq, cl, _lanes2(rows, e0, n), fext, buf, plastic, guard[:0], dt_min, worst - e0,
            qwork, inverted)
        worst += e0
        for i in range(n):
            e = e0 + i
            for c in range(6):
                sdev[e, c] = t_sdev[i, c]
            pressure[e], q[e], eps_p[e], eps_rate[e] = t_p[i], t_q[i], t_ep[i], t_rate[i]
            temperature[e], hard[e], thermal[e] = t_temp[i], t_hard[i], t_th[i]
            energy[e] = t_en[i]
            vol[e] = t_vol[i]
            vol_eos[e] = t_veos[i] if use_anp else t_vol[i]
    chunk_out[ch, OUT_DT] = dt_min
    chunk_out[ch, OUT_QWORK] = qwork
    chunk_out[ch, OUT_INVERTED] = inverted
    chunk_out[ch, OUT_WORST] = worst


# element_update runs on one thread below this many tets (`_update_serial`): four parts or
# fewer, where a second thread saves little, and the parallel kernel's compile (about 5 s with
# a cold cache) would cost a small case more than its whole run. The warm-up sets it to 0 for
# its PARALLEL_SCENES so that both versions are compiled.
PARALLEL_ELEMENTS = 4 * PART


def element_update(x, v, conn, elem_mat, status, sdev, pressure, q, eps_p, eps_rate, temperature,
                   hard, thermal, energy, vol, vol_eos, vol0, elem_mass, mat_params, jnode,
                   use_anp, dt, cq, cl, force, rows, fext, extra_ptr, extra_rows, part_chunks,
                   chunk_out, threads, plastic, guard=None, claimed=None, skip=None,
                   sum_rows=True):
    """Advance every element from step n to n+1 and compute its nodal forces at n+1.

    x (n,3) positions x^{n+1}; v (n,3) velocities U^{n+1} (the step's velocity); dt the step.
    hard, thermal (n_elem,) the per-element caches of the hardening term and the thermal factor
    of the yield stress (fill them with `yield_cache`; the kernel keeps them current).
    jnode (n,) nodal volume ratios of the averaged-nodal-pressure tet (Bonet & Burton 1998),
    read only when use_anp: then the EOS sees the element's mean of its
    nodes' ratios instead of its own V/V0, which removes volumetric locking of the linear tet in
    nearly incompressible flow. Writes sdev, pressure, q, eps_p, eps_rate, temperature, energy,
    vol, the nodal forces `force` (n, 3) and per chunk: [min stable dt, viscous work, inverted
    count, index of the element with min dt].

    The elements run in parts of `part_chunks` chunks, part t, t + T, t + 2T, ... on thread t
    of T = `threads` (numba.get_num_threads(), passed in: called here, it would keep numba from
    caching the kernel), each part's chunks in order. Every corner adds its force to its row of
    `fext` (`rows`, `extra_ptr`, `extra_rows`: `scatter.force_rows` for parts of that size),
    which has that one writer, and each node's rows are then summed in part order into
    `force` (and left zero: fext must be zero on entry). Every node thus gets its elements'
    forces in the same order whatever the number of threads.

    `claimed`: the caller's buffer of the parts' flags (`part_flags`; zeroed here), or None
    for a new one. `skip`: None, or (n_parts,) int64 with 1 for each part to leave as it is
    (its elements, rows and chunk_out untouched: subcycling, solver/subcycle.py). With
    `sum_rows` False the rows are left for the caller to sum (`force` is not written).

    `plastic`: None when every tet is elastic (the radial return is then not even compiled:
    a case of elastic bodies waits that much less for its first step with a cold cache), else
    True (`plastic_kernel`).

    `guard` (n_elem,) int8 or None: where given, the distortion guard's verdicts on the
    cells of every full block, for the fracture criteria that run next on the same x, v and dt
    (solver/guard.py): `_chunk` gives them on its blocks, `_masked_blocks` on the lanes of its
    passes (PASSED on eroded cells, which the criteria pass by), each with SPALL_CLEAR added
    where the stored stress is clear of the spall strength (``guard.spall_marks``); the mesh's
    last, partial block is not written. Compiled into the plastic specialisation only
    (`plastic` True): the elastic kernel, the demo's, would otherwise compile the guard's
    loop too (0.5-1 s of a cold cache) for scenes that never ask for it; with plastic None the
    array is left as it is.

    Three kernels: the full blocks of intact elements of one material (`_chunk`), then, only if
    a chunk left any (OUT_DEFERRED), the other blocks in masked passes and the mesh's last
    block (`_deferred_chunk`: after all full blocks of their part, on the same thread, so each
    force row still has one writer and one order), then the rows' sum. A case with no such
    block (the demo) never compiles the second. Below PARALLEL_ELEMENTS tets they run on one
    thread (`_update_serial`, `_sum_serial`: the same parts in the same order, so the same
    bits), which also spares a small case the compile of the parallel kernels (about 5 s of a
    cold cache).

    The stable dt of an element is L / (Q + sqrt(Q^2 + c^2)), L = 3V / max face area (smallest
    altitude), Q = C_l c + C_q^2 L |tr D| in compression, c the EOS sound speed with 4G/3rho.
    """
    parallel = conn.shape[0] >= PARALLEL_ELEMENTS
    claimed = part_flags(conn.shape[0], part_chunks, claimed)
    claimed[:] = 0 if skip is None else skip
    args = (x, v, conn, elem_mat, status, sdev, pressure, q, eps_p, eps_rate, temperature, hard,
            thermal, energy, vol, vol_eos, vol0, elem_mass, mat_params, jnode, use_anp, dt, cq,
            cl, rows, fext, part_chunks, chunk_out, threads, plastic,
            G.NONE_GIVEN if guard is None else guard, claimed)
    kernel = _update_parallel if parallel else _update_serial
    kernel(*args, None)
    if _deferred_left(chunk_out, skip, part_chunks):  # masked passes, the mesh's last block
        claimed[:] = 0 if skip is None else skip
        kernel(*args, True)
    if sum_rows:
        (_sum_parallel if parallel else _sum_serial)(force, fext, extra_ptr, extra_rows)


def _deferred_left(chunk_out, skip, part_chunks) -> bool:
    """Whether a chunk of a part that ran left blocks to the masked passes (the chunks of the
    parts skipped keep the bits of their last update)."""
    bits = chunk_out[:, OUT_DEFERRED]
    if skip is None:
        return bool(bits.any())
    ran = np.repeat(skip == 0, part_chunks)[:len(bits)]
    return bool((bits[ran] != 0.0).any())


def part_flags(n_elem: int, part_chunks: int, buf=None) -> np.ndarray:
    """element_update's flags, one per part of `part_chunks` chunks (int64): `buf` when it has
    that size, else a new array. Made outside the parallel kernel: its threads share an array
    its caller made (solver/workqueue.py)."""
    n_chunks = -(-n_elem // CHUNK)
    n_parts = -(-n_chunks // part_chunks)
    if buf is not None and buf.shape == (n_parts,) and buf.dtype == np.int64:
        return buf
    return np.zeros(n_parts, np.int64)


# nogil: the frame writer's thread (output/series.py) runs while the kernel does
@numba.njit(cache=True, parallel=True, nogil=True, error_model="numpy", fastmath=FAST)
def _update_parallel(x, v, conn, elem_mat, status, sdev, pressure, q, eps_p, eps_rate, temperature,
                     hard, thermal, energy, vol, vol_eos, vol0, elem_mass, mat_params, jnode,
                     use_anp, dt, cq, cl, rows, fext, part_chunks, chunk_out, threads, plastic,
                     guard, claimed, deferred):
    """element_update's blocks on `threads` threads: parts t, t + threads, t + 2 threads, ... on
    thread t, each in chunk order, then the parts of the other threads not begun yet, from
    their last (`_visit`; a part goes to the thread that claims it first, `claimed` (n_parts,)
    int64 zeros); the full blocks (`_chunk`) with `deferred` None, else the blocks they left
    (`_deferred_chunk`): two specialisations, pruned at compile time."""
    half = 0.5 * dt
    n_ch = (conn.shape[0] + CHUNK - 1) // CHUNK
    n_parts = (n_ch + part_chunks - 1) // part_chunks
    for t in numba.prange(threads):
        buf = aligned_empty(TET_ROWS * B)  # one block buffer per thread and step
        for k in range(n_parts):
            part = _visit(t, k, n_parts, threads)
            if fetch_add(claimed[part:part + 1], 1) != 0:
                continue
            c0, c1 = part * part_chunks, min(n_ch, (part + 1) * part_chunks)
            if deferred is None:
                _chunk(c0, c1, x, v, conn, elem_mat, status, sdev, pressure, q, eps_p, eps_rate,
                       temperature, hard, thermal, energy, vol, vol_eos, vol0, elem_mass,
                       mat_params, jnode, use_anp, half, dt, cq, cl, rows, fext, chunk_out, buf,
                       plastic, guard)
            else:
                for ch in range(c0, c1):
                    if chunk_out[ch, OUT_DEFERRED] != 0.0:
                        _deferred_chunk(ch, x, v, conn, elem_mat, status, sdev, pressure, q,
                                        eps_p, eps_rate, temperature, hard, thermal, energy, vol,
                                        vol_eos, vol0, elem_mass, mat_params, jnode, use_anp,
                                        half, dt, cq, cl, rows, fext, chunk_out, buf, plastic,
                                        guard)


@numba.njit(cache=True, inline="always")
def _visit(t, k, n_parts, threads):
    """The k-th of the n_parts parts thread t visits: its own (t, t + threads, ...) first to
    last, then each other thread's (from t + 1 on, cyclically) last to first. A thread keeps
    its parts from step to step and finds their state in the caches it filled; it takes
    another's only at the end of the loop, where that one has fallen behind (it lost its core
    for a while, or its parts hold more of a crush's plastic returns and masked passes)."""
    for s in range(threads):
        u = (t + s) % threads
        n_u = (n_parts - u + threads - 1) // threads if u < n_parts else 0
        if k < n_u:
            return u + k * threads if s == 0 else u + (n_u - 1 - k) * threads
        k -= n_u
    return -1


@numba.njit(cache=True, nogil=True, error_model="numpy", fastmath=FAST)
def _update_serial(x, v, conn, elem_mat, status, sdev, pressure, q, eps_p, eps_rate, temperature,
                   hard, thermal, energy, vol, vol_eos, vol0, elem_mass, mat_params, jnode,
                   use_anp, dt, cq, cl, rows, fext, part_chunks, chunk_out, threads, plastic,
                   guard, claimed, deferred):
    """`_update_parallel` on one thread: the parts not `claimed` (the caller's flags) in order,
    each part's chunks in order, `_chunk` called from here directly (numba links a called
    kernel's code into its caller and optimises it again there, so every level of calls costs
    compile time: one more, 1.5 s)."""
    buf = aligned_empty(TET_ROWS * B)
    n_ch = (conn.shape[0] + CHUNK - 1) // CHUNK
    if deferred is None:
        for part in range((n_ch + part_chunks - 1) // part_chunks):
            if claimed[part] == 0:  # not left out (subcycling: solver/subcycle.py)
                _chunk(part * part_chunks, min(n_ch, (part + 1) * part_chunks), x, v, conn,
                       elem_mat, status, sdev, pressure, q, eps_p, eps_rate, temperature, hard,
                       thermal, energy, vol, vol_eos, vol0, elem_mass, mat_params, jnode,
                       use_anp, 0.5 * dt, dt, cq, cl, rows, fext, chunk_out, buf, plastic,
                       guard)
        return
    for ch in range(n_ch):
        if chunk_out[ch, OUT_DEFERRED] != 0.0 and claimed[ch // part_chunks] == 0:
            _deferred_chunk(ch, x, v, conn, elem_mat, status, sdev, pressure, q, eps_p,
                            eps_rate, temperature, hard, thermal, energy, vol, vol_eos, vol0,
                            elem_mass, mat_params, jnode, use_anp, 0.5 * dt, dt, cq, cl, rows,
                            fext, chunk_out, buf, plastic, guard)


@numba.njit(cache=True, parallel=True, nogil=True)
def _sum_parallel(force, fext, extra_ptr, extra_rows):
    """Each node's rows summed in part order into force (`scatter.take_node`)."""
    for i in numba.prange(force.shape[0]):
        force[i, 0], force[i, 1], force[i, 2] = take_node(i, fext, extra_ptr, extra_rows)


@numba.njit(cache=True, nogil=True)
def _sum_serial(force, fext, extra_ptr, extra_rows):
    """`_sum_parallel` on one thread."""
    for i in range(force.shape[0]):
        force[i, 0], force[i, 1], force[i, 2] = take_node(i, fext, extra_ptr, extra_rows)


def plastic_kernel(elem_mat: np.ndarray, mat_params: np.ndarray):
    """element_update's `plastic` argument: None if every element of `elem_mat` is elastic, else
    True. The two values are two specialisations of the kernel; the warm-up compiles both."""
    used = np.unique(elem_mat)
    return True if (mat_params[used, P.STRENGTH] != P.ELASTIC).any() else None


# node_forces runs on one thread below this many nodes: it is called every step that erosion or
# particle conversion removes elements, for their few hundred nodes, where a parallel launch
# costs more than it saves (and much more when other processes hold the cores). The warm-up
# sets it to 0 for one scene so that both versions are compiled.
PARALLEL_FORCE_NODES = 20_000


def node_forces(nodes, x, conn, status, sdev, pressure, q, n2e_ptr, n2e, force):
    """Recompute the force on each of `nodes` from the current stress of its live elements
    (-V sigma grad N per element, summed in the node-to-element order n2e): after a pass
    removed elements, the forces the kernel added for them leave their nodes. An eroded or
    inverted element adds nothing, as in `element_update`. Every node's sum is
    `_node_force`'s, on one thread or on all (PARALLEL_FORCE_NODES)."""
    kernel = (_node_forces_parallel if nodes.shape[0] >= PARALLEL_FORCE_NODES
              else _node_forces_serial)
    kernel(nodes, x, conn, status, sdev, pressure, q, n2e_ptr, n2e, force)


@numba.njit(cache=True, parallel=True, error_model="numpy", fastmath=FAST)
def _node_forces_parallel(nodes, x, conn, status, sdev, pressure, q, n2e_ptr, n2e, force):
    for j in numba.prange(nodes.shape[0]):
        _node_force(nodes[j], x, conn, status, sdev, pressure, q, n2e_ptr, n2e, force)


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def _node_forces_serial(nodes, x, conn, status, sdev, pressure, q, n2e_ptr, n2e, force):
    for j in range(nodes.shape[0]):
        _node_force(nodes[j], x, conn, status, sdev, pressure, q, n2e_ptr, n2e, force)


@numba.njit(cache=True, error_model="numpy", fastmath=FAST, inline="always")
def stored_corner_force(e, a, x, conn, status, sdev, pressure, q):
    """The force corner a of tet e adds to its node from the stored stress, -V sigma grad N_a
    at the current coordinates (as the element update assembled it); zero for an eroded or
    inverted tet, which adds nothing."""
    if status[e] == ERODED:
        return 0.0, 0.0, 0.0
    i0, i1, i2, i3 = conn[e, 0], conn[e, 1], conn[e, 2], conn[e, 3]
    det, b1x, b1y, b1z, b2x, b2y, b2z, b3x, b3y, b3z = _tet_gradients(
        x[i0, 0], x[i0, 1], x[i0, 2], x[i1, 0], x[i1, 1], x[i1, 2],
        x[i2, 0], x[i2, 1], x[i2, 2], x[i3, 0], x[i3, 1], x[i3, 2])
    if not det > 0.0:
        return 0.0, 0.0, 0.0
    ptot = pressure[e] + q[e]
    f1x, f1y, f1z, f2x, f2y, f2z, f3x, f3y, f3z = _corner_forces(
        sdev[e, 0] - ptot, sdev[e, 1] - ptot, sdev[e, 2] - ptot, sdev[e, 3], sdev[e, 4],
        sdev[e, 5], b1x, b1y, b1z, b2x, b2y, b2z, b3x, b3y, b3z)
    if a == 0:
        return -(f1x + f2x + f3x), -(f1y + f2y + f3y), -(f1z + f2z + f3z)
    if a == 1:
        return f1x, f1y, f1z
    if a == 2:
        return f2x, f2y, f2z
    return f3x, f3y, f3z


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def _node_force(i, x, conn, status, sdev, pressure, q, n2e_ptr, n2e, force):
    """force[i] from node i's live elements (node_forces)."""
    fx = 0.0
    fy = 0.0
    fz = 0.0
    for k in range(n2e_ptr[i], n2e_ptr[i + 1]):
        e = n2e[k] // 4
        gx, gy, gz = stored_corner_force(e, n2e[k] - 4 * e, x, conn, status, sdev, pressure, q)
        fx += gx
        fy += gy
        fz += gz
    force[i, 0] = fx
    force[i, 1] = fy
    force[i, 2] = fz
