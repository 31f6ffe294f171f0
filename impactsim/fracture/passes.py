"""Fracture passes bound to the model (ALGORITHMS.md 4.1-4.2).

``make_fracture_passes(case, model)`` returns, when a material has failure data:

- ``fracture.particles`` (velocity stage, before the contact passes, solver/pipeline.py, so that
  contact corrects what the particles' impulses did to face nodes): particle-face and, with
  ``[fracture] particle_collisions``, particle-particle contact on the predictor velocities, then
  the particles move over the step (``impactsim.fracture.particles``); idle while there are
  no particles;
- ``fracture`` (fracture stage, after the element update): spall, loosening, Johnson-Cook damage,
  erosion and particle conversion (``criteria``), removal with mass-conserving orphan handling
  (``removal``), and the update of the free faces (``impactsim.fracture.boundary``, O(removed
  elements)) so the faces exposed by a deletion are free at once, for the next criteria
  evaluation and the particle contacts. The contact passes keep their own surface in step with
  ``model.status``.

Cost per step: the criteria kernel is one pass over the elements (numba); everything else is in
proportion to what changed (removed elements) or to the particles and the faces near them (the
particle broad phase hashes only the faces whose swept boxes meet the particles' bounding box
and touch a cell of a particle's box, ``particle_cells``).

Energy terms (model.energy_terms, [J]): ``eroded`` gains what leaves with eroded elements;
``particles`` is the particles' current kinetic plus internal energy (it enters the total energy
of impactsim.solver.loop); the work of particle impacts goes to ``contact_dissipated``.
History columns: particles, particle_kinetic_energy, particle_energy (kinetic + internal),
particle_momentum_x/y/z, damaged, fractured, eroded_elements. Summary: mass_initial,
mass_final (elements plus particles), particles, eroded_elements, and per body residual velocity
(and hole size for plates), see ``impactsim.fracture.measures``.
"""

from __future__ import annotations

import math

import numpy as np

from impactsim.contact.broadphase import SpatialHash, grid_from_bounds
from impactsim.contact.passes import PrescribedLock
from impactsim.fracture import criteria as C
from impactsim.fracture.boundary import Boundary
from impactsim.fracture.distortion import Distortion
from impactsim.fracture.fragments import cloud_axis, cloud_summary, leading_edge
from impactsim.solver.blocks import hex_corner_forces
from impactsim.fracture.hexes import HexFracture, pass_orphan_forces
from impactsim.fracture.measures import body_measures, shield_summary
from impactsim.fracture.particles import (NODE_COLS, Particles, faces_near, move_particles,
                                          particle_boxes,
                                          particle_face_sweep_packed, particle_particle_sweep,
                                          particle_walls)
from impactsim.fracture.particle_cells import ParticleCells
from impactsim.fracture.particle_faces import (FACE_CHUNK, faces_near_threads, pack_all_nodes,
                                               threaded_faces_wanted)
from impactsim.fracture.removal import remove_elements
from impactsim.fracture.spall import PRESSURE_CODES, SPALL_CELL
from impactsim.materials import params as P
from impactsim.model import DAMAGED, ERODED, FRACTURED
from impactsim.solver.guard import NONE_GIVEN, UNKNOWN
from impactsim.solver.passes import Pass

EPS_BARY = 1e-6
PARTICLE_QUERY_CHUNKS = 2  # the particle query runs on the threads from this many chunks
PAD = 1e-3  # box padding of the particle broad phase, a fraction of the mean face edge length


