"""Contact passes bound to the model (ALGORITHMS.md 1 step 3 and section 3).

``make_contact_passes(case, model)`` returns one velocity-stage pass per name in
``case.contact.passes``, in that order ("node-face" -> ``contact.node-face``, "edge-edge" ->
``contact.edge-edge``), or [] when the scene has fewer than two bodies and no self-contact.
Each pass sees model.x = x^n and model.v = U* and corrects model.v in place, pair after pair in
sorted order (Gauss-Seidel); positions move only after all passes of the step.

The passes share a ``ContactContext``: one ``Surface`` (kept in step with erosion through
``model.status``), the hash buffers, the per-step statistics and the penetration meter. The first
pass of the list reports the history columns of all contact passes:
``max_penetration`` [m] (measured independently, ``diagnostics``), ``contact_pairs`` (pairs
corrected in the step, all passes) and ``contact_impulse`` [N s] (sum of the normal impulses of
the step, all passes).
"""

from __future__ import annotations

import abc
import difflib

import numpy as np

from impactsim.contact.broadphase import SpatialHash, grid_for, swept_boxes
from impactsim.contact.diagnostics import PenetrationMeter
from impactsim.contact.edgeedge import edge_edge_sweep, edge_normals
from impactsim.contact.nodeface import node_face_sweep
from impactsim.contact.surface import Surface
from impactsim.solver.passes import Pass

BAND = 1e-3  # touching band, a fraction of the mean surface edge length (nodeface, edgeedge)
EPS_BARY = 1e-6  # tolerance of the inside-the-triangle test at the crossing
PAD = 2.0  # box padding, in bands: boxes reach the nodes that start inside the band


class ContactContext:
    """What the contact passes of one run share (see the module docstring).

    ``max_sweeps``: Gauss-Seidel sweeps per pass and step. One sweep is the algorithm of [D19];
    further sweeps (with a fresh broad phase on the corrected velocities) run only while the
    previous sweep corrected something, for pairs that a later correction pushed into contact.
    """

    def __init__(self, model, friction: float = 0.0, self_contact: bool = False,
                 band: float = BAND, eps_bary: float = EPS_BARY, max_sweeps: int = 1):
        self.surface = Surface.from_model(model)
        self._conn_shape = model.conn.shape
        self.friction = float(friction)
        self.self_contact = bool(self_contact)
        self.band_rel = float(band)
        self.eps_bary = float(eps_bary)
        self.max_sweeps = max(int(max_sweeps), 1)
        self.meter = PenetrationMeter()
        self.last = {}  # pass name -> {"pairs", "impulse", "candidates"} of its last run
        self._h_key = None
        self._h = 0.0
        self._buf = {}

    def prepare(self, model) -> float:
        """Follow erosion (status) and return the current mean surface edge length h [m]."""
        if model.conn.shape != self._conn_shape:
            self.surface = Surface.from_model(model)
            self._conn_shape = model.conn.shape
        changed = self.surface.sync(model.status)
        key = (model.step, self.surface.version)
        if changed or key != self._h_key:
            self._h = self.surface.mean_edge_length(model.x)
            self._h_key = key
        return self._h

    def buffer(self, name: str, rows: int) -> np.ndarray:
        """A reusable (rows, 3) float64 scratch array."""
        b = self._buf.get(name)
        if b is None or b.shape[0] != rows:
            b = np.empty((rows, 3))
            self._buf[name] = b
        return b

    def boxes(self, name, x, v, tau, ent, pad):
        lo = self.buffer(name + ".lo", ent.shape[0])
        hi = self.buffer(name + ".hi", ent.shape[0])
        swept_boxes(x, v, tau, ent, pad, lo, hi)
        return lo, hi


