"""Node kernels of the explicit scheme: predictor, move, nodal volume ratios, sums.

The element update adds the nodal forces itself (solver/element.py). Gathers go through the
node-to-element index (Model.n2e_ptr / n2e), so every node sums its element corners in a fixed
order: deterministic whatever the thread count. Reductions use fixed chunks summed in order for
the same reason.
"""

from __future__ import annotations

import numba
import numpy as np

CHUNK = 4096


# Below this many nodes predict and move run on one thread: they stream 7 and 6 numbers per
# node with one multiply-add each, and a parallel launch (a few us on an idle machine, up to
# milliseconds when other processes hold the cores and the threads wait for each other) costs
# more than the second thread saves. The warm-up (impactsim/warmup.py) sets it to 0 for one
# scene so that both versions are compiled.
PARALLEL_NODES = 200_000


def predict(force, mass, v, dtv):
    """U*_i = U_i + dtv force_i / m_i [D19 eq. 2]; force (n, 3) the nodal forces of the element
    update, dtv the velocity step (the mean of the previous and the new time step, so the
    leapfrog stays second order when dt changes). A node without mass is left alone. The same
    arithmetic per node on one thread or on all (PARALLEL_NODES)."""
    if mass.shape[0] >= PARALLEL_NODES:
        _predict_parallel(force, mass, v, dtv)
    else:
        _predict_serial(force, mass, v, dtv)


def move(x, v, dt):
    """x^{n+1} = x^n + dt U^{n+1}, after every velocity correction of the step [D19 eq. 3];
    on all threads from PARALLEL_NODES nodes on."""
    if x.shape[0] >= PARALLEL_NODES:
        _move_parallel(x, v, dt)
    else:
        _move_serial(x, v, dt)


# The node's update is written out in both loops: called as a helper (inline="always" or not)
# from the serial loop, numba kept an NRT incref and decref of every array per node: 10.7 ns
# per node instead of 1.3 (docs/performance.md, the hex section of session 8).
@numba.njit(cache=True, parallel=True)
def _predict_parallel(force, mass, v, dtv):
    for i in numba.prange(mass.shape[0]):
        mi = mass[i]
        if mi > 0.0:
            a = dtv / mi
            v[i, 0] += a * force[i, 0]
            v[i, 1] += a * force[i, 1]
            v[i, 2] += a * force[i, 2]


@numba.njit(cache=True)
def _predict_serial(force, mass, v, dtv):
    for i in range(mass.shape[0]):
        mi = mass[i]
        if mi > 0.0:
            a = dtv / mi
            v[i, 0] += a * force[i, 0]
            v[i, 1] += a * force[i, 1]
            v[i, 2] += a * force[i, 2]


@numba.njit(cache=True, parallel=True)
def _move_parallel(x, v, dt):
    for i in numba.prange(x.shape[0]):
        x[i, 0] += dt * v[i, 0]
        x[i, 1] += dt * v[i, 1]
        x[i, 2] += dt * v[i, 2]


@numba.njit(cache=True)
def _move_serial(x, v, dt):
    for i in range(x.shape[0]):
        x[i, 0] += dt * v[i, 0]
        x[i, 1] += dt * v[i, 1]
        x[i, 2] += dt * v[i, 2]


@numba.njit(cache=True, parallel=True)
def element_volumes(x, conn, status, out):
    """Current volumes of all elements (0 for eroded ones) [m^3]."""
    for e in numba.prange(conn.shape[0]):
        if status[e] == 3:
            out[e] = 0.0
            continue
        i0, i1, i2, i3 = conn[e, 0], conn[e, 1], conn[e, 2], conn[e, 3]
        ax, ay, az = x[i1, 0] - x[i0, 0], x[i1, 1] - x[i0, 1], x[i1, 2] - x[i0, 2]
        bx, by, bz = x[i2, 0] - x[i0, 0], x[i2, 1] - x[i0, 1], x[i2, 2] - x[i0, 2]
        cx, cy, cz = x[i3, 0] - x[i0, 0], x[i3, 1] - x[i0, 1], x[i3, 2] - x[i0, 2]
        out[e] = (ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)) / 6.0


@numba.njit(cache=True, parallel=True)
def nodal_volume_ratio(vol_now, vol0, status, n2e_ptr, n2e, jnode):
    """J_i = sum_e V_e / sum_e V0_e over the live elements around node i (Bonet & Burton 1998)."""
    n = jnode.shape[0]
    for i in numba.prange(n):
        num = 0.0
        den = 0.0
        for k in range(n2e_ptr[i], n2e_ptr[i + 1]):
            e = n2e[k] // 4
            if status[e] != 3:
                num += vol_now[e]
                den += vol0[e]
        jnode[i] = num / den if den > 0.0 else 1.0


@numba.njit(cache=True)
def kinetic_energy(v, mass):
    """Sum of m |v|^2 / 2 [J], in fixed chunks (thread-count independent)."""
    n = mass.shape[0]
    nch = (n + CHUNK - 1) // CHUNK
    part = np.zeros(max(nch, 1))
    for ch in range(nch):
        s = 0.0
        for i in range(ch * CHUNK, min(n, (ch + 1) * CHUNK)):
            s += mass[i] * (v[i, 0] * v[i, 0] + v[i, 1] * v[i, 1] + v[i, 2] * v[i, 2])
        part[ch] = s
    return 0.5 * part.sum()


@numba.njit(cache=True)
def force_power(force, v, mass):
    """Sum of F . v [W] over the nodes with mass, in fixed chunks (thread-count independent):
    with the velocities of t^{n+1/2} and the forces of t^{n+1}, half a velocity step of it is
    what the kinetic energy gains (and a prescribed node's reaction works) from t^{n+1/2} to
    t^{n+1} (Simulation.energies, the time-centred balance)."""
    n = mass.shape[0]
    total = 0.0
    for c in range(0, n, CHUNK):
        s = 0.0
        for i in range(c, min(n, c + CHUNK)):
            if mass[i] > 0.0:
                s += force[i, 0] * v[i, 0] + force[i, 1] * v[i, 1] + force[i, 2] * v[i, 2]
        total += s
    return total


@numba.njit(cache=True)
def internal_energy(energy, elem_mass, status):
    """Sum of m_e e_e over live elements [J]."""
    s = 0.0
    for e in range(energy.shape[0]):
        if status[e] != 3:
            s += elem_mass[e] * energy[e]
    return s
