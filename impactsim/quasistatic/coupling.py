"""The operators of one contact interface between a kinematic body A and a force body B.

Following [G15] each interface has a kinematic side A (its contact nodes get a prescribed
normal displacement) and a force side B (it gets the contact pressure of A as a traction):

- ``C_a`` (n x 3 N_A): rows n_m . u_A(m) of A's contact nodes m (vertices, and edge midpoints on
  tet10), n_m the area-averaged outward normal of A there;
- ``I_b`` (n x 3 N_B): n_m . u_B(s_m), B's displacement at the closest point s_m of m on B;
- ``gap`` (n): the initial normal gap delta_m = (x_s - x_m) . n_m;
- ``M_a`` (n x n): A's surface mass matrix on those nodes; the nodal pressures are
  p = M_a^-1 lambda (lambda the reactions): a uniform pressure gives uniform p exactly, on tet4
  and tet10 alike (the consistent nodal forces of a uniform pressure are M_a 1 p);
- ``G_b`` (3 N_B x n): B's nodal forces of the traction -p n_B, p interpolated from A's nodal
  pressures at the closest points of B's facet quadrature points (a mortar-like transfer: a
  uniform pressure is passed exactly across non-matching meshes).
- heat: per side, ``H`` (h times its surface mass), ``L`` (its loads from the other body's
  temperature at its facet quadrature points: integral h v T_other) and the other body's ``P``
  (interpolation of its temperature at those points), so only those values travel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from impactsim.quasistatic.heat import _mass
from impactsim.quasistatic.matching import locate
from impactsim.quasistatic.space import Space, shape_values


@dataclass
class Interface:
    a: int  # kinematic body index
    b: int  # force body index
    order: int
    friction: float
    conductance: float
    nodes: np.ndarray  # A's contact scalar dofs
    normals: np.ndarray  # (n, 3)
    gap: np.ndarray  # (n,)
    matched: np.ndarray  # (n,) bool: the node faces B's patch
    C_a: sp.csr_matrix
    I_b: sp.csr_matrix
    M_a: sp.csr_matrix
    G_b: sp.csr_matrix
    tied: bool = False
    points: np.ndarray | None = None  # (n, 3) A's contact node positions
    resultant: np.ndarray | None = None  # (6, n): force and moment (about the origin) on B
    anchor: bool = False  # A is anchored on B (interfaces.setup): the coarse correction
    heat_a: tuple | None = None  # (H_a, L_a, P_b): A's exchange matrix, load from values at
    heat_b: tuple | None = None  # A's quadrature points, B's interpolation there (and conversely)
    facets_a: np.ndarray | None = None
    facets_b: np.ndarray | None = None
    tangential: object | None = None  # friction.Tangential: the rows and transfer of friction
    robin: float = 0.0  # alpha of Robin conditions on both sides (0: kinematic / force)


def faceting(space: Space, facets: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(n,): how far the smooth surface through the facets' vertices lies beyond the facet at
    the closest points of `points`, along the facet's outward normal (a Nagata-type quadratic
    patch: each edge (i, j) bends by b_i b_j (x_j - x_i) . (n_j - n_i) / 2, n the vertex
    normals averaged over these facets; its midpoint by the sagitta of a circle through both
    ends). Zero on flat patches (equal normals), positive where the surface is convex."""
    facets = np.asarray(facets)
    x, nf = space.facet_geometry(facets)
    verts = space.mesh.facets[:, facets]  # (3, nf)
    area = 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1)
    vn = np.zeros((space.mesh.p.shape[1], 3))
    for r in range(3):
        np.add.at(vn, verts[r], nf * area[:, None])
    vn /= np.maximum(np.linalg.norm(vn, axis=1), 1e-300)[:, None]
    f, bary, _ = locate(points, x)
    xv = x[f]  # (n, 3, 3)
    nv = vn[verts[:, f].T]  # (n, 3, 3)
    out = np.zeros(len(points))
    for i, j in ((0, 1), (1, 2), (0, 2)):
        k = 0.5 * np.einsum("nc,nc->n", xv[:, j] - xv[:, i], nv[:, j] - nv[:, i])
        out += bary[:, i] * bary[:, j] * k
    return out


