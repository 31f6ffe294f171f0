"""The explicit time loop of ALGORITHMS.md 1 and its pass pipeline.

Per step n -> n+1:
  1. dt = C_cfl * min stable element step (growth limited, clamped to the next output time);
  2. predictor U* = U^n + dt F^n / m with the nodal forces F^n of the last element update;
  3. velocity-stage passes correct U* (prescribed velocities, walls, contact: ALGORITHMS.md 3);
  4. x^{n+1} = x^n + dt U^{n+1}, after all corrections;
  5. element update at x^{n+1}: strain rates, stresses, EOS, nodal forces F^{n+1}, next
     stable dt;
  6. fracture-stage passes.
"""

from __future__ import annotations

import math
import time as wallclock

import numba
import numpy as np

from impactsim.model import Model
from impactsim.solver import element as E
from impactsim.solver import hugepages
from impactsim.solver.constraints import WallPass, predict_walls_move
from impactsim.solver.nodal import (PARALLEL_NODES, element_volumes, force_power,
                                    internal_energy, kinetic_energy, move, nodal_volume_ratio,
                                    predict)
from impactsim.solver.passes import Pass
from impactsim.solver.scatter import force_rows
from impactsim.solver.subcycle import Subcycle, half_step_energy

DT_GROWTH = 1.1  # the step may grow by at most this factor per step


class SimulationStopped(Exception):
    """The run cannot go on (inverted element, collapsing time step, non-finite state)."""


