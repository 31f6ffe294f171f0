"""Hexahedral meshes (element = "hex8"): structured boxes, O-grid cylinders, cube-spheres,
imported hexahedron cells; orientation and quality of hexes.

All meshes are built centred at the origin in the VTK node order (0-3 the bottom face
counter-clockwise seen from above, 4-7 above them), positively oriented (exact volume > 0,
solver/hex8.py), renumbered along the Z-curve (renumber.py) and placed like the tets.

- box, plate: n_i = max(1, round(l_i / h)) cells per axis (structure of structured.py).
- cylinder: the butterfly (O-grid) disk extruded along the axis: a central square of half-width
  a = 0.5 R with n x n cells and four blocks between its sides and the circle, n cells along
  and m radially, the outer nodes equally spaced in angle. Every node inside has four quads,
  the square's corners three: no corner angle of 180 degrees as a single mapped square would
  have on the circle.
- sphere: the cube-sphere, the same in 3-D: a central cube of half-width a = 0.4 R with n^3
  cells and six blocks from its faces to the sphere, the surface nodes on the equiangular grid
  of the cubed sphere (direction (tan u, tan v, 1) on the +z face).
- file: the hexahedron cells of any meshio file; a hex with negative volume is mirrored
  (nodes 1 <-> 3 and 5 <-> 7), a degenerate one is an error.

Nodes shared by blocks are merged on their coordinates (rounded to 1e-9 of the body's size).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from impactsim.mesh import MeshError

# half-width of the central square (cylinder) and cube (sphere) over the radius: the cube's
# corner is at sqrt(3) a from the centre, so it needs the smaller fraction to keep the corner
# cells of the shell from being flat (aspect ratio 10 at 0.55, about 2.5 at 0.4)
A_DISK = 0.5
A_BALL = 0.4
MIRROR = np.array([0, 3, 2, 1, 4, 7, 6, 5])  # the same hex with the other orientation


def hex_volumes(points: np.ndarray, hexes: np.ndarray) -> np.ndarray:
    """Exact signed volumes (e,) [m^3] (solver/hex8.py)."""
    from impactsim.solver.hex8 import hex_volumes as kernel

    return kernel(np.ascontiguousarray(points, np.float64),
                  np.ascontiguousarray(hexes, np.int32))


def fix_hex_orientation(points: np.ndarray, hexes: np.ndarray) -> tuple[np.ndarray, int]:
    """(hexes with every negative one mirrored, number mirrored)."""
    out = np.array(hexes, dtype=np.int32, copy=True)
    neg = hex_volumes(points, out) < 0.0
    out[neg] = out[neg][:, MIRROR]
    return out, int(np.count_nonzero(neg))


def _merge(points: np.ndarray, hexes: np.ndarray, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Merge coincident nodes (rounded to 1e-9 scale); keeps the first occurrence's order."""
    key = np.round(points / (1e-9 * scale)).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    new = np.empty(len(order), np.int64)
    new[order] = np.arange(len(order))
    return points[first[order]], new[inverse.ravel()][hexes]


def box_hexes(size, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Structured hexes of the box size = (lx, ly, lz) [m] centred at the origin."""
    n = [max(1, int(round(float(length) / h))) for length in size]
    axes = [np.linspace(-0.5 * float(length), 0.5 * float(length), k + 1)
            for length, k in zip(size, n)]
    gx, gy, gz = np.meshgrid(*axes, indexing="ij")
    points = np.column_stack([gx.ravel(), gy.ravel(), gz.ravel()])
    return points, _grid_cells(*n)


def _grid_cells(nx: int, ny: int, nz: int) -> np.ndarray:
    """Hexes of an (nx+1, ny+1, nz+1) node grid numbered i-major (index ((i ny1) + j) nz1 + k)."""
    s = np.array([(ny + 1) * (nz + 1), nz + 1, 1])
    ci, cj, ck = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")
    base = np.column_stack([ci.ravel(), cj.ravel(), ck.ravel()]) @ s
    corner = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                       [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]]) @ s
    return (base[:, None] + corner[None, :]).astype(np.int64)


def _disk(radius: float, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Butterfly quads of the disk: points (k, 2), quads (q, 4) counter-clockwise."""
    a = A_DISK * radius
    n = max(2, int(round(2.0 * a / h)))
    m = max(1, int(round((radius - a) / h)))
    pts, quads = [], []

    def block(grid):  # grid (nu+1, nv+1, 2): quads counter-clockwise in (u, v)
        off = sum(len(p) for p in pts)
        nu, nv = grid.shape[0] - 1, grid.shape[1] - 1
        idx = np.arange((nu + 1) * (nv + 1)).reshape(nu + 1, nv + 1) + off
        q = np.stack([idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]], axis=-1)
        pts.append(grid.reshape(-1, 2))
        quads.append(q.reshape(-1, 4))

    s = np.linspace(-a, a, n + 1)
    block(np.stack(np.meshgrid(s, s, indexing="ij"), axis=-1))
    t = np.linspace(0.0, 1.0, m + 1)
    for side in range(4):
        rot = np.array([[np.cos(side * np.pi / 2), -np.sin(side * np.pi / 2)],
                        [np.sin(side * np.pi / 2), np.cos(side * np.pi / 2)]])
        inner = np.column_stack([np.full(n + 1, a), s])  # the square's side x = a
        ang = np.linspace(-np.pi / 4, np.pi / 4, n + 1)
        outer = radius * np.column_stack([np.cos(ang), np.sin(ang)])
        grid = inner[None, :, :] + t[:, None, None] * (outer - inner)[None, :, :]
        block(grid @ rot.T)  # u radial outward, v along the side: counter-clockwise
    return np.vstack(pts), np.vstack(quads)


