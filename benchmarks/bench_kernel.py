"""CPU time of the element kernel alone on a frozen state, one thread: the figure to compare
kernel changes with on a busy machine.

Builds the block of bench_element.py (202,752 tets, OFHC copper, Johnson-Cook + Mie-Grueneisen,
190 m/s onto a rigid wall), runs `--warm` steps (default 20: about a quarter of the elements
are then yielding in every step), freezes that state and calls `element_update` `--reps` times
on fresh copies of it, with Johnson-Cook and with the block made elastic, interleaved. Prints
the minimum and the median of the process CPU time per element; the minimum is the least
disturbed by other work on the machine.

    python benchmarks/bench_kernel.py [--warm 20] [--reps 15] [--erode] [--rev REV [--guard]]

It also times the Johnson-Cook kernel giving the distortion guard's verdicts (solver/guard.py,
as in a scene with fracture criteria): "JC + guard".

--erode erodes one tet of every block of 32 (status ERODED), the case of sphere-plate's mixed
blocks. --rev REV times the revision's kernel (its package exported as compare.py does) against
the working tree's instead, alternating on the same frozen state, with Johnson-Cook, and prints
how far apart their results are; with --guard both give the distortion guard's verdicts.
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

    from impactsim.kernel_cache import refresh

    refresh()  # kernels cached from older sources go first (kernel_cache.py), as the CLI does

    from impactsim.materials import params as P
    from impactsim.model import ERODED
    from impactsim.solver import element as E
    from impactsim.solver.loop import Simulation

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--warm", type=int, default=20)
    ap.add_argument("--reps", type=int, default=15)
    ap.add_argument("--erode", action="store_true", help="one tet of every block eroded")
    ap.add_argument("--rev", default="", help="A/B against this revision's kernel")
    ap.add_argument("--guard", action="store_true",
                    help="with --rev: both kernels give the guard's verdicts")
    args = ap.parse_args(argv)
    if args.rev:
        return _ab(args)
    numba.set_num_threads(1)
    _, model, passes = build()
    sim = Simulation(model, passes, cfl=0.6)
    for _ in range(args.warm):
        sim.step()
    if args.erode:
        model.status[5::E.B] = ERODED
    dt = sim.dt
    fr = sim.force_rows
    names = ["sdev", "pressure", "q", "eps_p", "eps_rate", "temperature", "energy", "vol"]
    frozen = {k: getattr(model, k).copy() for k in names}
    frozen["hard"], frozen["thermal"] = sim.hardening.copy(), sim.thermal.copy()
    params = {"JC": model.mat_params.copy(), "elastic": model.mat_params.copy()}
    params["elastic"][:, P.STRENGTH] = P.ELASTIC
    params["JC + guard"] = params["JC"]
    guard = np.zeros(model.n_elem, dtype=np.int8)
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
                             fr.part_size // E.CHUNK, sim.chunk_out, 1, sim.plastic,
                             guard if label == "JC + guard" else None)
            if rep:  # the first round compiles nothing but warms the caches
                times[label].append(1e9 * (time.process_time() - c0) / model.n_elem)
            if label == "JC":
                yielding = int(np.count_nonzero(a["eps_p"] > frozen["eps_p"]))
    print(f"element kernel, 1 thread, {model.n_elem} tets after {args.warm} steps "
          f"({yielding / model.n_elem:.0%} yielding in the step), CPU ns per element:")
    out = {}
    for label, t in times.items():
        out[label] = (min(t), float(np.median(t)))
        print(f"  {label:10s} min {min(t):7.1f}   median {np.median(t):7.1f}")
    return out


def _ab(args) -> dict:
    """The working tree's element_update against revision args.rev's on one frozen state."""
    import importlib
    import inspect

    from bench_element import build
    from compare import export

    from impactsim.model import ERODED
    from impactsim.solver import element as E
    from impactsim.solver.loop import Simulation

    sys.path.insert(0, export(args.rev))
    kernels = {args.rev: importlib.import_module("impactsim_rev.solver.element"),
               "working tree": E}
    numba.set_num_threads(1)
    _, model, passes = build()
    sim = Simulation(model, passes, cfl=0.6)
    for _ in range(args.warm):
        sim.step()
    if args.erode:
        model.status[5::E.B] = ERODED
    m, fr, dt = model, sim.force_rows, sim.dt
    names = ["sdev", "pressure", "q", "eps_p", "eps_rate", "temperature", "energy", "vol"]
    frozen = {k: getattr(m, k).copy() for k in names}
    frozen["hard"], frozen["thermal"] = sim.hardening.copy(), sim.thermal.copy()
    times = {k: [] for k in kernels}
    guards = {k: np.zeros(m.n_elem, dtype=np.int8) for k in kernels}
    results = {}
    for rep in range(args.reps + 1):
        for label, K in kernels.items():
            f = K.element_update
            takes_plastic = "plastic" in inspect.signature(getattr(f, "py_func", f)).parameters
            a = {k: v.copy() for k, v in frozen.items()}
            c0 = time.process_time()
            f(m.x, m.v, m.conn, m.elem_mat, m.status, a["sdev"], a["pressure"], a["q"],
              a["eps_p"], a["eps_rate"], a["temperature"], a["hard"], a["thermal"], a["energy"],
              a["vol"], a["vol"], m.vol0, m.elem_mass, m.mat_params, sim.jnode, False, dt,
              sim.cq, sim.cl, m.force, fr.rows, sim.fext, fr.extra_ptr, fr.extra_rows,
              fr.part_size // K.CHUNK, sim.chunk_out, 1, *((True,) if takes_plastic else ()),
              *((guards[label],) if args.guard else ()))
            if rep:
                times[label].append(1e9 * (time.process_time() - c0) / m.n_elem)
            results[label] = (a, m.force.copy())
    print(f"element kernel, 1 thread, {m.n_elem} tets after {args.warm} steps"
          f"{', one tet per block eroded' if args.erode else ''}, JC"
          f"{' + guard' if args.guard else ''}, CPU ns per element:")
    (ra, fa), (rb, fb) = results.values()
    for label, t in times.items():
        print(f"  {label:>14}: min {min(t):7.1f}   median {np.median(t):7.1f}")
    diff = max(float(np.abs(ra[k] - rb[k]).max() / max(np.abs(rb[k]).max(), 1e-300))
               for k in names)
    fdiff = float(np.abs(fa - fb).max() / np.abs(fb).max())
    print(f"  largest difference: state {diff:.1e}, forces {fdiff:.1e} (of each array's largest)")
    return {k: min(t) for k, t in times.items()}


if __name__ == "__main__":
    main()
