"""All bodies in one linear system: the check of the Schwarz iteration.

The same discrete contact problem as the Schwarz iteration (A's normal rows C_a, B's
displacement at the matching points I_b, the pressure transfer G_b M_aa^-1, the same active-set
rules), solved at once with Lagrange multipliers: one sparse LU of

    [ K_a        0      C_a^T          ] [u_a]   [f_a]
    [ 0          K_b   -G_b M_aa^-1    ] [u_b] = [f_b]
    [ C_a       -I_b    0              ] [lam]   [gap]

(one block row per body and per interface), repeated until the active set settles. With
friction (friction.py) the stick nodes add tangential rows and multipliers, the slip nodes the
tractions mu p d (linear in the multipliers), and the stick/slip sets settle with the active set
by the iteration's rules. Bodies held
only by their contacts get the same proximal weak springs as in the iteration, so the converged
answer does not depend on them. Temperatures come from the bodies' heat solvers as given.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from impactsim.quasistatic import friction
from impactsim.quasistatic.body import BodyState
from impactsim.quasistatic.schwarz import update_active


def solve_monolithic(states: dict[int, BodyState], interfaces, scale: float = 1.0,
                     max_active_iterations: int = 50, proximal_iterations: int = 30,
                     tolerance: float = 1e-12, friction_states: list | None = None
                     ) -> tuple[dict[int, np.ndarray], list]:
    """Displacements per body and the active sets per interface (and, into
    `friction_states` when given, the friction.FrictionState per interface)."""
    order = sorted(states)
    off = {}
    n = 0
    for i in order:
        st = states[i]
        st.mech_begin(scale)
        off[i] = n
        n += len(st.elastic.F)
    active = [itf.matched & ((itf.gap <= 1e-6 * np.sqrt(itf.M_a.diagonal().mean())) | itf.tied)
              for itf in interfaces]
    fstates = friction.initial(interfaces, active)
    friction.begin_step(fstates)
    if friction_states is not None:
        friction_states.extend(fstates)
    u_prev = {i: np.zeros(states[i].elastic.ndof) for i in order}
    u = u_prev
    for _ in range(max_active_iterations):
        for _ in range(proximal_iterations):
            u, lam, fric = _solve(states, interfaces, active, off, n, u_prev, fstates)
            change = max(np.max(np.abs(u[i] - u_prev[i]), initial=0) for i in order)
            size = max(np.max(np.abs(u[i]), initial=0) for i in order)
            u_prev = u
            if change <= tolerance * max(size, 1e-30):
                break
        size = max(np.max(np.abs(u[i]), initial=0) for i in order)
        new = []
        for c, itf in enumerate(interfaces):
            ua = itf.C_a @ u[itf.a]
            ub = itf.I_b @ u[itf.b]
            p = lam[c]
            pen = ua - ub - itf.gap
            pscale = max(max(np.max(np.abs(q), initial=0) for q in lam), 1e-30)
            new.append(update_active(itf, active[c], p, pen, 1e-4 * size, pscale))
        fchanged = friction.monolithic_update(interfaces, fstates, *fric, u, lam, active, new,
                                              size)
        if all((a == b).all() for a, b in zip(new, active)) and not fchanged:
            return u, active
        active = new
    raise RuntimeError("monolithic: the active set did not settle")


def _mass(itf):
    """The surface mass of A's pressures: lumped on Robin interfaces (interfaces.robin_mass)."""
    if itf.robin:
        from impactsim.quasistatic.interfaces import robin_mass
        return robin_mass(itf)
    return itf.M_a


def _solve(states, interfaces, active, off, n, u_prev, fstates=None):
    rows, cols, vals = [], [], []
    rhs = np.zeros(n)

    def add(block: sp.spmatrix, r0: int, c0: int):
        b = block.tocoo()
        rows.append(b.row + r0)
        cols.append(b.col + c0)
        vals.append(b.data)

    for i, st in states.items():
        e = st.elastic
        Kff = e.K[e.F][:, e.F]
        add(Kff + e.springs, off[i], off[i])
        # the same springs as the iteration's: to the previous iterate, across a centering
        # axis to the reference position (they hold the pellets' sideways position; pulling
        # to the previous iterate instead left it free: 2.9e-3 axially, 12 % sideways)
        rhs[off[i]:off[i] + len(e.F)] = (st.f[e.F] - e.KfD @ st.uD
                                         + e.spring_rhs(u_prev[i]))
    m = n
    lam_slices = []
    extra_rhs = []
    for c, itf in enumerate(interfaces):
        idx = np.nonzero(active[c])[0]
        lam_slices.append((m, idx))
        if not len(idx):
            continue
        ea, eb = states[itf.a].elastic, states[itf.b].elastic
        Ca = itf.C_a[idx]
        Ib = itf.I_b[idx]
        Maa = _mass(itf)[idx][:, idx].tocsc()
        Minv = sp.csr_matrix(np.linalg.inv(Maa.toarray()))
        # equilibrium rows
        add(Ca[:, ea.F].T, off[itf.a], m)
        add(-(itf.G_b[:, idx][eb.F] @ Minv), off[itf.b], m)
        # constraint rows (prescribed dofs to the right-hand side)
        add(Ca[:, ea.F], m, off[itf.a])
        add(-Ib[:, eb.F], m, off[itf.b])
        g = itf.gap[idx] - Ca[:, ea.D] @ states[itf.a].uD + Ib[:, eb.D] @ states[itf.b].uD
        extra_rhs.append(g)
        m += len(idx)
    f_rhs, f_slices, m = friction.monolithic_blocks(states, interfaces, active, fstates,
                                                    lam_slices, off, m, add)
    extra_rhs += f_rhs
    A = sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(m, m))
    b = np.concatenate([rhs] + extra_rhs)
    x = sla.splu(A).solve(b)
    u = {}
    for i, st in states.items():
        e = st.elastic
        ui = np.zeros(e.ndof)
        ui[e.F] = x[off[i]:off[i] + len(e.F)]
        ui[e.D] = st.uD
        u[i] = ui
    lam = []
    for c, (m0, idx) in enumerate(lam_slices):
        p = np.zeros(len(interfaces[c].gap))
        if len(idx):
            Maa = _mass(interfaces[c])[idx][:, idx].toarray()
            p[idx] = np.linalg.solve(Maa, x[m0:m0 + len(idx)])
        lam.append(p)
    return u, lam, (f_slices, x)
