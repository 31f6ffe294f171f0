"""Import of a tet mesh from any format meshio reads (.vtu, .msh, .inp, .med, ...).

Only the 4-node tetra cells are kept (every other cell block, such as surface triangles or
lines, is dropped). Coordinates are multiplied by `scale` (e.g. 1e-3 for a file in mm).
The mesh is then moved so its volume centroid (the centre of mass at uniform density) is at the
origin: for an imported body that centroid is the "primitive's centre" that Body.position and
Body.rotation refer to. Inverted tets are repaired (two nodes swapped); zero-volume tets are an
error, since no node order can make them valid.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from impactsim.mesh import MeshError
from impactsim.mesh.orient import degenerate_tets, fix_orientation, signed_volumes


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
    try:
        mesh = meshio.read(path)
    except Exception as err:  # meshio raises many types (ReadError, KeyError, ValueError, ...)
        raise MeshError(f"cannot read mesh file {path}: {err}") from err
    blocks = [np.asarray(block.data) for block in mesh.cells if block.type == "tetra"]
    if not blocks:
        found = sorted({block.type for block in mesh.cells}) or ["no cells"]
        raise MeshError(f"{path} holds no 4-node tetrahedra (tetra cells); found: "
                        f"{', '.join(found)}")
    tets = np.vstack(blocks).astype(np.int64)
    points = np.asarray(mesh.points, dtype=np.float64)[:, :3] * float(scale)
    if points.shape[1] != 3:
        raise MeshError(f"{path}: points must be 3-dimensional, got {points.shape[1]} coordinates")
    if tets.min() < 0 or tets.max() >= len(points):
        raise MeshError(f"{path}: tetra cells refer to nodes outside 0..{len(points) - 1}")

    bad = degenerate_tets(points, tets)
    if len(bad):
        shown = ", ".join(str(i) for i in bad[:10]) + (", ..." if len(bad) > 10 else "")
        raise MeshError(f"{path}: {len(bad)} degenerate (zero-volume) tetrahedra, cells {shown}")
    tets, flipped = fix_orientation(points, tets)

    volumes = signed_volumes(points, tets)
    centroid = (points[tets].mean(axis=1) * volumes[:, None]).sum(axis=0) / volumes.sum()
    return points - centroid, tets, flipped
