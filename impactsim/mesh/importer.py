"""Import of a tet mesh from any format meshio reads (.vtu, .msh, .inp, .med, ...).

Only the 4-node tetra cells are kept (every other cell block, such as surface triangles or
lines, is dropped). Coordinates are multiplied by `scale` (e.g. 1e-3 for a file in mm).
The mesh is then moved so its volume centroid (the centre of mass at uniform density) is at the
origin: for an imported body that centroid is the "primitive's centre" that Body.position and
Body.rotation refer to. Inverted tets are repaired (two nodes swapped); zero-volume tets are an
error, since no node order can make them valid. So are a file meshio cannot read (its reader
exits the process on some corrupt files: that is caught), a file without tetrahedra, non-finite
coordinates, cells naming nodes that do not exist and the same tetrahedron listed twice.
"""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import numpy as np

from impactsim.mesh import MeshError
from impactsim.mesh.orient import degenerate_tets, fix_orientation, signed_volumes
from impactsim.mesh.topology import face_adjacency


MAX_COORDINATE = 1e6  # [m] a body larger than 1000 km is a wrong scale or a corrupt file


def read_tets(path: Path, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray, int]:
    """Read `path` with meshio and return (points (n,3) [m], tets (e,4) int32, tets flipped).

    Points are scaled and centred on the volume centroid; tets are positively oriented.
    Raises MeshError if the file cannot be read, holds no tetra cells, or has degenerate tets.
    """
    import meshio

    path = Path(path)
    if not path.is_file():
        raise MeshError(f"mesh file not found: {path}")
    if not scale > 0.0:
        raise MeshError(f"scale must be > 0, got {scale}")
    said = io.StringIO()
    try:
        with contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
            mesh = meshio.read(path)
        blocks = [np.asarray(block.data) for block in mesh.cells if block.type == "tetra"]
        points = np.asarray(mesh.points, dtype=np.float64)
    except (Exception, SystemExit) as err:  # meshio raises many types, or exits the process
        why = " ".join((said.getvalue() + " " + str(err)).split()) or type(err).__name__
        if isinstance(err, SystemExit):
            why = " ".join(said.getvalue().split()) or "meshio could not read it"
        raise MeshError(f"cannot read mesh file {path}: {why[:300]}") from None
    tets = np.vstack(blocks).astype(np.int64) if blocks else np.zeros((0, 4), np.int64)
    if not len(tets):
        found = sorted({block.type for block in mesh.cells if len(block.data)}) or ["no cells"]
        raise MeshError(f"{path} holds no 4-node tetrahedra (tetra cells); found: "
                        f"{', '.join(found)}")
    if points.ndim != 2 or points.shape[1] < 3:
        raise MeshError(f"{path}: points must be 3-dimensional, got shape {points.shape}")
    points = points[:, :3] * float(scale)
    if tets.ndim != 2 or tets.shape[1] != 4:
        raise MeshError(f"{path}: tetra cells must have 4 nodes, got shape {tets.shape}")
    if tets.min() < 0 or tets.max() >= len(points):
        raise MeshError(f"{path}: tetra cells refer to nodes outside 0..{len(points) - 1}")
    used = np.unique(tets)
    bad_nodes = used[~np.isfinite(points[used]).all(axis=1)]
    if len(bad_nodes):
        raise MeshError(f"{path}: {len(bad_nodes)} node(s) with non-finite coordinates (nan or "
                        f"inf), first node {int(bad_nodes[0])}")
    if np.abs(points[used]).max() > MAX_COORDINATE:
        raise MeshError(f"{path}: coordinates beyond {MAX_COORDINATE:g} m after scale "
                        f"{scale:g}: not a plausible body")
    key = np.sort(tets, axis=1)
    _, first, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    if (counts > 1).any():
        dup = int(np.sort(first[counts > 1])[0])
        raise MeshError(f"{path}: {int((counts - 1).sum())} tetrahedra listed more than once "
                        f"(the same four nodes), first cell {dup}")
    try:  # every solver pass assumes a face has one or two sides
        face_adjacency(tets)
    except ValueError as err:  # "non-manifold mesh: a face is shared by more than two ..."
        raise MeshError(f"{path}: {err}") from None

    bad = degenerate_tets(points, tets)
    if len(bad):
        shown = ", ".join(str(i) for i in bad[:10]) + (", ..." if len(bad) > 10 else "")
        raise MeshError(f"{path}: {len(bad)} degenerate (zero-volume) tetrahedra, cells {shown}")
    tets, flipped = fix_orientation(points, tets)

    volumes = signed_volumes(points, tets)
    centroid = (points[tets].mean(axis=1) * volumes[:, None]).sum(axis=0) / volumes.sum()
    return points - centroid, tets, flipped
