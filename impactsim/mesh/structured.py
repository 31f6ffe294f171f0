"""Structured tet meshes of a box, and the 12-tetrahedron cube of [D19].

Both are built centred at the origin (the primitive's centre); placement happens later.

Structured box: n_i = max(1, round(l_i / h)) cells per axis. Each hexahedral cell is split into
the 6 tets of the Kuhn (Freudenthal) triangulation: for each permutation (p, q, r) of the axes,
the tet walks from the cell's lowest corner v0 along e_p, then e_q, then e_r to the opposite
corner v0 + e_p + e_q + e_r. All six share the cell's main diagonal, and every face of a cell is
split by the diagonal through its lowest and highest corner; since every cell uses the same
pattern, neighbouring cells split a shared face the same way and the mesh is conforming.

cube12 [D19, the two-cubes scene]: 8 corners and the centre; each of the 6 faces is split into
two triangles by the diagonal joining its two "even" corners (i + j + k even, corner at
(i, j, k) in {0, 1}^3), so the six diagonals are the edges of the regular tetrahedron inscribed
in the cube and the pattern is the same on every face up to the cube's symmetry; each of the 12
surface triangles is joined to the centre node.
"""

from __future__ import annotations

from itertools import permutations

import numpy as np

from impactsim.mesh.orient import fix_orientation


def cells_per_axis(size: tuple[float, float, float], mesh_size: float) -> tuple[int, int, int]:
    """n_i = max(1, round(l_i / mesh_size)) for the three box edge lengths."""
    return tuple(max(1, int(round(float(length) / mesh_size))) for length in size)


def structured_box(size: tuple[float, float, float], mesh_size: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Kuhn-split structured mesh of the box size = (lx, ly, lz) [m] centred at the origin.

    Returns points ((nx+1)(ny+1)(nz+1), 3) float64 [m] and tets (6 nx ny nz, 4) int32, every tet
    positively oriented.
    """
    nx, ny, nz = cells_per_axis(size, mesh_size)
    axes = [np.linspace(-0.5 * float(length), 0.5 * float(length), n + 1)
            for length, n in zip(size, (nx, ny, nz))]
    gx, gy, gz = np.meshgrid(*axes, indexing="ij")
    points = np.column_stack([gx.ravel(), gy.ravel(), gz.ravel()])

    stride = np.array([(ny + 1) * (nz + 1), nz + 1, 1])  # node index of grid point (i, j, k)
    ci, cj, ck = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")
    base = (np.column_stack([ci.ravel(), cj.ravel(), ck.ravel()]) @ stride)  # lowest corners
    unit = np.eye(3, dtype=np.int64)
    local = []  # the 6 Kuhn tets as offsets of their nodes from the lowest corner
    for perm in permutations(range(3)):
        corner = np.zeros(3, dtype=np.int64)
        path = [corner.copy()]
        for axis in perm:
            corner = corner + unit[axis]
            path.append(corner.copy())
        local.append([int(p @ stride) for p in path])
    tets = (base[:, None, None] + np.array(local)[None, :, :]).reshape(-1, 4)
    tets, _ = fix_orientation(points, tets)
    return points, tets


def cube12(edge: float) -> tuple[np.ndarray, np.ndarray]:
    """The 12-tet cube of edge length `edge` [m] centred at the origin (module docstring).

    Returns points (9, 3) float64 [m] (corner (i, j, k) is node i + 2j + 4k, the centre is node 8)
    and tets (12, 4) int32, positively oriented, each with the centre as one node.
    """
    bits = np.array([[c & 1, (c >> 1) & 1, (c >> 2) & 1] for c in range(8)])
    points = np.vstack([(bits - 0.5) * float(edge), np.zeros((1, 3))])
    even = bits.sum(axis=1) % 2 == 0
    tets = []
    for axis in range(3):
        for side in (0, 1):
            face = np.flatnonzero(bits[:, axis] == side)
            diagonal = face[even[face]]
            for corner in face[~even[face]]:
                tets.append([8, diagonal[0], diagonal[1], corner])
    tets, _ = fix_orientation(points, np.array(tets))
    return points, tets