class ContactPass(Pass):
    stage = "velocity"
    key = ""

    def __init__(self, ctx: ContactContext):
        self.ctx = ctx
        self.hash = SpatialHash()
        self.reports_history = False
        self.totals = {"pairs": 0, "impulse": 0.0, "candidates": 0, "sweeps": 0,
                       "steps_in_contact": 0}
        self.max_penetration_seen = 0.0

    def run(self, model, dt: float) -> None:
        h = self.ctx.prepare(model)
        pairs_total = 0
        impulse_total = 0.0
        candidates = 0
        for sweep in range(self.ctx.max_sweeps):
            n_cand, applied, impulse = self._sweep(model, dt, h)
            candidates += n_cand
            pairs_total += applied
            impulse_total += impulse
            self.totals["sweeps"] += 1
            if applied == 0:
                break
        self.ctx.last[self.name] = {"pairs": pairs_total, "impulse": impulse_total,
                                    "candidates": candidates}
        self.totals["pairs"] += pairs_total
        self.totals["impulse"] += impulse_total
        self.totals["candidates"] += candidates
        self.totals["steps_in_contact"] += int(pairs_total > 0)

    @abc.abstractmethod
    def _sweep(self, model, dt, h):
        """One broad phase and one Gauss-Seidel sweep: (candidates, pairs corrected, impulse)."""

    def history(self, model) -> dict[str, float]:
        if not self.reports_history:
            return {}
        ctx = self.ctx
        ctx.surface.sync(model.status)
        pen = ctx.meter.measure(model.x, model.conn, model.elem_body, model.status,
                                ctx.surface)["max_penetration"]
        self.max_penetration_seen = max(self.max_penetration_seen, pen)
        return {"max_penetration": pen,
                "contact_pairs": float(sum(s["pairs"] for s in ctx.last.values())),
                "contact_impulse": float(sum(s["impulse"] for s in ctx.last.values()))}

    def summary(self, model) -> dict:
        out = {"candidate_pairs": int(self.totals["candidates"]),
               "corrections": int(self.totals["pairs"]),
               "impulse": float(self.totals["impulse"]),
               "sweeps": int(self.totals["sweeps"]),
               "steps_in_contact": int(self.totals["steps_in_contact"]),
               "hash_grows": int(self.hash.grows)}
        if self.reports_history:
            out["max_penetration_seen"] = float(self.max_penetration_seen)
            out["surface"] = {"faces": self.ctx.surface.n_faces,
                              "edges": self.ctx.surface.n_edges,
                              "nodes": self.ctx.surface.n_nodes}
        return {self.name: out}


class NodeFacePass(ContactPass):
    """Symmetric node-face pass (ALGORITHMS.md 3.1): every boundary node against the boundary
    faces of the other bodies (and of its own body, minus the faces it belongs to, with
    self-contact)."""

    name = "contact.node-face"
    key = "node-face"

    def _sweep(self, model, dt, h):
        ctx = self.ctx
        s = ctx.surface
        if s.n_faces == 0:
            return 0, 0, 0.0
        x, v = model.x, model.v
        band = ctx.band_rel * h
        nodes2 = s.nodes.reshape(-1, 1)
        nlo, nhi = ctx.boxes("nf.node", x, v, dt, nodes2, PAD * band)
        flo, fhi = ctx.boxes("nf.face", x, v, dt, s.faces, PAD * band)
        origin, cell = grid_for([(nlo, nhi), (flo, fhi)], h)
        self.hash.build(flo, fhi, origin, cell)
        pairs = self.hash.query(nlo, nhi, nodes2, s.node_body, s.faces, s.face_body, False,
                                ctx.self_contact)
        applied, impulse = node_face_sweep(pairs, s.nodes, s.faces, x, v, model.mass, dt,
                                           ctx.friction, band, ctx.eps_bary)
        return pairs.shape[0], int(applied), float(impulse)


class EdgeEdgePass(ContactPass):
    """Edge-edge pass of [D19] (ALGORITHMS.md 3.2): every pair of boundary edges of different
    bodies (or of one body without a shared node, with self-contact)."""

    name = "contact.edge-edge"
    key = "edge-edge"

    def _sweep(self, model, dt, h):
        ctx = self.ctx
        s = ctx.surface
        if s.n_edges == 0:
            return 0, 0, 0.0
        x, v = model.x, model.v
        band = ctx.band_rel * h
        elo, ehi = ctx.boxes("ee.edge", x, v, dt, s.edges, PAD * band)
        origin, cell = grid_for([(elo, ehi)], h)
        self.hash.build(elo, ehi, origin, cell)
        pairs = self.hash.query(elo, ehi, s.edges, s.edge_body, s.edges, s.edge_body, True,
                                ctx.self_contact)
        if pairs.shape[0] == 0:
            return 0, 0, 0.0
        normals = ctx.buffer("ee.normals", s.n_edges)
        edge_normals(x, s.faces, s.face_edges, normals)
        applied, impulse = edge_edge_sweep(pairs, s.edges, normals, x, v, model.mass, dt,
                                           ctx.friction, band)
        return pairs.shape[0], int(applied), float(impulse)


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
    passes[0].reports_history = True
    return passes