def surface_interpolation(space: Space, facets: np.ndarray, points: np.ndarray):
    """(sparse (n_points x N) interpolation of the scalar field at the closest points of
    `points` (n, 3) on the facets, closest points (n, 3), facet normals there (n, 3))."""
    x, normals = space.facet_geometry(facets)
    f, bary, _ = locate(points, x)
    fd = space.facet_dofs(facets)[:, f]  # (k, n)
    vals = shape_values(space.order, bary)  # (n, k)
    n = len(points)
    rows = np.repeat(np.arange(n), fd.shape[0])
    P = sp.csr_matrix((vals.ravel(), (rows, fd.T.ravel())), shape=(n, space.n))
    closest = np.einsum("nk,nkc->nc", bary, x[f])
    return P, closest, normals[f]


def _vectorise(P: sp.csr_matrix, normals: np.ndarray) -> sp.csr_matrix:
    """Rows n . u (3 N columns) from scalar interpolation rows."""
    P = P.tocoo()
    rows = np.repeat(P.row, 3)
    cols = (3 * P.col[:, None] + np.arange(3)).ravel()
    vals = (P.data[:, None] * normals[P.row]).ravel()
    return sp.csr_matrix((vals, (rows, cols)), shape=(P.shape[0], 3 * P.shape[1]))


SUBDIVISION = 3  # B's facets are cut 4^SUBDIVISION times for the pressure transfer


def _sub_rule(level: int) -> tuple[np.ndarray, np.ndarray]:
    """Barycentric points (n, 3) and weights (sum 1) of the 3-point (degree 2) rule on each of
    the 4^level sub-triangles of a triangle."""
    tris = [np.eye(3)]
    for _ in range(level):
        new = []
        for t in tris:
            m01, m12, m02 = (t[0] + t[1]) / 2, (t[1] + t[2]) / 2, (t[0] + t[2]) / 2
            new += [np.array([t[0], m01, m02]), np.array([m01, t[1], m12]),
                    np.array([m02, m12, t[2]]), np.array([m01, m12, m02])]
        tris = new
    ref = np.array([[2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]])
    pts = np.concatenate([ref @ t for t in tris])
    return pts, np.full(len(pts), 1.0 / len(pts))


def transfer_matrix(sa: Space, facets_a, nodes, sb: Space, facets_b, h: float,
                    directions: np.ndarray | None = None) -> sp.csr_matrix:
    """G_b (3 N_B x n): B's nodal forces of the traction -p n_B, p interpolated from A's nodal
    pressures, points off A's patch getting no pressure (with `directions` (n, 3): of the
    traction sum_m phi_m p_m d_m instead, the vector field interpolated from A's nodal
    values: friction.py's tangential tractions). B's facets whose corners, edge
    midpoints and centroid all lie on A's patch are integrated on 4 sub-triangles, those A
    covers in part on 4^SUBDIVISION (the force of the covered part to within the sub-triangle
    size), those with none of those points on it are skipped. The rule is of degree 2 on each
    sub-triangle: a uniform pressure is passed exactly where A covers B's facets whole."""
    facets_b = np.asarray(facets_b)
    xb, nb = sb.facet_geometry(facets_b)
    probe = np.concatenate([xb, (xb + np.roll(xb, 1, axis=1)) / 2,
                            xb.mean(axis=1, keepdims=True)], axis=1).reshape(-1, 3)
    inside = _on_patch(sa, facets_a, probe, np.repeat(nb, 7, axis=0), h).reshape(-1, 7)
    full = inside.all(axis=1)
    part = inside.any(axis=1) & ~full
    G = sp.csr_matrix((3 * sb.n, len(nodes)))
    for mask, level in ((full, 1), (part, SUBDIVISION)):
        if mask.any():
            G = G + _transfer(sa, facets_a, nodes, sb, facets_b[mask], h, level, directions)
    return G.tocsr()


def _on_patch(sa: Space, facets_a, points: np.ndarray, normals: np.ndarray, h: float):
    """Whether each point lies over A's patch (the line through it along `normals` meets it)."""
    return project_along(sa, facets_a, points, normals)[2]


RAY_CANDIDATES = 16  # facets of A (nearest centroids) tried for each ray


