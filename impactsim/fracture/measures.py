"""Result measures of a fracture run, for summary.json: per body the residual velocity (the
mass-weighted mean velocity of its largest remaining fragment) and, for a plate, the hole size.

Fragments: connected components of a body's live elements through shared faces
(impactsim.mesh.topology.face_adjacency). Plates: a body whose initial nodes have a thickness
(extent along the smallest principal axis of their spread) below a quarter of the next extent.
Hole: the live elements of the plate's largest connected piece (its most elements, joined
through shared nodes, so that a torn plate whose cells still touch at edges stays one piece;
detached plugs, petals and spall fragments flying below the plate are not the plate), at their
current positions, are projected onto its initial mid-plane and rasterised on a grid of cell
size h/2 (h the mean initial edge length); uncovered cells not connected to the grid border are
holes. The largest hole is reported by its area, the diameter of the circle of that area, and
its extent along the plate's two in-plane axes; `definition` names this definition in
summary.json. Counting every live element instead made the hole smaller than the opening a
reader measures on the plate itself whenever a plug or fragment flew just below it.
Debris: the particles that came from a body (their number, mass and mean velocity), and the mean
velocity of all of a body's material, for a projectile that has broken up.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from impactsim.mesh.topology import face_adjacency
from impactsim.model import ERODED

MAX_CELLS = 1200  # raster cells per axis at most
# five tets filling a hex (VTK corner order): the projection of a hex for the hole raster
HEX_TETS = np.array([[0, 1, 3, 4], [1, 2, 3, 6], [1, 6, 4, 5], [3, 4, 6, 7], [1, 3, 4, 6]],
                    dtype=np.int64)
HOLE_DEFINITION = ("largest uncovered region, enclosed by the plate, of the projection onto "
                   "the initial mid-plane of the plate's largest piece (live elements joined "
                   "through shared nodes)")


def node_pieces(conn, active):
    """Label per element (-1 where inactive) of the pieces of live elements joined through
    shared nodes, and the number of pieces. Coarser than `fragments` (faces): cells of a torn
    plate that still touch at an edge or a node are one piece."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    ne, nn = conn.shape[0], int(conn.max()) + 1 if conn.size else 0
    e = np.repeat(np.nonzero(active)[0], conn.shape[1])
    n = conn[active].ravel()
    g = coo_matrix((np.ones(e.size), (e, ne + n)), shape=(ne + nn, ne + nn))
    _, lab = connected_components(g, directed=False)
    lab = lab[:ne]
    lab = np.where(active, lab, -1)
    used = np.unique(lab[lab >= 0])
    remap = np.full(lab.max() + 1 if used.size else 1, -1)
    remap[used] = np.arange(used.size)
    return np.where(lab >= 0, remap[np.maximum(lab, 0)], -1), int(used.size)


