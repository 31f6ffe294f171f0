"""Nanoseconds per element per step of the elastic-plastic tet loop (Johnson-Cook + Mie-Grueneisen).

A copper block of about 200k tetrahedra (structured, 6 tets per cell) hits a rigid wall at
190 m/s, so the kernel runs its plastic branch; after a warm-up the loop is timed for a number
of steps, on one thread and on all threads, once with the Johnson-Cook strength and once with
the same block made elastic (mat_params[:, STRENGTH] = ELASTIC). "ns/elem-step" is the whole
step (node gather, walls, move, element update) per element; "kernel ns" the element update
alone; "cpu ns" the whole step in process CPU time per thread, which a busy shared machine
disturbs less than the wall clock (with 1 thread it is the figure to compare). Then
`impactsim run cases/elastic-bar-wall.toml` runs twice in a subprocess (the first run fills
numba's cache if needed) and the second run's seconds_to_first_step (summary.json) is the time
to the first step with a warm cache; once more with numba's cache in an empty folder gives it
with a cold cache (what the first run after an install waits for the kernels to compile;
benchmarks/compile_times.py says which take how long). Prints a table and returns the figures.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np


def case_text(n_cells_per_axis=(32, 32, 33)) -> str:
    """The bench scene: a copper block of 6 n_x n_y n_z tets 0.1 um above a rigid wall at
    190 m/s (also built by benchmarks/compare.py with another version of the package)."""
    nx, ny, nz = n_cells_per_axis
    h = 0.5e-3
    return f"""
[run]
name = "bench"
end_time = 1e-3
[[body]]
name = "block"
material = "ofhc-copper"
shape = "box"
size = [{nx * h}, {ny * h}, {nz * h}]
position = [0, 0, {nz * h / 2 + 1e-7}]
mesh_size = {h}
mesher = "structured"
velocity = [0, 0, -190]
[[wall]]
point = [0, 0, 0]
normal = [0, 0, 1]
"""


def build(n_cells_per_axis=(32, 32, 33)):
    from impactsim.case import load_case_text
    from impactsim.mesh import mesh_body
    from impactsim.solver.build import build_model
    from impactsim.solver.pipeline import build_passes

    case = load_case_text(case_text(n_cells_per_axis))
    model = build_model(case, [mesh_body(case.bodies[0], use_cache=False)])
    return case, model, build_passes(case, model)


def time_steps(threads: int, steps: int = 60, warm: int = 20, elastic: bool = False) -> dict:
    from impactsim.materials import params as P
    from impactsim.solver.loop import Simulation

    numba.set_num_threads(threads)
    case, model, passes = build()
    if elastic:
        model.mat_params[:, P.STRENGTH] = P.ELASTIC
    sim = Simulation(model, passes, cfl=0.6)
    for _ in range(warm):
        sim.step()
    for key in sim.timings:
        sim.timings[key] = 0.0
    t0, c0 = time.perf_counter(), time.process_time()
    for _ in range(steps):
        sim.step()
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    n = model.n_elem * steps
    return {"material": "elastic" if elastic else "JC", "threads": threads, "elements": model.n_elem, "steps": steps,
            "ns_per_element_step": 1e9 * wall / n,
            "cpu_ns_per_element_step": 1e9 * cpu / n / threads,
            "element_kernel_ns": 1e9 * sim.timings["element"] / n,
            "plastic_elements": int(np.count_nonzero(model.eps_p))}


def time_to_first_step(case: str = "cases/elastic-bar-wall.toml", cold: bool = False) -> float:
    """seconds_to_first_step of `impactsim run` with a warm numba cache (second of two runs), or
    with a cold one (numba's cache in an empty folder: every kernel the run uses compiles)."""
    root = Path(__file__).resolve().parents[1]
    with tempfile.TemporaryDirectory() as tmp, tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache) if cold else None
        for _ in range(1 if cold else 2):
            subprocess.run([sys.executable, "-m", "impactsim.cli", "run", case, "-o", tmp, "-q",
                            "--overwrite"],
                           cwd=root, check=True, capture_output=True, env=env)
        return json.loads((Path(tmp) / "summary.json").read_text())["seconds_to_first_step"]


def main() -> list[dict]:
    from impactsim.kernel_cache import refresh

    refresh()  # kernels cached from older sources go first, as the CLI does
    n_threads = numba.config.NUMBA_NUM_THREADS
    rows = [time_steps(t, elastic=el) for el in (False, True) for t in (1, n_threads)]
    print(f"{'material':>9}{'threads':>8}{'elements':>10}{'steps':>7}{'ns/elem-step':>14}"
          f"{'cpu ns':>8}{'kernel ns':>11}{'plastic':>9}")
    for r in rows:
        print(f"{r['material']:>9}{r['threads']:>8}{r['elements']:>10}{r['steps']:>7}"
              f"{r['ns_per_element_step']:>14.1f}{r['cpu_ns_per_element_step']:>8.1f}"
              f"{r['element_kernel_ns']:>11.1f}{r['plastic_elements']:>9}")
    print(f"time to first step (elastic-bar-wall): warm cache {time_to_first_step():.2f} s "
          "(cold cache and every bundled case: bench_first_run.py)")
    return rows


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
