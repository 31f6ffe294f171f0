"""Cost of the contact passes: nanoseconds per boundary node per step, and their share of a run.

1. Scaling: a block pressed into a plate at 50 m/s (structured meshes that do not match at the
   contact), at three mesh sizes (each halving the size: four times the boundary nodes). After a
   warm-up, each pass is timed over a number of steps and divided by (boundary nodes x steps);
   a cost linear in the number of surface entities shows as a flat column. The penetration
   measure (history rows, one every step as in the warm-up) is timed the same way.
2. Share: cases/two-cylinders.toml for its first 2 us (the 1 mm meshes), the seconds of each
   part of the step as summary.json reports them.
Prints two tables and returns the figures.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numba

HERE = Path(__file__).parent


def pressed_blocks(h: float) -> str:
    return f"""
[run]
name = "bench-contact"
end_time = 1.0
[[body]]
name = "plate"
material = "aluminium-elastic"
shape = "box"
size = [0.04, 0.04, 0.01]
position = [0, 0, -0.005]
mesh_size = {h}
mesher = "structured"
[[body]]
name = "block"
material = "aluminium-elastic"
shape = "box"
size = [0.02, 0.02, 0.01]
position = [{0.37 * h}, {0.21 * h}, 0.005]
mesh_size = {h * 0.7}
mesher = "structured"
velocity = [0, 0, -50]
"""


def time_passes(h: float, warm: int = 30, steps: int = 40) -> dict:
    from impactsim.case import load_case_text
    from impactsim.mesh import mesh_body
    from impactsim.solver.build import build_model
    from impactsim.solver.loop import Simulation
    from impactsim.solver.pipeline import build_passes

    case = load_case_text(pressed_blocks(h))
    model = build_model(case, [mesh_body(b, use_cache=False) for b in case.bodies])
    passes = build_passes(case, model)
    sim = Simulation(model, passes, cfl=0.6)
    contact = [p for p in passes if p.name.startswith("contact.")]
    for _ in range(warm):
        sim.step()
        contact[0].history(model)  # (the measure warms up too: first calls, buffers, candidates)
    for key in sim.timings:
        sim.timings[key] = 0.0
    meter = 0.0
    pairs = 0
    for _ in range(steps):
        sim.step()
        t0 = time.perf_counter()
        row = contact[0].history(model)
        meter += time.perf_counter() - t0
        pairs += row["contact_pairs"]
    surface = contact[0].ctx.surface
    n = surface.n_nodes * steps
    out = {"mesh_size_mm": 1e3 * h, "elements": model.n_elem, "boundary_nodes": surface.n_nodes,
           "pairs_per_step": pairs / steps,
           "element_ns_per_node": 1e9 * sim.timings["element"] / n,
           "meter_ns_per_node": 1e9 * meter / n}
    for p in contact:
        out[p.name] = 1e9 * sim.timings[p.name] / n
    return out


def cylinders_share(end_time: str = "2 us") -> dict:
    from impactsim.case import load_case
    from impactsim.solver.run import run_case

    case = load_case(HERE.parent / "cases" / "two-cylinders.toml",
                     [f'run.end_time="{end_time}"', f'output.times=["0 us", "{end_time}"]'])
    with tempfile.TemporaryDirectory() as out:
        summary = run_case(case, Path(out), progress=False)
    parts = {k: v for k, v in summary["seconds_per_pass"].items()
             if k not in ("meshing", "setup")}
    total = sum(parts.values())
    return {"steps": summary["steps"], "elements": summary["elements"], "seconds": parts,
            "share": {k: v / total for k, v in parts.items()}}


def main() -> dict:
    numba.set_num_threads(1)
    rows = [time_passes(h) for h in (0.002, 0.001, 0.0005)]
    print("contact cost per boundary node per step (one thread), block pressed into a plate")
    print(f"{'h [mm]':>7}{'elements':>10}{'bnd nodes':>10}{'pairs':>8}{'node-face':>11}"
          f"{'edge-edge':>11}{'meter':>9}{'element':>9}   [ns / boundary node / step]")
    for r in rows:
        print(f"{r['mesh_size_mm']:>7.2f}{r['elements']:>10}{r['boundary_nodes']:>10}"
              f"{r['pairs_per_step']:>8.0f}{r['contact.node-face']:>11.0f}"
              f"{r['contact.edge-edge']:>11.0f}{r['meter_ns_per_node']:>9.0f}"
              f"{r['element_ns_per_node']:>9.0f}")
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    share = cylinders_share()
    print(f"\ntwo-cylinders, first 2 us ({share['elements']} elements, {share['steps']} steps, "
          f"{numba.config.NUMBA_NUM_THREADS} threads): share of the run")
    for k, v in share["share"].items():
        print(f"  {k:<20}{100 * v:6.1f} %  ({share['seconds'][k]:.2f} s)")
    return {"scaling": rows, "two_cylinders": share}


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
