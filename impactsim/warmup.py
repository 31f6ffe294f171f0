"""Compile every numba kernel a run can use, once, into numba's on-disk cache.

The kernels are `numba.njit(cache=True)`: the first process that calls one compiles it (the
element kernel alone takes 15-20 s) and writes the machine code next to the sources
(`__pycache__/*.nbi, *.nbc`); every later process loads it in milliseconds. `make setup` runs
this module after the install, so that the first `impactsim run` of a user starts at once
instead of compiling for half a minute.

It runs a few tiny scenes (a few hundred tets each, a handful of steps) that between them take
every path of the pipeline: elastic and Johnson-Cook + Mie-Grueneisen elements, the tet4 and
ANP formulations, rigid walls, prescribed velocities, node-face and edge-edge contact with the
penetration measure, spall, loosening, erosion, particles with face, wall and particle-particle
impacts, hexahedra with stiffness hourglass control in contact with tets, fracture and
self-contact of hexes, node separation and distortion erosion, and the history and frame
outputs. A kernel reached with the types of a real run is
compiled with exactly those types, so the cache serves the real runs
(tests/unit/test_warmup.py checks that a second process compiles nothing). The scenes run in
two processes at once where there are two cores (STAGES, `warm_up_parallel`): numba compiles
one kernel at a time per process.

    python -m impactsim.warmup [--workers N]      (or: impactsim warmup [--workers N])
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

from impactsim.kernel_cache import CompileCounter

# Tiny scenes: case text; each runs for at most `steps` steps.
_BLOCK = """
[[body]]
name = "{name}"
material = "{material}"
shape = "box"
size = [{sx}, {sy}, {sz}]
position = [{px}, {py}, {pz}]
mesh_size = {h}
mesher = "structured"
velocity = [{vx}, 0, {vz}]
"""

_WALL = """
[[wall]]
point = [0, 0, 0]
normal = [0, 0, 1]
"""


def _block(name, material, size, position, h, velocity=(0.0, 0.0)):
    sx, sy, sz = size
    px, py, pz = position
    return _BLOCK.format(name=name, material=material, sx=sx, sy=sy, sz=sz, px=px, py=py, pz=pz,
                         h=h, vx=velocity[0], vz=velocity[1])


def scenes() -> list[tuple[str, str, int]]:
    """(name, case text, steps) of the warm-up scenes."""
    h = 1e-3
    bar = _block("bar", "steel-elastic", (2e-3, 2e-3, 6e-3), (0, 0, 3.0001e-3), h, (0, -100.0))
    copper = _block("rod", "ofhc-copper", (2e-3, 2e-3, 6e-3), (0, 0, 3.0001e-3), h, (0, -190.0))
    out = [
        ("elastic-wall", "[run]\nname = 'w'\nend_time = 1e-6\n" + bar + _WALL, 4),
        ("elastic-wall-threads", "[run]\nname = 'w'\nend_time = 1e-6\n" + bar + _WALL, 2),
        ("jc-wall", "[run]\nname = 'w'\nend_time = 1e-6\n" + copper + _WALL, 4),
        ("jc-wall-anp", "[run]\nname = 'w'\nend_time = 1e-6\nelement = 'anp'\n" + copper + _WALL,
         4),
    ]
    # two blocks pressed together, the upper one turned so that edges cross edges
    lower = _block("lower", "al-ideal-plastic", (4e-3, 4e-3, 2e-3), (0, 0, -1e-3), h)
    upper = _block("upper", "al-ideal-plastic", (2e-3, 2e-3, 2e-3), (0, 0, 1.0001e-3), h,
                   (0, -300.0)).replace('mesher = "structured"',
                                        'mesher = "structured"\nrotation = [0, 0, "30 deg"]')
    contact = ("[run]\nname = 'c'\nend_time = 1e-6\n" + lower + upper
               + "[contact]\npasses = ['node-face', 'edge-edge']\nfriction = 0.1\n")
    out.append(("contact", contact, 12))
    # the same on every thread (PARALLEL_SCENES): the parallel versions of the contact query
    # and of the tet kernel for plastic tets without the guard; they need no fracture kernel,
    # so they compile in the first stage, after the contact scene (STAGES)
    out.append(("contact-threads", contact, 6))
    # fracture: a fast block through a thin plate that spalls at once, erodes, and sheds
    # particles that hit faces, the wall and each other; flat enough to be measured as a plate
    # (its hole: fracture.measures)
    plate_mat = """
