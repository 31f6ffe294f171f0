"""Meshing of bodies into 4-node tetrahedra.

``mesh_body(body) -> (points (n, 3) float64 [m], tets (e, 4) int32)`` is the contract with the
solver: the body meshed around the primitive's centre, every tet positively oriented
(det[x1-x0, x2-x0, x3-x0] > 0), unused nodes removed, nodes and elements in Z-order for memory
locality (renumber.py), then placed: x = position + R @ x_local (orient.py). Same body, same
arrays, bit for bit.

Shapes (Body.dimensions, SI):
  box, plate   size (lx, ly, lz), centred at the origin; mesher "gmsh" or "structured"
  cylinder     radius, height, axis (3,); centred at the origin; gmsh
  sphere       radius; gmsh
  file         path, scale; any meshio format, tetra cells only, centred on its volume centroid
  cube12       size (edge length); the 12-tet cube of [D19]; mesh_size and mesher are ignored

Modules: primitives (gmsh), structured (structured box, cube12), importer (meshio),
orient (orientation and placement), renumber (Z-order), quality (measures), report (the
``impactsim mesh`` command), cache (meshes kept on disk), topology (faces and adjacency).
Note: the attribute ``impactsim.mesh.quality`` is the function ``quality(points, tets)``; the
module's other names are imported with ``from impactsim.mesh.quality import ...``.
"""

from __future__ import annotations

import numpy as np

from impactsim.case.errors import CaseError
from impactsim.case.schema import Body


class MeshError(CaseError):
    """A body that cannot be meshed: bad dimensions, a failed mesher, a bad mesh file."""


from impactsim.mesh import cache  # noqa: E402  (submodules import MeshError from here)
from impactsim.mesh.orient import fix_orientation, place  # noqa: E402
from impactsim.mesh.quality import quality  # noqa: E402
from impactsim.mesh.renumber import renumber  # noqa: E402

SHAPES = ("box", "plate", "cylinder", "sphere", "file", "cube12")
MESHERS = ("gmsh", "structured")

__all__ = ["MeshError", "mesh_body", "mesh_bodies", "mesh_local", "quality", "SHAPES",
           "MESHERS"]


def _dimension(body: Body, name: str):
    try:
        return body.dimensions[name]
    except KeyError:
        raise MeshError(f"shape '{body.shape}' needs dimensions.{name}") from None


def _raw_mesh(body: Body) -> tuple[np.ndarray, np.ndarray]:
    """Mesh the body's shape centred at the origin: (points, tets) in any order or orientation."""
    from impactsim.mesh import primitives, structured

    shape, h = body.shape, float(body.mesh_size)
    if shape == "cube12":
        return structured.cube12(float(_dimension(body, "size")))
    if shape == "file":
        from impactsim.mesh.importer import read_tets

        points, tets, _ = read_tets(_dimension(body, "path"),
                                    float(body.dimensions.get("scale", 1.0)))
        return points, tets
    if body.mesher not in MESHERS:
        raise MeshError(f"unknown mesher '{body.mesher}'; expected one of: {', '.join(MESHERS)}")
    if body.mesher == "structured":
        if shape not in ("box", "plate"):
            raise MeshError(f"the structured mesher meshes box, plate and cube12, not '{shape}'")
        size = _dimension(body, "size")
        if not h > 0.0 or min(float(v) for v in size) <= 0.0:
            raise MeshError(f"structured mesh needs mesh_size > 0 and a positive size, got "
                            f"mesh_size {h}, size {tuple(size)}")
        return structured.structured_box(size, h)
    if shape in ("box", "plate"):
        return primitives.gmsh_box(_dimension(body, "size"), h)
    if shape == "cylinder":
        return primitives.gmsh_cylinder(float(_dimension(body, "radius")),
                                        float(_dimension(body, "height")),
                                        body.dimensions.get("axis", (0.0, 0.0, 1.0)), h)
    if shape == "sphere":
        return primitives.gmsh_sphere(float(_dimension(body, "radius")), h)
    raise MeshError(f"unknown shape '{shape}'; expected one of: {', '.join(SHAPES)}")


def mesh_local(body: Body, use_cache: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """The unplaced mesh of `body`: centred at the origin, positively oriented, renumbered.

    Taken from the on-disk cache when present (cache.py), else meshed and stored.
    """
    if getattr(body, "element", "tet") == "hex8":  # hexahedra: hexes.py (not cached: fast)
        from impactsim.mesh.hexes import hex_mesh_local

        return hex_mesh_local(body)
    key = None
    if use_cache:
        try:
            key = cache.cache_key(body)
        except OSError as err:  # an imported file that cannot be read
            raise MeshError(f"cannot read mesh file: {err}") from err
        except KeyError as err:
            raise MeshError(f"shape '{body.shape}' needs dimensions.{err.args[0]}") from None
        found = cache.load(key)
        if found is not None:
            return found
    points, tets = _raw_mesh(body)
    tets, _ = fix_orientation(points, tets)
    points, tets = renumber(points, tets)
    if key is not None:
        cache.store(key, points, tets)
    return points, tets


def mesh_body(body: Body, *, use_cache: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Mesh and place `body`: points (n, 3) float64 [m], tets (e, 4) int32 (module docstring);
    hexes (e, 8) int32 for an element = "hex8" body (hexes.py).

    Raises MeshError (a CaseError) with a message naming the problem; the caller adds the body.
    """
    points, tets = mesh_local(body, use_cache=use_cache)
    return place(points, body.rotation, body.position), tets


def mesh_bodies(case, which=None) -> list:
    """mesh_body of each body of `case` (only the indices in `which` when given, None for the
    others). A body that cannot be meshed raises MeshError naming the case file and the key:
    ``cases/x.toml: body[1].path (body "plate"): ...`` (the mesh_size for a primitive)."""
    out = []
    for i, body in enumerate(case.bodies):
        if which is not None and i not in which:
            out.append(None)
            continue
        try:
            out.append(mesh_body(body))
        except MeshError as err:
            where = f"{case.source}: " if case.source is not None else ""
            key = "path" if body.shape == "file" else "mesh_size"
            raise MeshError(f"{where}body[{i}].{key} (body \"{body.name}\"): {err}") from None
    return out
