"""Contact passes bound to the model (ALGORITHMS.md 1 step 3 and section 3).

``make_contact_passes(case, model)`` returns one velocity-stage pass per name in
``case.contact.passes``, in that order ("node-face" -> ``contact.node-face``, "edge-edge" ->
``contact.edge-edge``), or [] when the scene has fewer than two bodies and no self-contact.
Each pass sees model.x = x^n and model.v = U* and corrects model.v in place, pair after pair in
sorted order (Gauss-Seidel); positions move only after all passes of the step.

One run of a pass: the broad phase (swept boxes of this step, only entities near another body
unless self-contact, spatial hash) gives the candidate pairs once; then the first Gauss-Seidel
sweep over them, the algorithm of [D19]. A pair that gets an impulse becomes a constraint row
(its crossing geometry and accumulated impulse lam >= 0). After the first sweep of the last
pass of the list, the iteration of the step runs over the pairs and rows of all passes together
(``_solve``):

1. projection (``_project``, frictionless scenes only): projected Gauss-Seidel rounds over the
   rows of all passes (``impactsim.contact.rows``) that set each row's relative normal velocity
   to its target and may take impulse back, down to lam = 0, never below (a release, never a
   pull); mirror rows are solved in pairs. Rows left with lam = 0 stop being rows: their next
   visit tests the crossing afresh with the current velocities;
2. detection sweeps, push only, as the repeated sweeps of [D19]: every pass visits the pairs
   with a node changed since its previous sweep, tests the crossing of pairs that are not rows
   and pushes rows that approach again by more than SLACK * band / tau; until a sweep applies
   nothing or its largest velocity change falls below SWEEP_TOL of the first sweeps' (at most
   ``max_sweeps``). With PROJECTIONS > 1, step 1 runs again while a detection sweep still
   changes velocities by more than RELEASE_TOL of the first sweeps' (at most PROJECTIONS
   times in all). One projection is the default: a second one halves what remains of the
   energy gain in hertz-spheres (docs/physics.md) but in a flat, redundant contact (the block
   of benchmarks/bench_contact.py) it costs as much again as the rest of the contact passes.

The step thus always ends on a detection sweep, with the guarantee of the sequential algorithm
(no pair left crossing that a visit catches), and corrections are still applied one after the
other, in a fixed order, before any node moves (bit-identical results).

Departure from ALGORITHMS.md 3 ([D19] only ever adds impulse): later corrections of a step (the
symmetric node-face pass, edge-edge after node-face) often push an earlier pair apart; it then
ends the step opening while it holds a compressive impulse, and that impulse does positive work
(+3.6 % and +5.3 % of KE + IE in hertz-spheres). The projection takes it back. The slack of
the detection sweeps (SLACK = 0.01: a row left approaching that slowly moves at most a
hundredth of the touching band into the face in the step, and the next step's first sweep, with
no slack, restores it) keeps the sweeps after a projection from re-pushing rows by round-off
amounts, which would push their neighbours apart again. With friction the projection is not
run (the passes are the sequential algorithm). docs/physics.md, "Contact energy", has the
measurements.

The passes share a ``ContactContext``: one ``Surface`` (kept in step with erosion through
``model.status``), the per-step statistics, the energy bookkeeping and the penetration meter.
The first pass of the list reports the history columns of all contact passes:
``max_penetration`` [m] (measured independently, ``diagnostics``), ``contact_pairs`` (pairs
that got an impulse in the step, all passes) and ``contact_impulse`` [N s] (sum of the normal
impulses of the step, all passes). The last pass books the work of all contact impulses of the
step into ``model.energy_terms["contact_dissipated"]``.
"""

from __future__ import annotations

import abc
import difflib
import math

import numpy as np

from impactsim.contact.broadphase import (OCC_CELL, OCC_MAX_BODIES, Occupancy, SpatialHash,
                                          body_bounds, grid_from_bounds, mark_cells,
                                          select_boxes)
from impactsim.contact.diagnostics import PenetrationMeter
from impactsim.contact.edgeedge import GEO_COLS as EE_GEO_COLS
from impactsim.contact.edgeedge import (edge_edge_sweep, edge_normals_of, faces_at_edges)
from impactsim.contact.edgeedge import far_apart as ee_far_apart
from impactsim.contact.energy import impulse_work
from impactsim.contact.impulse import NO_LOCK as _NO_LOCK
from impactsim.contact.nodeface import GEO_COLS as NF_GEO_COLS
from impactsim.contact.nodeface import far_apart as nf_far_apart
from impactsim.contact.nodeface import node_face_sweep
from impactsim.contact.skin import SkinList, face_identities, increasing, overlapping_pairs
from impactsim.contact.rows import (gather_edge_edge, gather_node_face, row_partners,
                                   rows_round)
from impactsim.contact.surface import Surface
from impactsim.solver.passes import Pass