class FractureState:
    """What the two fracture passes share: the free faces, the particles, counters."""

    def __init__(self, case, model):
        self.rebuild_mesh(model)
        self.surface_only = case.fracture.erosion_region != "anywhere"
        self.n_per = int(case.fracture.particles_per_element)
        self.collisions = bool(case.fracture.particle_collisions)
        self.particles = Particles()
        self.distortion = Distortion(case, model)  # distortion erosion [Z] (None when off)
        self.axis = cloud_axis(case)  # the debris cloud's direction (fracture/fragments.py)
        self.action = np.zeros(model.n_elem, dtype=np.int8)
        self.ids = np.zeros(model.n_elem, dtype=np.int64)
        e = np.vstack([b.faces[:b.n] for b in self.face_lists()])
        d = np.linalg.norm(model.x[e[:, 1]] - model.x[e[:, 0]], axis=1) if len(e) else np.ones(1)
        self.h_face = float(d.mean())  # [m] mean edge length of the free faces at t = 0
        self.eps_p_prev = model.eps_p.copy()
        self.mass_initial = float(model.mass.sum())
        self.counts = {"damaged": 0, "fractured": 0, "eroded": 0, "converted": 0, "guard": 0,
                       "melt": 0, "ductile": 0}
        # nodal means of pressure and volume ratio over the live elements (criteria.patch_fields)
        self.spall_mode = PRESSURE_CODES[case.fracture.spall_pressure]
        self.spall_integrate = case.fracture.spall_criterion == "tuler-butcher"
        self.spall_k = np.zeros(model.n_elem)  # [s] Tuler-Butcher accumulators (spall.py)
        self.pnode = np.zeros(model.n_node)
        self.jnode = np.ones(model.n_node)
        model.energy_terms.setdefault("eroded", 0.0)
        model.energy_terms["particles"] = 0.0

    def rebuild_mesh(self, model) -> None:
        """The free faces and the live corners per node from model.conn afresh (at the start,
        and after node separation repointed corners)."""
        self.boundary = Boundary.from_model(model)
        # the hex blocks' criteria state and free quads (fracture/hexes.py)
        if getattr(self, "hexes", None) is None:
            self.hexes = [HexFracture(model, blk) for blk in model.blocks]
        else:
            for hf in self.hexes:
                hf.rebuild(model)
        self.node_live = np.bincount(model.conn[model.status != ERODED].reshape(-1),
                                     minlength=model.n_node).astype(np.int32)
        for blk in model.blocks:  # hex corners keep their nodes alive too
            self.node_live += np.bincount(blk.conn[blk.status != ERODED].reshape(-1),
                                          minlength=model.n_node).astype(np.int32)

    def face_lists(self) -> list:
        """The free-face lists the particles hit: the tets' Boundary, then each hex block's."""
        return [self.boundary] + [h.boundary for h in self.hexes]

    def damaged_fractured(self, model) -> tuple[int, int]:
        """Elements (tets and hexes) now damaged and fractured."""
        st = [model.status] + [blk.status for blk in model.blocks]
        return (sum(int(np.count_nonzero(a == DAMAGED)) for a in st),
                sum(int(np.count_nonzero(a == FRACTURED)) for a in st))

    def update_particle_energy(self, model) -> None:
        _, ke, ie, _ = self.particles.sums()
        model.energy_terms["particles"] = ke + ie