[[material]]
name = "brittle"
library = "d16t"
failure = { erosion = "jc-damage", erosion_value = 1.0, jc_damage = [0.0, 0.01, -1.5, 0.0, 0.0], spall_strength = "1 MPa", loosening = 0.001 }
"""
    plate = _block("plate", "brittle", (5e-3, 5e-3, 1e-3), (0, 0, 2e-3), 0.5e-3)
    proj = _block("proj", "steel-4340", (2e-3, 2e-3, 2e-3), (0, 0, 3.5001e-3), 1e-3,
                  (0, -3000.0))
    frac = ("[run]\nname = 'f'\nend_time = 2e-6\n" + plate_mat + plate + proj + _WALL
            + "[contact]\npasses = ['node-face', 'edge-edge']\n"
            + "[fracture]\nerosion_region = 'anywhere'\nparticles_per_element = 1\n"
            + "particle_collisions = true\n")
    out.append(("fracture", frac, 60))
    # the same with the parallel versions of the kernels that run on one thread for small
    # meshes (PARALLEL_SCENES)
    out.append(("fracture-threads", frac, 20))
    # hexahedra (solver/hex8.py): a Johnson-Cook rod of hexes with stiffness hourglass control
    # on a wall, struck by an elastic tet block through contact (hex quads against tets)
    hex_rod = copper.replace('mesher = "structured"',
                             'mesher = "structured"\nelement = "hex8"\nhourglass = "stiffness"')
    striker = _block("striker", "steel-elastic", (1e-3, 1e-3, 1e-3), (0, 0, 6.6001e-3), 0.5e-3,
                     (0, -300.0))
    out.append(("hex", "[run]\nname = 'h'\nend_time = 1e-6\n" + hex_rod + striker + _WALL
                + "[contact]\npasses = ['node-face', 'edge-edge']\n", 8))
    # node separation and distortion erosion [Z] (fracture/separation.py, distortion.py): a
    # separable block dragged apart fast enough to release families and delete cells, under
    # the default energy stop: its worst balance error is 4.0 % at step 1 (4.3 % with hexes),
    # where the impulsive drag tears the face layer off as single tets (their viscous heat:
    # SeparationPass.centre_heat; with the kernels' booking it gained 10.9 %)
    sep_mat = """
[[material]]
name = "sep"
library = "al-ideal-plastic"
failure = { fracture_strain = 0.05 }
"""
    sep = ("[run]\nname = 's'\nend_time = 2e-6\n" + sep_mat
           + _block("block", "sep", (3e-3, 3e-3, 3e-3), (0, 0, 0), 1e-3)
           + """[[body.constraint]]