BAND = 1e-3  # touching band, a fraction of the mean surface edge length h (nodeface, edgeedge)
BOX_PAD = 0.05  # padding of the swept boxes, a fraction of h (covers the band and the changes of
#                 velocity by the corrections of the step)
EPS_BARY = 1e-6  # tolerance of the inside-the-triangle test at the crossing
RESTORE = 1.0  # share of a small overlap (inside the band) undone in one step
MAX_SWEEPS = 16  # Gauss-Seidel sweeps per pass and step, at most
SWEEP_TOL = 1e-8  # sweeps stop when the largest velocity change is below this share of the first
RELEASE_TOL = 1e-3  # projected rounds end when a round changes velocities by less than this
#                     share of the first sweeps' largest change
RELEASE_ENERGY_TOL = 1e-3  # ... or when a round lowers the rounds' objective (the kinetic energy
#                            of the rows' nodes less their targets' work) by less than this share
#                            of what the rounds before it lowered it by
RELEASE_ROUNDS = 16  # projected rounds of one projection, at most
PROJECTIONS = 1  # projections (each followed by detection sweeps) per step, at most
SLACK = 0.01  # detection sweeps leave a row that approaches by at most SLACK * band / tau


class ContactContext:
    """What the contact passes of one run share (see the module docstring)."""

    def __init__(self, model, friction: float = 0.0, self_contact: bool = False,
                 band: float = BAND, eps_bary: float = EPS_BARY, max_sweeps: int = MAX_SWEEPS,
                 restore: float = RESTORE):
        self.surface = Surface.from_model(model)
        self._conn_shape = model.conn.shape
        # the hexes' tet cover of the penetration measure (contact/hexes.py), built here so that
        # a state built from the case has it (checkpoints restore into it)
        self.proxy = _proxy(model)
        self.n_body = int(model.n_body)
        self.friction = float(friction)
        self.self_contact = bool(self_contact)
        self.band_rel = float(band)
        self.eps_bary = float(eps_bary)
        self.max_sweeps = max(int(max_sweeps), 1)
        self.restore = float(restore)
        self.skip_unchanged = True  # repeated sweeps visit only pairs whose nodes changed
        self.meter = PenetrationMeter()
        # the history's penetration measure in the meter's thread (the run sets it: its
        # history writer takes the Future, output/history.py); off, it is taken at once
        self.measure_later = False
        self.passes: list[ContactPass] = []
        self.last = {}  # pass name -> statistics of its last run
        self._h_key = None
        self._h = 0.0
        self._buf = {}
        self._v_star = None
        self.sweep_id = 0
        self.unconverged = 0  # steps whose projected rounds met neither test (_project)
        self.release_rounds = RELEASE_ROUNDS
        self.release_tol = RELEASE_TOL
        self.release_energy_tol = RELEASE_ENERGY_TOL
        self.projections = PROJECTIONS
        self.slack = SLACK
        self._locks = PrescribedLock()
        # the pre-selection of the broad phase by a coarse grid of the bodies' boxes
        # (broadphase.Occupancy); not with self-contact (every row is near its own body)
        self.occupancy = (Occupancy() if not self.self_contact and self.n_body <= OCC_MAX_BODIES
                          else None)
        # node -> the key the self-contact exclusion compares (None: the node itself). Node
        # separation sets the mesh node each copy came from, so that the faces a release opens
        # (coincident, sharing the copies of one node) are not taken for contacting ones.
        self.node_key = None
        # counts the surface's rebuilds and reconnections (node separation): a kept candidate
        # list follows erosion (contact.skin), and is built afresh after those
        self.topology = 0
        self._ident = (None, -1, None)

    def identities(self):
        """(faces, edges, nodes): the identities of the surface's entities, increasing in the
        canonical order of its compact arrays (``SkinList.follow``): a face's element and local
        face (and which of a hex quad's two triangles: ``skin.face_identities``), an edge's
        mesh edge, a node's index; None for a list out of that order."""
        s = self.surface
        if self._ident[0] is not s or self._ident[1] != s.version:
            f = np.empty(s.face_elem.shape[0], np.int64)
            out = [f if face_identities(s.face_elem, s.face_local, f) else None]
            for keys in (s.edge_mesh, s.nodes):
                out.append(keys if increasing(keys) else None)
            self._ident = (s, s.version, tuple(out))
        return self._ident[2]

    def lock(self, model) -> np.ndarray:
        """``prescribed_lock(model)``, cached (`PrescribedLock`)."""
        return self._locks.get(model)

    def rebuild_surface(self, model) -> None:
        """Start the surface afresh from model.conn (for a pass that renumbers or splits nodes in
        place, e.g. node separation; erosion needs nothing: ``prepare`` follows model.status)."""
        self.surface = Surface.from_model(model)
        self._conn_shape = model.conn.shape
        self._h_key = None
        self.proxy = _proxy(model)
        self.topology += 1

    def reconnect_surface(self, model, changed, hex_changed=None) -> None:
        """After node separation repointed the corners of the tets ``changed`` and of the hexes
        ``hex_changed`` (indices into the blocks' concatenated hexes): the surface updated in
        place (``Surface.reconnect``, ``HexSurface.reconnect``: the same arrays as
        ``rebuild_surface``, in proportion to the change), and the hexes' penetration cover."""
        hex_changed = np.unique(np.asarray(
            hex_changed if hex_changed is not None else [], np.int64))
        if hex_changed.shape[0] or self.proxy is not None:
            sizes = [b.conn.shape[0] for b in model.blocks]
            start = np.concatenate([[0], np.cumsum(sizes)])
            k = np.searchsorted(start, hex_changed, side="right") - 1
            rows = np.zeros((hex_changed.shape[0], 8), np.int32)
            for i, blk in enumerate(model.blocks):  # a loop over the (few) blocks
                sel = k == i
                rows[sel] = blk.conn[hex_changed[sel] - start[i]]
            self.surface.reconnect(model.conn, changed, hex_changed, rows)
            self.proxy.reconnect(model, changed, hex_changed, rows)
        else:
            self.surface.reconnect(model.conn, changed)
        self._conn_shape = model.conn.shape
        self._h_key = None
        self.topology += 1

    def prepare(self, model) -> float:
        """Follow erosion (status) and return the current mean surface edge length h [m]."""
        if model.conn.shape != self._conn_shape:
            self.surface = Surface.from_model(model)
            self._conn_shape = model.conn.shape
            self.topology += 1
        changed = self.surface.sync(model.status)
        key = (model.step, self.surface.version)
        if changed or key != self._h_key:
            self._h = self.surface.mean_edge_length(model.x)
            self._h_key = key
        return self._h

    def buffer(self, name: str, shape, dtype=np.float64) -> np.ndarray:
        """A reusable scratch array (contents undefined), reallocated only when it must grow."""
        b = self._buf.get(name)
        rows = shape[0] if isinstance(shape, tuple) else shape
        if b is None or b.shape[0] < rows or b.dtype != np.dtype(dtype):
            full = (max(rows, 16),) + (tuple(shape[1:]) if isinstance(shape, tuple) else ())
            b = np.empty(full, dtype=dtype)
            self._buf[name] = b
        return b[:rows]

    def stamps(self, n_node: int) -> np.ndarray:
        """Per node, the number of the sweep that last changed its velocity (see
        ``nodeface.node_face_sweep``); numbers only grow, so the array is never reset."""
        st = self._buf.get("stamp")
        if st is None or st.shape[0] != n_node:
            st = np.zeros(n_node, dtype=np.int64)  # sweeps are numbered from 1
            self._buf["stamp"] = st
            self.sweep_id = 0
        return st

    def bounds(self, model, dt, pad):
        """Per-body bounding boxes (n_body, 3) of the surface nodes swept over the step."""
        s = self.surface
        blo = self.buffer("blo", (self.n_body, 3))
        bhi = self.buffer("bhi", (self.n_body, 3))
        if not body_bounds(model.x, model.v, dt, s.nodes, s.node_body, pad, blo, bhi):
            raise FloatingPointError("non-finite position or velocity in the contact broad phase")
        return blo, bhi

    def select(self, name, model, dt, ent, pad, body, blo, bhi):
        """(rows, lo, hi): the rows of ``ent`` that can meet another body (all of them with
        self-contact) and their swept boxes."""
        n = ent.shape[0]
        sel = self.buffer(name + ".sel", n, np.int64)
        lo = self.buffer(name + ".lo", (n, 3))
        hi = self.buffer(name + ".hi", (n, 3))
        k = select_boxes(model.x, model.v, dt, ent, pad, body, blo, bhi, self.self_contact,
                         _NO_SKIP, sel, lo, hi)
        return sel[:k], lo[:k], hi[:k]

    def all_boxes(self, name, model, dt, ent, body, pad):
        """(lo, hi): the swept, padded boxes of every row of ``ent`` (the arithmetic of
        ``select``; ``body`` is not read)."""
        n = ent.shape[0]
        sel = self.buffer(name + ".all", n, np.int64)
        lo = self.buffer(name + ".alo", (n, 3))
        hi = self.buffer(name + ".ahi", (n, 3))
        select_boxes(model.x, model.v, dt, ent, pad, body, _NO_BOUNDS, _NO_BOUNDS, True,
                     _NO_SKIP, sel, lo, hi)
        return lo, hi

    def grid(self, blo, bhi, h):
        live = blo[:, 0] <= bhi[:, 0]
        return grid_from_bounds(blo[live].min(axis=0), bhi[live].max(axis=0), h)

    # --- energy of the contact impulses of one step ------------------------------------------
    def begin_step(self, model) -> None:
        if not _books_energy(model):
            return
        nodes = self.surface.nodes
        self._v_star = self.buffer("v_star", (nodes.shape[0], 3))
        np.take(model.v, nodes, axis=0, out=self._v_star)
        self.stamps(model.n_node)
        self._start = self.sweep_id  # the nodes the step changes get larger stamps

    def end_step(self, model) -> None:
        if self._v_star is None or not _books_energy(model):
            return
        work = impulse_work(self.surface.nodes, self._v_star, model.v, model.mass, model.force,
                            float(model.dtv), self.stamps(model.n_node), self._start)
        model.energy_terms["contact_dissipated"] = (
            model.energy_terms.get("contact_dissipated", 0.0) - work)
        self._v_star = None


