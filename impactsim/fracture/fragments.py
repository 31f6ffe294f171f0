"""Fragments and the debris cloud (issue 12, item 4): connected pieces of the mesh plus particles.

A fragment is a connected set of live elements (tets and hexes; two elements are connected when
they share a node, so pieces that node separation has cut apart are fragments of their own) or
one particle. Per fragment: mass (the nodes' lumped masses, or the particle's), centre of mass,
mean velocity. The debris cloud is made of the fragments of the bodies' material moving along
the impact direction; its statistics:

- ``count``, ``largest_mass`` and the cumulative mass by fragment size (``mass_by_size``: for
  thresholds m_k, the mass in fragments of at most m_k, m_k a geometric series from the smallest
  to the largest fragment);
- the cloud: nodes, particles and fragments moving along ``axis`` at CLOUD_FRACTION (10 %) of
  the fastest or more (plates at rest or ringing ahead of it are not part of it);
- leading edge: the largest position of any node or particle of the cloud along ``axis``
  (history ``leading_edge``), its speed (the velocity component along the axis of that point);
- spread angle: the half-angle of the cone around the axis that holds the velocities of the
  cloud's fragments (the largest angle between a fragment's mean velocity and the axis), in
  degrees.

Connected components by scipy.sparse.csgraph over the element-node incidence (O(N)).
"""

from __future__ import annotations

import numba
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

ERODED = 3


def live_cells(model):
    """[(conn, live mask)] of the tets and every block."""
    out = [(model.conn, model.status != ERODED)]
    out += [(b.conn, b.status != ERODED) for b in model.blocks]
    return out


def node_components(model) -> tuple[int, np.ndarray]:
    """(number of pieces, label per node; -1 for nodes of no live element): the connected
    pieces of the live mesh."""
    n = model.n_node
    rows, cols = [], []
    for conn, live in live_cells(model):
        c = conn[live]
        if c.shape[0] == 0:
            continue
        k = c.shape[1]
        first = np.repeat(c[:, 0], k - 1)
        rows.append(first)
        cols.append(c[:, 1:].reshape(-1))
    used = np.zeros(n, bool)
    for conn, live in live_cells(model):
        used[conn[live].reshape(-1)] = True
    if not rows:
        return 0, np.full(n, -1, np.int64)
    r, c = np.concatenate(rows), np.concatenate(cols)
    g = coo_matrix((np.ones(r.size, np.int8), (r, c)), shape=(n, n))
    _, lab = connected_components(g, directed=False)
    lab = np.where(used, lab, -1)
    uniq, lab2 = np.unique(lab[used], return_inverse=True)
    out = np.full(n, -1, np.int64)
    out[used] = lab2
    return int(uniq.size), out


def fragment_table(model, particles=None):
    """(mass (f,), centre (f,3), velocity (f,3)) of every fragment: mesh pieces then particles."""
    n_piece, lab = node_components(model)
    m = model.mass
    use = lab >= 0
    mass = np.bincount(lab[use], weights=m[use], minlength=n_piece)
    mom = np.stack([np.bincount(lab[use], weights=m[use] * model.v[use, d], minlength=n_piece)
                    for d in range(3)], axis=1)
    cen = np.stack([np.bincount(lab[use], weights=m[use] * model.x[use, d], minlength=n_piece)
                    for d in range(3)], axis=1)
    safe = np.where(mass > 0, mass, 1.0)[:, None]
    vel, cen = mom / safe, cen / safe
    if particles is not None and particles.n:
        k = particles.n
        mass = np.concatenate([mass, particles.m[:k]])
        cen = np.vstack([cen, particles.x[:k]])
        vel = np.vstack([vel, particles.v[:k]])
    return mass, cen, vel


CLOUD_FRACTION = 0.1  # the cloud: what moves along the axis at >= this share of the fastest