def fragments(conn, active):
    """Component label per element (-1 where inactive) and the number of components."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    if conn.shape[1] == 8:  # hexes: neighbours across their quads
        from impactsim.fracture.separation import HEX_FACES, face_adjacency_k

        adj = face_adjacency_k(conn, HEX_FACES)
        adj = np.where(np.asarray(active, bool)[:, None], adj, -1)
        adj = np.where((adj >= 0) & np.asarray(active, bool)[np.maximum(adj, 0)], adj, -1)
    else:
        adj = face_adjacency(conn, active)
    ne = conn.shape[0]
    e, k = np.nonzero(adj >= 0)
    g = coo_matrix((np.ones(e.size), (e, adj[e, k])), shape=(ne, ne))
    n, lab = connected_components(g, directed=False)
    lab = np.where(active, lab, -1)
    used = np.unique(lab[lab >= 0])
    remap = np.full(n, -1)
    remap[used] = np.arange(used.size)
    return np.where(lab >= 0, remap[np.maximum(lab, 0)], -1), int(used.size)


@numba.njit(cache=True)
def _raster(pu, pv, conn, live, u0, v0, cell, nu, nv, covered):
    """Mark grid cells whose centres lie in the projection of a live tet (the union of the
    triangles of any three of its four projected corners)."""
    for e in range(conn.shape[0]):
        if not live[e]:
            continue
        lo_u = 1e300
        hi_u = -1e300
        lo_v = 1e300
        hi_v = -1e300
        for k in range(4):
            i = conn[e, k]
            lo_u = min(lo_u, pu[i])
            hi_u = max(hi_u, pu[i])
            lo_v = min(lo_v, pv[i])
            hi_v = max(hi_v, pv[i])
        i0 = max(int(math.floor((lo_u - u0) / cell)), 0)
        i1 = min(int(math.floor((hi_u - u0) / cell)), nu - 1)
        j0 = max(int(math.floor((lo_v - v0) / cell)), 0)
        j1 = min(int(math.floor((hi_v - v0) / cell)), nv - 1)
        for a in range(i0, i1 + 1):
            cu = u0 + (a + 0.5) * cell
            for b in range(j0, j1 + 1):
                if covered[a, b]:
                    continue
                cv = v0 + (b + 0.5) * cell
                for t in range(4):
                    ia = conn[e, (t + 1) % 4]
                    ib = conn[e, (t + 2) % 4]
                    ic = conn[e, (t + 3) % 4]
                    d = (pu[ib] - pu[ia]) * (pv[ic] - pv[ia]) - (pv[ib] - pv[ia]) * (pu[ic] - pu[ia])
                    if d == 0.0:
                        continue
                    l1 = ((cu - pu[ia]) * (pv[ic] - pv[ia]) - (cv - pv[ia]) * (pu[ic] - pu[ia])) / d
                    l2 = ((pu[ib] - pu[ia]) * (cv - pv[ia]) - (pv[ib] - pv[ia]) * (cu - pu[ia])) / d
                    if l1 >= 0.0 and l2 >= 0.0 and l1 + l2 <= 1.0:
                        covered[a, b] = True
                        break


def plate_axes(x0):
    """(normal, in-plane axis 1, in-plane axis 2, centre) if the node cloud is a plate, else None."""
    c = x0.mean(axis=0)
    _, _, vt = np.linalg.svd(x0 - c, full_matrices=False)
    ext = np.ptp((x0 - c) @ vt.T, axis=0)  # extents along the principal axes, largest first
    if ext[2] >= 0.25 * ext[1]:
        return None
    return vt[2], vt[0], vt[1], c


def hole_size(x, x0, conn, live, h):
    """Largest hole of a plate (module docstring), or None if the body is not a plate."""
    from scipy import ndimage

    ax = plate_axes(x0)
    if ax is None:
        return None
    _, a1, a2, c = ax
    u0s, v0s = (x0 - c) @ a1, (x0 - c) @ a2
    cell = max(0.5 * h, max(np.ptp(u0s), np.ptp(v0s)) / MAX_CELLS)
    margin = 2.0 * cell
    u0, v0 = u0s.min() - margin, v0s.min() - margin
    nu = int(math.ceil((u0s.max() + margin - u0) / cell))
    nv = int(math.ceil((v0s.max() + margin - v0) / cell))
    pu, pv = (x - c) @ a1, (x - c) @ a2
    covered = np.zeros((nu, nv), dtype=bool)
    if conn.shape[1] == 8:  # a hex covers what its five tets cover
        conn, live = conn[:, HEX_TETS].reshape(-1, 4), np.repeat(live, 5)
    _raster(pu, pv, conn, live, u0, v0, cell, nu, nv, covered)
    lab, n = ndimage.label(~covered)
    border = np.unique(np.concatenate([lab[0], lab[-1], lab[:, 0], lab[:, -1]]))
    sizes = np.bincount(lab.ravel(), minlength=n + 1)
    sizes[0] = 0
    sizes[border] = 0
    if sizes.max() == 0:
        return {"area": 0.0, "diameter_equivalent": 0.0, "extent": [0.0, 0.0], "axes":
                [a1.tolist(), a2.tolist()], "definition": HOLE_DEFINITION}
    k = int(np.argmax(sizes))
    ii, jj = np.nonzero(lab == k)
    area = float(sizes[k]) * cell * cell
    return {"area": area, "diameter_equivalent": math.sqrt(4.0 * area / math.pi),
            "extent": [float((ii.max() - ii.min() + 1) * cell),
                       float((jj.max() - jj.min() + 1) * cell)],
            "axes": [a1.tolist(), a2.tolist()], "definition": HOLE_DEFINITION}


def body_measures(model, node_live=None, particles=None) -> dict:
    """Per body: residual velocity, mass and fragments; hole size for plates (docstring).
    With ``particles`` (impactsim.fracture.particles.Particles): ``debris`` of each body, the
    number, mass and mass-weighted mean velocity of the particles that came from it, and
    ``mean_velocity_all``, the mean velocity of all the body's material (nodes and particles):
    the projectile's velocity when it has broken up entirely."""
    out = {}
    n_p = 0 if particles is None else particles.n
    live_all = model.status != ERODED
    for b, name in enumerate(model.body_names):
        es = slice(model.elem_start[b], model.elem_start[b + 1])
        ns = slice(model.node_start[b], model.node_start[b + 1])
        off = model.node_start[b]
        conn = model.conn[es] - off
        live = live_all[es]
        for blk in getattr(model, "blocks", []):  # a hex body: its rows of the block
            rows = slice(blk.body_start[b], blk.body_start[b + 1])
            if rows.stop > rows.start:
                conn, live = blk.conn[rows] - off, blk.status[rows] != ERODED
        x, x0 = model.x[ns], model.x0[ns]
        m, v = model.mass[ns], model.v[ns]
        info = {"remaining_elements": int(live.sum())}
        piece = live
        if live.any():
            plab, _ = node_pieces(conn, live)
            piece = plab == int(np.argmax(np.bincount(plab[plab >= 0])))
            lab, nfrag = fragments(conn, live)
            counts = np.bincount(lab[lab >= 0], minlength=nfrag)
            big = int(np.argmax(counts))
            nodes = np.unique(conn[lab == big])
            mm = m[nodes]
            vel = (mm @ v[nodes]) / mm.sum() if mm.sum() > 0 else np.zeros(3)
            info.update(fragments=nfrag, residual_velocity=vel.tolist(),
                        residual_speed=float(np.linalg.norm(vel)),
                        largest_fragment_mass=float(mm.sum()))
        else:
            info.update(fragments=0, residual_velocity=[0.0, 0.0, 0.0], residual_speed=0.0,
                        largest_fragment_mass=0.0)
        e01 = x0[conn[:, 1]] - x0[conn[:, 0]]
        h = float(np.sqrt((e01 * e01).sum(axis=1)).mean()) if conn.shape[0] else 0.0
        hole = hole_size(x, x0, conn, piece, h) if conn.shape[0] else None
        if hole is not None:
            info["hole"] = hole
        if particles is not None:
            mine = particles.body[:n_p] == b
            pm = particles.m[:n_p][mine]
            pp = pm @ particles.v[:n_p][mine] if pm.size else np.zeros(3)
            mp = float(pm.sum())
            info["debris"] = {"particles": int(mine.sum()), "mass": mp,
                              "mean_velocity": (pp / mp).tolist() if mp > 0 else [0.0] * 3}
            mall = float(m.sum()) + mp
            pall = m @ v + pp
            info["mean_velocity_all"] = (pall / mall).tolist() if mall > 0 else [0.0] * 3
        out[name] = info
    return out


def shield_summary(model, bodies: dict, axis) -> dict | None:
    """A multi-plate shield (two plates or more): the plates in the order the projectile meets
    them (their initial centres along the cloud axis), each perforated or not (its largest hole
    has an area) with its hole diameter (the circle of the hole's area), and d1, d2, ... those
    diameters by plate number. None with fewer than two plates."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    plates = []
    for b, name in enumerate(model.body_names):
        hole = bodies.get(name, {}).get("hole")
        if hole is None:
            continue
        ns = slice(model.node_start[b], model.node_start[b + 1])
        plates.append((float(model.x0[ns].mean(axis=0) @ a), name, hole))
    if len(plates) < 2:
        return None
    plates.sort()
    out = {"plates": []}
    for k, (_, name, hole) in enumerate(plates, 1):
        d = float(hole["diameter_equivalent"])
        out["plates"].append({"name": name, "perforated": bool(hole["area"] > 0.0),
                              "hole_diameter": d, "hole_extent": hole["extent"]})
        out[f"d{k}"] = d
    out["perforated"] = [p["perforated"] for p in out["plates"]]
    return out