def _proxy(model):
    """The tet cover of the hexes for the penetration measure, None without hexes."""
    if not getattr(model, "blocks", None):
        return None
    from impactsim.contact.hexes import ProxyTets

    return ProxyTets(model)


def prescribed_lock(model) -> np.ndarray:
    """Prescribed velocity components (model.bc_nodes, model.bc_mask): ``(n_node, 3)`` with 0.0
    where the case prescribes a component, else 1.0; an empty ``(0, 3)`` array when it prescribes
    none (the kernels then run their plain code, bit-identical to a scene without boundary
    conditions). The boundary-conditions pass runs before contact (ALGORITHMS.md 1 step 3); a
    prescribed component is an infinite mass along its axis and the contact impulses leave it
    alone (``impactsim.contact.impulse``; also the ``lock`` argument of
    ``impactsim.fracture.particles.particle_face_sweep``)."""
    bc_nodes = getattr(model, "bc_nodes", None)
    bc_mask = getattr(model, "bc_mask", None)
    if bc_nodes is None or bc_mask is None or len(bc_nodes) == 0 or not np.any(bc_mask):
        return _NO_LOCK
    lock = np.ones((model.v.shape[0], 3))
    lock[np.asarray(bc_nodes)] = np.where(np.asarray(bc_mask, bool), 0.0, 1.0)
    return lock


