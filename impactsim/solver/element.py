"""The fused element update of the explicit scheme (ALGORITHMS.md 1-2) for 4-node tetrahedra.

One kernel does, per element: geometry at x^{n+1}, velocity gradient on the mid-step
configuration x^{n+1/2} = x^{n+1} - dt/2 U^{n+1}, hypoelastic Jaumann update of the deviator,
radial return, EOS pressure with the per-element internal energy integrated implicitly in e,
bulk artificial viscosity, the element's nodal forces and its stable time step. Forces are stored
per element corner and gathered per node afterwards (deterministic, no racing scatter).

Elements are processed in fixed chunks; per-chunk reductions (time step, viscous work, inverted
elements) are summed in chunk order, so results do not depend on the number of threads.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from impactsim.materials import params as P
from impactsim.materials.laws import eos_linear_part, radial_return
from impactsim.model import DAMAGED, ERODED, FRACTURED

CHUNK = 512
# IEEE semantics are kept (no nnan/ninf: inf marks "no limit"); numpy's error model drops the
# zero-division checks that Python semantics would put on every division.
FAST = {"nsz", "arcp", "contract", "afn", "reassoc"}
# columns of the per-chunk reduction array
OUT_DT, OUT_QWORK, OUT_INVERTED, OUT_WORST = 0, 1, 2, 3
N_OUT = 4


def n_chunks(n_elem: int) -> int:
    return max(1, (n_elem + CHUNK - 1) // CHUNK)


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


@numba.njit(cache=True, parallel=True, error_model="numpy", fastmath=FAST)
def element_update(x, v, conn, elem_mat, status, sdev, pressure, q, eps_p, eps_rate, temperature,
                   energy, vol, vol_eos, vol0, elem_mass, mat_params, jnode, use_anp, dt, cq, cl,
                   elem_force, chunk_out):
    """Advance every element from step n to n+1 and compute its nodal forces at n+1.

    x (n,3) positions x^{n+1}; v (n,3) velocities U^{n+1} (the step's velocity); dt the step.
    jnode (n,) nodal volume ratios of the averaged-nodal-pressure tet (Bonet & Burton 1998), read
    only when use_anp: then the EOS sees the element's mean of its nodes' ratios instead of its
    own V/V0, which removes volumetric locking of the linear tet in nearly incompressible flow.
    Writes sdev, pressure, q, eps_p, eps_rate, temperature, energy, vol, elem_force (4e, 3) and
    per chunk: [min stable dt, viscous work, inverted count, index of the element with min dt].
    The stable dt of an element is L / (Q + sqrt(Q^2 + c^2)), L = 3V / max face area (smallest
    altitude), Q = C_l c + C_q^2 L |tr D| in compression, c the EOS sound speed with 4G/3rho.
    """
    n_elem = conn.shape[0]
    nch = chunk_out.shape[0]
    half = 0.5 * dt
    for ch in numba.prange(nch):
        dt_min = math.inf
        worst = -1
        qwork = 0.0
        inverted = 0
        e_end = min(n_elem, (ch + 1) * CHUNK)
        for e in range(ch * CHUNK, e_end):
            st = status[e]
            if st == ERODED:
                for k in range(4):
                    for d in range(3):
                        elem_force[4 * e + k, d] = 0.0
                continue
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
            det, a1x, a1y, a1z, a2x, a2y, a2z, a3x, a3y, a3z = _tet_gradients(
                p0x - half * v0x, p0y - half * v0y, p0z - half * v0z,
                p1x - half * v1x, p1y - half * v1y, p1z - half * v1z,
                p2x - half * v2x, p2y - half * v2y, p2z - half * v2z,
                p3x - half * v3x, p3y - half * v3y, p3z - half * v3z)
            # velocity differences to node 0
            w1x, w1y, w1z = v1x - v0x, v1y - v0y, v1z - v0z
            w2x, w2y, w2z = v2x - v0x, v2y - v0y, v2z - v0z
            w3x, w3y, w3z = v3x - v0x, v3y - v0y, v3z - v0z
            inv = 1.0 / det if det != 0.0 else 0.0
            # L_ij = sum_a w_a,i dN_a/dx_j
            lxx = (w1x * a1x + w2x * a2x + w3x * a3x) * inv
            lxy = (w1x * a1y + w2x * a2y + w3x * a3y) * inv
            lxz = (w1x * a1z + w2x * a2z + w3x * a3z) * inv
            lyx = (w1y * a1x + w2y * a2x + w3y * a3x) * inv
            lyy = (w1y * a1y + w2y * a2y + w3y * a3y) * inv
            lyz = (w1y * a1z + w2y * a2z + w3y * a3z) * inv
            lzx = (w1z * a1x + w2z * a2x + w3z * a3x) * inv
            lzy = (w1z * a1y + w2z * a2y + w3z * a3y) * inv
            lzz = (w1z * a1z + w2z * a2z + w3z * a3z) * inv
            dxy = 0.5 * (lxy + lyx)
            dyz = 0.5 * (lyz + lzy)
            dzx = 0.5 * (lzx + lxz)
            wxy = 0.5 * (lxy - lyx)  # spin W = (L - L^T)/2
            wyz = 0.5 * (lyz - lzy)
            wzx = 0.5 * (lzx - lxz)
            trd = lxx + lyy + lzz
            third = trd / 3.0
            exx, eyy, ezz = lxx - third, lyy - third, lzz - third  # deviatoric D'
            # --- geometry at n+1: volume and force gradients
            det1, b1x, b1y, b1z, b2x, b2y, b2z, b3x, b3y, b3z = _tet_gradients(
                p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z, p3x, p3y, p3z)
            vnew = det1 / 6.0
            if vnew <= 0.0:
                inverted += 1
                for k in range(4):
                    for d in range(3):
                        elem_force[4 * e + k, d] = 0.0
                continue
            vold = vol[e]
            veos_old = vol_eos[e]  # the same array as vol for tet4
            mk = elem_mat[e]
            mass = elem_mass[e]
            rho = mass / vnew
            rho0 = mat_params[mk, P.RHO0]
            shear = mat_params[mk, P.G]
            # --- deviatoric stress: Jaumann rate s' = 2G D' + W s - s W
            sxx, syy, szz = sdev[e, 0], sdev[e, 1], sdev[e, 2]
            sxy, syz, szx = sdev[e, 3], sdev[e, 4], sdev[e, 5]
            # (W s - s W) for symmetric s, skew W with W_xy = wxy, W_yz = wyz, W_zx = wzx
            rxx = 2.0 * (wxy * sxy - wzx * szx)
            ryy = 2.0 * (wyz * syz - wxy * sxy)
            rzz = 2.0 * (wzx * szx - wyz * syz)
            rxy = wxy * (syy - sxx) + wzx * syz - wyz * szx
            ryz = wyz * (szz - syy) + wxy * szx - wzx * sxy
            rzx = wzx * (sxx - szz) + wyz * sxy - wxy * syz
            g2 = 2.0 * shear
            nxx = sxx + dt * (g2 * exx + rxx)
            nyy = syy + dt * (g2 * eyy + ryy)
            nzz = szz + dt * (g2 * ezz + rzz)
            nxy = sxy + dt * (g2 * dxy + rxy)
            nyz = syz + dt * (g2 * dyz + ryz)
            nzx = szx + dt * (g2 * dzx + rzx)
            # effective deviatoric strain rate sqrt(2/3 D':D')
            rate = math.sqrt((2.0 / 3.0) * (exx * exx + eyy * eyy + ezz * ezz
                                            + 2.0 * (dxy * dxy + dyz * dyz + dzx * dzx)))
            eps_rate[e] = rate
            code = int(mat_params[mk, P.STRENGTH])
            deps = 0.0
            sy = 0.0
            if st != 0:  # damaged or fractured: no deviatoric stress (ALGORITHMS.md 4.1)
                nxx = nyy = nzz = nxy = nyz = nzx = 0.0
            elif code != P.ELASTIC:
                j2 = 0.5 * (nxx * nxx + nyy * nyy + nzz * nzz) + nxy * nxy + nyz * nyz + nzx * nzx
                seq = math.sqrt(3.0 * j2)
                deps, sy = radial_return(code, mat_params, mk, shear, seq, eps_p[e], rate, temperature[e])
                if deps > 0.0:
                    scale = sy / seq if seq > 0.0 else 0.0
                    nxx *= scale
                    nyy *= scale
                    nzz *= scale
                    nxy *= scale
                    nyz *= scale
                    nzx *= scale
                    eps_p[e] += deps
                    temperature[e] += mat_params[mk, P.TQ] * sy * deps / (rho * mat_params[mk, P.CV])
            # deviatoric work over the step with the mid-step stress and volume
            wdev = 0.5 * dt * (vold + vnew) * 0.5 * (
                (sxx + nxx) * exx + (syy + nyy) * eyy + (szz + nzz) * ezz
                + 2.0 * ((sxy + nxy) * dxy + (syz + nyz) * dyz + (szx + nzx) * dzx))
            sdev[e, 0], sdev[e, 1], sdev[e, 2] = nxx, nyy, nzz
            sdev[e, 3], sdev[e, 4], sdev[e, 5] = nxy, nyz, nzx
            # --- artificial bulk viscosity and characteristic length
            f1 = b1x * b1x + b1y * b1y + b1z * b1z
            f2 = b2x * b2x + b2y * b2y + b2z * b2z
            f3 = b3x * b3x + b3y * b3y + b3z * b3z
            s0x, s0y, s0z = b1x + b2x + b3x, b1y + b2y + b3y, b1z + b2z + b3z
            f0 = s0x * s0x + s0y * s0y + s0z * s0z
            # |grad N_a| det = 2 * (area of the face opposite a); L = 3V / A_max = det / |g|max
            fmax = max(max(f0, f1), max(f2, f3))
            length = det1 / math.sqrt(fmax)
            # --- pressure: EOS with the energy integrated implicitly (p = a + b e); the ANP tet
            # feeds the EOS the averaged nodal volume ratio and integrates p dV with its volume
            if use_anp:
                veos = 0.25 * (jnode[i0] + jnode[i1] + jnode[i2] + jnode[i3]) * vol0[e]
            else:
                veos = vnew
            pa, pb, c2a, c2b = eos_linear_part(int(mat_params[mk, P.EOS]), mass / veos, rho0, mat_params[mk, P.K], mat_params[mk, P.C0],
                                               mat_params[mk, P.S], mat_params[mk, P.GAMMA0])
            pold = pressure[e]
            dv = veos - veos_old
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
            qwork -= qn * dv
            vol[e] = vnew
            vol_eos[e] = veos
            # --- stable time step
            c2 = c2a + c2b * max(pn, 0.0)
            if c2 < 0.0:
                c2 = 0.0
            if st == 0:
                c2 += 4.0 * shear / (3.0 * rho)
            c = math.sqrt(c2)
            qq = 0.0
            if trd < 0.0:
                qq = cl * c + cq * cq * length * (-trd)
            dte = length / (qq + math.sqrt(qq * qq + c2)) if c2 > 0.0 or qq > 0.0 else math.inf
            if dte < dt_min:
                dt_min = dte
                worst = e
            # --- nodal forces f_a = -V sigma grad N_a, sigma = s - (p + q) I
            ptot = pn + qn
            txx, tyy, tzz = nxx - ptot, nyy - ptot, nzz - ptot
            # V grad N_a = (det/6) (b_a / det) = b_a / 6
            s6 = -1.0 / 6.0
            f1x = s6 * (txx * b1x + nxy * b1y + nzx * b1z)
            f1y = s6 * (nxy * b1x + tyy * b1y + nyz * b1z)
            f1z = s6 * (nzx * b1x + nyz * b1y + tzz * b1z)
            f2x = s6 * (txx * b2x + nxy * b2y + nzx * b2z)
            f2y = s6 * (nxy * b2x + tyy * b2y + nyz * b2z)
            f2z = s6 * (nzx * b2x + nyz * b2y + tzz * b2z)
            f3x = s6 * (txx * b3x + nxy * b3y + nzx * b3z)
            f3y = s6 * (nxy * b3x + tyy * b3y + nyz * b3z)
            f3z = s6 * (nzx * b3x + nyz * b3y + tzz * b3z)
            k4 = 4 * e
            elem_force[k4, 0] = -(f1x + f2x + f3x)
            elem_force[k4, 1] = -(f1y + f2y + f3y)
            elem_force[k4, 2] = -(f1z + f2z + f3z)
            elem_force[k4 + 1, 0], elem_force[k4 + 1, 1], elem_force[k4 + 1, 2] = f1x, f1y, f1z
            elem_force[k4 + 2, 0], elem_force[k4 + 2, 1], elem_force[k4 + 2, 2] = f2x, f2y, f2z
            elem_force[k4 + 3, 0], elem_force[k4 + 3, 1], elem_force[k4 + 3, 2] = f3x, f3y, f3z
        chunk_out[ch, OUT_DT] = dt_min
        chunk_out[ch, OUT_QWORK] = qwork
        chunk_out[ch, OUT_INVERTED] = inverted
        chunk_out[ch, OUT_WORST] = worst
