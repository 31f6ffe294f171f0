"""What a case will cost before it runs: elements, time steps and wall time.

``estimate_cost(case)`` returns an ``Estimate``; ``estimate_lines(case)`` the lines that
``impactsim check`` prints, ending with

    ≈ N elements, ≈ M steps, ≈ T wall (at X ns/element-step measured on this machine)

Elements. Structured boxes and the 12-tet cube are counted exactly. For gmsh primitives the count
is a fit to the real mesher (``GMSH_PER_H3``, ``GMSH_PER_H2``): a volume term plus a surface term,
since elements near the surface are smaller than inside. A body thinner than its mesh size gets
one layer of elements (``THIN_PER_H2`` per h^2 of its mid-surface). Mesh files: unknown before
reading, so not counted.

Steps. M = F end_time / (cfl · min(L / c)): L a body's smallest element altitude (the element
length of the time step, ALGORITHMS.md 1) and c its material's longitudinal wave speed
sqrt((K + 4G/3)/rho), the smallest ratio over the bodies. Structured boxes: L exact, from the
Kuhn split of one cell. gmsh: L = ``GMSH_ALTITUDE_RATIO`` · h, measured on the same meshes.
Compression raises the sound speed, the artificial viscosity lowers the step (by
sqrt(1 + C_l^2) - C_l, taken always) and each output frame inside the run costs about
FRAME_STEPS steps. F, the crush factor, is the mean shrink of the step as plastic impacts
flatten and shear the elements (case/crush.py: the Taylor bar 3.1, the tet two-cylinders 14,
the elastic cases 1).

Wall time. The element loop's time per step t_step + N · t_element, with the two constants
measured on this machine by a short run of the element loop (a Johnson-Cook copper block on a
rigid wall, with the per-step history accounting of a real run): ``calibrate_speed``, about two
seconds, run by ``python -m impactsim.case.estimate`` or the first time an estimate is asked
for. The figures are stored per host and thread count in ``speed.json`` next to the mesh cache
(the parent of $IMPACTSIM_CACHE when set, else ~/.cache/impactsim). IMPACTSIM_NO_CALIBRATE=1
skips the measurement when no file exists and uses ``DEFAULT_SPEED`` (for tests and CI).
The speed is measured and used for the thread count the run will use (``run_threads``: the rule
of solver.run.thread_count, one thread below 50,000 elements); a measurement outside
PLAUSIBLE_NS / PLAUSIBLE_STEP_SECONDS is noise and is discarded (never stored).

Every pass is counted in units of t_element (the calibration keeps its quietest moment: the
speed of a free core) times the contention (``contention``: 1 / the share of a core this process
gets now, ``cpu_share``: from the Linux scheduler's run and run-queue times of the thread, or
elsewhere a 0.3 s busy loop; on a machine shared with other jobs a
run gets about that share on average): the element loop
(ANP_COST for the averaged nodal pressure, HEX_COST for a hex, HEX_FAILING_COST for a hex of a
material that can be damaged, SEPARABLE_COST for an element of a body that comes apart by node
separation, PARALLEL_COST on two threads), the node passes and the watch, the contact passes
(per boundary face and step, more with self-contact), the fracture passes (``fracture_work``:
the criteria per element and step, a hex's with its scalar path and removals; the distortion
check per element once per interval; node separation per element of a separable body and
step), frame output (per element and frame), the history rows (with contact, its
max_penetration measure per boundary face), setting up (fixed and per element), and gmsh meshing of bodies not in the mesh cache: the constants are fitted to the bundled cases
(docs/estimates.md, benchmarks/estimates.py).

Re-estimate. After RE_ESTIMATE_SHARE of its simulated time or RE_ESTIMATE_SECONDS of stepping a
run estimates itself again (``re_estimate``): the steps left at the step it takes now, shrunk
further as the crush model says from there on, at the seconds per step it measured; printed, and
kept in summary.json (``re_estimate``).

Memory. BASE_BYTES + BYTES_PER_ELEMENT per element (peak RSS of the bundled runs: 300-350 MB up
to 35k tets, 531 MB at 164k, 740 MB at 212k). ``check_fits`` refuses, before meshing, a case
whose estimate exceeds the memory the machine has available, naming the largest body's
mesh_size and both figures.
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

from impactsim.case.crush import crushes, shrink_profile, step_factor
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
# 2: one-thread calibrations timed in the thread's CPU time (a free core's figure); the
# wall-time figures of version 1 mean something else and are not read
SPEED_FILE_VERSION = 2
# A calibration outside these bounds is noise (a busy machine, a timer glitch) and is discarded:
# the element kernel costs 100-1000 ns per element-step on any x86 core of the last decade.
PLAUSIBLE_NS = (30.0, 30_000.0)
PLAUSIBLE_STEP_SECONDS = (0.0, 0.05)
# The run's passes in units of t_e, the calibrated seconds per element-step (the fastest chunk
# of the calibration: a free core), for a run that has a core to itself; the wall time divides
# them by the share of a core the run gets (contention()). Fitted to the seconds per pass of the
# bundled runs times their share of a core (process CPU over wall; benchmarks/estimates.py,
# docs/estimates.md):
# - the element loop 0.9-1.7 t_e per tet-step with tet4 (the calibration's block is a best
#   case; the small scenes pay a per-step overhead), ANP_COST times that with the averaged
#   nodal pressure (Taylor bar), a hex HEX_COST tet-steps; on two threads PARALLEL_COST times
#   the two-thread calibration (a thread waits for the other at every launch when the cores
#   are shared);
# - the node passes and the watch 0.1-0.3 t_e per element-step;
# - the contact passes 2.6-9.4 t_e per boundary face and step;
# - the fracture passes 0.8-2.0 t_e per element-step (oblique-sphere, sphere-plate);
# - a frame 20-95 t_e per element (the large ones cheapest) and its own 10 ms; a history row
#   with contact, its max_penetration measure, 2-4 t_e per boundary face in the crushing
#   scenes, next to nothing in the elastic ones;
# - setting up a run (imports, loading the compiled kernels, building the state) 0.55-0.7 s of
#   CPU and about 12 us per element; gmsh about 250 us per tetrahedron when the mesh is not in
#   the cache (a 17k-tet sphere in 4.7 s).
ELEMENT_TE = 1.1
ANP_COST = 1.4
PARALLEL_COST = 1.65
NODES_TE = 0.15
CONTACT_TE_PER_FACE = 6.0
FRACTURE_TE = 1.3
# a hex's fracture criteria (fracture/hexes.py, with its removals re-running the hex kernel):
# fitted in-sample to sphere-plate-hex (4.4 t_e per element-step in all, the distortion checks
# and the sphere's tets taken out), one case
HEX_FRACTURE_TE = 4.5
# the distortion check [Z] per element and check (one pass, fracture/distortion.py), measured
# on the sphere-plate-hex meshes: 31 ns a tet, 55 ns a hex at 60-68 ns per element-step;
# keyed by "is a hex"
DISTORTION_TE = {False: 0.5, True: 0.9}
# node separation [Z] (fracture/separation.py) per element of a separable body and step, and
# contact with self-contact per boundary face and step (every face also searched against its
# own body's, the faces that node separation opens inside included): fitted in-sample to the
# first 1.5 us of three-plate-shield (its passes' seconds times the run's CPU / wall, 0.21 of
# a core, at the calibrated 69 ns per element-step: 3.6 and 64 t_e; 12.2 for the separation
# before its refresh in place, d766aef), one case; there its element loop cost 1.6 t_e per
# tet-step and the node passes 0.24 (a separable body's elements each have their own corner
# nodes, build.split_points), SEPARABLE_COST times a tet's, and its criteria and particle
# passes 1.1 t_e per element-step (FRACTURE_TE)
SEPARATION_TE = 3.6
SELF_CONTACT_TE_PER_FACE = 60.0
SEPARABLE_COST = 1.5
FRAME_TE_PER_ELEMENT = {"zlib": 45.0, "none": 12.0}
FRAME_SECONDS = 0.01  # a frame's own cost (files, the series' index), whatever its size
ROW_TE_PER_FACE = 2.0
RUN_SECONDS_PER_STEP = 3e-5
SETUP_SECONDS = 0.6
SETUP_SECONDS_PER_ELEMENT = 12e-6
GMSH_SECONDS_PER_ELEMENT = 2.5e-4
FACES_PER_H2 = 2.2  # boundary triangles per h^2 of surface (structured 2, gmsh about 2.3)
# Peak memory: the interpreter with numpy, numba, gmsh and meshio loaded, and per element the
# state, the integrator's buffers, the contact surface and the frames being written.
BASE_BYTES = 400e6
BYTES_PER_ELEMENT = 2000.0
# A step clamped to land on an output time inside the run: the loop reaches it in one or two
# steps of at least half the stable one and grows back by 10 % a step (solver.loop.DT_GROWTH);
# the bundled runs lose about one step per such frame (elastic-bar-wall: 7 for 11 frames).
FRAME_STEPS = 1


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
    threads: int = 1  # numba threads the run will use
    memory_bytes: float = 0.0  # peak memory of the run
    seconds: dict | None = None  # wall seconds per part: elements, contact, fracture, output
    steps_needed: int = 0  # steps to end_time (steps is this, capped at run.max_steps)
    crush_factor: float = 1.0  # mean shrink of the step by crushing (case/crush.py)
    contention: float = 1.0  # 1 / the share of a core the run gets (contention())
    # the crush model behind crush_factor: (crushes, each body's first step l/c, the run's)
    crush: tuple = ((), (), 0.0)

    def shrink_ahead(self, time: float, end_time: float) -> float:
        """How many times more steps [time, end_time] takes than at the step of `time`, by the
        crush model: the mean over it of dt(time) / dt(t)."""
        found, own, first = self.crush
        if not found or not end_time > time:
            return 1.0
        now = float(shrink_profile(found, own, first, [time])[0])
        return step_factor(found, own, first, end_time, start=time) / now

    def line(self) -> str:
        src = self.speed.get("source", "default")
        where = "measured on this machine" if src.startswith("measured") else \
            "default, not measured"
        extra = f" + the mesh files of {', '.join(self.unknown_bodies)}" if self.unknown_bodies \
            else ""
        return (f"≈ {self.elements:,} elements{extra}, ≈ {self.steps:,} steps, "
                f"≈ {format_bytes(self.memory_bytes)} memory, "
                f"≈ {format_seconds(self.wall_seconds)} wall on {self.threads} thread(s) (at "
                f"{self.speed['ns_per_element_step']:.0f} ns/element-step {where})")

    def detail_lines(self) -> list[str]:
        """The wall time per part, and a warning when max_steps ends the run early."""
        parts = self.seconds or {}
        out = []
        if self.crush_factor > 1.05:
            found = self.crush[0]
            worst = max(found, key=lambda c: c.shrink) if found else None
            out.append(f"crushing: the step shrinks ≈ {self.crush_factor:.2g} times on average "
                       "over the run" + (f" (crush number {worst.phi:.2g}, foot strain "
                                         f"{worst.strain:.2g}: down to 1/{worst.shrink:.2g} "
                                         "of a body's first step)" if worst else ""))
        if parts:
            out.append("wall time: " + ", ".join(f"{k} ≈ {format_seconds(v)}"
                                                 for k, v in parts.items()))
        if self.steps_needed > self.steps:
            out.append(f"warning: run.max_steps = {self.steps:,} stops the run before its end "
                       f"time (≈ {self.steps_needed:,} steps needed)")
        return out


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

    if body.shape == "cube12":
        return 12
    if body.shape == "file":
        return None
    if body.element == "hex8":  # hexes (mesh/hexes.py): meshed here while that is cheap
        n = _hex_count(body)
        return len(_hex_mesh(body)[1]) if n <= HEX_MESH_LIMIT else _count(n)
    h = body.mesh_size
    if body.mesher == "structured":
        n = 6.0
        for length in body.dimensions["size"]:
            k = length / h
            n *= max(1.0, float(round(k)) if k < MAX_COUNT else k)
        return _count(n)
    volume = body_volume(body)
    t = _smallest_extent(body)
    if t < h:
        return _count(THIN_PER_H2 * (volume / t) / h / h)
    return _count(GMSH_PER_H3 * volume / h / h / h + GMSH_PER_H2 * body_area(body) / h / h)


MAX_COUNT = 10**18  # element counts are capped here (a mesh_size of 1e-300 m is refused anyway)


def _count(n: float) -> int:
    """A float count as an int >= 1, capped at MAX_COUNT (inf and overflow included)."""
    if not n < MAX_COUNT:
        return MAX_COUNT
    return max(1, round(n))


# a hex-step costs about this many tet-steps (docs/performance.md: 190 against 80 ns on one
# thread, the Johnson-Cook bench of each, measured at the same time; in the bundled Taylor bar
# with hexes 2.8 of the element loop's calibrated tet-steps, docs/estimates.md)
HEX_COST = 2.8
# a hex of a material that can be damaged (spall, loosening, erosion): a block of 32 hexes with
# one damaged hex takes the scalar path (848 against 192 ns per hex-step, docs/performance.md);
# fitted in-sample to sphere-plate-hex's element loop (its plate's hexes 4.8 tet-steps each),
# one case
HEX_FAILING_COST = 4.8


# above this many hexes (about a second of meshing) the count is not made by meshing: a case
# with a huge body (a fuzzed size, a typo in the mesh size) must not allocate the mesh just to
# be told it does not fit
HEX_MESH_LIMIT = 1_000_000
# the smallest V / largest face of O-grid cylinders and cube-spheres over their mesh size (the
# corner cells; 0.61-0.74 on the bundled cylinders, 0.41-0.47 on cube-spheres), for bodies
# above that limit
HEX_CURVED_LENGTH = 0.4


def _hex_count(body: Body) -> float:
    """The hexes of a primitive's mesh without making it: exact cells per axis for boxes and
    plates, the volume over h^3 (the O-grid and cube-sphere cells are about h wide) for
    cylinders and spheres."""
    from impactsim.case.describe import body_volume

    h = body.mesh_size
    if body.shape in ("box", "plate"):
        n = 1.0
        for length in body.dimensions["size"]:
            k = length / h
            n *= max(1.0, float(round(k)) if k < MAX_COUNT else k)
        return n
    return body_volume(body) / h / h / h


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
        from impactsim.mesh.hexes import hex_lengths

        if _hex_count(body) <= HEX_MESH_LIMIT:
            return float(hex_lengths(*_hex_mesh(body)).min())
        if body.shape in ("box", "plate"):  # a box cell's V / largest face: its least side
            return min(length / max(1.0, round(length / body.mesh_size))
                       for length in d["size"])
        return HEX_CURVED_LENGTH * body.mesh_size
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
    """(elements, loop seconds per step) of the copper block run for about `seconds`: the fastest
    of the chunks of `chunk` steps, since other processes holding the cores only ever slow a
    chunk down (the median of a busy minute measured 4x the quiet figure); on one thread in
    the thread's CPU time (a chunk's wall time under a share of 0.4 of a core was 1.7 times
    its CPU time even in the fastest chunk)."""
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
    # on one thread the kernels run in this thread: its CPU time is what a free core takes, even
    # when other jobs hold the cores (a chunk's wall time then includes their turns)
    import numba

    clock = wallclock.thread_time if numba.get_num_threads() == 1 else wallclock.perf_counter
    rates, start = [], wallclock.perf_counter()
    while wallclock.perf_counter() - start < seconds or len(rates) < 3:
        t0 = clock()
        for _ in range(chunk):
            sim.step()
            sim.energies(), sim.momentum()  # what a history row costs per step
        rates.append((clock() - t0) / chunk)
    return model.n_elem, float(np.min(rates))


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
    if not plausible(speed):
        return dict(DEFAULT_SPEED, threads=threads,
                    source=f"default (a measurement of {speed['ns_per_element_step']:.3g} "
                           f"ns/element-step, {speed['seconds_per_step']:.3g} s/step was "
                           "implausible and discarded)")
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


def plausible(speed: dict) -> bool:
    """A measured speed within PLAUSIBLE_NS and PLAUSIBLE_STEP_SECONDS."""
    try:
        ns, step = float(speed["ns_per_element_step"]), float(speed["seconds_per_step"])
    except (KeyError, TypeError, ValueError):
        return False
    return (PLAUSIBLE_NS[0] <= ns <= PLAUSIBLE_NS[1]
            and PLAUSIBLE_STEP_SECONDS[0] <= step <= PLAUSIBLE_STEP_SECONDS[1])


def machine_speed(threads: int | None = None, calibrate: bool | None = None) -> dict:
    """The stored speed of this machine for `threads`; measured now if missing (unless
    IMPACTSIM_NO_CALIBRATE=1 or calibrate=False, which give DEFAULT_SPEED)."""
    threads = threads or _threads()
    found = _read_speeds(speed_file())["machines"].get(_machine_key(threads))
    if found and plausible(found):
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
_SCHEDSTAT = "/proc/thread-self/schedstat"
_last_schedstat: tuple[int, int] | None = None


def _schedstat() -> tuple[int, int] | None:
    """(ns on a core, ns waiting in the run queue) of this thread since it started, from the
    Linux scheduler's statistics; None where the kernel does not provide them."""
    try:
        with open(_SCHEDSTAT) as f:
            ran, waited = f.read().split()[:2]
        return int(ran), int(waited)
    except (OSError, ValueError):
        return None


