"""The hex kernel alone, the working tree against a git revision, in one process.

compare.py times whole steps; on the shared machine its ratio for two identical versions came
out anywhere in 0.93-1.07. This times `hex8.hex_update` alone: each version (the revision
exported by compare.export as `impactsim_rev`) builds the hex bench scene (bench_hex.py, 48^3
copper hexes onto a rigid wall, Johnson-Cook + Mie-Grueneisen), runs `--warm` steps, and the
two kernels are then called alternately on fresh copies of their frozen states, one thread;
prints the minimum CPU ns per hex of each over `--rounds` calls and their ratio.

    python benchmarks/hex_ab.py REV [--hourglass viscous|stiffness] [--rounds 15] [--warm 30]
        [--swap] [--scalar] [--cold]

`--cold` evicts the caches before every call (writes a 256 MB array): the element state then
comes from memory, as in a step of the time loop (where the kernel runs ~10-20 ns per hex
slower than on the state just copied, which the caches still hold).

The version built first comes out about 2-3 % slower: REV against an identical working tree
gave ratios of 1.006-1.071 (median 1.022) over six runs. `--swap` builds the working tree
first; the geometric mean of the ratios of both orders, sqrt(r * r_swap), cancels the bias.
"""

from __future__ import annotations

import argparse
import importlib
import math
import sys
import time
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import compare  # noqa: E402

STATE = ["sdev", "pressure", "q", "eps_p", "eps_rate", "temperature", "energy", "vol", "hg"]


def kernel_call(pkg: str, hourglass: str, warm: int, scalar: bool = False):
    """(call(state), frozen state, hexes) of package `pkg` after `warm` steps; with `scalar`
    every hex is then marked damaged, so that all take the scalar path `_hex_element`."""
    model, sim = compare.build(pkg, 48, False, hourglass)
    for _ in range(warm):
        sim.step()
    if scalar:
        model.blocks[0].status[:] = importlib.import_module(f"{pkg}.model").DAMAGED
    H = importlib.import_module(f"{pkg}.solver.hex8")
    blk, run = model.blocks[0], sim.block_runners[0]
    state = {k: getattr(blk, k).copy() for k in STATE}
    state["hard"], state["thermal"] = run.hard.copy(), run.thermal.copy()
    fr = run.rows

    def call(a):
        H.hex_update(model.x, model.v, blk.conn, blk.elem_mat, blk.status, a["sdev"],
                     a["pressure"], a["q"], a["eps_p"], a["eps_rate"], a["temperature"],
                     a["hard"], a["thermal"], a["energy"], a["vol"], blk.elem_mass, a["hg"],
                     blk.hg_visc, blk.hg_stiff, model.mat_params, sim.dt, sim.cq, sim.cl,
                     model.force, fr.rows, run.fext, fr.extra_ptr, fr.extra_rows,
                     fr.part_size // H.CHUNK, run.chunk_out, 1, False)
    return call, state, blk.n_elem


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rev")
    ap.add_argument("--hourglass", default="viscous")
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--warm", type=int, default=30)
    ap.add_argument("--swap", action="store_true", help="build the working tree's scene first")
    ap.add_argument("--scalar", action="store_true",
                    help="every hex marked damaged: the scalar path alone")
    ap.add_argument("--cold", action="store_true",
                    help="evict the caches before every call (the state from memory)")
    args = ap.parse_args(argv)
    sys.path.insert(0, compare.export(args.rev))
    sys.path.insert(0, str(compare.ROOT))
    numba.set_num_threads(1)
    order = [(args.rev, "impactsim_rev"), ("working tree", "impactsim")]
    built = {label: kernel_call(pkg, args.hourglass, args.warm, args.scalar)
             for label, pkg in (order[::-1] if args.swap else order)}
    runs = {label: built[label] for label, _ in order}
    best = {label: math.inf for label in runs}
    junk = np.zeros(32 << 20) if args.cold else None
    for _ in range(args.rounds):
        for label, (call, state, n) in runs.items():
            a = {k: v.copy() for k, v in state.items()}
            if junk is not None:
                junk += 1.0
            t0 = time.process_time()
            call(a)
            best[label] = min(best[label], 1e9 * (time.process_time() - t0) / n)
    print(f"hex kernel alone, {args.hourglass} hourglass, one thread, state after {args.warm} "
          f"steps: min CPU ns per hex of {args.rounds} calls"
          + (" (working tree built first)" if args.swap else "")
          + (", caches evicted before each call" if args.cold else ""))
    for label, t in best.items():
        print(f"  {label:>14}: {t:7.1f}")
    a, b = best.values()
    print(f"  ratio {args.rev} / working tree: {a / b:.3f}")
    return {"ns": best, "ratio": a / b}


if __name__ == "__main__":
    main()