class FracturePass(Pass):
    """Spall, loosening, erosion and particle conversion (module docstring)."""

    name = "fracture"
    stage = "fracture"

    def __init__(self, state: FractureState):
        self.s = state
        self.sim = None
        self.criteria = None  # any material with failure data (set at the first run)
        self.guard = C.GuardPretest()  # whether the distortion guard's pre-test pays

    def attach(self, sim) -> None:
        """Bind the integrator: the nodal forces of a removed element's nodes are recomputed
        without it, so it no longer acts on them at the next predictor; and where the criteria
        run on tets, have its tet kernel give the distortion guard's verdicts
        (solver/guard.py; its plastic specialisation does: an elastic scene's criteria
        gather the corners themselves)."""
        self.sim = sim
        model = sim.model
        if model.n_elem and sim.plastic is not None and self._wanted(model):
            sim.guard = np.full(model.n_elem, UNKNOWN, dtype=np.int8)

    def _wanted(self, model) -> bool:
        """Whether the criteria run (decided once)."""
        if self.criteria is None:
            mp = model.mat_params
            # criteria.failing_material or the ductile criterion (fracture/ductile.py) of any
            # material: a new failure mode of element_state must be named here too
            self.criteria = bool(np.any((mp[:, P.EROSION] != 0) | (mp[:, P.SPALL] < np.inf)
                                        | (mp[:, P.CHI_STAR] < np.inf)
                                        | (mp[:, P.DUCTILE] > 0.0)))
        return self.criteria

    def run(self, model, dt):
        if self._wanted(model):
            self._criteria(model, dt)
        s = self.s
        if s.distortion is not None and s.distortion.due(model, dt):
            tets, blocks = s.distortion.check(model)
            if tets.shape[0]:
                self._remove(model, tets, np.full(tets.shape[0], C.ERODE, np.int8))
            for blk, ids in blocks:  # hexes: as the criteria's erosion (fracture/hexes.py)
                hf = next(h for h in s.hexes if h.blk is blk)
                ids = ids[blk.status[ids] != ERODED]
                if ids.shape[0]:
                    self._remove_hexes(model, hf, ids, np.full(ids.shape[0], C.ERODE, np.int8),
                                       dt)
        # the particles' energy at the end of the step (contacts, motion, new particles)
        s.update_particle_energy(model)

    def _criteria(self, model, dt):
        """Spall, loosening, damage and the element actions on the tets and the hex blocks.
        Skipped when no material has failure data (``criteria.failing_material``: no erosion
        criterion, spall or loosening, and no ductile criterion; node separation or distortion
        erosion alone): they change nothing then (no status change, no action, no guard; eps_p_prev is read by
        damage erosion only), and cost more than the separation pass on a tied hex body."""
        s = self.s
        b = s.boundary
        if s.spall_mode != SPALL_CELL:
            C.patch_fields(model.vol, model.vol0, model.pressure, model.status, model.n2e_ptr,
                           model.n2e, s.pnode, s.jnode, 4)
        sim = self.sim
        given = (sim.guard if sim is not None and sim.guard is not None
                 and sim.guard_step == model.step else NONE_GIVEN)
        # with the kernel's verdicts only the mesh's last, partial block runs the full test
        # here: the pre-test would not pay for itself on one block
        reach = self.guard.reach(model, dt) if given is NONE_GIVEN else math.inf
        n_dam, n_frac, n_act, n_duct, n_guard, n_clear = C.fracture_criteria(
            model.x, model.v, model.x0, model.conn, model.elem_mat, model.status, model.sdev,
            model.pressure, model.vol, model.vol0, model.eps_p, s.eps_p_prev, model.damage,
            model.eps_rate, model.temperature, model.mat_params, b.face_flag, b.adj,
            s.surface_only, dt, s.action, s.spall_mode, s.pnode, s.jnode, s.spall_k,
            s.spall_integrate, reach, given)
        if given is NONE_GIVEN:  # the pre-test's share decides for the hexes otherwise
            self.guard.count(n_guard, n_clear)
        s.counts["damaged"] += int(n_dam)
        s.counts["ductile"] += int(n_duct)
        s.counts["fractured"] += int(n_frac)
        if n_act:
            self._remove(model, s.ids[:C.action_ids(s.action, s.ids)])
        for hf in s.hexes:  # the hex blocks (fracture/hexes.py)
            n_dam, n_frac, ids = hf.criteria(model, dt, s.surface_only, s.spall_mode,
                                             s.spall_integrate, self.guard)
            s.counts["damaged"] += n_dam
            s.counts["fractured"] += n_frac
            if ids.shape[0]:
                self._remove_hexes(model, hf, ids, hf.action[ids], dt)
        self.guard.end_step()

    def _remove(self, model, ids, kinds=None):
        s = self.s
        kinds = s.action[ids] if kinds is None else kinds
        s.counts["guard"] += int(np.count_nonzero(kinds == C.GUARD))
        s.counts["melt"] += int(np.count_nonzero(kinds == C.MELT))
        pa = s.particles
        pa.reserve(s.n_per * ids.shape[0])
        n_p, e_out, n_er, n_conv = remove_elements(
            ids, (kinds == C.PARTICLE) | (kinds == C.MELT), model.conn, model.status, model.elem_mass, model.energy,
            model.elem_body, model.x, model.v, model.mass, s.node_live, s.n_per, pa.x, pa.v,
            pa.m, pa.radius, pa.energy, pa.body, pa.n)
        pa.n = int(n_p)
        model.energy_terms["eroded"] += float(e_out)
        s.counts["eroded"] += int(n_er)
        s.counts["converted"] += int(n_conv)
        if self.sim is not None:
            self.sim.refresh_forces(ids)
        s.boundary.remove(ids)

    def _remove_hexes(self, model, hf, ids, kinds, dt):
        """Hexes ``ids`` of block hf.blk leave the mesh (fracture/hexes.py): their forces of the
        last element update are taken off their nodes, then ``remove_elements`` erodes them or
        turns them into particles, and the block's free quads follow."""
        s = self.s
        blk = hf.blk
        s.counts["guard"] += int(np.count_nonzero(kinds == C.GUARD))
        s.counts["melt"] += int(np.count_nonzero(kinds == C.MELT))
        if self.sim is not None:
            runner = self.sim.block_runners[[b is blk for b in model.blocks].index(True)]
            f = hex_corner_forces(model, blk, runner, ids, self.sim.cq, self.sim.cl, dt,
                                  hf.status_before)
            np.subtract.at(model.force, blk.conn[ids].reshape(-1), f.reshape(-1, 3))
        pa = s.particles
        pa.reserve(s.n_per * ids.shape[0])
        n_p, e_out, n_er, n_conv = remove_elements(
            ids, (kinds == C.PARTICLE) | (kinds == C.MELT), blk.conn, blk.status, blk.elem_mass,
            blk.energy, blk.elem_body, model.x, model.v, model.mass, s.node_live, s.n_per, pa.x,
            pa.v, pa.m, pa.radius, pa.energy, pa.body, pa.n)
        pa.n = int(n_p)
        pass_orphan_forces(ids, blk.conn, s.node_live, model.force)
        model.energy_terms["eroded"] += float(e_out)
        s.counts["eroded"] += int(n_er)
        s.counts["converted"] += int(n_conv)
        hf.boundary.remove(ids)

    def history(self, model):
        s = self.s
        pa = s.particles
        _, ke, ie, p = pa.sums()
        n_dam, n_frac = s.damaged_fractured(model)
        return {"particles": float(pa.n), "particle_kinetic_energy": ke,
                "particle_energy": ke + ie,
                "particle_momentum_x": float(p[0]), "particle_momentum_y": float(p[1]),
                "particle_momentum_z": float(p[2]),
                "damaged": float(n_dam), "fractured": float(n_frac),
                "eroded_elements": float(s.counts["eroded"] + s.counts["converted"]),
                "leading_edge": leading_edge(model, s.axis, pa)[0]}

    def summary(self, model):
        s = self.s
        pa = s.particles
        mass_final = float(model.mass.sum()) + pa.mass()
        bodies = body_measures(model, s.node_live, pa)
        shield = shield_summary(model, bodies, s.axis)
        return {**({"shield": shield} if shield is not None else {}),"mass_initial": s.mass_initial, "mass_final": mass_final,
                "mass_error": (mass_final - s.mass_initial) / s.mass_initial,
                "particles": int(pa.n), "eroded_elements": int(s.counts["eroded"]
                                                             + s.counts["converted"]),
                "bodies": bodies,
                "fragments": cloud_summary(model, s.axis, pa),
                "fracture": {"damaged_total": s.counts["damaged"],
                             # of which by the ductile criterion (fracture/ductile.py)
                             "damaged_ductile": s.counts["ductile"] + sum(
                                 h.ductile for h in s.hexes),
                             "fractured_total": s.counts["fractured"],
                             "eroded": s.counts["eroded"],
                             "converted_to_particles": s.counts["converted"],
                             "distortion_guard": s.counts["guard"],
                             "molten_or_runaway_strain": s.counts["melt"],
                             "particles_per_element": s.n_per,
                             "particle_mass": pa.mass(),
                             "particle_momentum": pa.momentum().tolist(),
                             "particle_buffer_grows": pa.grows,
                             "free_faces": s.boundary.n + sum(
                                 h.boundary.n for h in s.hexes),
                             "free_face_grows": s.boundary.grows + sum(
                                 h.boundary.grows for h in s.hexes),
                             **({"distortion": s.distortion.summary()}
                                if s.distortion is not None else {})}}