def cpu_share(seconds: float = 0.3) -> float:
    """The share of a core this process gets now (0-1]: on a machine shared with other jobs a
    one-thread run gets about this share, so its wall time is its CPU time over it.

    On Linux the scheduler counts how long this thread ran and how long it waited in the run
    queue for a core; the share is ran / (ran + waited) since the last call (or since the thread
    started, when the thread has wanted a core for less than `seconds` since then), which costs
    nothing. Elsewhere (or before the thread has wanted a core for `seconds`): the thread's CPU
    time over the wall time of a busy loop of `seconds`."""
    global _last_schedstat
    now = _schedstat()
    if now is not None:
        since = _last_schedstat if _last_schedstat is not None else (0, 0)
        if sum(now) - sum(since) < seconds * 1e9:
            since = (0, 0)
        if sum(now) - sum(since) >= seconds * 1e9:
            _last_schedstat = now
            ran, wanted = now[0] - since[0], sum(now) - sum(since)
            return min(1.0, max(ran / wanted, 0.01))
    t0, c0 = wallclock.perf_counter(), wallclock.thread_time()
    x = 0
    while wallclock.perf_counter() - t0 < seconds:
        for i in range(2000):
            x += i
    wall = wallclock.perf_counter() - t0
    return min(1.0, max((wallclock.thread_time() - c0) / wall, 0.01)) if wall > 0 else 1.0