class PrescribedLock:
    """``prescribed_lock(model)`` for passes that run every step: built again only when the node
    count or the model's boundary-condition arrays change, not allocated each step."""

    def __init__(self):
        self._key = None
        self._lock = _NO_LOCK

    def get(self, model) -> np.ndarray:
        key = (model.v.shape[0], id(getattr(model, "bc_nodes", None)),
               id(getattr(model, "bc_mask", None)))
        if key != self._key:
            self._lock = prescribed_lock(model)
            self._key = key
        return self._lock


def _books_energy(model) -> bool:
    return (hasattr(model, "dtv") and hasattr(model, "force")
            and isinstance(getattr(model, "energy_terms", None), dict))


_NO_SKIP = np.zeros(0, np.uint8)
_NO_PAIRS = np.zeros((0, 2), dtype=np.int64)
_NO_BOUNDS = np.zeros((0, 3))


def _first_sweep(model, dt, p) -> None:
    """The first sweep of pass p in the step: every candidate pair, the algorithm of [D19]."""
    ctx = p.ctx
    if p._pairs.shape[0] == 0:
        return
    stamp = ctx.stamps(model.n_node)
    ctx.sweep_id += 1
    p._last_sweep = ctx.sweep_id
    applied, imp, jump = p._sweep(model, dt, p._h, p._pairs, p._active, stamp, ctx.sweep_id, 0,
                                  p._geo, 0.0)
    p._impulse += imp
    p._sweeps += 1
    p._first = jump if applied else 0.0


def _solve(model, dt, group) -> None:
    """After the first sweep of every pass of ``group``: projections of the rows and push-only
    detection sweeps over the pairs of all passes (module docstring, steps 1 and 2)."""
    ctx = group[0].ctx
    first = max(p._first for p in group)
    if not first > 0.0:
        return  # the first sweeps applied nothing
    stamp = ctx.stamps(model.n_node)
    project = ctx.friction == 0.0
    release = True
    nproj = 0
    for _ in range(ctx.max_sweeps):
        if release and project and nproj < ctx.projections:
            _project(model, group, stamp, first)
            nproj += 1
        applied = 0
        jump = 0.0
        for p in group:
            if p._pairs.shape[0] == 0:
                continue
            since = p._last_sweep if ctx.skip_unchanged else 0
            ctx.sweep_id += 1
            p._last_sweep = ctx.sweep_id
            slack = ctx.slack * ctx.band_rel * p._h / dt if project else 0.0
            a, imp, jmp = p._sweep(model, dt, p._h, p._pairs, p._active, stamp, ctx.sweep_id,
                                   since, p._geo, slack)
            p._impulse += imp
            p._sweeps += 1
            applied += a
            jump = max(jump, jmp)
        if applied == 0 or jump <= SWEEP_TOL * first:
            return
        if jump <= ctx.release_tol * first:
            release = False  # what is left is the push-only convergence of the sequential sweeps


def _project(model, group, stamp, first) -> None:
    """The projected rounds (``rows``) over the rows of all passes of ``group``, at most
    ``release_rounds``, until a round's largest velocity change falls below RELEASE_TOL of the
    first sweeps' (``first``) or the round lowers the rounds' objective by at most
    RELEASE_ENERGY_TOL of what the rounds before it lowered it by; then rows left without
    impulse are dropped (their next visit tests the crossing afresh, with the current
    velocities).

    The energy test: on a flat, redundant contact (every node in several rows) the rounds cut
    the largest velocity change by only about 0.92 a round, so the first test alone ran to the
    limit at almost every step, while the energy the projection takes back converges at once
    (on bench_contact.py's 1 mm block the rounds' kinetic energy changes by 6 %, 0.7 %, 0.1 %,
    0.02 % of the first round's from the second round on, and the energy left after round 5 is
    1e-4 of the total). The projection is there for the energy (module docstring): its rows'
    velocities after it matter only through the detection sweeps that follow, which push
    whatever still approaches."""
    ctx = group[0].ctx
    rows = [np.flatnonzero(p._active[:p._pairs.shape[0]] == 1) for p in group]
    n = sum(r.shape[0] for r in rows)
    if n == 0:
        return
    idx = ctx.buffer("rows.idx", (n, 4), np.int64)
    coef = ctx.buffer("rows.coef", (n, 4))
    nrm = ctx.buffer("rows.n", (n, 3))
    tgt = ctx.buffer("rows.t", n)
    lam = ctx.buffer("rows.lam", n)
    diag = ctx.buffer("rows.diag", n)
    partner = ctx.buffer("rows.partner", n, np.int64)
    off = 0
    for p, r in zip(group, rows):
        p._gather(r, off, idx, coef, nrm, tgt, lam)
        off += r.shape[0]
    lock = ctx.lock(model)
    row_partners(idx, coef, nrm, model.mass, diag, partner, lock)
    rounds = 0
    decrease = 0.0  # of the rounds' objective so far (rows.rows_round)
    for _ in range(ctx.release_rounds):
        ctx.sweep_id += 1
        changed, _, jump, dphi = rows_round(idx, coef, nrm, tgt, lam, diag, partner, model.v,
                                            model.mass, stamp, ctx.sweep_id, lock)
        rounds += 1
        decrease -= dphi
        if (changed == 0 or jump <= ctx.release_tol * first
                or -dphi <= ctx.release_energy_tol * decrease):
            break
    else:
        ctx.unconverged += 1
    off = 0
    for p, r in zip(group, rows):
        m = r.shape[0]
        p._impulse += float(lam[off:off + m].sum() - p._geo[r, 0].sum())  # taken back: < 0
        p._rounds += rounds
        p._geo[r, 0] = lam[off:off + m]
        p._active[r[~(lam[off:off + m] > 0.0)]] = 0
        off += m


