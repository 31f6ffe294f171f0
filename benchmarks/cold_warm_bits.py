"""Do a process that compiles the tet kernel and one that loads it from the cache compute the
same bits? (docs/performance.md, "Whole scenes, session 23": they did not; session 24:
impactsim/numba_linking.py makes them.)

Runs a small elastic block (1,536 tets, random velocities; the serial kernel, or with
--parallel the threaded one on two threads) for two steps in two fresh processes sharing one
empty NUMBA_CACHE_DIR: the first compiles every kernel and writes the cache, the second loads
it. Each prints digests of the velocities, positions, forces and cell state after the
predictor, the move and the element update of each step (-0.0 taken as 0.0), and this script
says where the two first part.

    python benchmarks/cold_warm_bits.py [--parallel]
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = """
import hashlib
import sys
import numpy as np
from impactsim.solver import element
from impactsim.mesh.renumber import renumber
from impactsim.mesh.structured import structured_box
from impactsim.solver.build import build_model
from impactsim.solver.loop import Simulation
from impactsim.solver.nodal import move, predict
from tests.builders import box_case, material

def dg(a):
    return hashlib.sha1((np.ascontiguousarray(a) + 0.0).tobytes()).hexdigest()[:8]

h = 0.002
size = (8 * h, 8 * h, 4 * h)
case = box_case(material(), size=size, h=h, velocity=(0.0, 0.0, -50.0))
m = build_model(case, [renumber(*structured_box(size, h))])
m.v += np.random.default_rng(0).normal(0.0, 10.0, m.v.shape)
if sys.argv[1] == "parallel":
    element.PARALLEL_ELEMENTS = 0  # the threaded kernel on this small block
sim = Simulation(m, [], cfl=0.6)
print("initial force", dg(m.force))
for k in range(2):
    dt = sim.next_dt()
    predict(m.force, m.mass, m.v, 0.5 * (sim.dt + dt) if sim.dt > 0 else 0.5 * dt)
    print(f"step {k} predictor v", dg(m.v))
    move(m.x, m.v, dt)
    print(f"step {k} move x", dg(m.x))
    sim._update_elements(dt)
    sim.dt = dt
    for name in ("force", "sdev", "pressure", "energy", "q", "vol"):
        print(f"step {k} element {name}", dg(getattr(m, name)))
"""


def cold_and_warm(parallel: bool = False) -> tuple[list[str], list[str]]:
    """The digests of the compiling process and of the loading one."""
    with tempfile.TemporaryDirectory(prefix="impactsim-bits-") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONPATH=str(ROOT))
        if parallel:
            env["NUMBA_NUM_THREADS"] = "2"
        mode = "parallel" if parallel else "serial"
        runs = [subprocess.run([sys.executable, "-c", CHILD, mode], env=env, cwd=ROOT,
                               check=True, capture_output=True, text=True).stdout.splitlines()
                for _ in range(2)]
    return runs[0], runs[1]


def main() -> int:
    runs = cold_and_warm("--parallel" in sys.argv[1:])
    for cold, warm in zip(*runs):
        mark = "" if cold == warm else "   <- differs"
        print(f"{cold:40s} {warm.split()[-1]}{mark}")
    same = runs[0] == runs[1]
    print("compiling and cached processes agree" if same else
          "compiling and cached processes differ")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