def contention(share: float | None = None) -> float:
    """How much slower than on a free core a run goes now: 1 / the share of a core this process
    gets (``cpu_share``, measured unless `share` is given; not measured, and 1, under
    IMPACTSIM_NO_CALIBRATE=1)."""
    if share is None:
        if os.environ.get("IMPACTSIM_NO_CALIBRATE", "") in ("1", "true", "yes"):
            return 1.0
        share = cpu_share()
    return 1.0 / min(max(float(share), 0.01), 1.0)


def estimate_cost(case: Case, speed: dict | None = None, meshes: list | None = None,
                  share: float | None = None) -> Estimate:
    """Elements, steps, memory and wall time of `case` (module docstring). `meshes`: the bodies'
    (points, tets), or None per body not meshed yet; counts and lengths are then exact.
    `share`: the share of a core the run will get (``cpu_share``); by default measured now when
    the speed is this machine's (speed None), a whole core when a speed is given."""
    from impactsim.case.describe import has_contact

    per_body, unknown = {}, []
    l_min, c_max, faces = math.inf, 0.0, 0.0
    own_steps = [math.inf] * len(case.bodies)  # each body's first step l / c [s] (cfl 1)
    for i, body in enumerate(case.bodies):
        mesh = meshes[i] if meshes is not None and i < len(meshes) else None
        if mesh is not None:
            from impactsim.mesh.quality import altitudes

            n = len(mesh[1])
            if n and mesh[1].shape[1] == 8:  # hexes: the hex kernel's V / largest face area
                from impactsim.mesh.hexes import hex_report

                length = float(hex_report(*mesh, 1.0, 1.0)["length_min"])
            else:
                length = float(altitudes(*mesh).min()) if n else None
            faces += _mesh_faces(mesh[1])
        else:
            n = body_elements(body)
            length = body_min_length(body) if n is not None and n < MAX_COUNT else None
            faces += _surface_faces(body) if n is not None else 0.0
        per_body[body.name] = n
        if n is None:
            unknown.append(body.name)
            continue
        c = wave_speed(case, body)
        if length is not None:
            l_min = min(l_min, length)
            if c > 0.0:
                own_steps[i] = length / c
        c_max = max(c_max, c)
    elements = min(sum(n for n in per_body.values() if n), MAX_COUNT)
    # the cost in tet-steps: a hex costs HEX_COST of them, a tet with the averaged nodal
    # pressure ANP_COST
    from impactsim.solver.formulation import resolve_element

    tet = ANP_COST if resolve_element(case) == "anp" else 1.0
    work = min(sum(n * (_hex_cost(case, b) if b.element == "hex8" else tet)
                   * (SEPARABLE_COST if separable(case, b) else 1.0)
                   for b, n in zip(case.bodies, per_body.values()) if n), float(MAX_COUNT))
    node_work = min(sum(n * (SEPARABLE_COST if separable(case, b) else 1.0)
                        for b, n in zip(case.bodies, per_body.values()) if n), float(MAX_COUNT))
    threads = run_threads(case, elements)
    frames = len(case.output.times) if case.output.times else case.output.frames + 1
    crush_factor, crush = 1.0, ((), (), 0.0)
    if elements and c_max > 0.0 and 0.0 < l_min < math.inf:
        first = min(own_steps)  # the smallest l / c of the bodies (not l_min / c_max)
        first = first if 0.0 < first < math.inf else l_min / c_max
        dt = case.run.cfl * first
        # the linear viscosity's share of the step in compression, L / (Q + sqrt(Q^2 + c^2))
        # with Q = C_l c (physics.md), the step's shrink as impacts crush the elements
        # (case/crush.py), and the steps lost landing on each output frame
        viscous = math.sqrt(1.0 + case.run.q_linear**2) - case.run.q_linear
        crush = (crushes(case, meshes), own_steps, first)
        crush_factor = step_factor(*crush, case.run.end_time)
        wanted = (case.run.end_time * crush_factor / (viscous * dt)
                  + FRAME_STEPS * inner_frames(case))
        steps_needed = int(min(wanted, 1e18)) + 1
        steps = min(case.run.max_steps, steps_needed)
    else:
        dt, steps, steps_needed = math.nan, 0, 0
    if speed is None:
        speed = machine_speed(threads)
        slow = contention(share)
    else:
        slow = contention(share if share is not None else 1.0)
    t_elem = 1e-9 * speed["ns_per_element_step"]
    parallel = PARALLEL_COST if threads > 1 else 1.0
    parts = {"elements": steps * (speed["seconds_per_step"]
                                  + (ELEMENT_TE * parallel * work + NODES_TE * node_work)
                                  * t_elem)}
    contact = has_contact(case)
    if contact:
        per_face = SELF_CONTACT_TE_PER_FACE if case.contact.self_contact else CONTACT_TE_PER_FACE
        parts["contact"] = steps * faces * per_face * t_elem
    fracture = fracture_work(case, per_body, steps)
    if fracture > 0.0:
        parts["fracture"] = fracture * t_elem
    per_frame = FRAME_TE_PER_ELEMENT[case.output.compression] * t_elem
    # at most a frame a step: the run stops at max_steps, before the frames beyond it
    parts["output"] = min(frames, steps + 1) * (elements * per_frame + FRAME_SECONDS)
    rows = steps / max(case.output.history_every, 1)
    # the history row's max_penetration measure costs where bodies crush into each other
    # (none in the elastic contacts, 2-4 t_e per face in the crushing ones)
    crushing = min(1.0, crush_factor - 1.0)
    parts["per-step output and checks"] = (RUN_SECONDS_PER_STEP * steps
                                           + (rows * faces * ROW_TE_PER_FACE * crushing
                                              * t_elem if contact else 0.0))
    parts["setup"] = SETUP_SECONDS + SETUP_SECONDS_PER_ELEMENT * elements
    if meshes is None:
        parts["meshing"] = sum(GMSH_SECONDS_PER_ELEMENT * (n or 0) for b, n in zip(
            case.bodies, per_body.values()) if b.mesher == "gmsh" and b.shape != "file"
            and not _cached(b))
    parts = {k: v * slow for k, v in parts.items()}  # what the run's share of a core makes them
    return Estimate(elements=elements, per_body=per_body, l_min=l_min, wave_speed=c_max, dt=dt,
                    contention=slow,
                    steps=steps, wall_seconds=sum(parts.values()), speed=speed,
                    unknown_bodies=unknown, threads=threads, memory_bytes=memory_bytes(elements),
                    seconds=parts, steps_needed=steps_needed, crush_factor=crush_factor,
                    crush=crush)