nodes = { box = { lo = ["1.4 mm", "-2 mm", "-2 mm"], hi = ["2 mm", "2 mm", "2 mm"] } }
velocity = ["2000 m/s", "0 m/s", "0 m/s"]
[fracture]
distortion_interval = "20 ns"
""")
    out.append(("separation", sep, 40))
    # fracture of hexes (fracture/hexes.py) with self-contact (contact/hexes.py: quad keys) and
    # the patch pressure (patch_fields on tets and hexes): the brittle plate in hexes, struck by
    # a tet block; its hexes spall, erode and shed particles that hit the hex faces
    hex_plate = plate.replace('mesher = "structured"', 'mesher = "structured"\nelement = "hex8"')
    hex_frac = ("[run]\nname = 'hf'\nend_time = 2e-6\n" + plate_mat + hex_plate + proj + _WALL
                + "[contact]\npasses = ['node-face', 'edge-edge']\nself_contact = true\n"
                + "[fracture]\nerosion_region = 'anywhere'\nparticles_per_element = 1\n"
                + "particle_collisions = true\nspall_pressure = 'patch'\n"
                # compile coverage, not a balance: the balance error of this coarse 3 km/s
                # hex-plate start peaks at 4.6 %, too close to the 5 % limit to gate on
                + "[checks]\nenergy_balance_action = 'warn'\n")
    out.append(("hex-fracture", hex_frac, 60))
    # with self-contact: the contact surface follows the releases in place (Surface.reconnect)
    # (worst balance 2.6 %; 4.99 % while the half-step energy took the coming velocity step's
    # weight instead of the last step's: the released tets halve the next step)
    out.append(("separation-contact", sep + "[contact]\nself_contact = true\n", 12))
    # the same block of hexes: the released corners' forces by the hex kernel re-run at dt = 0
    # (SeparationPass.move_forces, solver.blocks.hex_corner_forces)
    sep_hex = sep.replace('mesher = "structured"',
                          'mesher = "structured"\nelement = "hex8"\nhourglass = "stiffness"'
                          )
    # with self-contact: the hex contact surface and its tet cover follow the releases in
    # place (HexSurface.reconnect, ProxyTets.reconnect)
    out.append(("separation-hex", sep_hex + "[contact]\nself_contact = true\n", 12))
    return out


# scenes run with the size thresholds of the one-thread kernels at 0 (nodal.PARALLEL_NODES,
# element.PARALLEL_FORCE_NODES, element.PARALLEL_ELEMENTS, broadphase.QUERY_MIN_CHUNKS, the
# chunk count from which the broad-phase query runs on the threads, and
# particle_faces.THREADED_FACES, the free faces from which the particle pass finds those near
# the particles on them), so that their parallel versions are compiled too (the tet kernel's
# with elastic and with plastic tets: element.plastic_kernel); they run on every thread
# (run.threads), as a large scene does: the threaded query is only taken with more than one.
# Every scene runs with buckets.KERNEL_MIN_ROWS at 0 (the element faces or edges from which the
# face adjacency and the edges are found by a kernel instead of numpy's sort), so that the
# first scenes of the first stage compile those kernels
PARALLEL_SCENES = {"fracture-threads", "elastic-wall-threads", "contact-threads"}


def _thresholds(values=None):
    """The size thresholds above which kernels run on all threads; with ``values``, set them
    (returns the previous ones)."""
    from impactsim.contact import broadphase
    from impactsim.fracture import particle_faces
    from impactsim.solver import element, nodal

    old = (nodal.PARALLEL_NODES, element.PARALLEL_FORCE_NODES, element.PARALLEL_ELEMENTS,
           broadphase.QUERY_MIN_CHUNKS, particle_faces.THREADED_FACES)
    if values is not None:
        (nodal.PARALLEL_NODES, element.PARALLEL_FORCE_NODES, element.PARALLEL_ELEMENTS,
         broadphase.QUERY_MIN_CHUNKS, particle_faces.THREADED_FACES) = values
    return old


def warm_up(verbose: bool = True, names=None) -> dict[str, dict]:
    """Run the warm-up scenes (those of ``names``, in that order; default all of them);
    returns per scene the kernels it compiled ("compiled", none when the cache was already
    warm) and the run's summary ("summary")."""
    import contextlib
    import io

    import numba

    from impactsim.case import load_case_text
    from impactsim.mesh import buckets
    from impactsim.solver.run import run_case

    counts = {}
    table = {name: (text, steps) for name, text, steps in scenes()}
    for name in names if names is not None else list(table):
        text, steps = table[name]
        t0 = time.perf_counter()
        sets = [f"run.max_steps={steps}", "output.frames=1"]
        if name in PARALLEL_SCENES:  # on every thread, small as they are (run.thread_count)
            sets.append(f"run.threads={numba.config.NUMBA_NUM_THREADS}")
        case = load_case_text(text, overrides=sets)
        old = _thresholds((0, 0, 0, 0, 0) if name in PARALLEL_SCENES else None)
        old_rows, buckets.KERNEL_MIN_ROWS = buckets.KERNEL_MIN_ROWS, 0
        try:
            with (CompileCounter() as compiled,
                  tempfile.TemporaryDirectory(prefix="impactsim-warmup-") as out,
                  contextlib.redirect_stderr(io.StringIO())):  # "stopped: max_steps reached"
                summary = run_case(case, Path(out), progress=False)
        finally:
            _thresholds(old)
            buckets.KERNEL_MIN_ROWS = old_rows
        counts[name] = {"compiled": compiled.kernels, "summary": summary}
        if verbose:
            extra = ""
            if "particles" in summary:
                extra = (f", {summary['particles']} particles, "
                         f"{summary['fracture']['eroded']} eroded")
            print(f"warm-up {name:<14} {len(compiled.kernels):3d} kernels compiled "
                  f"({time.perf_counter() - t0:5.1f} s{extra})", flush=True)
    return counts


