"""Unstructured tet meshes of the primitives (box, plate, cylinder, sphere) with gmsh.

Each primitive is built with the OpenCASCADE kernel centred at the origin, meshed with a uniform
target edge length (Mesh.MeshSizeMin = Mesh.MeshSizeMax = mesh_size) and returned as raw
(points, tets); orientation, renumbering and placement happen in ``impactsim.mesh``.

Determinism: the 3D mesher is HXT (Mesh.Algorithm3D = 10) on one thread with a fixed random
seed. Measured with gmsh 4.15: on one thread HXT gives bit-identical meshes run after run (and is
about 5x faster than the Delaunay mesher: 2-3 s for a 200k-tet cylinder); on two threads
it does not.

A plate thinner than the mesh size still gets a valid mesh: its side faces are one segment high,
so the mesh is one (flat) tet layer thick; the quality report shows the price. HXT's optimiser
spends seconds on such flat tets (2.5 s for a 500-tet box, 15 s for a 1400-tet disk at mesh
size = 8 x thickness, where the Delaunay mesher takes 0.04 s and 0.2 s), so a primitive whose
smallest extent is below half the mesh size is meshed with the Delaunay mesher
(Mesh.Algorithm3D = 1), deterministic on one thread as well.

gmsh is imported inside the functions: importing impactsim.mesh stays cheap, and gmsh's global
state is confined to one session per call.
"""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np

from impactsim.mesh import MeshError

RANDOM_SEED = 1
ALGORITHM_3D = 10  # HXT
ALGORITHM_3D_THIN = 1  # Delaunay, for primitives thinner than THIN_RATIO * mesh size
THIN_RATIO = 0.5
# Tets of quality (gmsh's gamma) below this are optimised after meshing. gmsh's default 0.3;
# 0.4 raised the smallest altitude (hence the stable time step) of a 200k-tet cylinder by 12 %
# for 20 % more meshing time; 0.5 gained 6 % more for 7x the time.
OPTIMIZE_THRESHOLD = 0.4
TET4 = 4  # gmsh element type of the 4-node tetrahedron


@contextmanager
def _session(name: str, algorithm: int = ALGORITHM_3D):
    """A gmsh model with deterministic meshing options; the session is closed afterwards.

    If gmsh is already initialised (by the caller), a separate model is used and removed, and
    the caller's session is left open.
    """
    import gmsh

    owner = not gmsh.isInitialized()
    if owner:
        gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.option.setNumber("Mesh.MaxNumThreads3D", 1)
        gmsh.option.setNumber("Mesh.RandomSeed", RANDOM_SEED)
        gmsh.option.setNumber("Mesh.Algorithm3D", algorithm)
        gmsh.option.setNumber("Mesh.OptimizeThreshold", OPTIMIZE_THRESHOLD)
        gmsh.model.add(name)
        yield gmsh
    finally:
        if owner:
            gmsh.finalize()
        else:
            gmsh.model.remove()


def _generate(gmsh, mesh_size: float) -> tuple[np.ndarray, np.ndarray]:
    """Mesh the current model in 3D with a uniform size; return (points (n,3), tets (e,4) int32)."""
    gmsh.model.occ.synchronize()
    gmsh.option.setNumber("Mesh.MeshSizeMin", mesh_size)
    gmsh.option.setNumber("Mesh.MeshSizeMax", mesh_size)
    try:
        gmsh.model.mesh.generate(3)
    except Exception as err:  # gmsh reports every failure as a bare Exception
        raise MeshError(f"gmsh failed to mesh: {err}") from err
    tags, coords, _ = gmsh.model.mesh.getNodes()
    _, node_tags = gmsh.model.mesh.getElementsByType(TET4)
    if len(node_tags) == 0:
        raise MeshError("gmsh produced no tetrahedra")
    index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
    index[tags.astype(np.int64)] = np.arange(len(tags))
    points = np.asarray(coords, dtype=np.float64).reshape(-1, 3)
    tets = index[np.asarray(node_tags, dtype=np.int64).reshape(-1, 4)]
    if (tets < 0).any():
        raise MeshError("gmsh returned tetrahedra with unknown nodes")
    return points, tets.astype(np.int32)


def _algorithm(smallest_extent: float, mesh_size: float) -> int:
    """The 3D mesher for a primitive: HXT, or Delaunay when it is thin (module docstring)."""
    return ALGORITHM_3D_THIN if smallest_extent < THIN_RATIO * mesh_size else ALGORITHM_3D


def _check_size(mesh_size: float) -> float:
    if not mesh_size > 0.0:
        raise MeshError(f"mesh_size must be > 0 for the gmsh mesher, got {mesh_size}")
    return float(mesh_size)


def gmsh_box(size: tuple[float, float, float], mesh_size: float) -> tuple[np.ndarray, np.ndarray]:
    """Box (or plate) size = (lx, ly, lz) [m] centred at the origin."""
    h = _check_size(mesh_size)
    lx, ly, lz = (float(v) for v in size)
    if min(lx, ly, lz) <= 0.0:
        raise MeshError(f"box size must be positive, got {size}")
    with _session("box", _algorithm(min(lx, ly, lz), h)) as gmsh:
        gmsh.model.occ.addBox(-0.5 * lx, -0.5 * ly, -0.5 * lz, lx, ly, lz)
        return _generate(gmsh, h)


def gmsh_cylinder(radius: float, height: float, axis, mesh_size: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Cylinder of `radius`, `height` [m] along `axis` (normalised here), centred at the origin."""
    h = _check_size(mesh_size)
    axis = np.asarray(axis, dtype=np.float64)
    norm = float(np.linalg.norm(axis))
    if axis.shape != (3,) or norm == 0.0:
        raise MeshError(f"cylinder axis must be a non-zero 3-vector, got {axis.tolist()}")
    if not (radius > 0.0 and height > 0.0):
        raise MeshError(f"cylinder radius and height must be positive, got {radius}, {height}")
    d = axis / norm * float(height)
    with _session("cylinder", _algorithm(min(float(height), 2.0 * float(radius)), h)) as gmsh:
        gmsh.model.occ.addCylinder(*(-0.5 * d), *d, float(radius))
        return _generate(gmsh, h)


def gmsh_sphere(radius: float, mesh_size: float) -> tuple[np.ndarray, np.ndarray]:
    """Sphere of `radius` [m] centred at the origin."""
    h = _check_size(mesh_size)
    if not radius > 0.0:
        raise MeshError(f"sphere radius must be positive, got {radius}")
    with _session("sphere", _algorithm(2.0 * float(radius), h)) as gmsh:
        gmsh.model.occ.addSphere(0.0, 0.0, 0.0, float(radius))
        return _generate(gmsh, h)
