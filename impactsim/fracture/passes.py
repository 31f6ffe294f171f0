"""Fracture passes bound to the model (ALGORITHMS.md 4.1-4.2).

``make_fracture_passes(case, model)`` returns, when a material has failure data:

- ``fracture.particles`` (velocity stage, after the contact passes): particle-face and, with
  ``[fracture] particle_collisions``, particle-particle contact on the predictor velocities, then
  the particles move over the step (``impactsim.fracture.particles``); idle while there are
  no particles;
- ``fracture`` (fracture stage, after the element update): spall, loosening, Johnson-Cook damage,
  erosion and particle conversion (``criteria``), removal with mass-conserving orphan handling
  (``removal``), and the incremental surface update (``impactsim.contact.surface.Surface``) so the
  faces exposed by a deletion are on the surface at once, for the next criteria evaluation and
  for the contact passes (they follow ``model.status`` too).

Energy terms (model.energy_terms, [J]): ``eroded`` gains what leaves with eroded elements;
``particles`` is the particles' current kinetic plus internal energy (it enters the total energy
of impactsim.solver.loop); the work of particle impacts goes to ``contact_dissipated``.
History columns: particles, particle_kinetic_energy, particle_energy (kinetic + internal),
particle_momentum_x/y/z, damaged, fractured, eroded_elements. Summary: mass_initial,
mass_final (elements plus particles), particles, eroded_elements, and per body residual velocity
(and hole size for plates), see ``impactsim.fracture.measures``.
"""

from __future__ import annotations

import numpy as np

from impactsim.contact.broadphase import SpatialHash, grid_for, swept_boxes
from impactsim.contact.surface import Surface
from impactsim.fracture import criteria as C
from impactsim.fracture.measures import body_measures
from impactsim.fracture.particles import (Particles, move_particles, particle_boxes,
                                          particle_face_sweep, particle_particle_sweep,
                                          particle_walls)
from impactsim.fracture.removal import clear_corner_forces, remove_elements
from impactsim.model import DAMAGED, ERODED, FRACTURED
from impactsim.solver.passes import Pass

EPS_BARY = 1e-6


class FractureState:
    """What the two fracture passes share: the surface, the particles, counters."""

    def __init__(self, case, model):
        self.surface = Surface.from_model(model)
        self.surface_only = case.fracture.erosion_region != "anywhere"
        self.n_per = int(case.fracture.particles_per_element)
        self.collisions = bool(case.fracture.particle_collisions)
        self.particles = Particles()
        self.node_live = np.bincount(model.conn[model.status != ERODED].reshape(-1),
                                     minlength=model.n_node).astype(np.int32)
        self.action = np.zeros(model.n_elem, dtype=np.int8)
        self.eps_p_prev = model.eps_p.copy()
        self.mass_initial = float(model.mass.sum())
        self.counts = {"damaged": 0, "fractured": 0, "eroded": 0, "converted": 0, "guard": 0}
        model.energy_terms.setdefault("eroded", 0.0)
        model.energy_terms["particles"] = 0.0

    def update_particle_energy(self, model) -> None:
        pa = self.particles
        model.energy_terms["particles"] = pa.kinetic_energy() + pa.internal_energy()


class FracturePass(Pass):
    """Spall, loosening, erosion and particle conversion (module docstring)."""

    name = "fracture"
    stage = "fracture"

    def __init__(self, state: FractureState):
        self.s = state
        self.elem_force = None

    def attach(self, sim) -> None:
        """Bind the integrator's corner forces (4 e, 3): a removed element's forces of this step
        are cleared so it no longer acts on its nodes at the next gather."""
        self.elem_force = sim.elem_force

    def run(self, model, dt):
        s = self.s
        n_dam, n_frac, n_act = C.fracture_criteria(
            model.x, model.v, model.x0, model.conn, model.elem_mat, model.status, model.sdev,
            model.pressure, model.vol, model.vol0, model.eps_p, s.eps_p_prev, model.damage,
            model.eps_rate, model.temperature, model.mat_params, s.surface.face_flag,
            s.surface.adj, s.surface_only, dt, s.action)
        s.counts["damaged"] += int(n_dam)
        s.counts["fractured"] += int(n_frac)
        if n_act == 0:
            return
        ids = np.flatnonzero(s.action).astype(np.int64)
        kinds = s.action[ids]
        s.counts["guard"] += int(np.count_nonzero(kinds == C.GUARD))
        pa = s.particles
        pa.reserve(s.n_per * ids.shape[0])
        n_p, e_out, n_er, n_conv = remove_elements(
            ids, kinds == C.PARTICLE, model.conn, model.status, model.elem_mass, model.energy,
            model.elem_body, model.x, model.v, model.mass, s.node_live, s.n_per, pa.x, pa.v,
            pa.m, pa.radius, pa.energy, pa.body, pa.n)
        pa.n = int(n_p)
        model.energy_terms["eroded"] += float(e_out)
        s.counts["eroded"] += int(n_er)
        s.counts["converted"] += int(n_conv)
        if self.elem_force is not None:
            clear_corner_forces(ids, self.elem_force)
        s.surface.remove_elements(ids)
        s.update_particle_energy(model)

    def history(self, model):
        s = self.s
        pa = s.particles
        p = pa.momentum()
        return {"particles": float(pa.n), "particle_kinetic_energy": pa.kinetic_energy(),
                "particle_energy": pa.kinetic_energy() + pa.internal_energy(),
                "particle_momentum_x": float(p[0]), "particle_momentum_y": float(p[1]),
                "particle_momentum_z": float(p[2]),
                "damaged": float(np.count_nonzero(model.status == DAMAGED)),
                "fractured": float(np.count_nonzero(model.status == FRACTURED)),
                "eroded_elements": float(s.counts["eroded"] + s.counts["converted"])}

    def summary(self, model):
        s = self.s
        pa = s.particles
        mass_final = float(model.mass.sum()) + pa.mass()
        bodies = body_measures(model, s.node_live, pa)
        return {"mass_initial": s.mass_initial, "mass_final": mass_final,
                "mass_error": (mass_final - s.mass_initial) / s.mass_initial,
                "particles": int(pa.n), "eroded_elements": int(s.counts["eroded"]
                                                             + s.counts["converted"]),
                "bodies": bodies,
                "fracture": {"damaged_total": s.counts["damaged"],
                             "fractured_total": s.counts["fractured"],
                             "eroded": s.counts["eroded"],
                             "converted_to_particles": s.counts["converted"],
                             "distortion_guard": s.counts["guard"],
                             "particles_per_element": s.n_per,
                             "particle_mass": pa.mass(),
                             "particle_momentum": pa.momentum().tolist(),
                             "particle_buffer_grows": pa.grows,
                             "surface_faces": s.surface.n_faces}}


