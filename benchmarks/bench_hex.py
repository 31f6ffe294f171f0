"""Nanoseconds per hex per step of the one-point hex (Johnson-Cook + Mie-Grueneisen).

The scene of bench_element.py with element = "hex8": a copper block of 48^3 = 110,592
structured hexes hits a rigid wall at 190 m/s, so the kernel runs its plastic branch near the
wall. After a warm-up the loop is timed on one thread and on all threads. "ns/hex-step" is the
whole step (predictor, wall, move, element update) per hex; "kernel ns" the hex update alone;
"cpu ns" the whole step in process CPU time per thread (the figure to compare on one thread on
a busy machine). Issue 11 floor: 120 ns per hex-step on one thread. Prints a table and returns
the figures.
"""

from __future__ import annotations

import sys
import time

import numba
import numpy as np

CELLS = 48
H = 0.5e-3


def case_text(n: int = CELLS, hourglass: str = "viscous") -> str:
    return f"""
[run]
name = "bench-hex"
end_time = 1e-3
[[body]]
name = "block"
material = "ofhc-copper"
shape = "box"
size = [{n * H}, {n * H}, {n * H}]
position = [0, 0, {n * H / 2 + 1e-7}]
mesh_size = {H}
mesher = "structured"
element = "hex8"
hourglass = "{hourglass}"
velocity = [0, 0, -190]
[[wall]]
point = [0, 0, 0]
normal = [0, 0, 1]
"""


def time_steps(threads: int, steps: int = 60, warm: int = 20, hourglass: str = "viscous"
               ) -> dict:
    from impactsim.case import load_case_text
    from impactsim.mesh import mesh_body
    from impactsim.solver.build import build_model
    from impactsim.solver.loop import Simulation
    from impactsim.solver.pipeline import build_passes

    numba.set_num_threads(threads)
    case = load_case_text(case_text(hourglass=hourglass))
    model = build_model(case, [mesh_body(case.bodies[0])])
    sim = Simulation(model, build_passes(case, model), cfl=0.6)
    for _ in range(warm):
        sim.step()
    for key in sim.timings:
        sim.timings[key] = 0.0
    t0, c0 = time.perf_counter(), time.process_time()
    for _ in range(steps):
        sim.step()
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    blk = model.blocks[0]
    n = blk.n_elem * steps
    return {"hourglass": hourglass, "threads": threads, "hexes": blk.n_elem, "steps": steps,
            "ns_per_hex_step": 1e9 * wall / n, "cpu_ns_per_hex_step": 1e9 * cpu / n / threads,
            "kernel_ns": 1e9 * sim.timings["element"] / n,
            "plastic": int(np.count_nonzero(blk.eps_p))}


def main() -> list[dict]:
    n_threads = numba.config.NUMBA_NUM_THREADS
    rows = [time_steps(t, hourglass=hg) for hg in ("viscous", "stiffness")
            for t in sorted({1, n_threads})]
    print(f"{'hourglass':>10}{'threads':>8}{'hexes':>8}{'steps':>7}{'ns/hex-step':>13}"
          f"{'cpu ns':>8}{'kernel ns':>11}{'plastic':>9}")
    for r in rows:
        print(f"{r['hourglass']:>10}{r['threads']:>8}{r['hexes']:>8}{r['steps']:>7}"
              f"{r['ns_per_hex_step']:>13.1f}{r['cpu_ns_per_hex_step']:>8.1f}"
              f"{r['kernel_ns']:>11.1f}{r['plastic']:>9}")
    return rows


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
