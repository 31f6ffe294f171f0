"""What a case will cost before it runs: elements, time steps and wall time.

``estimate_cost(case)`` returns an ``Estimate``; ``estimate_lines(case)`` the lines that
``impactsim check`` prints, ending with

    ≈ N elements, ≈ M steps, ≈ T wall (at X ns/element-step measured on this machine)

Elements. Structured boxes and the 12-tet cube are counted exactly. For gmsh primitives the count
is a fit to the real mesher (``GMSH_PER_H3``, ``GMSH_PER_H2``): a volume term plus a surface term,
since elements near the surface are smaller than inside. A body thinner than its mesh size gets
one layer of elements (``THIN_PER_H2`` per h^2 of its mid-surface). Mesh files: unknown before
reading, so not counted.

Steps. M = end_time / (cfl · L_min / c): L_min the smallest element altitude (the element length
of the time step, ALGORITHMS.md 1) and c the longitudinal wave speed sqrt((K + 4G/3)/rho) of the
fastest material. Structured boxes: L_min exact, from the Kuhn split of one cell. gmsh:
L_min = ``GMSH_ALTITUDE_RATIO`` · h, measured on the same meshes. Compression raises the sound
speed, the artificial viscosity lowers the step (by sqrt(1 + C_l^2) - C_l, taken always) and
each output frame costs about FRAME_STEPS steps; plastic flattening shrinks elements, so a
Taylor-bar-like impact takes more steps than this (about 1.5 times: 3,509 against 2,300).

Wall time. T = M (t_step + N · t_element), the loop's time per step, with the two constants
measured on this machine by a short run of the element loop (a Johnson-Cook copper block on a
rigid wall, with the per-step history accounting of a real run): ``calibrate_speed``, about two
seconds, run by ``python -m impactsim.case.estimate`` or the first time an estimate is asked
for. The figures are stored per host and thread count in ``speed.json`` next to the mesh cache
(the parent of $IMPACTSIM_CACHE when set, else ~/.cache/impactsim). IMPACTSIM_NO_CALIBRATE=1
skips the measurement when no file exists and uses ``DEFAULT_SPEED`` (for tests and CI).
Contact and fracture passes and frame output come on top of this figure: the end-of-run table of
seconds per pass shows what they cost.
"""

from __future__ import annotations

import json
import math
import os
import platform
import tempfile
import time as wallclock
from dataclasses import dataclass
from datetime import datetime, timezone
from itertools import permutations
from pathlib import Path

import numpy as np

from impactsim.case.schema import Body, Case

# Measured with impactsim.mesh.mesh_body (gmsh 4.x, HXT mesher) on a unit box, a 1 x 0.5 x 0.25
# box, cylinders of radius 0.5 and 0.15 (height 1), a sphere of radius 0.5 and a 1 x 1 x 0.1
# plate, each at 4-6 mesh sizes h from 0.25 to 0.025 (300 to 93,000 tets). A least-squares fit of
# the relative error over the meshes of 1,000 tets or more gives
#   tets = GMSH_PER_H3 · V / h^3 + GMSH_PER_H2 · S / h^2     (V volume, S surface area),
# within 5 % of every one of them (within 30 % below 1,000 tets).
GMSH_PER_H3 = 3.62
GMSH_PER_H2 = 1.51
# Bodies thinner than h (plates of thickness t = 0.02 with h = 0.05, 0.1, 0.2): 7.3-8.0 tets per
# h^2 of mid-surface, one layer through the thickness.
THIN_PER_H2 = 7.5
# Smallest altitude / h over the same meshes: median 0.37, quartiles 0.32-0.40; 0.35 taken.
# (Thin bodies: 0.35 of the thickness; gmsh makes an occasional sliver there, far smaller.)
GMSH_ALTITUDE_RATIO = 0.35
# Used when there is no measurement and IMPACTSIM_NO_CALIBRATE=1: what calibrate_speed measured
# on the development machine (2 shared cores, numba 0.60, both threads), rounded up.
DEFAULT_SPEED = {"ns_per_element_step": 500.0, "seconds_per_step": 1.0e-4, "source": "default"}
SPEED_FILE_VERSION = 1
# A step clamped to land on an output time is a random fraction f of the stable one; growing back
# by 10 % a step (solver.loop.DT_GROWTH) then costs ln(1/f)/ln 1.1 - 11 (1 - f) steps more than
# at full size: 5 on average over f.
FRAME_STEPS = 5