def separable(case: Case, body: Body) -> bool:
    """The body comes apart by node separation (its material has a fracture strain)."""
    return case.materials[body.material].failure.fracture_strain is not None


def _hex_cost(case: Case, body: Body) -> float:
    """A hex-step of `body` in tet-steps: HEX_COST, HEX_FAILING_COST when its material can be
    damaged (a damaged hex sends its block of 32 to the scalar path)."""
    return HEX_FAILING_COST if case.materials[body.material].failure.active else HEX_COST


def fracture_work(case: Case, per_body: dict, steps: int) -> float:
    """The fracture passes of a run in element-steps of t_e (module docstring): the criteria
    and particle passes over every element (FRACTURE_TE a tet, HEX_FRACTURE_TE a hex), the
    distortion check every distortion_interval (DISTORTION_TE per element and check), and node
    separation every step over the bodies whose material has a fracture strain
    (SEPARATION_TE). 0 when no fracture pass runs (no failure data, no fracture strain, no
    distortion erosion: fracture/passes.py, fracture_wanted)."""
    mats = [case.materials[b.material].failure for b in case.bodies]
    counts = [float(n or 0) for n in per_body.values()]
    hexes = [b.element == "hex8" for b in case.bodies]
    interval = case.fracture.distortion_interval
    if not (any(f.active or f.fracture_strain is not None for f in mats)
            or interval is not None):
        return 0.0  # no fracture pass runs (fracture/passes.py, fracture_wanted)
    # the criteria and particle passes run over every element once any fracture pass runs
    work = steps * sum(n * (HEX_FRACTURE_TE if h else FRACTURE_TE)
                       for n, h in zip(counts, hexes))
    if interval is not None and interval > 0.0:
        checks = min(float(steps), case.run.end_time / interval)  # at most one a step
        work += checks * sum(n * DISTORTION_TE[h] for n, h in zip(counts, hexes))
    work += steps * sum(n * SEPARATION_TE for n, b in zip(counts, case.bodies)
                        if separable(case, b))
    return min(work, 1e300)