# The scenes for two processes on two cores, in two stages, each of two groups of about equal
# compile time (cold cache, AMD EPYC Zen 4, session 21; docs/performance.md "First run"). First
# tets with walls, hexes and node separation, then contact on the threads, whose contact
# kernels the other group's contact scene has put in the cache by then (88 s), beside contact
# and fracture (91 s, the longest chain: fracture needs the contact kernels); then the scenes
# that need the fracture kernels, hex fracture (18 s) beside fracture and an elastic bar on the
# threads (16 s). A kernel two groups of a stage reach (the tet element kernel, for one) is
# compiled in both; one reached before the other group cached it is compiled twice, not wrong.
STAGES = (
    (("elastic-wall", "jc-wall", "jc-wall-anp", "hex", "separation", "separation-contact",
      "separation-hex", "contact-threads"),
     ("contact", "fracture")),
    (("hex-fracture",), ("fracture-threads", "elastic-wall-threads")),
)


def _warm_group(names, lock_path, verbose):
    """One worker process of `warm_up_parallel`."""
    from impactsim.kernel_cache import serialize_cache_files

    serialize_cache_files(lock_path)
    return warm_up(verbose, names)


def warm_up_parallel(workers: int, verbose: bool = True, stages=STAGES) -> dict[str, dict]:
    """`warm_up` with the groups of scenes of each stage (STAGES) in ``workers`` processes at
    once (numba compiles one kernel at a time per process); their cache files are written
    under a common lock (kernel_cache.serialize_cache_files). One worker runs the scenes
    here, in order."""
    names = {name for stage in stages for group in stage for name in group}
    if workers <= 1 or sys.platform == "win32":
        return warm_up(verbose, [name for name, _, _ in scenes() if name in names])
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    with tempfile.TemporaryDirectory(prefix="impactsim-warmup-") as tmp:
        lock = Path(tmp) / "numba-cache.lock"
        done = []
        with ProcessPoolExecutor(min(workers, max(len(s) for s in stages)),
                                 mp_context=multiprocessing.get_context("spawn")) as pool:
            for stage in stages:
                jobs = [pool.submit(_warm_group, g, lock, verbose) for g in stage]
                done += [j.result() for j in jobs]
    merged = {k: v for d in done for k, v in d.items()}
    return {name: merged[name] for name, _, _ in scenes() if name in merged}


def main(argv=None) -> int:
    import argparse

    from impactsim.kernel_cache import refresh
    from impactsim.studies.cluster import default_workers  # the cores this process may use

    ap = argparse.ArgumentParser(prog="python -m impactsim.warmup", description=__doc__.split(
        "\n")[0])
    ap.add_argument("--workers", type=int, default=min(default_workers(), 2),
                    help="processes compiling at once (default: the cores, at most 2)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    refresh()  # kernels cached from older sources would be kept by numba: they go first
    counts = warm_up_parallel(args.workers)
    n = sum(len(c["compiled"]) for c in counts.values())
    print(f"numba cache warm: {n} kernels compiled in "
          f"{time.perf_counter() - t0:.1f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
