"""One body as a worker holds it between Schwarz iterations: its spaces, its heat and elastic
solvers (factorised once) and its sides of the contact interfaces.

``BodyGroup`` holds several bodies and answers one call per iteration for all of them (a Dask
actor wraps one group per worker, see ``pool``). Inputs and outputs are small: per interface,
values at contact nodes or quadrature points, never whole fields.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.linalg

from impactsim.quasistatic.elastic import ElasticBody
from impactsim.quasistatic.heat import HeatBody
from impactsim.quasistatic.model import BodyModel
from impactsim.quasistatic.space import Space


@dataclass
class BodySpec:
    """What a worker needs to build a body: its model and its sides of the interfaces."""

    index: int
    model: BodyModel
    regularization: float
    kin: list = field(default_factory=list)  # (interface id, C_a, M_a)
    force: list = field(default_factory=list)  # (interface id, I_b, G_b)
    heat: list = field(default_factory=list)  # (link id, H, L, P_other_for_neighbour)
    heat_send: list = field(default_factory=list)  # (link id, P): values the neighbour needs
    thermal: bool = False  # solve heat (else the temperature stays the initial one)
    solver: str = "direct"  # the elastic solver: direct or amg (interfaces.setup decides)
    # interfaces with friction: their C, I rows are [normal; t_1; t_2] and G's columns
    # [p, q_1, q_2] (friction.py)
    friction: set = field(default_factory=set)
    # interfaces with Robin conditions (schwarz.py): (interface id, side "a" or "b", rows R
    # (n x 3 N), force columns F (3 N x n), surface mass M (side a) or None, alpha)
    robin: list = field(default_factory=list)
    # tied contacts on which it is the kinematic side: (interface id, indices of their
    # matched rows, always active); ElasticBody holds the body by them instead of by springs
    tied: list = field(default_factory=list)


class BodyState:
    def __init__(self, spec: BodySpec):
        t0, c0 = time.perf_counter(), time.thread_time()
        self.spec = spec
        self.space = Space(spec.model.mesh(), spec.model.order)
        robin = None
        for _, H, _ in spec.heat:
            robin = H if robin is None else robin + H
        self.heat = HeatBody(spec.model, self.space, robin)
        kin = {k: C for k, C, _ in spec.kin}
        tied = sp.vstack([kin[k][rows] for k, rows in spec.tied]) if spec.tied else None
        self.elastic = ElasticBody(spec.model, self.space, spec.regularization,
                                   solver=spec.solver, tied_rows=tied)
        self.C = sp.vstack([c for _, c, _ in spec.kin]).tocsr() if spec.kin else None
        self.rows = np.cumsum([0] + [c.shape[0] for _, c, _ in spec.kin])
        self.f = np.zeros(self.elastic.ndof)
        self.uD = self.elastic.prescribed(1.0)
        self.u = np.zeros(self.elastic.ndof)
        self._mass_lu: dict = {}  # interface: (active set, Cholesky factor of M_aa)
        self._robin_cache: dict = {}  # (interface, side): (active set, F_c, R_a)
        # wall seconds per part, and "cpu": this thread's CPU seconds in all three (on a loaded
        # machine the wall figures count the waits for a core)
        self.seconds = {"factorization": time.perf_counter() - t0, "heat": 0.0, "solves": 0.0,
                        "cpu": time.thread_time() - c0}

    # --- heat ---
    def heat_begin(self, dt: float | None) -> dict:
        self.heat.begin_step(dt)
        return self.heat_send()

    def heat_send(self) -> dict:
        return {k: P @ self.heat.T for k, P in self.spec.heat_send}

    def heat_solve(self, received: dict, tolerance: float, max_picard: int) -> dict:
        t0, c0 = time.perf_counter(), time.thread_time()
        f = np.zeros(self.space.n)
        for k, _, L in self.spec.heat:
            if k in received:
                f += L @ received[k]
        change = 0.0
        if self.spec.thermal:
            self.heat.solve(f, tolerance, max_picard)
            change = self.heat.change
        self.seconds["heat"] += time.perf_counter() - t0
        self.seconds["cpu"] += time.thread_time() - c0
        return self.heat_send(), change

    # --- mechanics ---
    def mech_begin(self, scale: float) -> None:
        self.f = self.elastic.load(self.heat.T, scale)
        self.uD = self.elastic.prescribed(scale)

    def _robin(self, robin: dict, f: np.ndarray) -> list:
        """Robin conditions p = p0 + alpha (R u - t) on the active nodes of this body's Robin
        sides (t the other side's position, p0 its pressure, of the last iteration): the
        springs alpha F_c R go into the matrix (refactorised when the active sets change),
        -F_c (p0 - alpha t) into f. Returns (key, side, idx, R, p0, t, alpha) per side."""
        terms, key, springs = [], [], []
        for k, side, R, F, M, alpha in self.spec.robin:
            t, act, p0 = robin[(side, k)]
            idx = np.nonzero(act)[0]
            kk = idx.tobytes()
            key.append(kk + b"|")
            terms.append((k, side, idx, R, p0, t, alpha))
            if not len(idx):
                continue
            # F_c (and its springs) per active set: slicing them at every call was a quarter
            # of a pellet's solve (2.6 of 10.3 s, 145 iterations of the 50-pellet stack)
            cached = self._robin_cache.get((k, side))
            if cached is None or cached[0] != kk:
                Fc = F[:, idx] if M is None else F[:, idx] @ M[idx][:, idx]
                cached = (kk, Fc, R[idx])
                self._robin_cache[(k, side)] = cached
            _, Fc, Ra = cached
            f -= Fc @ (p0[idx] - alpha * t[idx])
            springs.append((alpha, Fc, Ra))
        key = b"".join(key)
        if key != self.elastic._robin_key:  # the springs only when the active sets change
            Kr = None
            for alpha, Fc, Ra in springs:
                Kr = alpha * (Fc @ Ra) if Kr is None else Kr + alpha * (Fc @ Ra)
            self.elastic.set_robin(key, Kr)
        return terms

    def mech_solve(self, g: dict, active: dict, pressure: dict, slip: dict | None = None,
                   robin: dict | None = None) -> dict:
        """One solve with the interface values of this iteration; the result also holds
        "move", how far the body moved from the previous iterate its weak springs pull it to
        (zero at a fixed point: the Schwarz iteration's motion residual)."""
        t0, c0 = time.perf_counter(), time.thread_time()
        before = self.elastic.u_prev
        f = self.f.copy()
        terms = self._robin(robin or {}, f) if self.spec.robin else []
        for k, _, G in self.spec.force:
            if k in pressure:
                f += G @ pressure[k]
        for k, C, M in self.spec.kin:
            if slip and k in slip:  # friction of slipping nodes: -C_t^T M q (active rows)
                n = M.shape[0]
                act = active[k][:n]
                q = slip[k]
                f -= C[n:].T @ np.concatenate([act * (M @ q[:n]), act * (M @ q[n:])])
        if self.C is not None:
            gg = np.concatenate([g[k] for k, _, _ in self.spec.kin])
            aa = np.concatenate([active[k] for k, _, _ in self.spec.kin])
        else:
            gg = aa = None
        tied_g = None
        if self.elastic.tied_rows is not None:
            tied_g = np.concatenate([g[k][rows] for k, rows in self.spec.tied])
        u, lam = self.elastic.solve(f, self.uD, self.C, gg, aa, tied_g)
        self.u = u
        # how far the body moved from where its springs pulled it: at a fixed point, zero
        out = {"move": float(np.max(np.abs(u - before), initial=0.0))}
        for i, (k, C, M) in enumerate(self.spec.kin):
            r = lam[self.rows[i]:self.rows[i + 1]]
            n = M.shape[0]
            Cu, a = C @ u, active[k]
            out[("a", k)] = (Cu[:n], self._pressures(k, M, r[:n], a[:n]))
            if k in self.spec.friction:  # tangential displacements, stick tractions
                out[("at", k)] = (Cu[n:], np.concatenate(
                    [self._pressures((k, j), M, r[j * n:(j + 1) * n], a[j * n:(j + 1) * n])
                     for j in (1, 2)]))
        for k, side, idx, R, p0, t, alpha in terms:
            Ru = R @ u
            p = np.zeros(len(Ru))
            p[idx] = p0[idx] + alpha * (Ru[idx] - t[idx])
            # side a: (C_a u, p_A); side b: (I_b u, p_B), R = -I_b there
            out[("r" + side, k)] = (Ru if side == "a" else -Ru, p)
        for k, I, _ in self.spec.force:
            Iu = I @ u
            if k in self.spec.friction:
                n = len(Iu) // 3
                out[("b", k)], out[("bt", k)] = Iu[:n], Iu[n:]
            else:
                out[("b", k)] = Iu
        self.seconds["solves"] += time.perf_counter() - t0
        self.seconds["cpu"] += time.thread_time() - c0
        return out

    def _pressures(self, k, M: sp.csr_matrix, reactions: np.ndarray,
                   active: np.ndarray) -> np.ndarray:
        """Nodal pressures p of the active nodes from their reactions: M_aa p_a = lambda_a
        (the surface mass restricted to the active nodes; zero elsewhere). M_aa is factorised
        once per interface and active set (slicing and factorising it at every call was half
        of a pellet's solve: 13 of 26 s over 100 iterations of the 50-pellet stack)."""
        p = np.zeros(len(reactions))
        idx = np.nonzero(active)[0]
        if not len(idx):
            return p
        key = idx.tobytes()
        cached = self._mass_lu.get(k)
        if cached is None or cached[0] != key:
            Maa = M[idx][:, idx].toarray()
            cached = (key, scipy.linalg.cho_factor(Maa))
            self._mass_lu[k] = cached
        p[idx] = scipy.linalg.cho_solve(cached[1], reactions[idx])
        return p

    def fields(self) -> dict:
        T = self.heat.T
        return {"u": self.u, "T": T, "stress": self.elastic.stress_at_vertices(self.u, T),
                "seconds": dict(self.seconds)}


class BodyGroup:
    """Several bodies; every method takes and returns dicts keyed by body index."""

    def __init__(self, specs: list[BodySpec]):
        self.bodies = {s.index: BodyState(s) for s in specs}

    def heat_begin(self, dt):
        return {i: b.heat_begin(dt) for i, b in self.bodies.items()}

    def heat_solve(self, received: dict, tolerance: float, max_picard: int):
        return {i: b.heat_solve(received.get(i, {}), tolerance, max_picard)
                for i, b in self.bodies.items()}

    def mech_begin(self, scale: float):
        for b in self.bodies.values():
            b.mech_begin(scale)
        return {}

    def mech_solve(self, inputs: dict):
        return {i: b.mech_solve(*inputs.get(i, ({}, {}, {}))) for i, b in self.bodies.items()}

    def fields(self):
        return {i: b.fields() for i, b in self.bodies.items()}