def _band_max(ctx, h, pad_b) -> float:
    """The largest touching band of the steps a candidate list built with mean edge length h
    and padding pad_b is kept (``ContactPass._far_apart``): each surface node moves at most
    pad_b per axis meanwhile, so an edge's length, and their mean h, by at most 2 sqrt(3)
    pad_b."""
    return ctx.band_rel * (h + 2.0 * math.sqrt(3.0) * pad_b)


def _copies(record, sel, lo, hi):
    """(sel, lo, hi) copied when a build records what it selects (else None)."""
    return None if record is None else (sel.copy(), lo.copy(), hi.copy())


def _mark_dropped(marks, before, sel, body) -> None:
    """Mark in ``marks`` the cells of the rows of ``before`` (sel, lo, hi) not in ``sel``
    (the rows the occupancy grid kept, a subsequence): the rows it left out."""
    if marks is None:
        return
    sel0, lo0, hi0 = before
    at = np.minimum(np.searchsorted(sel, sel0), max(sel.shape[0] - 1, 0))
    out = ~((sel.shape[0] > 0) & (sel[at] == sel0)) if sel.shape[0] else np.ones(
        sel0.shape[0], bool)
    mark_cells(sel0[out], lo0[out], hi0[out], body, marks.origin, marks.inv_c, marks.dims,
               marks.gen, marks.bits, marks.g)


def _lift(pairs, qsel, esel):
    """Pairs of selected rows -> pairs of full rows (order is kept: the maps are increasing)."""
    if pairs.shape[0]:
        pairs[:, 0] = qsel[pairs[:, 0]]
        pairs[:, 1] = esel[pairs[:, 1]]
    return pairs


