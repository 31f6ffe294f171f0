"""Cost of the per-step watch (solver/watch.py: energies + non-finite test of the whole state)
against the step itself, on a Johnson-Cook copper block hitting a wall.

    python benchmarks/bench_watch.py [cells per side, default 24 -> 82,944 tets]

Prints the median seconds per step of Simulation.step and of Watch.after_step over chunks of
steps, and their ratio, measured in one process (one thread and all threads).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main() -> None:
    from impactsim.case.estimate import _speed_case
    from impactsim.mesh import mesh_body
    from impactsim.solver.build import build_model
    from impactsim.solver.loop import Simulation
    from impactsim.solver.pipeline import build_passes
    from impactsim.solver.watch import Watch

    cells = int(sys.argv[1]) if len(sys.argv) > 1 else 24
    case = _speed_case(cells)
    model = build_model(case, [mesh_body(case.bodies[0], use_cache=False)])
    for threads in sorted({1, numba.config.NUMBA_NUM_THREADS}):
        numba.set_num_threads(threads)
        sim = Simulation(model, build_passes(case, model), cfl=0.6)
        watch = Watch(sim)
        for _ in range(3):
            sim.step()
            watch.after_step()
        steps, watches = [], []
        for _ in range(7):
            t0 = time.perf_counter()
            for _ in range(5):
                sim.step()
            t1 = time.perf_counter()
            for _ in range(5):
                watch.after_step()
            t2 = time.perf_counter()
            steps.append((t1 - t0) / 5)
            watches.append((t2 - t1) / 5)
        s, w = float(np.median(steps)), float(np.median(watches))
        print(f"{model.n_elem} tets, {threads} thread(s): step {1e3 * s:.2f} ms, watch "
              f"{1e3 * w:.3f} ms = {100 * w / s:.1f} % of a step")


if __name__ == "__main__":
    main()
