"""Subcycling: the tets of a part whose stable step is 2^k times the global one are updated
every 2^k steps (a nodal partition, Belytschko, Yen & Mullen 1979; LS-DYNA's
*CONTROL_SUBCYCLE).

Levels (docs/performance.md, "What subcycling would take"):

- each part of the tet kernel (solver/element.py PART tets, the unit of the force rows) gets the
  level R = the largest r <= K with 2^r * MARGIN * s_min <= s_part (s its smallest stable
  step, s_min the mesh's);
- each node the least level of the parts around it (L = min R; 0 for the nodes of the
  hexahedral blocks, which run every step, and of prescribed velocities);
- each part is updated at the level U = the least level of its nodes (U <= L <= R).

A cycle is 2^K steps. At its step j (0 at the cycle's start) the nodes of the levels L with
j mod 2^L = 0 are due: their velocity takes its kick, U += dtv F / m, with dtv the mean of the
time since their last kick and the 2^L steps to their next one (each the step's dt times 2^L:
the leapfrog of ALGORITHMS.md 1, with a node's own step). Every node moves at every step with
its velocity (the velocity passes, contact, act on all of them as before; they see as the
model's force the force of each node's own kick over the step's dtv, with which they book
their work), so between its kicks a coarse node moves on a line, which its fine neighbours
see. At the end of a step the parts of the levels U due then (the same rule at step j + 1) are
updated over the time D since their last update with the velocity (x - x_last) / D, the line
their nodes moved on since (contact impulses in between included), and their rows' sums become
the forces of the nodes due; the rows of the other nodes are cleared, and their forces are
kept. A node's kick thus always finds every part around it updated at that moment.

The global step is C_cfl times the least of s_part / 2^M over the parts (M the coarsest level
of the part's nodes; the stable steps of the parts not updated in the step as of their last
update), so no part's update and no node's kick spans more than its own stable step. When a
part's step over its interval comes below the least stable step (a coarse part crushed, the
finest cells eroded) the cycle ends at once (`_binding`) instead of the step shrinking. At the
cycle's end, at such an early end and at a step that ends on a time limit (a frame, the end)
every part is updated, a kick cut short is made as long as the time that passed (`_settle`),
and the levels are set again from the fresh stable steps. A refresh
(`Simulation.refresh_stable_step` after erosion: a zero step) gives the parts updated at the
end of the step their stable steps and their nodes their forces at the positions of the moment;
the levels stand.

With every part at level 0 (a mesh whose parts' steps are within a factor 2 MARGIN) the run is
the run without subcycling, bit for bit.
"""

from __future__ import annotations

import numba
import numpy as np

from impactsim.case.schema import MAX_SUBCYCLE
from impactsim.model import ERODED
from impactsim.solver import element as E
from impactsim.solver import guard as G
from impactsim.solver.nodal import PARALLEL_NODES
from impactsim.solver.scatter import take_node

# a part takes level r only if its stable step is MARGIN * 2^r times the least one. The global
# step is bounded by every part's step over its interval (`effective_steps`), and a part that
# comes to bind it ends the cycle (`_binding`), so the margin only keeps that from happening at
# once; it costs levels (on oblique-sphere the parts' own levels would leave 72 % of the
# updates at 1.25, 61 % at 1.0: docs/performance.md, "Whole scenes, session 23")
MARGIN = 1.05
MAX_LEVELS = MAX_SUBCYCLE  # K at most: a cycle of 16 steps


