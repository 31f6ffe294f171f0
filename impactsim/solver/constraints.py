"""Kinematic constraints on the predictor velocities: prescribed node velocities and rigid walls.

Both are velocity-stage passes (ALGORITHMS.md 1, step 3): they see x^n and U* and correct U*.
Energy: a velocity correction is an impulse J = m (U - U*) at time t^n, where the node moves
with the mean of its old and new velocities (U^{n-1/2} + U^{n+1/2}) / 2; the impulse does the work
J . (U^{n-1/2} + U^{n+1/2}) / 2 (zero for a node held at rest or resting on a wall, as it must
be: the predictor's U* is not a velocity the node ever has). U^{n-1/2} = U* - dtv F / m is
recovered from the force of the step. A prescribed velocity's work is external work; a
stationary wall's work is kinetic energy lost in inelastic node impacts (``contact_dissipated``),
so the balance KE + IE + dissipated - external work stays closed.
"""

from __future__ import annotations

import numba
import numpy as np

from impactsim.solver.passes import Pass


@numba.njit(cache=True)
def apply_prescribed(v, mass, force, dtv, nodes, mask, velocity):
    """Set the prescribed components; return the work of the reactions over the step [J]."""
    work = 0.0
    for k in range(nodes.shape[0]):
        i = nodes[k]
        if mass[i] <= 0.0:  # a node orphaned by erosion carries no mass (ALGORITHMS.md 4.2)
            continue
        for d in range(3):
            if mask[k, d]:
                vn = velocity[k, d]
                v_old = v[i, d] - dtv * force[i, d] / mass[i]
                work += mass[i] * (vn - v[i, d]) * 0.5 * (v_old + vn)
                v[i, d] = vn
    return work


@numba.njit(cache=True)
def apply_walls(x, v, mass, force, dtv, walls, dt):
    """Rigid planar walls as a kinematic constraint (compressive only).

    walls (w, 7): point, unit normal (into the allowed side), Coulomb friction coefficient.
    A node whose predicted position x + dt U* would lie behind a wall gets the normal velocity
    that lands it on the wall (a node already behind it by round-off is put back on it); the
    wall never pulls. Friction takes up to mu times the normal velocity change from the
    tangential velocity. Returns (work of the wall on the nodes [J], number of nodes touched,
    normal impulse [N s]).
    """
    work = 0.0
    impulse = 0.0
    touched = 0
    for w in range(walls.shape[0]):
        px, py, pz = walls[w, 0], walls[w, 1], walls[w, 2]
        nx, ny, nz = walls[w, 3], walls[w, 4], walls[w, 5]
        mu = walls[w, 6]
        for i in range(x.shape[0]):
            if mass[i] <= 0.0:  # orphaned by erosion: no mass, nothing to hold
                continue
            d_now = (x[i, 0] - px) * nx + (x[i, 1] - py) * ny + (x[i, 2] - pz) * nz
            vn = v[i, 0] * nx + v[i, 1] * ny + v[i, 2] * nz
            # the node must end on or in front of the wall: d_now + dt vn >= 0
            vn_min = -d_now / dt
            if vn >= vn_min:
                continue
            dvn = vn_min - vn
            a = dtv / mass[i]
            ox, oy, oz = v[i, 0] - a * force[i, 0], v[i, 1] - a * force[i, 1], v[i, 2] - a * force[i, 2]
            sx, sy, sz = v[i, 0], v[i, 1], v[i, 2]
            v[i, 0] += dvn * nx
            v[i, 1] += dvn * ny
            v[i, 2] += dvn * nz
            if mu > 0.0:
                vn2 = v[i, 0] * nx + v[i, 1] * ny + v[i, 2] * nz
                tx, ty, tz = v[i, 0] - vn2 * nx, v[i, 1] - vn2 * ny, v[i, 2] - vn2 * nz
                vt = np.sqrt(tx * tx + ty * ty + tz * tz)
                if vt > 0.0:
                    cut = min(vt, mu * dvn) / vt
                    v[i, 0] -= cut * tx
                    v[i, 1] -= cut * ty
                    v[i, 2] -= cut * tz
            mi = mass[i]
            work += mi * ((v[i, 0] - sx) * 0.5 * (ox + v[i, 0]) + (v[i, 1] - sy) * 0.5 * (oy + v[i, 1])
                          + (v[i, 2] - sz) * 0.5 * (oz + v[i, 2]))
            impulse += mi * dvn
            touched += 1
    return work, touched, impulse


class PrescribedVelocityPass(Pass):
    """Fixed and prescribed-velocity node sets of the case ([[body.constraint]])."""

    name = "boundary-conditions"
    stage = "velocity"

    def run(self, model, dt):
        model.energy_terms["external_work"] += apply_prescribed(
            model.v, model.mass, model.force, model.dtv, model.bc_nodes, model.bc_mask,
            model.bc_velocity)


class WallPass(Pass):
    """Rigid planar walls of the case ([[wall]])."""

    name = "walls"
    stage = "velocity"

    def __init__(self):
        self.touched = 0
        self.force = 0.0

    def run(self, model, dt):
        work, self.touched, impulse = apply_walls(model.x, model.v, model.mass, model.force,
                                                  model.dtv, model.walls, dt)
        self.force = impulse / dt
        model.energy_terms["contact_dissipated"] -= work

    def history(self, model):
        """wall_nodes: nodes held by a wall this step; wall_force [N]: total normal force."""
        return {"wall_nodes": float(self.touched), "wall_force": self.force}