def cylinder_hexes(radius: float, height: float, axis, h: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """O-grid hexes of the cylinder (module docstring), centred at the origin along `axis`."""
    p2, quads = _disk(float(radius), h)
    nz = max(1, int(round(float(height) / h)))
    z = np.linspace(-0.5 * height, 0.5 * height, nz + 1)
    k = len(p2)
    points = np.column_stack([np.tile(p2, (nz + 1, 1)), np.repeat(z, k)])
    layers = []
    for i in range(nz):
        lo, hi = quads + i * k, quads + (i + 1) * k
        layers.append(np.hstack([lo, hi]))
    points, hexes = _merge(points, np.vstack(layers), max(radius, height))
    axis = np.asarray(axis, float)
    axis = axis / np.linalg.norm(axis)
    return points @ _frame(axis).T, hexes


def _frame(axis: np.ndarray) -> np.ndarray:
    """A rotation taking e_z to `axis` (columns: e1, e2, axis)."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(helper, axis)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    return np.column_stack([e1, e2, axis])


def sphere_hexes(radius: float, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Cube-sphere hexes of the ball (module docstring), centred at the origin."""
    a = A_BALL * radius
    n = max(2, int(round(2.0 * a / h)))
    m = max(1, int(round((radius - a) / h)))
    pts, cells = [], []
    off = 0
    pc, hc = box_hexes((2 * a, 2 * a, 2 * a), 2 * a / n)
    pts.append(pc)
    cells.append(hc)
    off += len(pc)
    s = np.linspace(-a, a, n + 1)
    ang = np.linspace(-np.pi / 4, np.pi / 4, n + 1)
    t = np.linspace(0.0, 1.0, m + 1)
    u, v = np.meshgrid(s, s, indexing="ij")
    tu, tv = np.meshgrid(np.tan(ang), np.tan(ang), indexing="ij")
    inner = np.stack([u, v, np.full_like(u, a)], axis=-1)  # the +z face
    d = np.stack([tu, tv, np.ones_like(tu)], axis=-1)
    outer = radius * d / np.linalg.norm(d, axis=-1, keepdims=True)
    grid = inner[:, :, None, :] + t[None, None, :, None] * (outer - inner)[:, :, None, :]
    local = _grid_cells(n, n, m)
    rots = [np.eye(3)]
    for axis_idx, angle in ((0, np.pi / 2), (0, np.pi), (0, -np.pi / 2), (1, np.pi / 2),
                            (1, -np.pi / 2)):
        c, si = np.cos(angle), np.sin(angle)
        if axis_idx == 0:
            rots.append(np.array([[1, 0, 0], [0, c, -si], [0, si, c]]))
        else:
            rots.append(np.array([[c, 0, si], [0, 1, 0], [-si, 0, c]]))
    for r in rots:
        p = grid.reshape(-1, 3) @ r.T
        pts.append(p)
        cells.append(local + off)
        off += len(p)
    points, hexes = _merge(np.vstack(pts), np.vstack(cells), radius)
    return points, hexes


def read_hexes(path: Path, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray, int]:
    """The hexahedron cells of a meshio file: (points [m], hexes (e, 8), hexes mirrored)."""
    import meshio

    try:
        mesh = meshio.read(path)
    except Exception as err:  # meshio raises many kinds
        raise MeshError(f"cannot read mesh file {path}: {err}") from err
    blocks = [np.asarray(b.data) for b in mesh.cells if b.type == "hexahedron"]
    if not blocks:
        found = ", ".join(sorted({b.type for b in mesh.cells})) or "no cells"
        raise MeshError(f"{path} holds no 8-node hexahedra (hexahedron cells); found: {found}")
    hexes = np.vstack(blocks).astype(np.int64)
    points = np.asarray(mesh.points, dtype=np.float64)[:, :3] * float(scale)
    if hexes.min() < 0 or hexes.max() >= len(points):
        raise MeshError(f"{path}: hexahedron cells refer to nodes outside 0..{len(points) - 1}")
    hexes, flipped = fix_hex_orientation(points, hexes)
    vol = hex_volumes(points, hexes)
    ext = np.ptp(points[hexes], axis=1).max(axis=1)
    bad = np.flatnonzero(vol <= 1e-10 * ext ** 3)
    if len(bad):
        raise MeshError(f"{path}: {len(bad)} degenerate or tangled hexahedra, cells "
                        f"{', '.join(map(str, bad[:5]))}")
    points = points - (vol @ points[hexes].mean(axis=1)) / vol.sum()  # centred on the volume
    return points, hexes, flipped


def raw_hex_mesh(body) -> tuple[np.ndarray, np.ndarray]:
    """The hex mesh of body's shape centred at the origin, in any orientation."""
    shape, h = body.shape, float(body.mesh_size)
    dims = body.dimensions
    if shape == "file":
        points, hexes, _ = read_hexes(dims["path"], float(dims.get("scale", 1.0)))
        return points, hexes
    if not h > 0.0:
        raise MeshError(f"mesh_size must be > 0, got {h}")
    if shape in ("box", "plate"):
        return box_hexes(dims["size"], h)
    if shape == "cylinder":
        return cylinder_hexes(float(dims["radius"]), float(dims["height"]),
                              dims.get("axis", (0.0, 0.0, 1.0)), h)
    if shape == "sphere":
        return sphere_hexes(float(dims["radius"]), h)
    raise MeshError(f"shape '{shape}' has no hex mesher (box, plate, cylinder, sphere, file)")


def hex_mesh_local(body) -> tuple[np.ndarray, np.ndarray]:
    """The unplaced hex mesh of `body`: positively oriented, renumbered, int32."""
    from impactsim.mesh.renumber import renumber

    points, hexes = raw_hex_mesh(body)
    hexes, _ = fix_hex_orientation(points, hexes)
    points, hexes = renumber(points, hexes)
    return points, np.ascontiguousarray(hexes, np.int32)


# --- quality --------------------------------------------------------------------------------
# the corners of the reference hex and, for each corner, its three edge neighbours in the
# right-handed order (so that det[e1, e2, e3] > 0 at every corner of a good hex)
_CORNER_NEIGHBOURS = np.array([[1, 3, 4], [2, 0, 5], [3, 1, 6], [0, 2, 7],
                               [7, 5, 0], [4, 6, 1], [5, 7, 2], [6, 4, 3]])
_FACES = np.array([[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6],
                   [3, 0, 4, 7]])


def hex_quality(points: np.ndarray, hexes: np.ndarray) -> dict:
    """Quality measures of hexes, per element (e,) arrays:
    scaled_jacobian: min over the 8 corners of det[e1, e2, e3] / (|e1||e2||e3|) of the corner's
      three edges (1 for a cube, <= 0 for a tangled corner: the element is unusable);
    aspect_ratio: longest over shortest edge;
    warping: max over the 6 faces of the angle [deg] between the normals of the two triangles
      of a face split along either diagonal (0 for plane faces);
    volume: exact volume [m^3]."""
    x = points[hexes]  # (e, 8, 3)
    c = x[:, _CORNER_NEIGHBOURS] - x[:, :, None, :]  # (e, 8, 3, 3) corner edges
    det = np.einsum("ecj,ecj->ec", c[:, :, 0], np.cross(c[:, :, 1], c[:, :, 2]))
    norms = np.linalg.norm(c, axis=-1).prod(axis=-1)
    sj = (det / np.where(norms > 0, norms, np.inf)).min(axis=1)
    from impactsim.solver.hex8 import EDGES

    edges = np.linalg.norm(x[:, EDGES[:, 1]] - x[:, EDGES[:, 0]], axis=-1)
    ar = edges.max(axis=1) / np.maximum(edges.min(axis=1), 1e-300)
    f = x[:, _FACES]  # (e, 6, 4, 3)
    warp = np.zeros(len(hexes))
    for a, b, cc, d in ((0, 1, 2, 3), (1, 2, 3, 0)):
        n1 = np.cross(f[:, :, b] - f[:, :, a], f[:, :, cc] - f[:, :, a])
        n2 = np.cross(f[:, :, cc] - f[:, :, a], f[:, :, d] - f[:, :, a])
        cosang = np.einsum("efi,efi->ef", n1, n2) / np.maximum(
            np.linalg.norm(n1, axis=-1) * np.linalg.norm(n2, axis=-1), 1e-300)
        warp = np.maximum(warp, np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0))).max(axis=1))
    return {"scaled_jacobian": sj, "aspect_ratio": ar, "warping": warp,
            "volume": hex_volumes(points, hexes)}