class ContactPass(Pass):
    stage = "velocity"

    def __init__(self, ctx: ContactContext):
        self.ctx = ctx
        self.hash = SpatialHash()
        self.skin = SkinList()
        self._init = None  # the sweeps' start values of this step's pairs (_broad_phase)
        self.reports_history = False
        self.totals = {"pairs": 0, "impulse": 0.0, "candidates": 0, "sweeps": 0, "rounds": 0,
                       "steps_in_contact": 0}
        self.max_penetration_seen = 0.0

    def run(self, model, dt: float) -> None:
        ctx = self.ctx
        group = ctx.passes if self in ctx.passes else [self]
        h = ctx.prepare(model)
        if self is group[0]:
            ctx.begin_step(model)
        self._h = h
        self._init = None
        self._pairs = self._candidates(model, dt, h)
        k = self._pairs.shape[0]
        self._active = ctx.buffer(self.name + ".active", k, np.uint8)
        if self._init is None or self._init.shape[0] != k:
            self._active[:] = 0
        else:  # pairs apart while the candidate list is kept (_far_apart) are skipped
            self._active[:] = self._init
        self._geo = ctx.buffer(self.name + ".geo", (k, self.geo_cols))
        self._impulse = 0.0
        self._sweeps = 0
        self._last_sweep = 0
        self._rounds = 0
        self._first = 0.0  # largest velocity change of the first sweep
        _first_sweep(model, dt, self)
        if self is group[-1]:
            # the corrections of a later pass can push apart pairs of an earlier one: the
            # iteration runs over the rows of all passes together
            _solve(model, dt, group)
            for p in group:
                p._finish()
            ctx.end_step(model)

    def _finish(self) -> None:
        """Statistics of the step (after all sweeps of all passes)."""
        k = self._pairs.shape[0]
        n_active = int(np.count_nonzero((self._active[:k] == 1) & (self._geo[:k, 0] > 0.0)))
        self.ctx.last[self.name] = {"pairs": n_active, "impulse": self._impulse,
                                    "candidates": int(k), "sweeps": self._sweeps,
                                    "rounds": self._rounds}
        t = self.totals
        t["pairs"] += n_active
        t["impulse"] += self._impulse
        t["candidates"] += int(k)
        t["sweeps"] += self._sweeps
        t["rounds"] += self._rounds
        t["steps_in_contact"] += int(n_active > 0)

    @abc.abstractmethod
    def _candidates(self, model, dt, h) -> np.ndarray:
        """Broad phase: sorted candidate pairs (k, 2) int64 of this step."""

    def _broad_phase(self, model, dt, h, hashed, queries=None) -> np.ndarray:
        """Sorted pairs (query row, hashed row) of rows of entity arrays whose swept, padded
        boxes overlap: ``hashed`` and ``queries`` are (buffer name, rows (k, w), bodies (k,)
        [, keys (k, w')]), only rows near another body take part (all with self-contact), and
        without ``queries`` the hashed rows are queried against themselves (each pair once,
        i < j). The self-contact exclusion compares the rows' keys (default: the rows; a hex
        surface's triangles and creases give their whole quad, contact/hexes.py).

        The pairs come from a list kept over steps with a skin (``contact.skin``): built with
        static boxes padded by the skin when a node has moved too far, and filtered each step
        with this step's boxes; the same pairs, in the same order, as a fresh broad phase."""
        ctx = self.ctx
        s = ctx.surface
        pad = BOX_PAD * h
        sk = self.skin
        if not sk.skin_rel > 0.0:  # no kept list: the broad phase afresh every step
            return self._fresh_pairs(model, dt, h, pad, hashed, queries)
        sides = self._sides(hashed, queries)
        state = sk.state(s, ctx.node_key, ctx.topology, model.x, model.v, dt, pad, h)
        if state == "changed" and not sk.follow(s, sides, ctx.node_key, self.hash,
                                                self._far_of_list):
            state = "build"
        if state == "build":
            pad_b = pad + 0.5 * sk.build_skin() * h
            record = sk.new_record()
            kept = self._fresh_pairs(model, 0.0, h, pad_b, hashed, queries, record)
            self._h_b = h
            sk.keep(s, ctx.node_key, ctx.topology, sides, model.x, kept, pad_b,
                    h + 2.0 * math.sqrt(3.0) * pad_b,
                    self._far_apart(model.x, kept, h, pad_b), record, ctx.self_contact)
        kept = sk.pairs
        if kept.shape[0] == 0:
            return _NO_PAIRS
        name, _, body = hashed[:3]
        elo, ehi = ctx.all_boxes(name, model, dt, sk.e_ent, body, pad)
        qlo, qhi = elo, ehi
        if queries is not None:
            qlo, qhi = ctx.all_boxes(queries[0], model, dt, sk.q_ent, queries[2], pad)
        out = ctx.buffer(self.name + ".pairs", (kept.shape[0], 2), np.int64)
        far = ctx.buffer(self.name + ".far", kept.shape[0], np.uint8)
        n = overlapping_pairs(sk.local, qlo, qhi, elo, ehi, sk.q_map, sk.e_map, sk.far, out, far)
        self._init = far[:n]
        return out[:n]

    def _sides(self, hashed, queries):
        """Per side of the broad phase (hashed, then queries if any): (entity rows, bodies,
        keys, identities) for the kept list (``SkinList.follow``)."""
        faces, edges, nodes = self.ctx.identities()
        ident = {"nf.face": faces, "ee.edge": edges, "nf.node": nodes}
        out = []
        for side in (hashed, queries):
            if side is not None:
                out.append((side[1], side[2], side[3] if len(side) > 3 else side[1],
                            ident[side[0]]))
        return out

    def _far_of_list(self, pairs, xb):
        """``_far_apart`` of pairs added to the kept list: at the build's positions ``xb``,
        with its h and padding."""
        return self._far_apart(xb, pairs, self._h_b, self.skin._pad_b)

    def _far_apart(self, x, kept, h, pad_b):
        """Per kept pair, the sweep's start value: its pass's FAR for the pairs apart for as
        long as the list is kept (the pass's ``far_apart``, at the build's positions x), else
        0; None: all 0."""
        return None

    def _fresh_pairs(self, model, dt, h, pad, hashed, queries, record=None) -> np.ndarray:
        """The broad phase of ``_broad_phase`` run afresh with boxes swept over dt (0: static
        boxes) and padded by ``pad``; ``record`` (``skin.BuildRecord``, or None): what a build
        of the kept list selected against, kept to follow surface changes."""
        ctx = self.ctx
        blo, bhi = ctx.bounds(model, dt, pad)
        name, ent, body = hashed[:3]
        ekey = hashed[3] if len(hashed) > 3 else ent
        esel, elo, ehi = ctx.select(name, model, dt, ent, pad, body, blo, bhi)
        if queries is None:
            qsel, qlo, qhi, qkey, qbody = esel, elo, ehi, ekey, body
        else:
            qname, qent, qbody = queries[:3]
            qkey = queries[3] if len(queries) > 3 else qent
            qsel, qlo, qhi = ctx.select(qname, model, dt, qent, pad, qbody, blo, bhi)
        if qsel.shape[0] == 0 or esel.shape[0] == 0:
            return _NO_PAIRS
        origin, cell = ctx.grid(blo, bhi, h)
        drop = [None, None]
        if ctx.occupancy is not None:  # only rows near another body's rows (Occupancy)
            occ = ctx.occupancy
            occ_hi = bhi[blo[:, 0] <= bhi[:, 0]].max(axis=0)
            occ.grid(origin, occ_hi, OCC_CELL * cell)
            if record is not None:  # marks of the rows the grid leaves out, per side
                for t in range(1 if queries is None else 2):
                    record.marks[t].grid(origin, occ_hi, OCC_CELL * cell)
                    drop[t] = record.marks[t]
            if queries is None:
                occ.mark(esel, elo, ehi, body)
                before = _copies(record, esel, elo, ehi)
                esel, elo, ehi = occ.keep(esel, elo, ehi, body)
                _mark_dropped(drop[0], before, esel, body)
                qsel, qlo, qhi = esel, elo, ehi
            else:
                occ.mark(qsel, qlo, qhi, qbody)
                before = _copies(record, esel, elo, ehi)
                esel, elo, ehi = occ.keep(esel, elo, ehi, body)
                _mark_dropped(drop[0], before, esel, body)
                occ.next()
                occ.mark(esel, elo, ehi, body)
                before = _copies(record, qsel, qlo, qhi)
                qsel, qlo, qhi = occ.keep(qsel, qlo, qhi, qbody)
                _mark_dropped(drop[1], before, qsel, qbody)
            if qsel.shape[0] == 0 or esel.shape[0] == 0:
                return _NO_PAIRS
        self.hash.build(elo, ehi, origin, cell)
        qk, ek = qkey[qsel], ekey[esel]
        if ctx.node_key is not None:  # self-contact exclusion by node family (separation)
            qk, ek = ctx.node_key[qk], ctx.node_key[ek]
        if record is not None:
            record.complete = True
            record.blo, record.bhi = blo.copy(), bhi.copy()
            record.grid = (origin, cell)
            record.dropped = drop
            record.rows[0] = esel.copy()
            record.keys[0] = np.ascontiguousarray(ek, np.int64)
            record.bodies[0] = body[esel]
            if queries is not None:
                record.rows[1] = qsel.copy()
                record.keys[1] = np.ascontiguousarray(qk, np.int64)
                record.bodies[1] = qbody[qsel]
                record.q_boxes = (qlo.copy(), qhi.copy())
        pairs = self.hash.query(qlo, qhi, qk, qbody[qsel], ek, body[esel],
                                queries is None, ctx.self_contact)
        return _lift(pairs, qsel, esel)

    @abc.abstractmethod
    def _sweep(self, model, dt, h, pairs, active, stamp, sweep, since, geo, slack):
        """One push-only Gauss-Seidel sweep: (pairs corrected, impulse [N s], largest velocity
        change); ``active`` and ``geo`` hold the constraint rows of the pairs corrected so far
        in the step."""

    @abc.abstractmethod
    def _gather(self, rows, off, idx, coef, nrm, tgt, lam):
        """The constraint rows ``rows`` of this pass into the table of ``rows.rows_round``,
        from row ``off`` on."""

    def history(self, model) -> dict[str, float]:
        if not self.reports_history:
            return {}
        ctx = self.ctx
        ctx.surface.sync(model.status)
        x, conn, elem_body, status = model.x, model.conn, model.elem_body, model.status
        if ctx.proxy is not None:  # hexes: against a tet cover (contact/hexes.py)
            x, conn, elem_body, status = ctx.proxy.update(model)
        if ctx.measure_later:  # a Future: the measure is taken in the meter's thread
            pen = ctx.meter.measure_later(x, conn, elem_body, status, ctx.surface,
                                          ctx.topology, self._seen)
        else:
            pen = self._seen(ctx.meter.measure(x, conn, elem_body, status, ctx.surface))
        return {"max_penetration": pen,
                "contact_pairs": float(sum(s["pairs"] for s in ctx.last.values())),
                "contact_impulse": float(sum(s["impulse"] for s in ctx.last.values()))}

    def _seen(self, measured: dict) -> float:
        """A measure's max_penetration, kept in ``max_penetration_seen``."""
        pen = measured["max_penetration"]
        self.max_penetration_seen = max(self.max_penetration_seen, pen)
        return pen

    def summary(self, model) -> dict:
        self.ctx.meter.wait()  # (max_penetration_seen of the measures still being taken)
        t = self.totals
        out = {"candidate_pairs": int(t["candidates"]), "corrected_pairs": int(t["pairs"]),
               "impulse": float(t["impulse"]), "sweeps": int(t["sweeps"]),
               "projected_rounds": int(t["rounds"]),
               "steps_in_contact": int(t["steps_in_contact"]), "hash_grows": int(self.hash.grows),
               "candidate_list_builds": int(self.skin.builds),
               "candidate_list_follows": int(self.skin.follows),
               "candidate_list_uncovered": int(self.skin.uncovered)}
        if self.reports_history:
            out["max_penetration_seen"] = float(self.max_penetration_seen)
            out["unconverged_steps"] = int(self.ctx.unconverged)
            out["surface"] = {"faces": self.ctx.surface.n_faces,
                              "edges": self.ctx.surface.n_edges,
                              "nodes": self.ctx.surface.n_nodes}
        return {self.name: out}