@dataclass
class Estimate:
    """The cost of a case. elements/l_min exclude mesh-file bodies (``unknown_bodies``)."""

    elements: int  # tetrahedra of the bodies that can be estimated
    per_body: dict  # body name -> element count (None for a mesh file)
    l_min: float  # [m] smallest element altitude
    wave_speed: float  # [m/s] fastest longitudinal wave speed
    dt: float  # [s] first time step, cfl · l_min / c
    steps: int
    wall_seconds: float
    speed: dict  # ns_per_element_step, seconds_per_step, source ("measured ..." or "default")
    unknown_bodies: list

    def line(self) -> str:
        src = self.speed.get("source", "default")
        where = "measured on this machine" if src.startswith("measured") else \
            "default, not measured"
        extra = f" + the mesh files of {', '.join(self.unknown_bodies)}" if self.unknown_bodies \
            else ""
        return (f"≈ {self.elements:,} elements{extra}, ≈ {self.steps:,} steps, "
                f"≈ {format_seconds(self.wall_seconds)} wall (at "
                f"{self.speed['ns_per_element_step']:.0f} ns/element-step {where})")


# --- elements and element sizes ---------------------------------------------------------------
def body_area(body: Body) -> float | None:
    """Surface area [m^2] of the primitive; None for a mesh file."""
    d = body.dimensions
    if body.shape in ("box", "plate"):
        lx, ly, lz = d["size"]
        return 2.0 * (lx * ly + ly * lz + lz * lx)
    if body.shape == "cube12":
        return 6.0 * d["size"] ** 2
    if body.shape == "cylinder":
        r, h = d["radius"], d["height"]
        return 2.0 * math.pi * r * r + 2.0 * math.pi * r * h
    if body.shape == "sphere":
        return 4.0 * math.pi * d["radius"] ** 2
    return None


def _smallest_extent(body: Body) -> float:
    d = body.dimensions
    if body.shape in ("box", "plate"):
        return min(d["size"])
    if body.shape == "cylinder":
        return min(2.0 * d["radius"], d["height"])
    return 2.0 * d["radius"]


def body_elements(body: Body) -> int | None:
    """Tetrahedra of the body's mesh: exact for structured boxes and cube12, fitted for gmsh."""
    from impactsim.case.describe import body_volume
    from impactsim.mesh.structured import cells_per_axis

    if body.shape == "cube12":
        return 12
    if body.shape == "file":
        return None
    if body.element == "hex8":  # hexes (mesh/hexes.py): meshed here, it takes milliseconds
        return len(_hex_mesh(body)[1])
    h = body.mesh_size
    if body.mesher == "structured":
        nx, ny, nz = cells_per_axis(body.dimensions["size"], h)
        return 6 * nx * ny * nz
    volume = body_volume(body)
    t = _smallest_extent(body)
    if t < h:
        return max(1, round(THIN_PER_H2 * (volume / t) / h**2))
    return max(1, round(GMSH_PER_H3 * volume / h**3 + GMSH_PER_H2 * body_area(body) / h**2))


# a hex-step costs about this many tet-steps (docs/performance.md: 190 against 80 ns on one
# thread, the Johnson-Cook bench of each, measured at the same time)
HEX_COST = 2.4


def _hex_mesh(body: Body):
    from impactsim.mesh.hexes import raw_hex_mesh

    return raw_hex_mesh(body)


def kuhn_min_altitude(dx: float, dy: float, dz: float) -> float:
    """Smallest altitude [m] of the six Kuhn tets of a dx × dy × dz cell (the structured mesh)."""
    from impactsim.mesh.quality import altitudes

    corner = np.zeros(3)
    points, tets = [corner], []
    for perm in permutations(range(3)):
        path = [0]
        c = np.zeros(3)
        for axis in perm:
            c = c.copy()
            c[axis] = (dx, dy, dz)[axis]
            points.append(c)
            path.append(len(points) - 1)
        tets.append(path)
    return float(altitudes(np.array(points), np.array(tets)).min())


def body_min_length(body: Body) -> float | None:
    """Smallest element altitude [m] of the body's mesh (estimated for gmsh, exact otherwise)."""
    from impactsim.mesh.structured import cells_per_axis

    d = body.dimensions
    if body.shape == "file":
        return None
    if body.element == "hex8":  # the hex kernel's V / largest face area
        from impactsim.mesh.hexes import hex_report

        return hex_report(*_hex_mesh(body), 1.0, 1.0)["length_min"]
    if body.shape == "cube12":
        from impactsim.mesh.quality import altitudes
        from impactsim.mesh.structured import cube12

        return float(altitudes(*cube12(d["size"])).min())
    h = body.mesh_size
    if body.mesher == "structured":
        size = d["size"]
        n = cells_per_axis(size, h)
        return kuhn_min_altitude(*(length / k for length, k in zip(size, n)))
    return GMSH_ALTITUDE_RATIO * min(h, _smallest_extent(body))


