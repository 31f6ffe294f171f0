"""The ``impactsim mesh`` command as a library function: mesh every body, write one VTU, report.

``mesh_case(case, out_dir)`` writes ``<out_dir>/mesh.vtu`` (all bodies, cell data "body" = the
body's index in the case) and returns the text report: per body its shape, mesh size, counts,
mass, edge lengths, worst aspect ratio, dihedral range, smallest altitude and the expected stable
time step cfl * L_min / c with the material's dilatational wave speed c = sqrt((K + 4G/3) / rho)
(the artificial viscosity of the run lowers it further); then the totals and the overall step.
"""

from __future__ import annotations

import math
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from impactsim.case.schema import Case
from impactsim.mesh import MeshError, mesh_body
from impactsim.mesh.quality import quality, sound_speed

ASPECT_WARN = 10.0  # worst aspect ratio R / (3 r) above which the report warns
DIHEDRAL_WARN = 5.0  # [deg] smallest dihedral angle below which the report warns

_PREFIXES = [(1e-9, "n"), (1e-6, "u"), (1e-3, "m"), (1.0, ""), (1e3, "k")]


def si(value: float, unit: str, digits: int = 4) -> str:
    """`value` with an SI prefix making the mantissa 1..1000: si(2.5e-8, 's') == '25 ns'."""
    if value == 0.0 or not math.isfinite(value):
        return f"{value:g} {unit}"
    scale, prefix = _PREFIXES[0]
    for s, p in _PREFIXES:
        if abs(value) >= s:
            scale, prefix = s, p
    return f"{value / scale:.{digits}g} {prefix}{unit}"


def _mass(value: float) -> str:
    """Mass in g below 1 kg, else kg (si() would say 'kg' for grams)."""
    return f"{value * 1e3:.4g} g" if value < 1.0 else f"{value:.4g} kg"


def default_out_dir(case: Case) -> Path:
    """case.output.directory if set, else out/<run.name>."""
    if case.output.directory is not None:
        return Path(case.output.directory)
    return Path("out") / case.run.name


_HEX_MESHER = {"box": "structured", "plate": "structured", "cylinder": "O-grid",
               "sphere": "cube-sphere"}


def write_vtu(path: Path, meshes: list[tuple[np.ndarray, np.ndarray]]) -> None:
    """Write all bodies' tets into one VTU at `path` (cell data "body"), atomically."""
    import meshio

    offsets = np.cumsum([0] + [len(p) for p, _ in meshes])
    points = np.vstack([p for p, _ in meshes])
    blocks, bodies = [], []
    for width, kind in ((4, "tetra"), (8, "hexahedron")):  # one cell block per element type
        parts = [(i, t, off) for i, ((_, t), off) in enumerate(zip(meshes, offsets))
                 if t.shape[1] == width]
        if parts:
            blocks.append((kind, np.vstack([t.astype(np.int64) + off for _, t, off in parts])))
            bodies.append(np.concatenate([np.full(len(t), i, dtype=np.int32)
                                          for i, t, _ in parts]))
    mesh = meshio.Mesh(points, blocks, cell_data={"body": bodies})
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        meshio.write(tmp, mesh, file_format="vtu")
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _body_lines(i: int, body, q: dict | None, mass: float, seconds: float, cfl: float,
                counts: dict | None = None) -> list[str]:
    """The report lines of a tet body (quality dict q); with q None and `counts` given, only
    its first two lines (a hex body: mesh/hexes.py adds its own)."""
    dims = ", ".join(f"{k}={_dim(k, v)}" for k, v in body.dimensions.items())
    how = {"cube12": "the 12-tet cube of [D19]", "file": "imported"}.get(
        body.shape, f"mesher {body.mesher}, mesh size {si(body.mesh_size, 'm')}")
    if body.element == "hex8":
        how = ("imported hexahedra" if body.shape == "file" else
               f"hexahedra ({_HEX_MESHER.get(body.shape, 'structured')}), mesh size "
               f"{si(body.mesh_size, 'm')}")
    if q is None:
        return [f"body[{i}] {body.name}: {body.shape} ({dims}), {how}",
                f"  nodes {counts['nodes']}, elements {counts['elements']}, volume "
                f"{counts['volume']:.6g} m^3, mass {_mass(mass)}, meshed in {seconds:.2f} s"]
    lines = [
        f"body[{i}] {body.name}: {body.shape} ({dims}), {how}",
        f"  nodes {q['nodes']}, elements {q['elements']}, volume {q['volume']:.6g} m^3, "
        f"mass {_mass(mass)}, meshed in {seconds:.2f} s",
        f"  edge length min/mean/max {si(q['edge_min'], 'm')} / {si(q['edge_mean'], 'm')} / "
        f"{si(q['edge_max'], 'm')}",
        f"  aspect ratio R/3r worst {q['aspect_max']:.3g} (mean {q['aspect_mean']:.3g}), "
        f"dihedral {q['dihedral_min']:.1f}..{q['dihedral_max']:.1f} deg, "
        f"smallest altitude {si(q['altitude_min'], 'm')}",
        f"  expected stable dt {si(q['stable_dt'], 's')} (cfl {cfl:g}, "
        f"c = {q['wave_speed']:.0f} m/s)",
    ]
    if q["aspect_max"] > ASPECT_WARN or q["dihedral_min"] < DIHEDRAL_WARN:
        lines.append(f"  warning: poorly shaped elements (worst aspect ratio {q['aspect_max']:.3g} "
                     f"> {ASPECT_WARN:g} or smallest dihedral {q['dihedral_min']:.1f} deg < "
                     f"{DIHEDRAL_WARN:g} deg): they set a small time step and are inaccurate")
    return lines