class NodeFacePass(ContactPass):
    """Symmetric node-face pass (ALGORITHMS.md 3.1): every boundary node against the boundary
    faces of the other bodies (and of its own body, minus the faces it belongs to, with
    self-contact)."""

    name = "contact.node-face"
    geo_cols = NF_GEO_COLS

    def _candidates(self, model, dt, h):
        s = self.ctx.surface
        if s.n_faces == 0:
            return _NO_PAIRS
        return self._broad_phase(model, dt, h, ("nf.face", s.faces, s.face_body, s.face_key),
                                 ("nf.node", s.nodes.reshape(-1, 1), s.node_body))

    def _far_apart(self, x, kept, h, pad_b):
        s = self.ctx.surface
        out = np.empty(kept.shape[0], np.uint8)
        nf_far_apart(kept, s.nodes, s.faces, x, _band_max(self.ctx, h, pad_b), pad_b, out)
        return out

    def _sweep(self, model, dt, h, pairs, active, stamp, sweep, since, geo, slack):
        ctx = self.ctx
        s = ctx.surface
        return node_face_sweep(pairs, s.nodes, s.faces, model.x, model.v, model.mass, dt,
                               ctx.friction, ctx.band_rel * h, ctx.eps_bary, ctx.restore,
                               active, stamp, sweep, since, geo, slack, ctx.lock(model))

    def _gather(self, rows, off, idx, coef, nrm, tgt, lam):
        s = self.ctx.surface
        gather_node_face(rows, self._pairs, s.nodes, s.faces, self._geo, off, idx, coef, nrm,
                         tgt, lam)


