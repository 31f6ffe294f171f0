"""Thermoelastic equilibrium of one body: sigma = C : (eps - alpha (T - T_ref) I).

``ElasticBody`` assembles the stiffness once (scikit-fem), eliminates the prescribed
displacement components of its boundary conditions and factorises the free block once (scipy
SuperLU). Contact enters as kinematic rows ``C u = g`` (the normal displacement of contact
nodes), solved with Lagrange multipliers through the Schur complement ``S = C K^-1 C^T`` on the
same factorisation (recomputed only when the set of active rows changes), and as nodal forces.

Floating bodies: every solve adds weak springs ``eps diag(K)`` tying the body to its own
displacement of the previous iteration (a proximal step). At a converged iterate the springs
carry no force, so the answer does not depend on eps; between iterations they remove the
rigid-body modes a body held only by its contacts would otherwise have. Where the contacts leave
a mode undetermined for good (the lateral position of a pellet in a column with convex, heated
ends: the column is indifferent to sideways motion), the body's `centering_axis` ties it to its
reference position across that axis instead: a weak elastic foundation whose force is eps times
the lateral displacement (thermal radial growth: a self-balanced 1e-6 relative perturbation).
A body that its displacement conditions, the rows of its tied contacts (always closed; it is
their kinematic side) and its centering axis together hold in every rigid-body mode (a pellet
of a tied column) is not pulled to its previous iterate at all: the tied rows also enter its
matrix as a penalty rho P^T (P u - g), zero wherever the rows hold, and only the centering
springs across the axis are left (`_springs`).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla
import skfem as fem
from skfem.helpers import ddot, sym_grad, trace, eye, dot

from impactsim.quasistatic.model import BodyModel
from impactsim.quasistatic.space import Space


def _stiffness(lam: float, mu: float):
    @fem.BilinearForm
    def form(u, v, w):
        e = sym_grad(u)
        return ddot(2.0 * mu * e + eye(lam * trace(e), 3), sym_grad(v))
    return form


@fem.LinearForm
def _thermal(v, w):
    # sigma_T : eps(v) with sigma_T = (3 lam + 2 mu) alpha dT I
    return w.beta * w.dT * trace(sym_grad(v))


@fem.LinearForm
def _traction(v, w):
    return dot(w.t, v)


@fem.LinearForm
def _pressure(v, w):
    return -w.p * dot(w.n, v)


def rigid_modes(doflocs: np.ndarray, centred: bool = True) -> np.ndarray:
    """(3 N, 6): the rigid-body modes of the vector dofs (interleaved x y z per node), the
    rotations about the points' mean (or, `centred=False`, about the origin)."""
    x = doflocs.T - (doflocs.mean(axis=1) if centred else 0.0)
    n = len(x)
    B = np.zeros((n, 3, 6))
    for k in range(3):
        B[:, k, k] = 1.0
    # theta x r: rotation about x moves (0, -z, y), about y (z, 0, -x), about z (-y, x, 0)
    B[:, 1, 3], B[:, 2, 3] = -x[:, 2], x[:, 1]
    B[:, 0, 4], B[:, 2, 4] = x[:, 2], -x[:, 0]
    B[:, 0, 5], B[:, 1, 5] = -x[:, 1], x[:, 0]
    return B.reshape(3 * n, 6)


class AMGSolver:
    """For bodies too large to factorise: smoothed-aggregation algebraic multigrid (pyamg)
    with the rigid-body modes as near-null space, as the preconditioner of conjugate
    gradients, set up once; `solve` has the interface of SuperLU's (relative residual
    `tolerance`)."""

    def __init__(self, A: sp.csr_matrix, modes: np.ndarray, tolerance: float = 1e-10):
        import pyamg

        self.A = A
        self.ml = pyamg.smoothed_aggregation_solver(A, B=modes, symmetry="symmetric",
                                                    max_coarse=500)
        self.tolerance = tolerance

    def solve(self, b: np.ndarray) -> np.ndarray:
        if not np.any(b):
            return np.zeros_like(b)
        return self.ml.solve(b, tol=self.tolerance, accel="cg", maxiter=1000)


