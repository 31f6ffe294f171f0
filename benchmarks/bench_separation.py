"""Node separation [Z]: ns per element-step of a separable body against the same mesh without.

The scene of bench_hex.py (a copper block hitting a rigid wall at 190 m/s, plastic near the
wall) at 32^3 = 32,768 hexes and at 16^3 cubes = 24,576 tets, once plain and once with
failure.fracture_strain = 1e6 (every element owns its node copies, the families stay tied:
node count x ~8 for hexes, x ~20 for tets; the release check runs every step). The whole step
(predictor, wall, move, element update, the fracture and separation passes) is timed after a
warm-up, on one thread. Issue 12 floor: the separable hex body at most 2x the plain one.
"""

from __future__ import annotations

import sys
import time

import numba

H = 0.5e-3


def case_text(n: int, element: str, separable: bool) -> str:
    fail = "failure = { fracture_strain = 1e6 }" if separable else ""
    return f"""
[run]
name = "bench-separation"
end_time = 1e-3
[[material]]
name = "cu"
library = "ofhc-copper"
{fail}
[[body]]
name = "block"
material = "cu"
shape = "box"
size = [{n * H}, {n * H}, {n * H}]
position = [0, 0, {n * H / 2 + 1e-7}]
mesh_size = {H}
mesher = "structured"
element = "{element}"
velocity = [0, 0, -190]
[[wall]]
point = [0, 0, 0]
normal = [0, 0, 1]
"""


def time_steps(n: int, element: str, separable: bool, steps: int = 40, warm: int = 10,
               threads: int = 1) -> dict:
    from impactsim.case import load_case_text
    from impactsim.solver.build import build_model
    from impactsim.solver.loop import Simulation
    from impactsim.solver.pipeline import build_passes

    numba.set_num_threads(threads)
    case = load_case_text(case_text(n, element, separable))
    model = build_model(case)
    sim = Simulation(model, build_passes(case, model), cfl=0.6)
    for _ in range(warm):
        sim.step()
    t0 = time.perf_counter()
    c0 = time.process_time()
    for _ in range(steps):
        sim.step()
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    n_elem = model.n_elem + sum(b.n_elem for b in model.blocks)
    return {"element": element, "separable": separable, "elements": n_elem,
            "nodes": model.n_node, "ns": 1e9 * wall / (n_elem * steps),
            "cpu_ns": 1e9 * cpu / (n_elem * steps) / threads}


def main() -> list[dict]:
    rows = []
    for element, n in (("hex8", 32), ("tet", 16)):
        plain = time_steps(n, element, False)
        tied = time_steps(n, element, True)
        tied["ratio"] = tied["ns"] / plain["ns"]
        tied["cpu_ratio"] = tied["cpu_ns"] / plain["cpu_ns"]
        rows += [plain, tied]
    print(f"{'element':>8}{'separable':>10}{'elements':>10}{'nodes':>9}{'ns/el-step':>12}"
          f"{'cpu ns':>9}{'ratio':>7}{'cpu ratio':>10}")
    for r in rows:
        print(f"{r['element']:>8}{str(r['separable']):>10}{r['elements']:>10}{r['nodes']:>9}"
              f"{r['ns']:>12.1f}{r['cpu_ns']:>9.1f}{r.get('ratio', 1.0):>7.2f}"
              f"{r.get('cpu_ratio', 1.0):>10.2f}")
    return rows


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
