"""CPU time of the element kernel alone on a frozen state, one thread: the figure to compare
kernel changes with on a busy machine.

Builds the block of bench_element.py (202,752 tets, OFHC copper, Johnson-Cook + Mie-Grueneisen,
190 m/s onto a rigid wall), runs `--warm` steps (default 20: about a quarter of the elements
are then yielding in every step), freezes that state and calls `element_update` `--reps` times
on fresh copies of it, with Johnson-Cook and with the block made elastic, interleaved. Prints
the minimum and the median of the process CPU time per element; the minimum is the least
disturbed by other work on the machine.

    python benchmarks/bench_kernel.py [--warm 20] [--reps 15]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def main(argv=None) -> dict:
    from bench_element import build

    from impactsim.materials import params as P
    from impactsim.solver import element as E
    from impactsim.solver.loop import Simulation

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--warm", type=int, default=20)
    ap.add_argument("--reps", type=int, default=15)
    args = ap.parse_args(argv)
    numba.set_num_threads(1)
    _, model, passes = build()
    sim = Simulation(model, passes, cfl=0.6)
    for _ in range(args.warm):
        sim.step()
    dt = sim.dt
    fr = sim.force_rows
    names = ["sdev", "pressure", "q", "eps_p", "eps_rate", "temperature", "energy", "vol"]
    frozen = {k: getattr(model, k).copy() for k in names}
    frozen["hard"], frozen["thermal"] = sim.hardening.copy(), sim.thermal.copy()
    params = {"JC": model.mat_params.copy(), "elastic": model.mat_params.copy()}
    params["elastic"][:, P.STRENGTH] = P.ELASTIC
    times = {k: [] for k in params}
    yielding = 0
    for rep in range(args.reps + 1):
        for label, mp in params.items():
            a = {k: v.copy() for k, v in frozen.items()}
            c0 = time.process_time()
            E.element_update(model.x, model.v, model.conn, model.elem_mat, model.status, a["sdev"],
                             a["pressure"], a["q"], a["eps_p"], a["eps_rate"], a["temperature"],
                             a["hard"], a["thermal"], a["energy"], a["vol"], a["vol"], model.vol0,
                             model.elem_mass, mp, sim.jnode, False, dt, sim.cq, sim.cl,
                             model.force, fr.rows, sim.fext, fr.extra_ptr, fr.extra_rows,
                             fr.part_size // E.CHUNK, sim.chunk_out, 1, True)
            if rep:  # the first round compiles nothing but warms the caches
                times[label].append(1e9 * (time.process_time() - c0) / model.n_elem)
            if label == "JC":
                yielding = int(np.count_nonzero(a["eps_p"] > frozen["eps_p"]))
    print(f"element kernel, 1 thread, {model.n_elem} tets after {args.warm} steps "
          f"({yielding / model.n_elem:.0%} yielding in the step), CPU ns per element:")
    out = {}
    for label, t in times.items():
        out[label] = (min(t), float(np.median(t)))
        print(f"  {label:8s} min {min(t):7.1f}   median {np.median(t):7.1f}")
    return out


if __name__ == "__main__":
    main()
