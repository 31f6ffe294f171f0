"""Scale study: element-steps per second and memory per element, 10k to 2M elements.

The bench scene of bench_element.py (a copper block, Johnson-Cook + Mie-Grueneisen, onto a
rigid wall) at growing sizes, each size in a fresh process (so that its peak memory is its
own): build time, the bytes numpy holds for the run's state after the steps (per element), the
process's peak resident memory (per element, the interpreter and numba's ~150 MB included,
which is why it falls with the size), the estimate of impactsim/solver/footprint.py, and the
whole step's rate in element-steps per second (wall, all threads; and CPU ns per element-step
per thread). Both figures should be flat in the size: the per-element work and state do not
depend on it, only the caches do (the node data of a 200k-element block no longer fits in L2,
above 2M not in L3).

    python benchmarks/bench_scale.py [--sizes 10e3,50e3,200e3,1e6,2e6] [--steps 10]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent

_ONE = """
import json, resource, sys, time, tracemalloc
import numba, numpy as np
sys.path.insert(0, {here!r})
from bench_element import case_text
from impactsim.case import load_case_text
from impactsim.mesh import mesh_body
from impactsim.solver.build import build_model
from impactsim.solver.footprint import peak_bytes, run_bytes
from impactsim.solver.loop import Simulation
from impactsim.solver.pipeline import build_passes
n, steps = int(sys.argv[1]), int(sys.argv[2])
nx = max(2, round((n / 6.0) ** (1.0 / 3.0)))
case = load_case_text(case_text((nx, nx, nx + 1)))
tracemalloc.start()
t0 = time.perf_counter()
model = build_model(case, [mesh_body(case.bodies[0], use_cache=False)])
sim = Simulation(model, build_passes(case, model), cfl=0.6)
build = time.perf_counter() - t0
for _ in range(3):
    sim.step()
snap = tracemalloc.take_snapshot().filter_traces(
    [tracemalloc.DomainFilter(True, np.lib.tracemalloc_domain)])
held = sum(t.size for t in snap.traces)
tracemalloc.stop()  # (tracing slows allocations; none happen in the time loop)
c0, w0 = time.process_time(), time.perf_counter()
for _ in range(steps):
    sim.step()
cpu, wall = time.process_time() - c0, time.perf_counter() - w0
ne = model.n_elem
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps(dict(elements=ne, nodes=model.n_node, build=build, held=held / ne,
                      rss=rss / ne, estimate=run_bytes(ne, model.n_node) / ne,
                      estimate_peak=peak_bytes(ne, model.n_node) / ne,
                      rate=ne * steps / wall, cpu_ns=1e9 * cpu / (ne * steps) / numba.get_num_threads(),
                      threads=numba.get_num_threads())))
"""


def one_size(n: int, steps: int) -> dict:
    p = subprocess.run([sys.executable, "-c", _ONE.format(here=str(HERE)), str(n), str(steps)],
                       check=True, capture_output=True, text=True, cwd=HERE.parent)
    return json.loads(p.stdout.strip().splitlines()[-1])


def main(argv=None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="10e3,50e3,200e3,1e6,2e6")
    ap.add_argument("--steps", type=int, default=10, help="timed steps at least; smaller "
                    "sizes take more, for 2e7 element-steps each")
    args = ap.parse_args(argv)
    rows = []
    print(f"{'elements':>10}{'build s':>9}{'held B/el':>11}{'estimate':>10}{'peak RSS B/el':>15}"
          f"{'Melem-steps/s':>15}{'CPU ns/el-step':>16}")
    for n in (int(float(s)) for s in args.sizes.split(",")):
        r = one_size(n, max(args.steps, int(2e7 / n)))
        rows.append(r)
        print(f"{r['elements']:>10}{r['build']:>9.1f}{r['held']:>11.0f}{r['estimate']:>10.0f}"
              f"{r['rss']:>15.0f}{r['rate'] / 1e6:>15.2f}{r['cpu_ns']:>16.1f}", flush=True)
    print(f"({rows[0]['threads']} threads; held: numpy's bytes for the run's state; estimate: "
          "impactsim.solver.footprint.run_bytes)")
    return rows


if __name__ == "__main__":
    main()
