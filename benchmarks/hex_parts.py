"""Where the hex kernel's time goes: the vector path cut short after each part, and the memory
traffic alone.

One thread, process CPU time per hex, the minimum of `--reps` calls on fresh copies of a state
frozen after `--warm` steps of the hex bench scene (bench_hex.py: 48^3 copper hexes onto a
rigid wall, Johnson-Cook + Mie-Grueneisen):

- "kernel": the whole `hex8.hex_update` (one thread);
- "stream": a loop that reads and writes every array the kernel reads and writes (element
  state, the corners' x and v, the force rows) without its arithmetic: the memory floor of
  this layout on one core;
- "parts": every full block through the vector path cut short after loading, the kinematics,
  the radial return, the EOS with the stress and hourglass forces, the store.

    python benchmarks/hex_parts.py [--reps 7] [--warm 30] [--hourglass viscous|stiffness]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from impactsim.materials import params as P  # noqa: E402
from impactsim.solver import element as E  # noqa: E402
from impactsim.solver import hex8 as H  # noqa: E402
from impactsim.solver import hex8_block as HB  # noqa: E402

# the digest of hex8_block.py (scripts/gen_hex8_block.py), so that numba recompiles `_parts`
# when the block functions it compiles in change (its cache is keyed by this file alone)
BLOCK_SOURCE = "6a9859e1f3a00d65"
STATE = ["sdev", "pressure", "q", "eps_p", "eps_rate", "temperature", "energy", "vol", "hg"]


@numba.njit(cache=True)
def _stream(x, v, conn, rows, sdev, pressure, q, eps_rate, energy, vol, elem_mass, fext,
            eps_p, temperature, hard, thermal, hg, stiff):
    """Read and write what the hex kernel reads and writes, hex by hex, without its
    arithmetic."""
    acc = 0.0
    for e in range(conn.shape[0]):
        s = 0.0
        for k in range(8):
            n = np.uint64(conn[e, k])
            s += x[n, 0] + x[n, 1] + x[n, 2] + v[n, 0] + v[n, 1] + v[n, 2]
        s = 1e-30 * (s + vol[e] + elem_mass[e] + energy[e] + pressure[e])
        for c in range(6):
            sdev[e, c] += s
        if stiff:
            for c in range(12):
                hg[e, c] += s
        pressure[e] = s
        q[e] = s
        eps_rate[e] = s
        energy[e] = s
        vol[e] += s
        eps_p[e] += s
        temperature[e] += s
        hard[e] += s
        thermal[e] -= s
        for k in range(8):
            r = np.uint64(rows[e, k])
            fext[r, 0] += s
            fext[r, 1] += s
            fext[r, 2] += s
        acc += s
    return acc


@numba.njit(cache=True)
def _parts(level, x, v, conn, rows, sdev, pressure, q, eps_p, eps_rate, temperature, hard,
           thermal, energy, vol, elem_mass, hg, hg_visc, hg_stiff, mat_params, dt, fext):
    """Every full block through the vector path (hex8._block) cut short after part `level`:
    0 load, 1 kinematics, 2 return, 3 EOS, stress and hourglass forces, 4 store."""
    B = E.B
    buf = E.aligned_empty(HB.HROWS * B)
    mk = 0
    half = 0.5 * dt
    shear = mat_params[mk, P.G]
    bulk = mat_params[mk, P.K]
    acc = 0.0
    for blk in range(conn.shape[0] // B):
        e0 = blk * B
        stiff = hg_stiff[e0] > 0.0
        HB.load_block(x, v, conn, sdev, pressure, energy, vol, elem_mass, hg, hg_visc,
                      hg_stiff, e0, buf, stiff)
        if level >= 1:
            HB.kinematics_block(buf, half, dt, shear)
        if level >= 2:
            E._jc_return_block(buf, mat_params, mk, shear, eps_p, temperature, hard, thermal,
                               e0)
        if level >= 3:
            HB.forces_block(buf, dt, int(mat_params[mk, P.EOS]), mat_params[mk, P.RHO0],
                            bulk, mat_params[mk, P.C0], mat_params[mk, P.S],
                            mat_params[mk, P.GAMMA0], shear, 1.2, 0.06, stiff)
        if level >= 4:
            r = HB.store_block(rows, sdev, pressure, q, eps_rate, energy, vol, hg, fext, e0,
                               buf, stiff)
            acc += r[0]
        acc += buf[7 * B]
    return acc


def frozen(warm: int, hourglass: str, cells: int = 48):
    from bench_hex import case_text

    from impactsim.case import load_case_text
    from impactsim.mesh import mesh_body
    from impactsim.solver.build import build_model
    from impactsim.solver.loop import Simulation
    from impactsim.solver.pipeline import build_passes

    case = load_case_text(case_text(cells, hourglass=hourglass))
    model = build_model(case, [mesh_body(case.bodies[0])])
    sim = Simulation(model, build_passes(case, model), cfl=0.6)
    for _ in range(warm):
        sim.step()
    blk, run = model.blocks[0], sim.block_runners[0]
    state = {k: getattr(blk, k).copy() for k in STATE}
    state["hard"], state["thermal"] = run.hard.copy(), run.thermal.copy()
    return model, sim, state


def cpu_ns(fn, state, n_elem, reps, inner=1):
    """Minimum CPU ns per hex of `inner` calls of fn(copy of state) over reps timings (plus
    one untimed)."""
    best = math.inf
    for rep in range(reps + 1):
        a = {k: v.copy() for k, v in state.items()}
        t0 = time.process_time()
        for _ in range(inner):
            fn(a)
        t = 1e9 * (time.process_time() - t0) / (n_elem * inner)
        if rep:
            best = min(best, t)
    return best


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=7)
    ap.add_argument("--warm", type=int, default=30, help="steps before the state is frozen")
    ap.add_argument("--hourglass", default="viscous")
    ap.add_argument("--cells", type=int, default=48, help="hexes along an edge of the block "
                    "(16: 4,096 hexes, whose data stays in the L2 cache)")
    args = ap.parse_args(argv)
    numba.set_num_threads(1)
    model, sim, state = frozen(args.warm, args.hourglass, args.cells)
    m, blk, run, dt = model, model.blocks[0], sim.block_runners[0], sim.dt
    fr = run.rows
    n = blk.n_elem
    stiff = args.hourglass == "stiffness"
    inner = max(1, 100_000 // n)

    def kernel(a):
        H.hex_update(m.x, m.v, blk.conn, blk.elem_mat, blk.status, a["sdev"], a["pressure"],
                     a["q"], a["eps_p"], a["eps_rate"], a["temperature"], a["hard"],
                     a["thermal"], a["energy"], a["vol"], blk.elem_mass, a["hg"], blk.hg_visc,
                     blk.hg_stiff, m.mat_params, dt, sim.cq, sim.cl, m.force, fr.rows, run.fext,
                     fr.extra_ptr, fr.extra_rows, fr.part_size // H.CHUNK, run.chunk_out, 1,
                     False)

    out = {"kernel": cpu_ns(kernel, state, n, args.reps, inner),
           "stream": cpu_ns(lambda a: _stream(
               m.x, m.v, blk.conn, fr.rows, a["sdev"], a["pressure"], a["q"], a["eps_rate"],
               a["energy"], a["vol"], blk.elem_mass, run.fext, a["eps_p"], a["temperature"],
               a["hard"], a["thermal"], a["hg"], stiff), state, n, args.reps, inner)}
    for level, part in enumerate(["load", "+ kinematics", "+ return",
                                  "+ EOS, stress, hourglass", "+ store"]):
        out[f"parts: {part}"] = cpu_ns(lambda a: _parts(
            level, m.x, m.v, blk.conn, fr.rows, a["sdev"], a["pressure"], a["q"], a["eps_p"],
            a["eps_rate"], a["temperature"], a["hard"], a["thermal"], a["energy"], a["vol"],
            blk.elem_mass, a["hg"], blk.hg_visc, blk.hg_stiff, m.mat_params, dt, run.fext),
            state, n, args.reps, inner)
    a = {k: v.copy() for k, v in state.items()}
    kernel(a)
    yielding = np.count_nonzero(a["eps_p"] > state["eps_p"]) / n
    print(f"one thread, CPU ns per hex, {n} hexes, {args.hourglass} hourglass, state after "
          f"{args.warm} steps ({yielding:.0%} yield in the step):")
    for k, t in out.items():
        print(f"  {k:28s} {t:7.1f}")
    return out


if __name__ == "__main__":
    main()