class ParticlePass(Pass):
    """Particle contacts and motion (velocity stage; module docstring)."""

    name = "fracture.particles"
    stage = "velocity"

    def __init__(self, state: FractureState):
        self.s = state
        self.hash = SpatialHash()
        self.pp_hash = SpatialHash()
        self.impacts = 0
        self.collisions = 0
        self._buf = {}

    def _buffer(self, name, rows):
        b = self._buf.get(name)
        if b is None or b.shape[0] < rows:
            b = np.empty((max(rows, 16) * 3 // 2, 3))
            self._buf[name] = b
        return b[:rows]

    def run(self, model, dt):
        s = self.s
        pa = s.particles
        n = pa.n
        if n == 0:
            return
        surf = s.surface
        surf.sync(model.status)
        pad = 1e-3 * float(pa.radius[:n].mean())
        plo, phi = self._buffer("plo", n), self._buffer("phi", n)
        particle_boxes(pa.x, pa.v, pa.radius, n, dt, pad, plo, phi)
        work = 0.0
        if surf.n_faces:
            flo, fhi = self._buffer("flo", surf.n_faces), self._buffer("fhi", surf.n_faces)
            swept_boxes(model.x, model.v, dt, surf.faces, pad, flo, fhi)
            h = max(surf.mean_edge_length(model.x), 2.0 * float(pa.radius[:n].max()))
            origin, cell = grid_for([(plo, phi), (flo, fhi)], h)
            self.hash.build(flo, fhi, origin, cell)
            pairs = self.hash.query(plo, phi, pa.ids[:n], pa.no_body[:n], surf.faces,
                                    surf.face_body, False, False)
            if pairs.shape[0]:
                applied, w = particle_face_sweep(pairs, pa.x, pa.v, pa.m, pa.radius, surf.faces,
                                                 model.x, model.v, model.mass, model.force,
                                                 model.dtv, dt, EPS_BARY)
                self.impacts += int(applied)
                work += float(w)
        if s.collisions and n > 1:
            h = 2.0 * float(pa.radius[:n].max())
            origin, cell = grid_for([(plo, phi)], h)
            self.pp_hash.build(plo, phi, origin, cell)
            pairs = self.pp_hash.query(plo, phi, pa.ids[:n], pa.no_body[:n], pa.ids[:n],
                                       pa.no_body[:n], True, True)
            if pairs.shape[0]:
                applied, dke = particle_particle_sweep(pairs, pa.x, pa.v, pa.m, pa.radius, dt)
                self.collisions += int(applied)
                work += float(dke)
        if model.walls.shape[0]:
            work += float(particle_walls(pa.x, pa.v, pa.m, pa.radius, n, model.walls, dt))
        model.energy_terms["contact_dissipated"] -= work
        move_particles(pa.x, pa.v, n, dt)
        s.update_particle_energy(model)

    def summary(self, model):
        return {"fracture.particles": {"particle_face_impacts": self.impacts,
                                       "particle_collisions": self.collisions,
                                       "hash_grows": self.hash.grows + self.pp_hash.grows}}

    def frame(self, model, time, out_dir):
        """Write particles_XXXXX.vtu of the particles.pvd series (called with every frame)."""
        from impactsim.output.series import SeriesWriter

        if getattr(self, "_series", None) is None or self._series_dir != out_dir:
            self._series = SeriesWriter(out_dir, prefix="particles", pvd_name="particles.pvd")
            self._series_dir = out_dir
        pa = self.s.particles
        n = pa.n
        data = {"velocity": pa.v[:n], "mass": pa.m[:n], "radius": pa.radius[:n],
                "internal_energy": pa.energy[:n], "body": pa.body[:n]}
        self._series.write(time, pa.x[:n], None, point_data=data)


def has_failure(mat) -> bool:
    f = mat.failure
    return any(v is not None for v in (f.spall_strength, f.loosening, f.erosion))


def make_fracture_passes(case, model) -> list[Pass]:
    """[particle pass, fracture pass] for a case with failure data, else []."""
    if not any(has_failure(m) for m in case.materials.values()):
        return []
    state = FractureState(case, model)
    return [ParticlePass(state), FracturePass(state)]