def project_along(space: Space, facets, points: np.ndarray, directions: np.ndarray):
    """Where the lines through `points` along `directions` meet the facets: (facet index into
    `facets` (n,), barycentrics (n, 3), hit (n,) bool). B's side of a contact is projected
    along its own normal onto A's patch: on flat parallel patches this is the closest point,
    on a curved A (a sphere over a block) the closest point of A lies along A's normal and
    not over the point (off the patch beyond a few elements from the pole), the line along
    B's normal does."""
    from scipy.spatial import cKDTree

    x, _ = space.facet_geometry(np.asarray(facets))
    k = min(RAY_CANDIDATES, len(x))
    _, cand = cKDTree(x.mean(axis=1)).query(points, k=k)
    cand = cand.reshape(len(points), k)
    a, b, c = (x[cand, i] for i in range(3))  # (n, k, 3)
    d = directions[:, None, :]
    e1, e2 = b - a, c - a
    pv = np.cross(np.broadcast_to(d, e2.shape), e2)
    det = np.einsum("nkc,nkc->nk", e1, pv)
    det = np.where(np.abs(det) > 1e-300, det, 1e-300)
    tv = points[:, None, :] - a
    u = np.einsum("nkc,nkc->nk", tv, pv) / det
    qv = np.cross(tv, e1)
    v = np.einsum("nkc,nkc->nk", np.broadcast_to(d, qv.shape), qv) / det
    t = np.einsum("nkc,nkc->nk", e2, qv) / det
    eps = 1e-9
    inside = (u >= -eps) & (v >= -eps) & (u + v <= 1 + eps)
    score = np.where(inside, np.abs(t), np.inf)
    j = np.argmin(score, axis=1)
    rows = np.arange(len(points))
    hit = np.isfinite(score[rows, j])
    uu, vv = np.clip(u[rows, j], 0, 1), np.clip(v[rows, j], 0, 1)
    bary = np.stack([1 - uu - vv, uu, vv], axis=1)
    return cand[rows, j], bary, hit


def _transfer(sa: Space, facets_a, nodes, sb: Space, facets_b, h: float, level: int,
              directions: np.ndarray | None = None):
    bary, w = _sub_rule(level)
    xb, nb = sb.facet_geometry(facets_b)  # (nf, 3, 3), (nf, 3)
    area = 0.5 * np.linalg.norm(np.cross(xb[:, 1] - xb[:, 0], xb[:, 2] - xb[:, 0]), axis=1)
    xq = np.einsum("qv,fvc->fqc", bary, xb).reshape(-1, 3)
    nf, nq = len(facets_b), len(w)
    nrep = np.repeat(nb, nq, axis=0)
    # A's pressure where B's normal through the quadrature point meets A's patch
    fa, ba, inside = project_along(sa, facets_a, xq, nrep)
    fda = sa.facet_dofs(np.asarray(facets_a))[:, fa]  # (k, n)
    sv = shape_values(sa.order, ba)  # (n, k)
    Pa = sp.csr_matrix((sv.ravel(), (np.repeat(np.arange(len(xq)), fda.shape[0]),
                                     fda.T.ravel())), shape=(len(xq), sa.n))
    col = np.full(sa.n, -1)
    col[nodes] = np.arange(len(nodes))
    Pa = Pa.tocoo()
    keep = col[Pa.col] >= 0
    wq = (area[:, None] * w[None, :]).ravel() * inside  # (nf nq)
    vals = shape_values(sb.order, np.tile(bary, (nf, 1)))  # (nf nq, k)
    fd = sb.facet_dofs(facets_b)  # (k, nf)
    qa = Pa.row[keep]
    ca = col[Pa.col[keep]]
    va = Pa.data[keep]
    rows, cols, data = [], [], []
    fq = qa // nq
    for j in range(fd.shape[0]):
        for c in range(3):
            rows.append(3 * fd[j, fq] + c)
            cols.append(ca)
            d = -nb[fq, c] if directions is None else directions[ca, c]
            data.append(d * vals[qa, j] * wq[qa] * va)
    return sp.csr_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(3 * sb.n, len(nodes)))