# the run re-estimates itself once, after this share of its simulated time or these wall
# seconds of stepping, whichever comes first (solver/run.py)
RE_ESTIMATE_SHARE = 0.05
RE_ESTIMATE_SECONDS = 20.0


def re_estimate(est: Estimate, *, time: float, end_time: float, steps: int, dt: float,
                loop_seconds: float, elapsed: float, frames_left: int = 0,
                frames: int = 1) -> dict:
    """The run's own estimate of itself after its first part: the steps left at the step it
    takes now (`dt`, shrunk further from here on as the crush model says) at the seconds per
    step it measured (`loop_seconds` over `steps`), the frames still to write at the
    estimate's cost per frame, and the wall seconds `elapsed` so far. Returns the figures that
    summary.json keeps under ``re_estimate``."""
    per_step = loop_seconds / steps if steps > 0 else math.nan
    left = max(end_time - time, 0.0)
    ahead = est.shrink_ahead(time, end_time)
    steps_left = left / dt * ahead if dt > 0.0 and math.isfinite(dt) else math.nan
    per_frame = (est.seconds or {}).get("output", 0.0) / max(frames, 1)
    wall = elapsed + steps_left * per_step + frames_left * per_frame
    return {"time": time, "steps_so_far": steps, "elapsed_seconds": elapsed,
            "seconds_per_step": per_step, "dt": dt, "shrink_ahead": ahead,
            "steps": int(steps + steps_left) if math.isfinite(steps_left) else None,
            "wall_seconds": wall}


