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


@numba.njit(cache=True, inline="always")
def _wall_node(xx, xy, xz, vx, vy, vz, fx, fy, fz, mi, dtv, dt, px, py, pz, nx, ny, nz, mu):
    """One node against one wall (`apply_walls`): the corrected velocity, the wall's work on
    the node, its normal velocity change, whether the wall acts."""
    d_now = (xx - px) * nx + (xy - py) * ny + (xz - pz) * nz
    vn = vx * nx + vy * ny + vz * nz
    # the node must end on or in front of the wall: d_now + dt vn >= 0
    vn_min = -d_now / dt
    if vn >= vn_min:
        return vx, vy, vz, 0.0, 0.0, False
    dvn = vn_min - vn
    a = dtv / mi
    ox, oy, oz = vx - a * fx, vy - a * fy, vz - a * fz
    sx, sy, sz = vx, vy, vz
    vx += dvn * nx
    vy += dvn * ny
    vz += dvn * nz
    if mu > 0.0:
        vn2 = vx * nx + vy * ny + vz * nz
        tx, ty, tz = vx - vn2 * nx, vy - vn2 * ny, vz - vn2 * nz
        vt = np.sqrt(tx * tx + ty * ty + tz * tz)
        if vt > 0.0:
            cut = min(vt, mu * dvn) / vt
            vx -= cut * tx
            vy -= cut * ty
            vz -= cut * tz
    work = mi * ((vx - sx) * 0.5 * (ox + vx) + (vy - sy) * 0.5 * (oy + vy)
                 + (vz - sz) * 0.5 * (oz + vz))
    return vx, vy, vz, work, dvn, True


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
            mi = mass[i]
            if mi <= 0.0:  # orphaned by erosion: no mass, nothing to hold
                continue
            vx, vy, vz, wk, dvn, hit = _wall_node(x[i, 0], x[i, 1], x[i, 2], v[i, 0], v[i, 1],
                                             v[i, 2], force[i, 0], force[i, 1], force[i, 2],
                                             mi, dtv, dt, px, py, pz, nx, ny, nz, mu)
            if hit:
                v[i, 0], v[i, 1], v[i, 2] = vx, vy, vz
                work += wk
                impulse += mi * dvn
                touched += 1
    return work, touched, impulse


@numba.njit(cache=True)
def predict_walls_move(force, mass, v, x, dtv, walls, dt):
    """The predictor (nodal.predict), at most one wall (`apply_walls`) and the move
    (nodal.move) in one pass over the nodes, for a scene whose only velocity-stage pass is its
    wall (or none: `walls` of no rows): the same arithmetic per node, and with one wall the
    same sums, as the three passes (one sweep of x, v, force and mass through memory instead
    of three). Returns apply_walls' (work, nodes touched, normal impulse)."""
    has_wall = walls.shape[0] > 0
    px = py = pz = nx = ny = nz = mu = 0.0
    if has_wall:
        px, py, pz = walls[0, 0], walls[0, 1], walls[0, 2]
        nx, ny, nz = walls[0, 3], walls[0, 4], walls[0, 5]
        mu = walls[0, 6]
    work = 0.0
    impulse = 0.0
    touched = 0
    for i in range(mass.shape[0]):
        vx, vy, vz = v[i, 0], v[i, 1], v[i, 2]
        mi = mass[i]
        if mi > 0.0:
            fx, fy, fz = force[i, 0], force[i, 1], force[i, 2]
            a = dtv / mi
            vx += a * fx
            vy += a * fy
            vz += a * fz
            if has_wall:
                vx, vy, vz, wk, dvn, hit = _wall_node(x[i, 0], x[i, 1], x[i, 2], vx, vy, vz, fx, fy,
                                                 fz, mi, dtv, dt, px, py, pz, nx, ny, nz, mu)
                if hit:
                    work += wk
                    impulse += mi * dvn
                    touched += 1
            v[i, 0], v[i, 1], v[i, 2] = vx, vy, vz
        x[i, 0] += dt * vx
        x[i, 1] += dt * vy
        x[i, 2] += dt * vz
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
        self.book(model, dt, *apply_walls(model.x, model.v, model.mass, model.force, model.dtv,
                                          model.walls, dt))

    def book(self, model, dt, work, touched, impulse):
        """Record a step's wall results (from `run`, or from the time loop's fused
        `predict_walls_move`)."""
        self.touched = touched
        self.force = impulse / dt
        model.energy_terms["contact_dissipated"] -= work

    def history(self, model):
        """wall_nodes: nodes held by a wall this step; wall_force [N]: total normal force."""
        return {"wall_nodes": float(self.touched), "wall_force": self.force}