def hex_quality_summary(points: np.ndarray, hexes: np.ndarray) -> dict:
    """The report's numbers: element count, volume, min scaled Jacobian, max aspect ratio,
    max warping [deg], and the count of hexes with a corner Jacobian <= 0.2."""
    q = hex_quality(points, hexes)
    return {"elements": int(len(hexes)), "volume": float(q["volume"].sum()),
            "min_scaled_jacobian": float(q["scaled_jacobian"].min()),
            "max_aspect_ratio": float(q["aspect_ratio"].max()),
            "max_warping_deg": float(q["warping"].max()),
            "poor_jacobian": int(np.count_nonzero(q["scaled_jacobian"] <= 0.2))}


HEX_JACOBIAN_WARN = 0.2  # scaled corner Jacobian below which the report warns
HEX_WARP_WARN = 30.0  # [deg]


def hex_lengths(points: np.ndarray, hexes: np.ndarray,
                volume: np.ndarray | None = None) -> np.ndarray:
    """The hex kernel's element length (solver/hex8.py): V / its largest face area, (e,)."""
    f = points[hexes][:, _FACES]
    area = 0.5 * np.linalg.norm(np.cross(f[:, :, 2] - f[:, :, 0], f[:, :, 3] - f[:, :, 1]),
                                axis=-1).max(axis=1)
    return (hex_volumes(points, hexes) if volume is None else volume) / area


