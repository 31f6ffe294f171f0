"""Heat conduction in one body: c rho dT/dt = div(k(T) grad T) + Phi, backward Euler in time,
Picard iteration (k evaluated at the last iterate) when k depends on T.

Boundary conditions on facet sets: prescribed temperature (eliminated), flux into the body,
exchange alpha (T - T_env) with a fixed ambient, and the contact exchange h (T - T_other) whose
T_other comes from the neighbouring body (``coupling``): its matrix part is fixed, its load
changes from one Schwarz iteration to the next. With a constant k the matrix is factorised once
per time step size.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla
import skfem as fem
from skfem.helpers import dot, grad

from impactsim.quasistatic.model import BodyModel
from impactsim.quasistatic.space import Space


@fem.BilinearForm
def _laplace(u, v, w):
    return w.k * dot(grad(u), grad(v))


@fem.BilinearForm
def _mass(u, v, w):
    return w.c * u * v


@fem.LinearForm
def _load(v, w):
    return w.q * v


class HeatBody:
    def __init__(self, model: BodyModel, space: Space, robin: sp.spmatrix | None = None):
        """`robin`: the contact exchange matrix (sum of h u v over contact facets)."""
        self.model = model
        self.space = space
        sb = space.scalar
        mat = model.material
        self.M = _mass.assemble(sb, c=mat.density * mat.heat_capacity).tocsr()
        self.R = sp.csr_matrix((sb.N, sb.N)) if robin is None else robin.tocsr()
        self.f0 = np.zeros(sb.N)
        self.fixed: dict[int, float] = {}
        for c in model.conditions:
            if c.kind == "source":
                self.f0 += _load.assemble(sb, q=c.value)
            elif c.kind == "flux" and len(c.facets):
                self.f0 += _load.assemble(space.facet_basis(c.facets), q=c.value)
            elif c.kind == "exchange" and len(c.facets):
                fb = space.facet_basis(c.facets)
                self.R = self.R + _mass.assemble(fb, c=c.value)
                self.f0 += _load.assemble(fb, q=c.value * c.ambient)
            elif c.kind == "temperature" and len(c.facets):
                for d in sb.get_dofs(c.facets).all():
                    self.fixed[int(d)] = c.value
        self.D = np.array(sorted(self.fixed), dtype=np.int64)
        self.TD = np.array([self.fixed[d] for d in self.D])
        mask = np.ones(sb.N, bool)
        mask[self.D] = False
        self.F = np.nonzero(mask)[0]
        self.constant_k = mat.conductivity_table is None
        self._lu_key = None
        self.T = np.full(sb.N, model.initial_temperature)
        self.T[self.D] = self.TD
        self.T_old = self.T.copy()

    def _matrix(self, T: np.ndarray, dt: float | None):
        sb = self.space.scalar
        k = sb.interpolate(T)
        kq = self.model.material.k_of(np.asarray(k)) if not self.constant_k \
            else self.model.material.conductivity
        A = _laplace.assemble(sb, k=kq) + self.R
        if dt is not None:
            A = A + self.M / dt
        return A.tocsr()

    def begin_step(self, dt: float | None) -> None:
        """Start a time step of size dt (None: steady state) from the current temperature."""
        self.T_old = self.T.copy()
        self.dt = dt

    def solve(self, f_contact: np.ndarray, tolerance: float = 1e-8, max_picard: int = 30
              ) -> np.ndarray:
        """Temperature at the end of the step with the given contact load (h T_other terms)."""
        f = self.f0 + f_contact
        if self.dt is not None:
            f = f + self.M @ self.T_old / self.dt
        T = self.T.copy()
        for _ in range(max_picard if not self.constant_k else 1):
            key = (self.dt,) if self.constant_k else None
            if key is None or key != self._lu_key:
                A = self._matrix(T, self.dt)
                self._AfD = A[self.F][:, self.D]
                self._lu = sla.splu(A[self.F][:, self.F].tocsc())
                self._lu_key = key
            Tn = T.copy()
            Tn[self.F] = self._lu.solve(f[self.F] - self._AfD @ self.TD)
            Tn[self.D] = self.TD
            change = np.max(np.abs(Tn - T)) / max(np.max(np.abs(Tn)), 1e-30)
            T = Tn
            if self.constant_k or change < tolerance:
                break
        self.change = change
        self.T = T
        return T