def re_estimate_line(r: dict) -> str:
    """The line a run prints with its re-estimate."""
    from impactsim.case.units import format_quantity

    steps = f"≈ {r['steps']:,} steps" if r["steps"] is not None else "steps unknown"
    return (f"re-estimate at t = {format_quantity(r['time'], 'time')} (step "
            f"{r['steps_so_far']:,}): {steps}, ≈ {format_seconds(r['wall_seconds'])} wall in "
            f"all (measured {1e3 * r['seconds_per_step']:.3g} ms/step at a step of "
            f"{format_quantity(r['dt'], 'time')})")


def inner_frames(case: Case) -> int:
    """Output times strictly inside (0, end_time): the ones a step is clamped to land on."""
    end = case.run.end_time
    if case.output.times:
        return sum(1 for t in set(case.output.times) if 0.0 < t < end)
    return max(case.output.frames - 1, 0)


def _cached(body: Body) -> bool:
    """The body's mesh is in the mesh cache (meshing it costs nothing then)."""
    from impactsim.mesh import cache

    try:
        folder = cache.cache_dir()
        return folder is not None and (folder / f"{cache.cache_key(body)}.npz").exists()
    except Exception:  # noqa: BLE001  an estimate never fails on the cache
        return False


def run_threads(case: Case, elements: int) -> int:
    """The thread count a run of `case` will use (solver.run.thread_count's rule)."""
    from impactsim.solver.run import thread_count

    return thread_count(case.run.threads, elements)