class Subcycle:
    """The levels of a run's parts and nodes, and the time since each level's kick and update.

    `levels`: K >= 1, the coarsest level (an update every 2^K steps)."""

    def __init__(self, sim, levels: int):
        if not 1 <= levels <= MAX_LEVELS:
            raise ValueError(f"subcycle levels {levels} not in 1..{MAX_LEVELS}")
        m = sim.model
        self.levels = levels
        n_parts = len(E.part_flags(m.n_elem, sim.force_rows.part_size // E.CHUNK))
        self.part_chunks = sim.force_rows.part_size // E.CHUNK
        self.part_level = np.zeros(n_parts, np.int8)  # U
        self.node_level = np.zeros(m.n_node, np.int8)  # L, the kicks' levels
        self.next_node_level = self.node_level.copy()  # L from the next kick on
        # nodes of the further blocks (hexahedra) run every step: level 0
        # and the nodes of prescribed velocities (their work is booked with the step's dtv)
        self.fixed_nodes = np.zeros(m.n_node, np.bool_)
        for b in getattr(m, "blocks", None) or ():
            self.fixed_nodes[b.conn.reshape(-1)] = True
        self.fixed_nodes[m.bc_nodes] = True
        self.part_top = np.zeros(n_parts, np.int8)  # the coarsest level of a part's nodes
        self.stale = np.zeros(n_parts, np.int64)  # 1: a part not updated at the last update
        self.skip = np.zeros(n_parts, np.int64)  # element_update's claims: 1 = not this level
        self.x_last = [m.x.copy() for _ in range(levels + 1)]  # x at each level's last update
        self.v_level = np.zeros_like(m.x)
        self.kick_force = np.zeros_like(m.x)
        self.since_update = np.zeros(levels + 1)  # time since each level's last update [s]
        self.since_kick = np.zeros(levels + 1)  # time since each level's last kick [s]
        self.opened = np.zeros(levels + 1)  # the share of each level's last kick ahead of it [s]
        self.span = np.ldexp(1.0, np.arange(levels + 1))  # steps between a level's kicks: 2^L
        self.chunk_scale = np.ones(0)  # 2^-M of each chunk's part (`assign`)
        self.step_in_cycle = 0  # j
        self.synced = True  # every part was updated at the end of the last step
        self.top = levels  # the coarsest level updated then
        self.updates = np.zeros(levels + 1, np.int64)  # part updates per level (a count)
        self.resyncs = 0  # cycles ended early by a part that came to bind the step
        self.assign(sim)

    # --- levels ----------------------------------------------------------------------------
    def assign(self, sim) -> None:
        """Set the levels from the stable steps of a state where every part is fresh (the start,
        the end of a cycle, or a refresh at such a step). The nodes' new levels take effect at
        their next kick, which is every node's."""
        m = sim.model
        s_part = _part_steps(sim.chunk_out[:, E.OUT_DT], self.part_chunks, len(self.skip))
        s_min = min(float(s_part.min()) if len(s_part) else np.inf, sim.dt_blocks)
        r = np.zeros(len(s_part), np.int8)
        if np.isfinite(s_min) and s_min > 0.0:
            ratio = s_part / (MARGIN * s_min)
            with np.errstate(divide="ignore"):
                r = np.clip(np.floor(np.log2(np.maximum(ratio, 1.0))), 0, self.levels)
            r = r.astype(np.int8)
        _node_levels(m.conn, m.status, self.part_chunks * E.CHUNK, r, self.fixed_nodes,
                     self.levels, self.next_node_level)
        _part_levels(m.conn, m.status, self.part_chunks * E.CHUNK, self.next_node_level,
                     self.part_level, self.part_top)
        self.chunk_scale = np.repeat(np.ldexp(1.0, -self.part_top.astype(np.int64)),
                                     self.part_chunks)[:sim.chunk_out.shape[0]]
        if sim.guard is not None:  # the kernel gives the guard's verdicts at level 0 only
            coarse = np.repeat(self.part_level > 0, self.part_chunks * E.CHUNK)
            sim.guard[coarse[:m.n_elem]] = G.UNKNOWN
        self.step_in_cycle = 0
        self.synced = True

    def due(self, j: int) -> int:
        """The coarsest level due at step j of the cycle (all levels L <= it are due)."""
        if j == 0:
            return self.levels
        u = 0
        while u < self.levels and j % (2 << u) == 0:
            u += 1
        return u

    def effective_steps(self, chunk_out: np.ndarray) -> np.ndarray:
        """Each chunk's stable step divided by the longest interval, in steps, of its part's
        updates and its nodes' kicks (2^M, M the coarsest level of the part's nodes)."""
        return chunk_out[:, E.OUT_DT] * self.chunk_scale

    # --- the step --------------------------------------------------------------------------
    def kick(self, m, dt: float) -> np.ndarray:
        """The predictor of the nodes due at this step: U += dtv F / m, dtv the mean of the time
        since the node's last kick and its next 2^L steps of dt. Returns the force that gives
        each node's kick over the step's m.dtv (zero where there was none), for the velocity
        passes, which recover a node's velocity before the kick as U - m.dtv F / m to book
        their work."""
        due = self.due(self.step_in_cycle)
        # the last kick gave `opened` ahead of the time that then passed (`since_kick`): the
        # closing share makes the two together that time (exactly the leapfrog's with one level
        # and, at any level, while dt stays the same)
        closing = 2.0 * self.since_kick - self.opened
        opening = dt * self.span
        if self.kick_force.shape != m.force.shape:
            self.kick_force = np.zeros_like(m.force)
        _kick(m.force, m.mass, m.v, self.node_level, self.next_node_level, due, closing, opening,
              m.dtv, self.kick_force)
        self.since_kick[:due + 1] = 0.0
        self.opened[:due + 1] = opening[:due + 1]
        if self.step_in_cycle == 0:  # every node was kicked: its new level stands from now
            self.node_level[:] = self.next_node_level
        return self.kick_force

    def update_elements(self, sim, dt: float, final: bool) -> int:
        """The tet kernel on the parts due at the end of this step (every part when `final`: a
        cycle's or a time limit's end, or when a part's stable step has come to bind the step,
        `_binding`); the due nodes' forces from their rows. Returns the coarsest level
        updated."""
        m = sim.model
        self.since_kick += dt
        self.since_update += dt
        self.step_in_cycle += 1
        if self.step_in_cycle == 1 << self.levels:
            final = True
        top = self.levels if final else self.due(self.step_in_cycle)
        self._run_levels(sim, dt, 0, top)
        if not final and self._binding(sim):  # every part now, and levels set again
            final = True
            self._run_levels(sim, dt, top + 1, self.levels)
            top = self.levels
            self.resyncs += 1
        if final:  # kicks cut short: made as long as the time that passed (after the kernel,
            # whose level-0 parts took the velocities the nodes moved with)
            ahead = self.since_kick - self.opened
            ahead[0] = 0.0  # level 0: the step was its own
            if ahead.any():
                _settle(m.force, m.mass, m.v, self.node_level, ahead)
            self.opened[:] = self.since_kick
        np.greater(self.part_level, top, out=self.stale)
        for u in range(1, top + 1):  # a level with parts, or every level before new levels
            if final or (self.part_level == u).any():
                self.x_last[u][:] = m.x
        self.since_update[:top + 1] = 0.0
        fr = sim.force_rows
        _sum_due(m.force, sim.fext, fr.extra_ptr, fr.extra_rows, self.node_level, top,
                 m.n_node >= PARALLEL_NODES)
        self.top = top
        self.synced = final
        return top

    def _run_levels(self, sim, dt: float, first: int, last: int) -> None:
        """The tet kernel on the parts of levels first..last, each over its own interval."""
        m = sim.model
        for u in range(first, last + 1):
            np.not_equal(self.part_level, u, out=self.skip)
            if not (self.skip == 0).any():
                continue
            if u == 0:
                v, d = m.v, dt
            else:
                v, d = self.v_level, self.since_update[u]
                np.subtract(m.x, self.x_last[u], out=v)
                v /= d
            sim.tet_kernel(v, d, skip=self.skip, guard=u == 0)
            self.updates[u] += int((self.skip == 0).sum())

    def _binding(self, sim) -> bool:
        """Whether a part's stable step over its interval has come below the least stable step
        of all: the step would then shrink for the levels' sake (a crushed coarse part, or a
        fine part eroded), and the levels are set again instead."""
        out = sim.chunk_out
        return bool(self.effective_steps(out).min() < min(out[:, E.OUT_DT].min(),
                                                           sim.dt_blocks))

    def refresh(self, sim) -> None:
        """Forces and stable steps at the present positions (a zero step, after erosion) of the
        parts updated at the end of this step: on the others a zero step would not be one (their
        volume is that of their last update)."""
        m = sim.model
        fr = sim.force_rows
        if (self.stale == 0).any():
            sim.tet_kernel(m.v, 0.0, skip=self.stale)
        _sum_due(m.force, sim.fext, fr.extra_ptr, fr.extra_rows, self.node_level, self.top,
                 m.n_node >= PARALLEL_NODES)

    def report(self, steps: int) -> dict:
        """The summary's account: the part updates made, against one per part and step."""
        made = int(self.updates.sum())
        full = int(steps) * len(self.part_level)
        return {"levels": self.levels, "parts": len(self.part_level), "resyncs": self.resyncs,
                "part_updates_by_level": [int(k) for k in self.updates],
                "part_updates_share": made / full if full else 1.0}

    def after_update(self, sim) -> None:
        """Clear the chunks' sums that were counted (a part not updated next step must not count
        them again), and set the levels again after a step that updated every part."""
        sim.chunk_out[:, E.OUT_QWORK] = 0.0
        sim.chunk_out[:, E.OUT_INVERTED] = 0.0
        if self.synced:
            self.assign(sim)


@numba.njit(cache=True)
def half_step_energy(force, v, mass, level, since_kick, opened):
    """Sum over the nodes with mass of (since_kick - opened / 2)[L_i] F_i . U_i: the work the
    forces add from the mid-time of a node's velocity to the present (Simulation.energies'
    half-step energy; with one level dt / 2 sum F . U). Within an interval a coarse node's F is
    that of its last kick, and the term follows the work its elements take from it before
    their next update books it."""
    total = 0.0
    for i in range(mass.shape[0]):
        if mass[i] > 0.0:
            li = level[i]
            total += (since_kick[li] - 0.5 * opened[li]) * (
                force[i, 0] * v[i, 0] + force[i, 1] * v[i, 1] + force[i, 2] * v[i, 2])
    return total


def _part_steps(dt_chunks: np.ndarray, part_chunks: int, n_parts: int) -> np.ndarray:
    pad = np.full(n_parts * part_chunks, np.inf)
    pad[:len(dt_chunks)] = dt_chunks
    return pad.reshape(n_parts, part_chunks).min(axis=1)


@numba.njit(cache=True)
def _node_levels(conn, status, part_size, part_level, fixed, top, node_level):
    """L of each node: the least level of the parts of its live tets (`top` without any, 0 if
    `fixed`)."""
    node_level[:] = top
    for e in range(conn.shape[0]):
        if status[e] == ERODED:
            continue
        r = part_level[e // part_size]
        for k in range(4):
            n = conn[e, k]
            if r < node_level[n]:
                node_level[n] = r
    for i in range(node_level.shape[0]):
        if fixed[i]:
            node_level[i] = 0


@numba.njit(cache=True)
def _part_levels(conn, status, part_size, node_level, part_level, part_top):
    """U of each part: the least level of the nodes of its live tets, and M, the greatest (0
    and 0 for a part with none)."""
    for p in range(part_level.shape[0]):
        u, top = 127, 0
        for e in range(p * part_size, min(conn.shape[0], (p + 1) * part_size)):
            if status[e] == ERODED:
                continue
            for k in range(4):
                li = node_level[conn[e, k]]
                u = min(u, li)
                top = max(top, li)
        part_level[p] = 0 if u == 127 else u
        part_top[p] = top


@numba.njit(cache=True)
def _kick(force, mass, v, level, next_level, due, closing, opening, dtv_step, kick_force):
    """U_i += dtv F_i / m_i for the nodes of the levels <= `due`; dtv = (closing[L_i] +
    opening[L'_i]) / 2 (L' the level from this kick on): with one level, nodal.predict's
    arithmetic. kick_force_i = F_i dtv / dtv_step (F_i itself at level 0), zero for the nodes
    not kicked."""
    for i in range(mass.shape[0]):
        li = level[i]
        mi = mass[i]
        if li <= due and mi > 0.0:
            dtv = 0.5 * (closing[li] + opening[next_level[i]])
            a = dtv / mi
            v[i, 0] += a * force[i, 0]
            v[i, 1] += a * force[i, 1]
            v[i, 2] += a * force[i, 2]
            r = dtv / dtv_step
            kick_force[i, 0] = r * force[i, 0]
            kick_force[i, 1] = r * force[i, 1]
            kick_force[i, 2] = r * force[i, 2]
        else:
            kick_force[i, 0] = 0.0
            kick_force[i, 1] = 0.0
            kick_force[i, 2] = 0.0


@numba.njit(cache=True)
def _settle(force, mass, v, level, ahead):
    """U_i += ahead[L_i] / 2 F_i / m_i: a kick's share ahead (`Subcycle.opened`, half of it in
    the kick) made the time that has passed since, with the force of that kick (still in
    `force`: it is the node's until its next sum)."""
    for i in range(mass.shape[0]):
        d = ahead[level[i]]
        if d != 0.0 and mass[i] > 0.0:
            a = 0.5 * d / mass[i]
            v[i, 0] += a * force[i, 0]
            v[i, 1] += a * force[i, 1]
            v[i, 2] += a * force[i, 2]


def _sum_due(force, fext, extra_ptr, extra_rows, level, top, parallel):
    (_sum_due_parallel if parallel else _sum_due_serial)(force, fext, extra_ptr, extra_rows,
                                                         level, top)


@numba.njit(cache=True, parallel=True, nogil=True)
def _sum_due_parallel(force, fext, extra_ptr, extra_rows, level, top):
    """element._sum_parallel for the nodes of the levels <= `top`; the other nodes' rows are
    cleared and their forces kept."""
    for i in numba.prange(force.shape[0]):
        fx, fy, fz = take_node(i, fext, extra_ptr, extra_rows)
        if level[i] <= top:
            force[i, 0], force[i, 1], force[i, 2] = fx, fy, fz


@numba.njit(cache=True, nogil=True)
def _sum_due_serial(force, fext, extra_ptr, extra_rows, level, top):
    """`_sum_due_parallel` on one thread."""
    for i in range(force.shape[0]):
        fx, fy, fz = take_node(i, fext, extra_ptr, extra_rows)
        if level[i] <= top:
            force[i, 0], force[i, 1], force[i, 2] = fx, fy, fz