def build(a: int, b: int, sa: Space, sb: Space, facets_a: np.ndarray, facets_b: np.ndarray,
          friction: float = 0.0, conductance: float = 0.0, tied: bool = False) -> Interface:
    # A's contact nodes and their normals
    fd = sa.facet_dofs(facets_a)  # (k, nf)
    nodes, inverse = np.unique(fd, return_inverse=True)
    inverse = inverse.reshape(fd.shape)
    xa, na = sa.facet_geometry(facets_a)
    area = 0.5 * np.linalg.norm(np.cross(xa[:, 1] - xa[:, 0], xa[:, 2] - xa[:, 0]), axis=1)
    nsum = np.zeros((len(nodes), 3))
    for r in range(fd.shape[0]):
        np.add.at(nsum, inverse[r], na * area[:, None])
    normals = nsum / np.linalg.norm(nsum, axis=1)[:, None]
    xm = sa.doflocs[:, nodes].T
    # B at the closest points
    Pb, xs, nb = surface_interpolation(sb, facets_b, xm)
    d = xs - xm
    gap = np.einsum("ij,ij->i", d, normals)
    lateral_gap = gap.copy()
    # B's curved surface, not its facets: A's nodes lie on the true surface, B's facets are
    # chords of it (on a coarse cylinder their sagitta exceeds a fuel rod's 85 um gap)
    gap = gap + faceting(sb, facets_b, xm) * np.einsum("ij,ij->i", nb, normals)
    lateral = np.linalg.norm(d - lateral_gap[:, None] * normals, axis=1)
    h = np.sqrt(area.mean())
    # a node faces B when its closest point there lies along its normal (to within the angle
    # between facets of curved, faceted surfaces) on a facet turned towards it
    matched = (lateral <= 1e-3 * h + 0.5 * np.abs(gap)) & \
        (np.einsum("ij,ij->i", nb, normals) < -0.5) & (gap > -0.5 * h)
    n = len(nodes)
    # kinematic rows of A
    Sa = sp.csr_matrix((np.ones(n), (np.arange(n), nodes)), shape=(n, sa.n))
    C_a = _vectorise(Sa, normals)
    I_b = _vectorise(Pb, normals)
    # surface mass of A on its contact nodes
    fba = sa.facet_basis(facets_a)
    M_a = _mass.assemble(fba, c=1.0).tocsr()[nodes][:, nodes]
    # force transfer to B (see transfer_matrix)
    G_b = transfer_matrix(sa, facets_a, nodes, sb, facets_b, h)
    itf = Interface(a, b, sa.order, friction, conductance, nodes, normals, gap, matched, C_a, I_b,
                    M_a, G_b, facets_a=np.asarray(facets_a), facets_b=np.asarray(facets_b),
                    tied=tied, points=xm, resultant=resultant(G_b, sb.doflocs))
    if conductance > 0:
        itf.heat_a = _exchange(sa, facets_a, sb, facets_b, conductance)
        itf.heat_b = _exchange(sb, facets_b, sa, facets_a, conductance)
    return itf


def resultant(G: sp.spmatrix, doflocs: np.ndarray) -> np.ndarray:
    """(6, n): the force and the moment about the origin of B's nodal forces G @ p."""
    G = G.tocsr()
    f = [G[k::3] for k in range(3)]  # (N_B, n) per component
    x = doflocs  # (3, N_B)
    force = np.stack([np.asarray(fk.sum(axis=0)).ravel() for k, fk in enumerate(f)])
    moment = np.stack([np.asarray((f[k].T @ x[j] - f[j].T @ x[k])).ravel()
                       for j, k in ((1, 2), (2, 0), (0, 1))])
    return np.vstack([force, moment])


def _quadrature(space: Space, facets: np.ndarray, vector: bool, intorder: int | None = None):
    fb = space.facet_basis(facets, vector=vector, intorder=intorder)
    xq = fb.global_coordinates().value  # (3, nf, nq)
    return fb, xq.reshape(3, -1).T, fb.dx.ravel()


def _facet_to_qp(fb, weights_per_dof) -> sp.csr_matrix:
    """(N x nqp) sparse: rows the basis' dofs, columns the quadrature points."""
    nf, nq = fb.dx.shape
    rows, cols, vals = [], [], []
    qp = np.arange(nf * nq).reshape(nf, nq)
    for i in range(len(fb.basis)):
        v = weights_per_dof(fb.basis[i][0].value)  # (nf, nq)
        rows.append(np.repeat(fb.element_dofs[i], nq))
        cols.append(qp.ravel())
        vals.append(v.ravel())
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(fb.N, nf * nq))


def _exchange(s1: Space, f1, s2: Space, f2, h: float):
    """(h M on s1's facets, L (N1 x nq), P2 (nq x N2)): s1's load is L @ (P2 @ T_2), the
    integral h v T_2(s(x)) dS over s1's facets."""
    fb, xq, wq = _quadrature(s1, f1, vector=False)
    P2, _, _ = surface_interpolation(s2, f2, xq)
    L = (_facet_to_qp(fb, lambda v: v) @ sp.diags(h * wq)).tocsr()
    H = _mass.assemble(fb, c=h).tocsr()
    return H, L, P2