def _surface_faces(body: Body) -> float:
    """Boundary triangles of a primitive's mesh: about FACES_PER_H2 per h^2 of surface."""
    if body.shape == "cube12":
        return 12.0
    area, h = body_area(body), body.mesh_size
    if area is None or not h > 0.0:
        return 0.0
    return min(FACES_PER_H2 * (area / h) / h, float(MAX_COUNT))


def _mesh_faces(cells) -> float:
    """Boundary triangles of a meshed body (a hex body's quads count as two, as contact splits
    them)."""
    if not len(cells):
        return 0.0
    if cells.shape[1] == 8:
        from impactsim.contact.hexes import boundary_quads

        return 2.0 * len(boundary_quads(cells)[0])
    from impactsim.mesh.topology import boundary_faces

    return float(len(boundary_faces(cells)[0]))


def memory_bytes(elements: int) -> float:
    """Peak memory [bytes] of a run of `elements` tetrahedra (BASE_BYTES + BYTES_PER_ELEMENT)."""
    return BASE_BYTES + BYTES_PER_ELEMENT * float(elements)


def available_memory() -> float | None:
    """Bytes the system can give a new process (MemAvailable), None when unknown."""
    try:
        with open("/proc/meminfo") as stream:
            for line in stream:
                if line.startswith("MemAvailable:"):
                    return 1024.0 * float(line.split()[1])
    except (OSError, ValueError, IndexError):
        pass
    try:
        return float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def check_fits(case: Case, est: Estimate) -> None:
    """Raise a CaseError naming the largest body's mesh_size when the run would not fit in
    memory (the figure and what the machine has), before any meshing starts."""
    from impactsim.case.errors import CaseError

    have = available_memory()
    if have is None or est.memory_bytes <= have:
        return
    known = {k: v for k, v in est.per_body.items() if v}
    i = list(est.per_body).index(max(known, key=known.get)) if known else 0
    label = str(case.source) if case.source else "<string>"
    raise CaseError(f"{label}: body[{i}].mesh_size: the case would need ≈ "
                    f"{format_bytes(est.memory_bytes)} of memory for ≈ {est.elements:,} "
                    f"elements, and this machine has {format_bytes(have)} available: use a "
                    "larger mesh_size")


def format_bytes(n: float) -> str:
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if n >= size:
            return f"{n / size:.3g} {unit}" if n < 1e6 * 1e12 else f"{n:.2g} B"
    return f"{n / 1e3:.3g} kB"


def estimate_lines(case: Case, speed: dict | None = None, meshes: list | None = None
                   ) -> list[str]:
    """The cost lines of ``impactsim check`` (appended to describe.what_would_run)."""
    from impactsim.case.units import format_quantity

    est = estimate_cost(case, speed, meshes)
    lines = ["#", "# cost estimate:"]
    for name, n in est.per_body.items():
        lines.append(f"#   {name}: " + (f"≈ {n:,} elements" if n is not None
                                        else "mesh file: elements known after meshing"))
    if est.elements and math.isfinite(est.dt):
        lines.append(f"#   smallest element length ≈ {format_quantity(est.l_min, 'length')}, "
                     f"wave speed {est.wave_speed:,.0f} m/s -> first step ≈ "
                     f"{format_quantity(est.dt, 'time')}")
    lines += ["#   " + line for line in est.detail_lines()]
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
