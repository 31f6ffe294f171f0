"""The same scene built twice in one process, its arrays on huge pages (solver/hugepages.py) and
where numpy put them, the timed steps alternating between the two in turns of 5; prints the CPU
ns per element-step of each (one thread) and checks that both end in the same state.

    python benchmarks/hugepages_ab.py hex|tet [--first huge|plain] [--turns 20]

The version built first tends to come out slower (as in hex_ab.py): run both orders and take
the geometric mean of the two ratios.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("kind", choices=["hex", "tet"])
    ap.add_argument("--first", default="huge", choices=["huge", "plain"])
    ap.add_argument("--turns", type=int, default=20)
    args = ap.parse_args(argv)
    import bench_element
    import bench_hex

    from impactsim.case import load_case_text
    from impactsim.mesh import mesh_body
    from impactsim.solver import hugepages
    from impactsim.solver.build import build_model
    from impactsim.solver.loop import Simulation
    from impactsim.solver.pipeline import build_passes

    numba.set_num_threads(1)
    text = bench_hex.case_text() if args.kind == "hex" else bench_element.case_text()
    order = ["huge", "plain"] if args.first == "huge" else ["plain", "huge"]
    sims = {}
    for o in order:
        saved = hugepages.MIN_TOTAL
        if o == "plain":
            hugepages.MIN_TOTAL = 1 << 62  # nothing packed
        try:
            case = load_case_text(text)
            model = build_model(case, [mesh_body(case.bodies[0])])
            sims[o] = (model, Simulation(model, build_passes(case, model), cfl=0.6))
        finally:
            hugepages.MIN_TOTAL = saved
    for _, s in sims.values():
        for _ in range(20):
            s.step()
    cpu = {o: 0.0 for o in sims}
    for _ in range(args.turns):
        for o, (_, s) in sims.items():
            c0 = time.process_time()
            for _ in range(5):
                s.step()
            cpu[o] += time.process_time() - c0
    ns = {}
    for o, (m, _) in sims.items():
        n = (m.blocks[0].n_elem if args.kind == "hex" else m.n_elem) * 5 * args.turns
        ns[o] = 1e9 * cpu[o] / n
        print(f"{args.kind} {o:6s} {ns[o]:7.1f} CPU ns per element-step")
    print(f"  ratio plain / huge: {ns['plain'] / ns['huge']:.3f} ({order[0]} built first); "
          f"same end state: {np.array_equal(sims['huge'][0].x, sims['plain'][0].x)}")
    return ns


if __name__ == "__main__":
    main()