class Simulation:
    """The state of a run: a Model, its passes and the integrator's own buffers.

    cfl: Courant number; element: "tet4" or "anp"; cq, cl: artificial viscosity coefficients;
    dt_collapse: stop when dt falls below this fraction of the first step; subcycle: 0, or the
    number K of levels of subcycling (parts of tets updated every 2^k steps, k <= K:
    solver/subcycle.py).
    """

    def __init__(self, model: Model, passes: list[Pass], cfl: float = 0.6, element: str = "tet4",
                 cq: float = 1.2, cl: float = 0.06, dt_collapse: float = 1e-3,
                 subcycle: int = 0):
        self.model = model
        self.cfl = cfl
        self.cq, self.cl = cq, cl
        self.dt_collapse = dt_collapse
        self.use_anp = element == "anp"
        self.velocity_passes = [p for p in passes if p.stage == "velocity"]
        self.fracture_passes = [p for p in passes if p.stage == "fracture"]
        self.other_passes = [p for p in passes if p.stage not in ("velocity", "fracture")]
        # no velocity pass but one wall (or none): predictor, wall and move in one pass over the
        # nodes (constraints.predict_walls_move, the same bits), below PARALLEL_NODES nodes
        vp = self.velocity_passes
        self.fused_wall = None if not vp else vp[0]
        self.fused = (not vp or (len(vp) == 1 and isinstance(vp[0], WallPass)
                                 and len(model.walls) == 1))
        ne, nn = model.n_elem, model.n_node
        self.chunk_out = np.zeros((E.n_chunks(ne), E.N_OUT))
        self.set_parts(E.PART)
        self.jnode = np.ones(nn)
        self.vol_now = np.zeros(ne)
        self.vol_eos = model.vol.copy() if self.use_anp else model.vol
        # the element kernel's caches: hardening term and thermal factor of the yield stress
        # (only when a tet is plastic: with elastic tets the kernel compiled has no return)
        self.hardening, self.thermal = np.zeros(ne), np.zeros(ne)
        self.plastic = E.plastic_kernel(model.elem_mat, model.mat_params)
        if self.plastic is not None:
            E.yield_cache(model.elem_mat, model.mat_params, model.eps_p, model.temperature,
                          self.hardening, self.thermal)
        self.block_runners = []  # further element blocks (hexahedra: solver/blocks.py)
        if getattr(model, "blocks", None):
            from impactsim.solver.blocks import BlockRunner

            self.block_runners = [BlockRunner(model, b) for b in model.blocks]
        # the tet kernel's own buffers onto huge pages (hugepages.py; the model's are, since
        # build_model); by name: vol_eos may be model.vol itself, which must stay shared
        hugepages.pack(self, names=("fext", "chunk_out", "jnode", "vol_now", "hardening",
                                    "thermal") + (("vol_eos",) if self.use_anp else ()))
        # the distortion guard's verdicts the tet kernel gives while it has the corners at hand
        # (solver/guard.py), for the fracture criteria that run right after it: None unless a
        # pass asks for them (fracture: FracturePass.attach); guard_step: the step whose
        # element update gave them (-1: none is valid now)
        self.guard = None
        self.guard_step = -1
        for p in passes:  # passes that need the integrator (fracture: refresh_forces)
            if hasattr(p, "attach"):
                p.attach(self)
        self.timings: dict[str, float] = {"element": 0.0, "nodes": 0.0}
        for p in passes:
            self.timings[p.name] = 0.0
        self.dt = 0.0  # the last step taken [s]
        self.dt_free = 0.0  # the last step not shortened to meet a time limit [s]
        self.dt_stable = math.inf  # min stable element step at the current state [s]
        self.dt_first = None
        self.worst_element = -1
        # called as on_inverted(sim, dt) when elements invert, instead of stopping the run
        # (checks.negative_volume = "erode": solver/run.py)
        self.on_inverted = None
        self.sub = None  # the levels of subcycling (solver/subcycle.py), set after the first update
        self.dt_blocks = math.inf  # the hexahedral blocks' least stable step [s]
        self._update_elements(0.0)  # forces and stable step of the initial state
        if subcycle and model.n_elem > 0:
            self.sub = Subcycle(self, subcycle)
            self._stable_step()

    def set_parts(self, part_size: int) -> None:
        """Run the elements in parts of `part_size` (a multiple of element.CHUNK), the unit of
        work of a thread: every (node, part) pair adds its forces to a row of its own of
        `fext` (scatter.py)."""
        if part_size % E.CHUNK:
            raise ValueError(f"part size {part_size} is not a multiple of {E.CHUNK}")
        self.force_rows = force_rows(self.model.conn, self.model.n_node, part_size)
        self.fext = np.zeros((self.force_rows.n_rows, 3))
        self.part_claims = None  # the tet kernel's flags per part (element.part_flags)
        hugepages.pack(self.force_rows)  # the kernel's fext is packed in __init__

    def next_dt(self, limit: float = math.inf) -> float:
        """The next step: C_cfl times the stable step, at most DT_GROWTH times the last step that
        was not shortened to meet a limit (a frame time), and not beyond `limit`. When the limit
        is between one and two steps away it is reached in two equal steps, so that no sliver
        step is left before it."""
        dt = self.cfl * self.dt_stable
        if self.dt_free > 0.0:
            dt = min(dt, DT_GROWTH * self.dt_free)
        if dt < limit < 2.0 * dt:
            return 0.5 * limit
        return min(dt, limit)

    def step(self, limit: float = math.inf) -> float:
        """Advance one step, not beyond `limit` seconds; returns the step taken [s]."""
        m = self.model
        dt = self.next_dt(limit)
        free = self.next_dt()  # the step without the limit
        if not (dt > 0.0 and math.isfinite(dt)):
            raise SimulationStopped(f"non-finite or zero time step ({dt!r}) at t = {m.time:.6g} s")
        if self.dt_first is None:
            self.dt_first = dt
        elif dt < self.dt_collapse * self.dt_first and dt < limit:
            raise SimulationStopped(
                f"time step collapsed to {dt:.3e} s (first step {self.dt_first:.3e} s) at "
                f"t = {m.time:.6g} s; the smallest step is in {self._worst_name()}")
        dtv = 0.5 * (self.dt + dt) if self.dt > 0.0 else 0.5 * dt
        m.dtv = dtv
        t0 = wallclock.perf_counter()
        if self.sub is None and self.fused and m.mass.shape[0] < PARALLEL_NODES:
            # the wall's time is booked with the nodes' (one pass)
            res = predict_walls_move(m.force, m.mass, m.v, m.x, dtv, m.walls, dt)
            if self.fused_wall is not None:
                self.fused_wall.book(m, dt, *res)
            self.timings["nodes"] += wallclock.perf_counter() - t0
        else:
            kept = None
            if self.sub is not None:
                # the predictor of the nodes due (subcycle.py); the velocity passes see as
                # m.force the force of each node's kick over m.dtv (their work booking's)
                kept, m.force = m.force, self.sub.kick(m, dt)
            else:
                predict(m.force, m.mass, m.v, dtv)
            t1 = wallclock.perf_counter()
            self.timings["nodes"] += t1 - t0
            try:
                for p in self.velocity_passes:
                    p.run(m, dt)
                    t2 = wallclock.perf_counter()
                    self.timings[p.name] += t2 - t1
                    t1 = t2
            finally:
                if kept is not None:
                    m.force = kept
            move(m.x, m.v, dt)
            self.timings["nodes"] += wallclock.perf_counter() - t1
        self._update_elements(dt, final=dt >= limit)
        t1 = wallclock.perf_counter()
        for p in self.fracture_passes:
            p.run(m, dt)
            t2 = wallclock.perf_counter()
            self.timings[p.name] += t2 - t1
            t1 = t2
        for p in self.other_passes:
            p.run(m, dt)
            t2 = wallclock.perf_counter()
            self.timings[p.name] += t2 - t1
            t1 = t2
        self.dt = dt
        if dt >= free:
            self.dt_free = dt
        m.time += dt
        m.step += 1
        return dt

    def _worst_name(self) -> str:
        """The element with the smallest stable step, with its body (a hex is -(1 + index))."""
        m, k = self.model, self.worst_element
        if k < 0 and getattr(m, "blocks", None):
            b = m.blocks[0]
            return f"hex {-1 - k} (body {m.body_names[b.elem_body[-1 - k]]!r})"
        return f"element {k} (body {m.body_names[m.elem_body[k]]!r})"

    def tet_kernel(self, v: np.ndarray, dt: float, skip: np.ndarray | None = None,
                   guard: bool = True) -> None:
        """The tet kernel over step dt with the nodes' velocities v (element.element_update);
        with `skip` (subcycling) only on the parts not flagged, leaving the rows unsummed; the
        guard's verdicts (if asked for) with `guard`."""
        m = self.model
        fr = self.force_rows
        self.part_claims = E.part_flags(m.conn.shape[0], fr.part_size // E.CHUNK,
                                        self.part_claims)
        E.element_update(
            m.x, v, m.conn, m.elem_mat, m.status, m.sdev, m.pressure, m.q, m.eps_p,
            m.eps_rate, m.temperature, self.hardening, self.thermal, m.energy, m.vol,
            self.vol_eos, m.vol0, m.elem_mass, m.mat_params, self.jnode, self.use_anp, dt,
            self.cq, self.cl, m.force, fr.rows, self.fext, fr.extra_ptr, fr.extra_rows,
            fr.part_size // E.CHUNK, self.chunk_out, numba.get_num_threads(), self.plastic,
            self.guard if dt > 0.0 and guard else None, self.part_claims, skip, skip is None)

    def _update_elements(self, dt: float, final: bool = True) -> None:
        """The element update at the end of a step of dt (0: forces and stable steps of the
        state as it is). With subcycling, the parts due (every part if `final`)."""
        m = self.model
        t0 = wallclock.perf_counter()
        if self.use_anp:
            element_volumes(m.x, m.conn, m.status, self.vol_now)
            nodal_volume_ratio(self.vol_now, m.vol0, m.status, m.n2e_ptr, m.n2e, self.jnode)
        hexes_only = m.n_elem == 0 and bool(self.block_runners)
        if self.sub is not None:  # subcycling (never with hexes only)
            if dt > 0.0:
                self.sub.update_elements(self, dt, final)
            else:  # a refresh of the parts updated at the end of this step
                self.sub.refresh(self)
        elif not hexes_only:  # hexes only: no tet kernel to run (nor to compile); blocks write
            self.tet_kernel(m.v, dt)
        # verdicts for a step taken (a zero step refreshes forces only) by the tet kernel
        self.guard_step = m.step if dt > 0.0 and self.guard is not None and not hexes_only else -1
        out = self.chunk_out
        m.energy_terms["viscous"] += float(out[:, E.OUT_QWORK].sum())
        inverted = int(out[:, E.OUT_INVERTED].sum())
        if self.block_runners:  # after the tets: the blocks add their forces (blocks.py)
            from impactsim.solver.blocks import update_blocks

            bdt, bworst, bq, bhg, binv = update_blocks(self.block_runners, m, dt, self.cq,
                                                       self.cl, hexes_only)
            self.dt_blocks, self.worst_block = bdt, bworst
            m.energy_terms["viscous"] += bq
            m.energy_terms["hourglass"] += bhg
            inverted += binv
        if self.sub is not None:
            self.sub.after_update(self)  # the counted sums cleared, the levels set after a sync
        self._stable_step()
        self.timings["element"] += wallclock.perf_counter() - t0
        if inverted and self.on_inverted is not None:
            self.guard_step = -1  # the handler may change the state the verdicts were given on
            self.on_inverted(self, dt)
        elif inverted:
            raise SimulationStopped(
                f"{inverted} element(s) inverted (negative volume) at t = {m.time + dt:.6g} s"
                f"{self._first_inverted()}: a body starting inside another or a wall, a step "
                "too large, or crushing beyond what the mesh can follow (checks.negative_volume "
                "= \"erode\" removes such elements and goes on)")

    def _stable_step(self) -> None:
        """dt_stable and worst_element from the chunks' stable steps (with subcycling, each
        divided by its part's update interval) and the blocks'."""
        m = self.model
        out = self.chunk_out
        steps = out[:, E.OUT_DT] if self.sub is None else self.sub.effective_steps(out)
        if m.n_elem and len(steps):
            k = int(np.argmin(steps))
            self.dt_stable = float(steps[k])
            self.worst_element = int(out[k, E.OUT_WORST])
        if self.block_runners and (self.dt_blocks < self.dt_stable or m.n_elem == 0):
            self.dt_stable, self.worst_element = self.dt_blocks, self.worst_block

    def _first_inverted(self) -> str:
        m = self.model
        vol = np.zeros(m.n_elem)
        element_volumes(m.x, m.conn, m.status, vol)
        bad = np.flatnonzero((vol <= 0.0) & (m.status != 3))
        if not len(bad):
            return ""
        return f", first element {bad[0]} (body {m.body_names[m.elem_body[bad[0]]]!r})"

    def refresh_stable_step(self) -> None:
        """Recompute the forces and the stable step of the current state (after elements were
        removed: the step they set no longer holds). A zero step changes no stress."""
        self._update_elements(0.0)

    def refresh_forces(self, elements: np.ndarray) -> None:
        """Recompute the nodal forces of the nodes of `elements` from their live elements, after
        a pass changed those elements (erosion: a removed element no longer pushes its nodes)."""
        m = self.model
        nodes = np.unique(m.conn[elements])
        if self.sub is not None:  # subcycling: only the nodes whose forces this step summed
            # (levels <= the step's top). A node not due keeps the force of its last kick, which
            # a kick cut short is settled with (subcycle._settle) and the half-step term reads;
            # its parts are updated, without the removed elements, before its next kick
            nodes = nodes[self.sub.node_level[nodes] <= self.sub.top]
        E.node_forces(nodes, m.x, m.conn, m.status, m.sdev, m.pressure, m.q, m.n2e_ptr, m.n2e,
                      m.force)

    # --- accounting ----------------------------------------------------------------------------
    def energies(self, ke: float | None = None, ie: float | None = None,
                 power: float | None = None) -> dict[str, float]:
        """Energy terms [J]; total = kinetic + internal + dissipated + eroded - external work
        + half-step energy. `ke`, `ie`, `power`: the kinetic and internal energy and the force
        power sum F . v when already summed (solver/watch.py).

        The balance is time-centred. After a step the velocities are those of t^{n+1/2} and the
        stresses, internal energy and forces those of t^{n+1}; the work of prescribed velocities
        is booked up to t^{n+1/2} (constraints.py). ``half_step_energy`` = dt/2 sum F^{n+1} .
        U^{n+1/2} (dt the step just taken: t^{n+1} - t^{n+1/2} = dt/2) is what the forces add
        from t^{n+1/2} to t^{n+1}, and at a prescribed node the reaction's work over that half
        step. With a constant step it makes the kinetic energy the leapfrog's time-centred one,
        1/2 m U^{n+1/2} . U^{n+3/2}; when the step changes it stays the work of the half step
        the stress work was booked over (weighted by the coming velocity step instead, a
        release that halved the next step lost a quarter of a step's stress work from the
        balance until the step after). Without it a body driven from rest (a prescribed
        velocity, an initial strain-rate field) books its first step's stress work a step
        before the kinetic energy or the external work that pays for it (+14-18 % of the
        energy at step 1); the kinetic energy reported stays 1/2 m |U^{n+1/2}|^2."""
        m = self.model
        ke = kinetic_energy(m.v, m.mass) if ke is None else ke
        ie = internal_energy(m.energy, m.elem_mass, m.status) if ie is None else ie
        power = force_power(m.force, m.v, m.mass) if power is None else power
        if getattr(m, "blocks", None):
            from impactsim.solver.blocks import block_internal_energy

            ie += block_internal_energy(m)
        t = m.energy_terms
        if self.sub is None:
            half = 0.5 * self.dt * power
        else:  # each node's own time since its kick (subcycle.py)
            half = half_step_energy(m.force, m.v, m.mass, self.sub.node_level,
                                    self.sub.since_kick, self.sub.opened)
        out = {"kinetic_energy": ke, "internal_energy": ie, "viscous_energy": t["viscous"],
               "contact_dissipated": t["contact_dissipated"], "external_work": t["external_work"],
               "eroded_energy": t["eroded"]}
        for key, val in t.items():
            if key not in ("viscous", "contact_dissipated", "external_work", "eroded",
                           "hourglass"):
                out[key] = val
        out["half_step_energy"] = half
        out["total_energy"] = (ke + ie + t["contact_dissipated"] + t["eroded"]
                               + t.get("particles", 0.0) - t["external_work"] + half)
        if "hourglass" in t:  # the hourglass forces' work (hex8 blocks)
            out["hourglass_energy"] = t["hourglass"]
            out["total_energy"] += t["hourglass"]
        return out

    def momentum(self) -> np.ndarray:
        m = self.model
        return m.mass @ m.v