class ParticlePass(Pass):
    """Particle contacts and motion (velocity stage; module docstring)."""

    name = "fracture.particles"
    stage = "velocity"

    def __init__(self, state: FractureState):
        self.s = state
        # the particles' query on the threads from two chunks of rows (QUERY_CHUNK each): a
        # particle's row costs 0.2-0.4 us, so 2,048 rows pay for the launch (4,451 particles of
        # oblique-sphere at step 400: 1.6 -> 1.1 ms; docs/performance.md, session 26)
        self.hash = SpatialHash(min_chunks=PARTICLE_QUERY_CHUNKS)
        self.pp_hash = SpatialHash()
        self.cells = ParticleCells()  # the cells the particle boxes touch
        self.impacts = 0
        self.collisions = 0
        self.cloud = np.zeros((2, 3))  # bounds of the particle boxes of the step
        self.bounds = np.zeros((2, 3))  # ... and of the faces near them
        self.locks = PrescribedLock()  # prescribed velocity components of face nodes
        self._buf = {}
        self.nodes = np.zeros((0, NODE_COLS))  # the sweep's face-node table (faces_near)

    def _buffer(self, name, rows, dtype=np.float64, cols=3):
        """Reusable scratch rows (grows by half when short): no allocation in the time loop."""
        b = self._buf.get(name)
        if b is None or b.shape[0] < rows:
            shape = (max(rows, 16) * 3 // 2,) + ((cols,) if cols else ())
            b = np.empty(shape, dtype=dtype)
            self._buf[name] = b
        return b[:rows]

    def run(self, model, dt):
        s = self.s
        pa = s.particles
        n = pa.n
        if n == 0:
            return
        lists = s.face_lists()  # the tets' free faces, then each hex block's
        n_faces = sum(b.n for b in lists)
        pad = PAD * s.h_face
        plo, phi = self._buffer("plo", n), self._buffer("phi", n)
        cloud = self.cloud
        r_max = particle_boxes(pa.x, pa.v, pa.radius, n, dt, pad, plo, phi, cloud)
        work = 0.0
        if n_faces:
            flo, fhi = self._buffer("flo", n_faces), self._buffer("fhi", n_faces)
            sel = self._buffer("sel", n_faces, np.int32)
            sel_body = self._buffer("sel_body", n_faces, np.int32, None)
            bounds = self.bounds
            bounds[:] = cloud
            cell = max(s.h_face, 2.0 * r_max)  # the hash's cell and the particle cells'
            self.cells.mark_boxes(plo, phi, n, cloud, cell)
            occ = self.cells.args()  # the cells the particles touch (particle_cells.py)
            if self.nodes.shape[0] != model.n_node:
                self.nodes = np.zeros((model.n_node, NODE_COLS))
            k = 0
            threaded = threaded_faces_wanted(n_faces)  # fracture/particle_faces.py
            if threaded:
                pack_all_nodes(model.x, model.v, model.mass, self.nodes)
            for b in lists:  # the faces near the particles, list after list, their nodes packed
                if b.n and threaded:
                    k += self._faces_near_threads(model, dt, b, pad, cloud, occ, flo[k:],
                                                  fhi[k:], sel[k:], sel_body[k:])
                elif b.n:
                    k += faces_near(model.x, model.v, model.mass, dt, b.faces, b.face_body, b.n,
                                    pad, cloud, *occ, flo[k:], fhi[k:], sel[k:], sel_body[k:],
                                    bounds, self.nodes)
            if k:
                origin, h = grid_from_bounds(bounds[0], bounds[1], cell)
                self.hash.build(flo[:k], fhi[:k], origin, h)
                pairs = self.hash.query(plo, phi, pa.ids[:n], pa.no_body[:n], sel[:k],
                                        sel_body[:k], False, False)
                if pairs.shape[0]:
                    applied, w = particle_face_sweep_packed(
                        pairs, pa.x, pa.v, pa.m, pa.radius, sel, self.nodes, model.v,
                        model.mass, model.force, model.dtv, dt, EPS_BARY, self.locks.get(model))
                    self.impacts += int(applied)
                    work += float(w)
        if s.collisions and n > 1:
            origin, cell = grid_from_bounds(cloud[0], cloud[1], 2.0 * r_max)
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
        # the particles' energy is booked at the end of the step, by the fracture pass (which
        # runs in every step beside this one, after the particles made that step)

    def _faces_near_threads(self, model, dt, b, pad, cloud, occ, flo, fhi, sel, sel_body):
        """``faces_near_threads`` on face list b (its scratch rows here)."""
        n_chunk = -(-b.n // FACE_CHUNK)
        return faces_near_threads(
            model.x, model.v, dt, b.faces, b.face_body, b.n, pad, cloud, *occ, flo, fhi, sel,
            sel_body, self.bounds, self._buffer("box_lo", b.n), self._buffer("box_hi", b.n),
            self._buffer("near", b.n, np.uint8, None),
            self._buffer("chunk_counts", n_chunk, np.int64, None),
            self._buffer("chunk_bounds", n_chunk * 2, np.float64).reshape(n_chunk, 2, 3))

    def summary(self, model):
        return {"fracture.particles": {"particle_face_impacts": self.impacts,
                                       "particle_collisions": self.collisions,
                                       "hash_grows": self.hash.grows + self.pp_hash.grows}}

    def frame(self, model):
        """The particles as the points of a series of their own (particles_*.vtu in
        particles.pvd), written with every frame of the mesh."""
        pa = self.s.particles
        n = pa.n
        data = {"velocity": pa.v[:n], "mass": pa.m[:n], "radius": pa.radius[:n],
                "internal_energy": pa.energy[:n], "body": pa.body[:n]}
        return {"particles": (pa.x[:n], data)}


def fracture_wanted(case) -> bool:
    """A material with failure data, or distortion erosion: the fracture passes run."""
    return (any(m.failure.active or m.failure.fracture_strain is not None
                for m in case.materials.values())
            or case.fracture.distortion_interval is not None)


def make_fracture_passes(case, model) -> list[Pass]:
    """[particle pass, fracture pass] for a case with failure data or distortion erosion,
    else []."""
    if not fracture_wanted(case):
        return []
    state = FractureState(case, model)
    passes = [ParticlePass(state), FracturePass(state)]
    if any(model.separable_bodies):  # node separation [Z] (fracture/separation.py)
        from impactsim.fracture.separation import Separation, SeparationPass

        passes.append(SeparationPass(state, Separation(case, model)))
    return passes

