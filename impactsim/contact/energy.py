"""Energy bookkeeping of the contact impulses (history.csv ``contact_dissipated``)."""

from __future__ import annotations

import numba


@numba.njit(cache=True)
def impulse_work(nodes, v_star, v, mass, force, dtv, stamp, start):
    """Energy of the contact corrections of ALGORITHMS.md 3 (velocity equalisation is an
    inelastic impact, ALGORITHMS.md 1 energy accounting).

    Work [J] of the velocity corrections of ``nodes`` in one step, in the convention of the
    solver's walls (impactsim.solver.constraints): the impulse J = m (U - U*) acts at t^n while
    the node moves with the mean of U^{n-1/2} = U* - dtv F / m and U^{n+1/2} = U, so its work
    is J . (U^{n-1/2} + U) / 2. ``v_star (h, 3)``: U* of the nodes before any contact pass.
    Velocity equalisation is an inelastic impact: the work is negative (kinetic energy lost).
    ``stamp``, ``start``: the sweep numbers of ``passes.ContactContext.stamps`` and the last
    number before the step's first sweep; a node whose stamp is not above it was not changed
    (U = U*, no work) and is not read."""
    work = 0.0
    for k in range(nodes.shape[0]):
        i = nodes[k]
        if stamp[i] <= start:
            continue
        m = mass[i]
        if m <= 0.0:
            continue
        for d in range(3):
            dv = v[i, d] - v_star[k, d]
            if dv != 0.0:
                work += m * dv * 0.5 * (v_star[k, d] - dtv * force[i, d] / m + v[i, d])
    return work