class ElasticBody:
    def __init__(self, model: BodyModel, space: Space, regularization: float = 1e-6,
                 solver: str = "direct", tied_rows: sp.spmatrix | None = None):
        self.model = model
        self.space = space
        mat = model.material
        self.lam, self.mu = mat.lame
        vb = space.vector
        self.K = _stiffness(self.lam, self.mu).assemble(vb).tocsr()
        self.ndof = vb.N
        # prescribed components
        fixed: dict[int, float] = {}
        self._displacement_conditions = []
        for c in model.conditions:
            if c.kind != "displacement":
                continue
            dofs = space.scalar.get_dofs(c.facets).all() if len(c.facets) else np.array([], int)
            for k, val in enumerate(c.vector):
                if val is not None:
                    self._displacement_conditions.append((3 * dofs + k, val, c.ramp))
        for dofs, val, _ in self._displacement_conditions:
            for d in dofs:
                fixed[int(d)] = val
        self.D = np.array(sorted(fixed), dtype=np.int64)
        mask = np.ones(self.ndof, bool)
        mask[self.D] = False
        self.F = np.nonzero(mask)[0]
        Kff = self.K[self.F][:, self.F].tocsc()
        self.springs, self.proximal = self._springs(regularization, Kff.diagonal(), tied_rows)
        A = Kff + self.springs
        if self.tied_rows is not None:
            # the tied rows as a penalty too: rho P^T (P u - g) is zero wherever the rows hold,
            # so the constrained solution is the same for any rho, and the matrix is regular
            # without the springs along the modes they fix
            self._rho = float(Kff.diagonal().mean())
            A = A + self._rho * (self._PF.T @ self._PF)
        if solver == "amg":
            self.lu = AMGSolver(A.tocsr(), rigid_modes(space.doflocs)[self.F])
        else:
            self.lu = sla.splu(A.tocsc())
        self.KfD = self.K[self.F][:, self.D]
        self._schur_key = None
        self.u_prev = np.zeros(self.ndof)
        self._base = self.lu  # the factorisation without Robin springs
        self._base_matrix = A
        self._robin_key = b""
        self._KrFD = None

    def _springs(self, eps: float, diagonal: np.ndarray, tied_rows) -> tuple:
        """(the weak springs on the free dofs, whether they pull to the previous iterate).

        None (zero) on a body its displacement conditions hold: they would only slow its soft
        modes down (a thin tube held at one end bends as a cantilever whose stiffness is a
        thousandth of the springs': 0.998 per iteration, measured). Where the conditions, the
        rows of tied contacts on which it is the kinematic side (always closed: `tied_rows`)
        and a centering axis together fix every rigid-body mode, only the centering springs
        across the axis (to the reference position): no proximal pull to the previous iterate
        is left, whose anchor is state the accelerated iteration does not see (100 pellets:
        563 Schwarz iterations with the proximal pull along the axis, 311 without; the 350
        bodies converge). Otherwise the proximal springs eps diag(K) to the previous iterate
        (across a centering axis, to the reference position)."""
        F, n = self.F, len(self.F)
        modes = rigid_modes(self.space.doflocs)
        tol = 1e-9 * np.ptp(self.space.doflocs)
        held = len(self.D) and np.linalg.matrix_rank(modes[self.D], tol=tol) == 6
        self.tied_rows = None
        if held:
            return sp.csr_matrix((n, n)), False
        k = eps * diagonal
        axis = self.model.centering_axis
        if axis is not None:
            a = np.asarray(axis, float) / np.linalg.norm(axis)
            # per node D^1/2 (I - a a^T) D^1/2 over its free dofs (dofs interleaved x y z)
            full = np.zeros(self.ndof)
            full[F] = k
            r = np.sqrt(full).reshape(-1, 3)
            blocks = r[:, :, None] * (np.eye(3) - np.outer(a, a))[None] * r[:, None, :]
            node = np.arange(self.ndof).reshape(-1, 3)
            S = sp.csr_matrix((blocks.ravel(), (np.repeat(node, 3, axis=1).ravel(),
                                                np.tile(node, (1, 3)).ravel())),
                              shape=(self.ndof, self.ndof))[F][:, F]
            P = sp.csr_matrix((0, self.ndof)) if tied_rows is None else tied_rows.tocsr()
            fixing = np.vstack([modes[self.D], P @ modes, S @ modes[F]])
            if np.linalg.matrix_rank(fixing, tol=tol * max(np.abs(fixing).max(), 1e-300)) == 6:
                if P.shape[0]:
                    self.tied_rows = P
                    self._PF, self._PD = P[:, F], P[:, self.D]
                S.eliminate_zeros()
                return S, False
        return sp.diags(k).tocsr(), True

    def spring_rhs(self, u_prev: np.ndarray | None = None) -> np.ndarray | float:
        """The weak springs' pull on the free dofs: springs x their anchor (_anchor), or 0."""
        if not self.proximal:
            return 0.0
        return self.springs @ self._anchor(u_prev)[self.F]

    def set_robin(self, key: bytes, Kr: sp.spmatrix | None) -> None:
        """Robin (mixed) contact conditions add the springs alpha F_c R of their active nodes
        to the stiffness (schwarz.py): refactorise when their set changes (`key`), back to
        the plain factorisation when there are none. The Lagrange rows' Schur complement is
        built on whichever factorisation is current."""
        if key == self._robin_key:
            return
        self._robin_key = key
        self._schur_key = None
        if Kr is None or Kr.nnz == 0:
            self.lu = self._base
            self._KrFD = None
            return
        Kr = Kr.tocsr()[self.F]
        self._KrFD = Kr[:, self.D]
        self.lu = sla.splu((self._base_matrix + Kr[:, self.F]).tocsc())

    def prescribed(self, scale: float) -> np.ndarray:
        uD = np.zeros(self.ndof)
        for dofs, val, ramp in self._displacement_conditions:
            uD[dofs] = val * (scale if ramp else 1.0)
        return uD[self.D]

    def load(self, temperature: np.ndarray | None, scale: float) -> np.ndarray:
        """External load vector: tractions, pressures and the thermal strain."""
        vb = self.space.vector
        f = np.zeros(self.ndof)
        mat = self.model.material
        if temperature is not None and mat.expansion:
            dT = self.space.scalar.interpolate(temperature - mat.reference_temperature)
            f += _thermal.assemble(vb, dT=dT, beta=(3 * self.lam + 2 * self.mu) * mat.expansion)
        for c in self.model.conditions:
            s = scale if c.ramp else 1.0
            if c.kind == "traction" and len(c.facets):
                fb = self.space.facet_basis(c.facets, vector=True)
                t = np.array([0.0 if v is None else v for v in c.vector])[:, None, None]
                f += _traction.assemble(fb, t=s * t * np.ones((3,) + fb.dx.shape))
            elif c.kind == "pressure" and len(c.facets):
                fb = self.space.facet_basis(c.facets, vector=True)
                f += _pressure.assemble(fb, p=s * c.value)
        return f

    def solve(self, f: np.ndarray, uD: np.ndarray, C: sp.csr_matrix | None = None,
              g: np.ndarray | None = None, active: np.ndarray | None = None,
              tied_g: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Displacement u and the multipliers (contact reactions along the rows of C, > 0
        compressive) of K u = f - C_a^T lam, C_a u = g_a on the active rows; `tied_g` the
        values of the tied rows (`tied_rows`, which are rows of C too)."""
        rhs = f[self.F] - self.KfD @ uD + self.spring_rhs()
        if self._KrFD is not None:
            rhs = rhs - self._KrFD @ uD
        if self.tied_rows is not None:
            rhs = rhs + self._rho * (self._PF.T @ (tied_g - self._PD @ uD))
        u0 = self.lu.solve(rhs)
        lam = np.zeros(0 if C is None else C.shape[0])
        uf = u0
        if C is not None and active is not None and active.any():
            idx = np.nonzero(active)[0]
            key = idx.tobytes()
            if key != self._schur_key:
                Ca = C[idx]
                Cf = Ca[:, self.F].toarray()
                self._CD = Ca[:, self.D]
                # one column at a time: SuperLU's many-right-hand-side solve is slower
                W = np.empty((len(self.F), len(idx)))
                for j in range(len(idx)):
                    W[:, j] = self.lu.solve(np.ascontiguousarray(Cf[j]))
                S = Cf @ W
                self._W, self._Cf = W, Cf
                # a tiny shift keeps S definite when two rows constrain the same node alike
                # (a node on the edge between two patches): they then share the force
                S = 0.5 * (S + S.T)
                S[np.diag_indices_from(S)] += 1e-10 * np.abs(np.diag(S)).mean()
                self._S = np.linalg.cholesky(S)
                self._schur_key = key
            r = self._Cf @ u0 + self._CD @ uD - g[idx]
            la = np.linalg.solve(self._S.T, np.linalg.solve(self._S, r))
            uf = u0 - self._W @ la
            lam[idx] = la
        u = np.zeros(self.ndof)
        u[self.F] = uf
        u[self.D] = uD
        self.u_prev = u
        return u, lam

    def _anchor(self, u_prev: np.ndarray | None = None) -> np.ndarray:
        """Where the weak springs pull: the previous iterate, or (with a centering axis) its
        component along the axis only: across it, the reference position."""
        u_prev = self.u_prev if u_prev is None else u_prev
        a = self.model.centering_axis
        if a is None:
            return u_prev
        a = np.asarray(a, float) / np.linalg.norm(a)
        u = u_prev.reshape(-1, 3)
        return ((u @ a)[:, None] * a[None, :]).ravel()

    # --- post-processing ---
    def stress_at_vertices(self, u: np.ndarray, temperature: np.ndarray | None) -> np.ndarray:
        """Cauchy stress (6 components xx yy zz yz xz xy) averaged at the mesh vertices."""
        vb = self.space.vector
        mesh = self.space.mesh
        # stress per element at its centroid-like quadrature average
        uh = vb.interpolate(u)
        e = sym_grad(uh)
        tr = trace(e)
        iso = self.lam * tr
        if temperature is not None and self.model.material.expansion:
            mat = self.model.material
            dT = self.space.scalar.interpolate(temperature - mat.reference_temperature)
            iso = iso - (3 * self.lam + 2 * self.mu) * mat.expansion * np.asarray(dT)
        s = 2 * self.mu * e + eye(iso, 3)
        s = np.asarray(s)  # (3, 3, ne, nq)
        w = vb.dx
        se = (s * w).sum(axis=-1) / w.sum(axis=-1)  # (3, 3, ne)
        comps = np.stack([se[0, 0], se[1, 1], se[2, 2], se[1, 2], se[0, 2], se[0, 1]])
        vol = w.sum(axis=-1)
        acc = np.zeros((6, mesh.p.shape[1]))
        wsum = np.zeros(mesh.p.shape[1])
        for i in range(4):
            np.add.at(acc.T, mesh.t[i], (comps * vol).T)
            np.add.at(wsum, mesh.t[i], vol)
        return acc / wsum
