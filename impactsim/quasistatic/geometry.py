"""Meshes of the quasi-static primitives and the boundary facets a condition applies to.

Shapes (all centred at the origin, axis z before placement): box, cylinder, tube (a hollow
cylinder: the cladding of a fuel rod) and sphere, meshed by gmsh with the deterministic options
of ``impactsim.mesh.primitives``; an optional refinement ball (size `near` within `radius` of a
point, growing to the body's mesh size) resolves a contact patch; an optional clip box keeps a
symmetric part (a quarter model). Boxes can also be meshed structured (skfem's tensor mesh).
Imported meshes (any meshio format) keep their gmsh physical groups of triangles as named
surface parts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from impactsim.mesh import MeshError
from impactsim.mesh.primitives import _algorithm, _generate, _session


@dataclass
class Refine:
    point: tuple[float, float, float]
    size: float
    radius: float


def primitive(shape: str, dims: dict, mesh_size: float, refine: Refine | None = None,
              clip: tuple[tuple[float, ...], tuple[float, ...]] | None = None,
              structured: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(points (n, 3), tets (e, 4)) of a primitive centred at the origin."""
    if shape == "box" and structured and refine is None and clip is None:
        import skfem as fem

        size = np.asarray(dims["size"], dtype=float)
        n = np.maximum(1, np.round(size / mesh_size).astype(int))
        m = fem.MeshTet.init_tensor(*(np.linspace(-s / 2, s / 2, k + 1) for s, k in zip(size, n)))
        return m.p.T.copy(), m.t.T.copy()
    # thin shapes (a cladding wall thinner than half the mesh size) go to the Delaunay mesher:
    # HXT's optimiser spends minutes on their flat tets (impactsim.mesh.primitives)
    thin = {"box": lambda d: min(d["size"]), "cylinder": lambda d: min(2 * d["radius"],
                                                                      d["height"]),
            "tube": lambda d: d["radius"] - d["inner_radius"],
            "sphere": lambda d: 2 * d["radius"]}.get(shape, lambda d: mesh_size)(dims)
    with _session(shape, _algorithm(thin, mesh_size)) as gmsh:
        occ = gmsh.model.occ
        if shape == "box":
            lx, ly, lz = dims["size"]
            tag = occ.addBox(-lx / 2, -ly / 2, -lz / 2, lx, ly, lz)
        elif shape in ("cylinder", "tube"):
            r, h = dims["radius"], dims["height"]
            tag = occ.addCylinder(0, 0, -h / 2, 0, 0, h, r)
            if shape == "tube":
                inner = occ.addCylinder(0, 0, -h, 0, 0, 2 * h, dims["inner_radius"])
                out, _ = occ.cut([(3, tag)], [(3, inner)])
                tag = out[0][1]
        elif shape == "sphere":
            tag = occ.addSphere(0, 0, 0, dims["radius"])
        else:
            raise MeshError(f"unknown shape '{shape}'")
        if clip is not None:
            lo, hi = np.asarray(clip[0], float), np.asarray(clip[1], float)
            box = occ.addBox(*lo, *(hi - lo))
            out, _ = occ.intersect([(3, tag)], [(3, box)])
            if not out:
                raise MeshError("the clip box leaves nothing of the shape")
        if refine is not None:
            occ.synchronize()
            f = gmsh.model.mesh.field
            ball = f.add("Ball")
            f.setNumber(ball, "Radius", refine.radius)
            for k, c in zip("XYZ", refine.point):
                f.setNumber(ball, k + "Center", c)
            f.setNumber(ball, "VIn", refine.size)
            f.setNumber(ball, "VOut", mesh_size)
            f.setNumber(ball, "Thickness", refine.radius)
            f.setAsBackgroundMesh(ball)
            gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
            gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
            gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
            occ.synchronize()
            gmsh.option.setNumber("Mesh.MeshSizeMin", refine.size)
            gmsh.option.setNumber("Mesh.MeshSizeMax", mesh_size)
            gmsh.model.mesh.generate(3)
            return _collect(gmsh)
        return _generate(gmsh, mesh_size)


