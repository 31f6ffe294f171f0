"""Nanoseconds per element per step of the elastic-plastic tet loop (Johnson-Cook + Mie-Grueneisen).

A copper block of about 200k tetrahedra (structured, 6 tets per cell) hits a rigid wall at
190 m/s, so the kernel runs its plastic branch; after a warm-up the loop is timed for a number
of steps, on one thread and on all threads. Prints a table and returns the figures.
"""

from __future__ import annotations

import sys
import time

import numba
import numpy as np


def build(n_cells_per_axis=(32, 32, 33)):
    from impactsim.case import load_case_text
    from impactsim.mesh import mesh_body
    from impactsim.solver.build import build_model
    from impactsim.solver.pipeline import build_passes

    nx, ny, nz = n_cells_per_axis
    h = 0.5e-3
    size = (nx * h, ny * h, nz * h)
    case = load_case_text(f"""
[run]
name = "bench"
end_time = 1e-3
[[body]]
name = "block"
material = "ofhc-copper"
shape = "box"
size = [{size[0]}, {size[1]}, {size[2]}]
position = [0, 0, {size[2] / 2 + 1e-7}]
mesh_size = {h}
mesher = "structured"
velocity = [0, 0, -190]
[[wall]]
point = [0, 0, 0]
normal = [0, 0, 1]
""")
    model = build_model(case, [mesh_body(case.bodies[0], use_cache=False)])
    return case, model, build_passes(case, model)


def time_steps(threads: int, steps: int = 60, warm: int = 20) -> dict:
    from impactsim.solver.loop import Simulation

    numba.set_num_threads(threads)
    case, model, passes = build()
    sim = Simulation(model, passes, cfl=0.6)
    for _ in range(warm):
        sim.step()
    for key in sim.timings:
        sim.timings[key] = 0.0
    t0 = time.perf_counter()
    for _ in range(steps):
        sim.step()
    wall = time.perf_counter() - t0
    n = model.n_elem * steps
    return {"threads": threads, "elements": model.n_elem, "steps": steps,
            "ns_per_element_step": 1e9 * wall / n,
            "element_kernel_ns": 1e9 * sim.timings["element"] / n,
            "plastic_elements": int(np.count_nonzero(model.eps_p))}


def main() -> list[dict]:
    rows = [time_steps(1), time_steps(numba.config.NUMBA_NUM_THREADS)]
    print(f"{'threads':>8}{'elements':>10}{'steps':>7}{'ns/elem-step':>14}{'kernel ns':>11}{'plastic':>9}")
    for r in rows:
        print(f"{r['threads']:>8}{r['elements']:>10}{r['steps']:>7}{r['ns_per_element_step']:>14.1f}"
              f"{r['element_kernel_ns']:>11.1f}{r['plastic_elements']:>9}")
    return rows


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