def leading_edge(model, axis, particles=None) -> tuple[float, float]:
    """(position along axis [m], its velocity along axis [m/s]) of the foremost node with mass
    or particle of the cloud (moving along the axis at CLOUD_FRACTION of the fastest or more:
    the plates ahead of the cloud, at rest or ringing, are not its edge). A history column:
    one kernel pass over the nodes and particles (numpy's masks and copies took 1.6 ms a row
    on oblique-sphere's 45,000 nodes)."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    n_p = particles.n if particles is not None else 0
    px = particles.x if n_p else _NO_POINTS
    pv = particles.v if n_p else _NO_POINTS
    s, u = _leading_edge(model.x, model.v, model.mass, px, pv, n_p, a, CLOUD_FRACTION)
    return float(s), float(u)


_NO_POINTS = np.zeros((0, 3))


@numba.njit(cache=True)
def _leading_edge(x, v, mass, px, pv, n_p, a, fraction):
    """`leading_edge` over the nodes with mass, then the first n_p particles (rows of px, pv):
    the first of the largest positions among the cloud's points; (-inf, 0) for no point."""
    n = x.shape[0]
    umax = -np.inf
    count = 0
    for i in range(n + n_p):
        if i < n and not mass[i] > 0.0:
            continue
        w = v[i] if i < n else pv[i - n]
        umax = max(umax, w[0] * a[0] + w[1] * a[1] + w[2] * a[2])
        count += 1
    if count == 0:
        return -np.inf, 0.0
    lim = fraction * max(umax, 0.0)
    for everything in (False, True):  # the cloud; if nothing of it moves forward, every point
        best_s, best_u, found, forward = -np.inf, 0.0, False, False
        for i in range(n + n_p):
            if i < n and not mass[i] > 0.0:
                continue
            w = v[i] if i < n else pv[i - n]
            u = w[0] * a[0] + w[1] * a[1] + w[2] * a[2]
            if not (everything or u >= lim):
                continue
            forward |= u > 0.0
            p = x[i] if i < n else px[i - n]
            s = p[0] * a[0] + p[1] * a[1] + p[2] * a[2]
            if not found or s > best_s:
                best_s, best_u, found = s, u, True
        if everything or (found and forward):
            return best_s, best_u
    return -np.inf, 0.0


def cloud_summary(model, axis, particles=None, bins: int = 12) -> dict:
    """The fragment and debris-cloud statistics of summary.json (module docstring)."""
    mass, cen, vel = fragment_table(model, particles)
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    n_piece = int(node_components(model)[0])
    out = {"count": int(mass.size), "mesh_pieces": n_piece,
           "particles": int(mass.size - n_piece),
           "total_mass": float(mass.sum())}
    if mass.size == 0:
        return out
    order = np.argsort(mass)
    out["largest_mass"] = float(mass[order[-1]])
    pos = mass[mass > 0]
    if pos.size:
        edges = np.geomspace(pos.min(), pos.max(), bins) if pos.max() > pos.min() else \
            np.array([pos.max()])
        cum = [float(mass[mass <= e].sum()) for e in edges]
        out["mass_by_size"] = {"fragment_mass": edges.tolist(), "cumulative_mass": cum}
        counts, bin_edges = np.histogram(pos, bins=edges_for(pos, bins))
        msum, _ = np.histogram(pos, bins=bin_edges, weights=pos)
        out["size_histogram"] = {"mass_edges": bin_edges.tolist(), "count": counts.tolist(),
                                 "mass": msum.tolist()}
    x, v = leading_edge(model, a, particles)
    out["leading_edge"] = x
    out["leading_edge_speed"] = v
    speed = np.linalg.norm(vel, axis=1)
    ua = vel @ a
    fwd = (ua > 0.0) & (ua >= CLOUD_FRACTION * max(float(ua.max()), 0.0))
    if np.any(fwd):
        cosang = np.clip((vel[fwd] @ a) / np.maximum(speed[fwd], 1e-300), -1, 1)
        out["spread_angle_deg"] = float(np.degrees(np.arccos(cosang.min())))
    return out


def edges_for(masses: np.ndarray, bins: int) -> np.ndarray:
    """Logarithmic bin edges over the fragment masses (one bin when they are all equal)."""
    lo, hi = float(masses.min()), float(masses.max())
    if hi <= lo:
        return np.array([lo * 0.9, hi * 1.1])
    return np.geomspace(lo, hi * (1.0 + 1e-12), bins + 1)


def cloud_axis(case) -> np.ndarray:
    """The debris cloud's direction: the initial velocity of the fastest body (+z when every
    body starts at rest)."""
    best, axis = 0.0, np.array([0.0, 0.0, 1.0])
    for b in case.bodies:
        v = np.asarray(b.velocity, float)
        sp = float(np.linalg.norm(v))
        if sp > best:
            best, axis = sp, v / sp
    return axis