def _dim(key: str, value) -> str:
    """One dimension for the report: lengths with an SI prefix, axis and scale as plain numbers."""
    if key in ("axis", "scale"):
        if isinstance(value, (tuple, list, np.ndarray)):
            return "(" + ", ".join(f"{float(v):g}" for v in value) + ")"
        return f"{float(value):g}"
    if isinstance(value, (tuple, list, np.ndarray)):
        largest = si(max(abs(float(v)) for v in value), "m").split()[-1]
        scale = {p + "m": s for s, p in _PREFIXES}.get(largest, 1.0)
        return " x ".join(f"{float(v) / scale:.4g}" for v in value) + f" {largest}"
    if isinstance(value, (int, float)):
        return si(float(value), "m")
    return str(value)


def mesh_case(case: Case, out_dir: Path | None = None) -> str:
    """Mesh every body of `case`, write <out_dir>/mesh.vtu and return the quality report.

    out_dir defaults to case.output.directory, else out/<run.name>. A body that cannot be
    meshed raises MeshError naming the case file and the body.
    """
    out_dir = Path(out_dir) if out_dir is not None else default_out_dir(case)
    cfl = case.run.cfl
    meshes, lines = [], []
    total_nodes = total_elements = 0
    total_mass = 0.0
    overall_dt = math.inf
    for i, body in enumerate(case.bodies):
        start = time.perf_counter()
        try:
            points, tets = mesh_body(body)
        except MeshError as err:
            where = f"{case.source}: " if case.source is not None else ""
            raise MeshError(f"{where}body[{i}] (body \"{body.name}\"): {err}") from err
        seconds = time.perf_counter() - start
        material = case.materials[body.material]
        c = sound_speed(material.density, material.bulk_modulus, material.shear_modulus)
        if tets.shape[1] == 8:  # hexahedra (mesh/hexes.py)
            from impactsim.mesh.hexes import hex_report, hex_report_lines

            q = hex_report(points, tets, c, cfl)
            mass = material.density * q["volume"]
            lines += _body_lines(i, body, None, mass, seconds, cfl, q)[:2]
            lines += hex_report_lines(q, si)
        else:
            q = quality(points, tets, wave_speed=c, cfl=cfl)
            q["wave_speed"] = c
            mass = material.density * q["volume"]
            lines += _body_lines(i, body, q, mass, seconds, cfl)
        meshes.append((points, tets))
        total_nodes += q["nodes"]
        total_elements += q["elements"]
        total_mass += mass
        overall_dt = min(overall_dt, q["stable_dt"])
    path = out_dir / "mesh.vtu"
    if meshes:
        write_vtu(path, meshes)
        bodies = f"{len(meshes)} bod{'y' if len(meshes) == 1 else 'ies'}"
        lines.append(f"total: {bodies}, nodes {total_nodes}, elements {total_elements}, "
                     f"mass {_mass(total_mass)}, expected stable dt {si(overall_dt, 's')} "
                     f"(cfl {cfl:g})")
        lines.append(f"wrote {path}")
    else:
        lines.append("no bodies to mesh")
    return "\n".join(lines)