def wave_speed(case: Case, body: Body) -> float:
    """Longitudinal wave speed [m/s] sqrt((K + 4G/3)/rho) of the body's material at rest."""
    from impactsim.materials.params import longitudinal_wave_speed

    return longitudinal_wave_speed(case.materials[body.material])


# --- machine speed ----------------------------------------------------------------------------
def speed_file() -> Path:
    """Where the measured speed is kept: next to the mesh cache (module docstring)."""
    value = os.environ.get("IMPACTSIM_CACHE", "").strip()
    if value and value.lower() != "off":
        return Path(value).parent / "speed.json"
    return Path.home() / ".cache" / "impactsim" / "speed.json"


def _machine_key(threads: int) -> str:
    return f"{platform.node()}|{platform.machine()}|threads={threads}"


def _threads(case: Case | None = None) -> int:
    import numba

    if case is not None and case.run.threads > 0:
        return min(case.run.threads, numba.config.NUMBA_NUM_THREADS)
    return numba.config.NUMBA_NUM_THREADS


def _read_speeds(path: Path) -> dict:
    try:
        data = json.loads(path.read_text())
        if data.get("version") == SPEED_FILE_VERSION and isinstance(data.get("machines"), dict):
            return data
    except (OSError, ValueError):
        pass
    return {"version": SPEED_FILE_VERSION, "machines": {}}


def _speed_case(cells: int):
    from impactsim.case import load_case_text

    h = 0.5e-3
    side = cells * h
    return load_case_text(f"""
[run]
name = "speed"
end_time = 1.0
[[body]]
name = "block"
material = "ofhc-copper"
shape = "box"
size = [{side}, {side}, {side}]
position = [0, 0, {side / 2 + 1e-7}]
mesh_size = {h}
mesher = "structured"
velocity = [0, 0, -190]
[[wall]]
point = [0, 0, 0]
normal = [0, 0, 1]
""")


def _seconds_per_step(cells: int, seconds: float, chunk: int) -> tuple[int, float]:
    """(elements, loop seconds per step) of the copper block run for about `seconds`: the median
    over chunks of `chunk` steps, so a moment when other processes hold the cores counts little."""
    from impactsim.mesh import mesh_body
    from impactsim.solver.build import build_model
    from impactsim.solver.loop import Simulation
    from impactsim.solver.pipeline import build_passes

    case = _speed_case(cells)
    model = build_model(case, [mesh_body(case.bodies[0], use_cache=False)])
    sim = Simulation(model, build_passes(case, model), cfl=0.6)
    for _ in range(3):  # warm-up (loads the compiled kernels)
        sim.step()
        sim.energies(), sim.momentum()
    rates, start = [], wallclock.perf_counter()
    while wallclock.perf_counter() - start < seconds or len(rates) < 3:
        t0 = wallclock.perf_counter()
        for _ in range(chunk):
            sim.step()
            sim.energies(), sim.momentum()  # what a history row costs per step
        rates.append((wallclock.perf_counter() - t0) / chunk)
    return model.n_elem, float(np.median(rates))


def calibrate_speed(threads: int | None = None, seconds: float = 1.6, store: bool = True) -> dict:
    """Measure the loop's cost per step on this machine: t_step + N t_element.

    Two runs of the copper block on a wall: 384 tets (the per-step overhead dominates) and
    24,576 tets (the element loop dominates), about seconds/4 and 3 seconds/4 each; the two
    constants solve the two equations. Stored in speed_file() unless store is False.
    """
    import numba

    from impactsim import __version__

    threads = threads or _threads()
    previous = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        n_small, t_small = _seconds_per_step(4, 0.25 * seconds, 20)
        n_big, t_big = _seconds_per_step(16, 0.75 * seconds, 4)
    finally:
        numba.set_num_threads(previous)
    per_element = max((t_big - t_small) / (n_big - n_small), 1e-10)
    per_step = max(t_small - n_small * per_element, 0.0)
    speed = {"ns_per_element_step": 1e9 * per_element, "seconds_per_step": per_step,
             "threads": threads, "impactsim": __version__,
             "source": "measured " + datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")}
    if store:
        path = speed_file()
        data = _read_speeds(path)
        data["machines"][_machine_key(threads)] = speed
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".speed-", suffix=".json")
            with os.fdopen(fd, "w") as stream:
                json.dump(data, stream, indent=1)
            os.replace(tmp, path)
        except OSError:
            pass  # an unwritable cache only costs a new measurement next time
    return speed