def _collect(gmsh) -> tuple[np.ndarray, np.ndarray]:
    tags, coords, _ = gmsh.model.mesh.getNodes()
    _, node_tags = gmsh.model.mesh.getElementsByType(4)
    index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
    index[tags.astype(np.int64)] = np.arange(len(tags))
    points = np.asarray(coords, dtype=float).reshape(-1, 3)
    tets = index[np.asarray(node_tags, dtype=np.int64).reshape(-1, 4)]
    used = np.unique(tets)
    remap = np.full(len(points), -1)
    remap[used] = np.arange(len(used))
    return points[used], remap[tets]


def read_mesh(path, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """(points, tets, {physical group name: triangles (k, 3)}) of a mesh file."""
    import meshio

    try:
        m = meshio.read(path)
    except Exception as err:  # meshio raises many kinds
        raise MeshError(f"cannot read mesh '{path}': {err}") from err
    tets = [c.data for c in m.cells if c.type == "tetra"]
    if not tets:
        raise MeshError(f"mesh '{path}' has no tetrahedra")
    groups: dict[str, np.ndarray] = {}
    names = {int(v[0]): k for k, v in m.field_data.items()} if m.field_data else {}
    phys = m.cell_data.get("gmsh:physical")
    if phys is not None:
        for block, tags in zip(m.cells, phys):
            if block.type != "triangle":
                continue
            for tag in np.unique(tags):
                name = names.get(int(tag), str(int(tag)))
                groups.setdefault(name, [])
                groups[name].append(block.data[tags == tag])
    groups = {k: np.concatenate(v) for k, v in groups.items()}
    return np.asarray(m.points, float) * scale, np.concatenate(tets).astype(np.int64), groups


def place(points: np.ndarray, rotation, position) -> np.ndarray:
    """Rotate (intrinsic x-y-z Euler angles) then translate points (n, 3)."""
    from impactsim.mesh.orient import rotation_matrix

    return points @ rotation_matrix(tuple(rotation)).T + np.asarray(position, float)


def fix_orientation(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Tets with positive volume (skfem needs a consistent orientation)."""
    a, b, c, d = (points[tets[:, i]] for i in range(4))
    det = np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a)
    tets = tets.copy()
    flip = det < 0
    tets[flip, 2], tets[flip, 3] = tets[flip, 3], tets[flip, 2].copy()
    return tets


# --- facet selectors (on a skfem mesh: p (3, n), facets (3, nf)) ---

def select_plane(mesh, point, normal, tolerance: float) -> np.ndarray:
    """Boundary facets whose three vertices lie within `tolerance` of the plane."""
    n = np.asarray(normal, float)
    n = n / np.linalg.norm(n)
    bf = mesh.boundary_facets()
    x = mesh.p[:, mesh.facets[:, bf]]  # (3, 3, k)
    d = np.einsum("i,ijk->jk", n, x - np.asarray(point, float)[:, None, None])
    return bf[np.all(np.abs(d) <= tolerance, axis=0)]


def select_box(mesh, lo, hi, tolerance: float = 0.0) -> np.ndarray:
    """Boundary facets whose three vertices lie in the box (padded by tolerance)."""
    bf = mesh.boundary_facets()
    x = mesh.p[:, mesh.facets[:, bf]]
    lo = np.asarray(lo, float)[:, None, None] - tolerance
    hi = np.asarray(hi, float)[:, None, None] + tolerance
    return bf[np.all((x >= lo) & (x <= hi), axis=(0, 1))]


def select_cylinder(mesh, point, axis, radius: float, tolerance: float) -> np.ndarray:
    """Boundary facets whose vertices lie within `tolerance` of the cylinder surface."""
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    bf = mesh.boundary_facets()
    x = mesh.p[:, mesh.facets[:, bf]] - np.asarray(point, float)[:, None, None]
    along = np.einsum("i,ijk->jk", a, x)
    r = np.linalg.norm(x - a[:, None, None] * along[None], axis=0)
    return bf[np.all(np.abs(r - radius) <= tolerance, axis=0)]


def select_triangles(mesh, triangles: np.ndarray) -> np.ndarray:
    """Boundary facets equal to the given triangles (a physical group of an imported mesh)."""
    bf = mesh.boundary_facets()
    key = {tuple(sorted(f)): i for i, f in zip(bf, mesh.facets[:, bf].T)}
    out = [key.get(tuple(sorted(t))) for t in np.asarray(triangles)]
    return np.array(sorted(i for i in out if i is not None), dtype=np.int64)
