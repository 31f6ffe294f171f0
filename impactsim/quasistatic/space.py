"""The finite-element spaces of one body: a scalar and a vector Lagrange basis (tet4 or tet10)
on the body's skfem mesh, and the facet data the couplings need.

Vector dof numbering (skfem's ElementVector): vector dof = 3 * scalar dof + component.
"""

from __future__ import annotations

import numpy as np
import skfem as fem


def element(order: int):
    return fem.ElementTetP1() if order == 1 else fem.ElementTetP2()


class Space:
    def __init__(self, mesh, order: int):
        self.mesh = mesh
        self.order = order
        self.elem = element(order)
        self.scalar = fem.Basis(mesh, self.elem, intorder=2 * order)
        self.vector = fem.Basis(mesh, fem.ElementVector(self.elem), intorder=2 * order)
        self.n = self.scalar.N  # scalar dofs
        self.doflocs = self.scalar.doflocs  # (3, n)

    def facet_basis(self, facets: np.ndarray, vector: bool = False, intorder: int | None = None):
        e = fem.ElementVector(self.elem) if vector else self.elem
        return fem.FacetBasis(self.mesh, e, facets=np.asarray(facets),
                              intorder=intorder or 2 * self.order)

    def facet_dofs(self, facets: np.ndarray) -> np.ndarray:
        """Scalar dofs of each facet (k, nf): 3 corners then (tet10) 3 edge midpoints, in the
        order of ``shape_values``: corners v0 v1 v2, then edges (0,1), (1,2), (0,2)."""
        facets = np.asarray(facets)
        verts = self.mesh.facets[:, facets]  # (3, nf)
        if self.order == 1:
            return verts
        # edge dofs: midpoints located by coordinates among the element's dofs
        t = self.mesh.f2t[0, facets]
        edofs = self.scalar.element_dofs[:, t]  # (10, nf)
        x = self.doflocs[:, edofs]  # (3, 10, nf)
        out = [verts[0], verts[1], verts[2]]
        for a, b in ((0, 1), (1, 2), (0, 2)):
            mid = 0.5 * (self.mesh.p[:, verts[a]] + self.mesh.p[:, verts[b]])  # (3, nf)
            d = np.linalg.norm(x - mid[:, None, :], axis=0)  # (10, nf)
            out.append(edofs[np.argmin(d, axis=0), np.arange(len(facets))])
        return np.array(out)

    def facet_geometry(self, facets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(vertex coordinates (nf, 3, 3), outward unit normals (nf, 3))."""
        facets = np.asarray(facets)
        verts = self.mesh.facets[:, facets]
        x = self.mesh.p[:, verts].transpose(2, 1, 0)  # (nf, 3 vertices, 3)
        n = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
        n /= np.linalg.norm(n, axis=1)[:, None]
        t = self.mesh.f2t[0, facets]
        inside = self.mesh.p[:, self.mesh.t[:, t]].mean(axis=1).T  # (nf, 3)
        flip = np.einsum("ij,ij->i", n, inside - x[:, 0]) > 0
        n[flip] *= -1
        return x, n


def shape_values(order: int, bary: np.ndarray) -> np.ndarray:
    """Values (n, 3 or 6) of the facet's Lagrange shape functions at barycentrics (n, 3)."""
    if order == 1:
        return bary
    l0, l1, l2 = bary.T
    return np.stack([l0 * (2 * l0 - 1), l1 * (2 * l1 - 1), l2 * (2 * l2 - 1),
                     4 * l0 * l1, 4 * l1 * l2, 4 * l0 * l2], axis=1)


def vector_dofs(scalar_dofs: np.ndarray) -> np.ndarray:
    """(..., 3) vector dofs of scalar dofs."""
    return 3 * np.asarray(scalar_dofs)[..., None] + np.arange(3)