def hex_report(points: np.ndarray, hexes: np.ndarray, wave_speed: float, cfl: float) -> dict:
    """The `impactsim mesh` numbers of a hex body: counts, volume, edge lengths, the quality
    measures of `hex_quality` and the expected stable step cfl * min(V / largest face area) / c
    (the hex kernel's length, solver/hex8.py)."""
    from impactsim.solver.hex8 import EDGES

    q = hex_quality(points, hexes)
    x = points[hexes]
    edges = np.linalg.norm(x[:, EDGES[:, 1]] - x[:, EDGES[:, 0]], axis=-1)
    length = hex_lengths(points, hexes, q["volume"])
    return {"nodes": int(len(np.unique(hexes))), "elements": int(len(hexes)),
            "volume": float(q["volume"].sum()), "edge_min": float(edges.min()),
            "edge_mean": float(edges.mean()), "edge_max": float(edges.max()),
            "jacobian_min": float(q["scaled_jacobian"].min()),
            "jacobian_mean": float(q["scaled_jacobian"].mean()),
            "aspect_max": float(q["aspect_ratio"].max()),
            "warping_max": float(q["warping"].max()),
            "length_min": float(length.min()),
            "stable_dt": float(cfl * length.min() / wave_speed), "wave_speed": wave_speed}


def hex_report_lines(q: dict, si) -> list[str]:
    """The report lines of `hex_report` after the body's first two lines."""
    lines = [
        f"  hexahedra: edge length min/mean/max {si(q['edge_min'], 'm')} / "
        f"{si(q['edge_mean'], 'm')} / {si(q['edge_max'], 'm')}",
        f"  scaled corner Jacobian min {q['jacobian_min']:.3g} (mean {q['jacobian_mean']:.3g}), "
        f"aspect ratio worst {q['aspect_max']:.3g}, warping worst {q['warping_max']:.1f} deg, "
        f"smallest V/A {si(q['length_min'], 'm')}",
        f"  expected stable dt {si(q['stable_dt'], 's')} (c = {q['wave_speed']:.0f} m/s)",
    ]
    if q["jacobian_min"] < HEX_JACOBIAN_WARN or q["warping_max"] > HEX_WARP_WARN:
        lines.append(f"  warning: poorly shaped hexahedra (scaled Jacobian {q['jacobian_min']:.3g}"
                     f" < {HEX_JACOBIAN_WARN:g} or warping {q['warping_max']:.1f} deg > "
                     f"{HEX_WARP_WARN:g} deg): inaccurate, and a small time step")
    return lines