class EdgeEdgePass(ContactPass):
    """Edge-edge pass of [D19] (ALGORITHMS.md 3.2): every pair of boundary edges of different
    bodies (or of one body without a shared node, with self-contact)."""

    name = "contact.edge-edge"
    geo_cols = EE_GEO_COLS

    def _candidates(self, model, dt, h):
        ctx = self.ctx
        s = ctx.surface
        if s.n_edges == 0:
            return _NO_PAIRS
        pairs = self._broad_phase(model, dt, h, ("ee.edge", s.edges, s.edge_body, s.edge_key))
        if pairs.shape[0]:
            # outward normals at the edges, for touching pairs (edgeedge module docstring)
            self.normals = ctx.buffer("ee.normals", (s.n_edges, 3))
            if self._init is None:  # the faces at the pairs' edges (the other rows unread)
                fsel = ctx.buffer("ee.faces", s.n_faces, np.int64)
                mark = self._edge_marks(s.n_edges)
                fsel = fsel[:faces_at_edges(pairs, s.face_edges, mark, fsel)]
            else:  # pairs of the kept list: the faces at its edges, found at its build
                fsel = self._normal_faces()
            edge_normals_of(model.x, s.faces, s.face_edges, fsel, self.normals)
        return pairs

    def _edge_marks(self, n_edges: int) -> np.ndarray:
        """A bool per edge, all False (``faces_at_edges`` leaves them so)."""
        m = getattr(self, "_marks", None)
        if m is None or m.shape[0] < n_edges:
            m = self._marks = np.zeros(max(n_edges, 16) * 3 // 2, dtype=bool)
        return m[:n_edges]

    def _normal_faces(self) -> np.ndarray:
        """The faces at the edges of the kept candidate list (``edge_normals_of``), found again
        at each of its builds."""
        sk = self.skin
        if getattr(self, "_faces_version", None) != sk.version:
            s = self.ctx.surface
            fsel = np.empty(s.n_faces, np.int64)
            n = faces_at_edges(sk.pairs, s.face_edges, self._edge_marks(s.n_edges), fsel)
            self._faces = fsel[:n]
            self._faces_version = sk.version
        return self._faces

    def _far_apart(self, x, kept, h, pad_b):
        s = self.ctx.surface
        out = np.empty(kept.shape[0], np.uint8)
        ee_far_apart(kept, s.edges, x, _band_max(self.ctx, h, pad_b), pad_b, out)
        return out

    def _sweep(self, model, dt, h, pairs, active, stamp, sweep, since, geo, slack):
        ctx = self.ctx
        s = ctx.surface
        return edge_edge_sweep(pairs, s.edges, self.normals, model.x, model.v, model.mass, dt,
                               ctx.friction, ctx.band_rel * h, ctx.restore, active, stamp,
                               sweep, since, geo, slack, ctx.lock(model))

    def _gather(self, rows, off, idx, coef, nrm, tgt, lam):
        gather_edge_edge(rows, self._pairs, self.ctx.surface.edges, self._geo, off, idx, coef,
                         nrm, tgt, lam)


PASSES = {"node-face": NodeFacePass, "edge-edge": EdgeEdgePass}


def make_contact_passes(case, model) -> list[Pass]:
    """The contact passes the case asks for, in its order (see the module docstring)."""
    c = case.contact
    if model.n_body < 2 and not c.self_contact:
        return []
    names = list(c.passes)
    for name in names:
        if name not in PASSES:
            hint = difflib.get_close_matches(name, list(PASSES), n=1)
            msg = f"contact.passes: unknown pass {name!r}; known: {', '.join(PASSES)}"
            raise ValueError(msg + (f" (did you mean {hint[0]!r}?)" if hint else ""))
    if len(set(names)) != len(names):
        raise ValueError(f"contact.passes: a pass is listed twice: {names}")
    if not names:
        return []
    ctx = ContactContext(model, friction=c.friction, self_contact=c.self_contact)
    passes = [PASSES[name](ctx) for name in names]
    ctx.passes = passes
    passes[0].reports_history = True
    return passes