def machine_speed(threads: int | None = None, calibrate: bool | None = None) -> dict:
    """The stored speed of this machine for `threads`; measured now if missing (unless
    IMPACTSIM_NO_CALIBRATE=1 or calibrate=False, which give DEFAULT_SPEED)."""
    threads = threads or _threads()
    found = _read_speeds(speed_file())["machines"].get(_machine_key(threads))
    if found:
        return found
    if calibrate is None:
        calibrate = os.environ.get("IMPACTSIM_NO_CALIBRATE", "") not in ("1", "true", "yes")
    if not calibrate:
        return dict(DEFAULT_SPEED)
    try:
        return calibrate_speed(threads)
    except Exception as err:  # noqa: BLE001  an estimate must never stop `impactsim check`
        return dict(DEFAULT_SPEED, source=f"default (measuring failed: {err})")


# --- the estimate -----------------------------------------------------------------------------
def estimate_cost(case: Case, speed: dict | None = None) -> Estimate:
    """Elements, steps and wall time of `case` (module docstring)."""
    per_body, unknown = {}, []
    l_min, c_max = math.inf, 0.0
    for body in case.bodies:
        n = body_elements(body)
        per_body[body.name] = n
        if n is None:
            unknown.append(body.name)
            continue
        l_min = min(l_min, body_min_length(body))
        c_max = max(c_max, wave_speed(case, body))
    elements = sum(n for n in per_body.values() if n)
    # the cost in tet-steps: a hex costs HEX_COST of them
    work = sum(n * (HEX_COST if b.element == "hex8" else 1.0)
               for b, n in zip(case.bodies, per_body.values()) if n)
    if elements and c_max > 0.0:
        dt = case.run.cfl * l_min / c_max
        # the linear viscosity's share of the step in compression, L / (Q + sqrt(Q^2 + c^2))
        # with Q = C_l c (physics.md), and the steps lost landing on each output frame
        viscous = math.sqrt(1.0 + case.run.q_linear**2) - case.run.q_linear
        frames = len(case.output.times) if case.output.times else case.output.frames
        steps = math.ceil(case.run.end_time / (viscous * dt)) + FRAME_STEPS * frames
        steps = min(case.run.max_steps, steps)
    else:
        dt, steps = math.nan, 0
    if speed is None:
        speed = machine_speed(_threads(case))
    wall = steps * (speed["seconds_per_step"] + work * 1e-9 * speed["ns_per_element_step"])
    return Estimate(elements=elements, per_body=per_body, l_min=l_min, wave_speed=c_max, dt=dt,
                    steps=steps, wall_seconds=wall, speed=speed, unknown_bodies=unknown)


def estimate_lines(case: Case, speed: dict | None = None) -> list[str]:
    """The cost lines of ``impactsim check`` (appended to describe.what_would_run)."""
    from impactsim.case.units import format_quantity

    est = estimate_cost(case, speed)
    lines = ["#", "# cost estimate:"]
    for name, n in est.per_body.items():
        lines.append(f"#   {name}: " + (f"≈ {n:,} elements" if n is not None
                                        else "mesh file: elements known after meshing"))
    if est.elements:
        lines.append(f"#   smallest element length ≈ {format_quantity(est.l_min, 'length')}, "
                     f"wave speed {est.wave_speed:,.0f} m/s -> first step ≈ "
                     f"{format_quantity(est.dt, 'time')}")
    lines.append("#   " + est.line())
    return lines


def format_seconds(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    if seconds < 60:
        return f"{seconds:.2g} s" if seconds < 10 else f"{seconds:.0f} s"
    if seconds < 3600:
        return f"{seconds / 60:.1f} min"
    if seconds < 48 * 3600:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 86400:.1f} days"


def main() -> None:
    """``python -m impactsim.case.estimate``: measure this machine's speed and store it."""
    speed = calibrate_speed()
    print(f"{speed['ns_per_element_step']:.0f} ns/element-step, "
          f"{1e6 * speed['seconds_per_step']:.0f} us/step overhead on {speed['threads']} "
          f"thread(s); stored in {speed_file()}")


if __name__ == "__main__":
    main()
