"""Where the element kernel's time goes: memory traffic, the vector path's parts, cache size.

All on one thread, process CPU time per element, the minimum of `--reps` calls on fresh copies
of a state frozen after 20 steps of the bench scene (bench_element.py: copper onto a rigid
wall, Johnson-Cook + Mie-Grueneisen):

- "stream": a loop that reads and writes every array the kernel reads and writes (element
  state, the corners' x and v, the force rows) and does no arithmetic: the cost of the memory
  traffic alone, the limit of this data layout on one core;
- "vector path parts": the blocks of 32 run through the vector path cut short after loading,
  after the kinematics, after the EOS and forces, after storing (no radial return): what each
  part adds;
- "JC return parts": the same blocks with the Johnson-Cook return of `_jc_return_block` cut
  short after its floor check and the copy of its four arrays, after the rate term and Newton
  start, after one vector Newton iteration, after all of them, after the scalar returns of the
  lanes at their first yield or still iterating, after heating and the thermal factor (the
  copy back is left out); each figure is on top of load + kinematics;
- "kernel": the whole element kernel, Johnson-Cook and elastic, on the 202,752-tet block; the
  elastic kernel also on a 3,456-tet block whose data stays in the caches (called 20 times in
  a row per timing, so that the cost of a call from Python, some 20 us, is spread): the
  difference is what the memory costs the kernel, the small block's figure what its arithmetic
  costs. (A Johnson-Cook figure of the small block would not compare: a larger share of it
  yields.)

    python benchmarks/bench_limits.py [--reps 9] [--warm 20]

`--warm 60` freezes the state later, when two thirds of the elements yield in a step instead
of a quarter.
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

from impactsim.materials import params as P  # noqa: E402
from impactsim.solver import element as E  # noqa: E402

STATE = ["sdev", "pressure", "q", "eps_p", "eps_rate", "temperature", "energy", "vol"]


@numba.njit(cache=True)
def _stream(x, v, conn, rows, sdev, pressure, q, eps_rate, energy, vol, elem_mass, fext, jc,
            eps_p, temperature, hard, thermal):
    """Read and write what the element kernel reads and writes, element by element, without
    its arithmetic (the values written are only kept finite)."""
    acc = 0.0
    for e in range(conn.shape[0]):
        s = 0.0
        for k in range(4):
            n = np.uint64(conn[e, k])
            s += x[n, 0] + x[n, 1] + x[n, 2] + v[n, 0] + v[n, 1] + v[n, 2]
        s = 1e-30 * (s + vol[e] + elem_mass[e] + energy[e] + pressure[e])
        for c in range(6):
            sdev[e, c] += s
        pressure[e] = s
        q[e] = s
        eps_rate[e] = s
        energy[e] = s
        vol[e] += s
        if jc:
            eps_p[e] += s
            temperature[e] += s
            hard[e] += s
            thermal[e] -= s
        for k in range(4):
            r = np.uint64(rows[e, k])
            fext[r, 0] += s
            fext[r, 1] += s
            fext[r, 2] += s
        acc += s
    return acc


@numba.njit(cache=True)
def _vector_parts(level, x, v, conn, rows, sdev, pressure, q, eps_rate, energy, vol, vol0,
                  elem_mass, mat_params, jnode, dt, fext):
    """The vector path of every full block, cut short after part `level` (0 load, 1
    kinematics, 2 EOS and forces, 3 store); one material, no radial return."""
    B = E.B
    buf = np.empty(E.ROWS * B)
    shear = mat_params[0, P.G]
    acc = 0.0
    for b in range(conn.shape[0] // B):
        e0 = b * B
        E._load_block(x, v, conn, sdev, pressure, energy, vol, vol, vol0, elem_mass, jnode,
                      False, e0, buf)
        if level >= 1:
            E._kinematics_block(buf, 0.5 * dt, dt, shear)
        if level >= 2:
            E._pressure_block(buf, dt, False, int(mat_params[0, P.EOS]), mat_params[0, P.RHO0],
                              mat_params[0, P.K], mat_params[0, P.C0], mat_params[0, P.S],
                              mat_params[0, P.GAMMA0], shear, 1.2, 0.06, None)
        if level >= 3:
            E._store_block(rows, sdev, pressure, q, eps_rate, energy, vol, vol, fext, False, e0,
                           buf)
        acc += buf[5 * B]
    return acc


@numba.njit(cache=True)
def _jc_parts(level, x, v, conn, sdev, pressure, energy, vol, vol0, elem_mass, mat_params,
              jnode, dt, eps_p, temperature, hard, thermal):
    """Load + kinematics of every full block, then `_jc_return_block`'s steps up to `level`
    (0 none, 1 floor check and copy in, 2 start, 3 one Newton iteration, 4 all, 5 scalar
    returns, 6 finish); one material."""
    B = E.B
    buf = np.empty(E.ROWS * B)
    mk = 0
    shear = mat_params[mk, P.G]
    a0, b0, n = mat_params[mk, P.JC_A], mat_params[mk, P.JC_B], mat_params[mk, P.JC_N]
    g3 = 3.0 * shear
    acc = 0.0
    for b in range(conn.shape[0] // B):
        e0 = b * B
        E._load_block(x, v, conn, sdev, pressure, energy, vol, vol, vol0, elem_mass, jnode,
                      False, e0, buf)
        E._kinematics_block(buf, 0.5 * dt, dt, shear)
        acc += buf[E.R_SEQ * B]
        if level == 0:
            continue
        hd = hard[e0:e0 + B]
        th = thermal[e0:e0 + B]
        active = False
        for i in range(B):
            if buf[E.R_SEQ * B + i] > hd[i] * th[i]:
                active = True
                break
        if not active:
            continue
        E._copy_in(eps_p[e0:e0 + B], buf, E.R_EP)
        E._copy_in(temperature[e0:e0 + B], buf, E.R_TEMP)
        E._copy_in(hd, buf, E.R_HARD)
        E._copy_in(th, buf, E.R_THERM)
        if level == 1 or E._jc_start(buf, a0, n, mat_params[mk, P.JC_C], g3,
                                     1.0 / mat_params[mk, P.EPSDOT0]) == 0 or level == 2:
            continue
        for it in range(E.VECTOR_ITERATIONS):
            if E._jc_newton(buf, a0, b0, n, g3) == 0 or level == 3:
                break
        if level <= 4:
            continue
        for i in range(B):
            if buf[E.R_DONE * B + i] != E.FINISHED:
                deps, sy, hnew = E.radial_return(P.JOHNSON_COOK, mat_params, mk, shear,
                                                 buf[E.R_SEQ * B + i], buf[E.R_EP * B + i],
                                                 buf[E.R_RATE * B + i], buf[E.R_HARD * B + i],
                                                 buf[E.R_THERM * B + i])
                buf[E.R_DEPS * B + i] = deps
                buf[E.R_SY * B + i] = sy
                buf[E.R_HN * B + i] = hnew
        if level == 5:
            continue
        t_room = mat_params[mk, P.T_ROOM]
        E._jc_finish(buf, mat_params[mk, P.TQ] / mat_params[mk, P.CV], t_room,
                     1.0 / (mat_params[mk, P.T_MELT] - t_room), mat_params[mk, P.JC_M])
        acc += buf[E.R_EP * B]
    return acc


def _frozen(cells, warm):
    from bench_element import build

    from impactsim.solver.loop import Simulation

    _, model, passes = build(cells)
    sim = Simulation(model, passes, cfl=0.6)
    for _ in range(warm):
        sim.step()
    state = {k: getattr(model, k).copy() for k in STATE}
    state["hard"], state["thermal"] = sim.hardening.copy(), sim.thermal.copy()
    return model, sim, state


def _cpu_ns(fn, state, n_elem, reps, inner=1):
    """Minimum CPU ns per element of `inner` calls of fn(copy of state) over reps timings
    (plus one untimed)."""
    best = np.inf
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
    ap.add_argument("--reps", type=int, default=9)
    ap.add_argument("--warm", type=int, default=20, help="steps before the state is frozen")
    args = ap.parse_args(argv)
    numba.set_num_threads(1)
    out = {}
    for label, cells in (("202,752 tets", (32, 32, 33)), ("3,456 tets", (8, 8, 9))):
        model, sim, state = _frozen(cells, args.warm)
        m, fr, dt = model, sim.force_rows, sim.dt
        elastic = m.mat_params.copy()
        elastic[:, P.STRENGTH] = P.ELASTIC
        small = m.n_elem < 100_000

        def kernel(a, mp):
            E.element_update(m.x, m.v, m.conn, m.elem_mat, m.status, a["sdev"], a["pressure"],
                             a["q"], a["eps_p"], a["eps_rate"], a["temperature"], a["hard"],
                             a["thermal"], a["energy"], a["vol"], a["vol"], m.vol0, m.elem_mass,
                             mp, sim.jnode, False, dt, sim.cq, sim.cl, m.force, fr.rows,
                             sim.fext, fr.extra_ptr, fr.extra_rows, fr.part_size // E.CHUNK,
                             sim.chunk_out, 1, True)

        reps = args.reps
        row = {"kernel elastic": _cpu_ns(lambda a: kernel(a, elastic), state, m.n_elem, reps,
                                         20 if small else 1)}
        if not small:
            row["kernel JC"] = _cpu_ns(lambda a: kernel(a, m.mat_params), state, m.n_elem, reps)
            for jc in (False, True):
                row[f"stream, {'JC' if jc else 'elastic'} arrays"] = _cpu_ns(
                    lambda a: _stream(m.x, m.v, m.conn, fr.rows, a["sdev"], a["pressure"],
                                      a["q"], a["eps_rate"], a["energy"], a["vol"],
                                      m.elem_mass, sim.fext, jc, a["eps_p"], a["temperature"],
                                      a["hard"], a["thermal"]), state, m.n_elem, reps)
            for level, part in enumerate(["load", "+ kinematics", "+ EOS and forces",
                                          "+ store"]):
                row[f"vector path: {part}"] = _cpu_ns(
                    lambda a: _vector_parts(level, m.x, m.v, m.conn, fr.rows, a["sdev"],
                                            a["pressure"], a["q"], a["eps_rate"], a["energy"],
                                            a["vol"], m.vol0, m.elem_mass, elastic, sim.jnode,
                                            dt, sim.fext), state, m.n_elem, reps)
            for level, part in enumerate(["load + kinematics", "+ floor check, copy in",
                                          "+ rate term, Newton start", "+ 1 Newton iteration",
                                          "+ all Newton iterations", "+ scalar returns",
                                          "+ heating, thermal factor"]):
                row[f"JC return: {part}"] = _cpu_ns(
                    lambda a: _jc_parts(level, m.x, m.v, m.conn, a["sdev"], a["pressure"],
                                        a["energy"], a["vol"], m.vol0, m.elem_mass, m.mat_params,
                                        sim.jnode, dt, a["eps_p"], a["temperature"], a["hard"],
                                        a["thermal"]), state, m.n_elem, reps)
            a = {k: v.copy() for k, v in state.items()}
            kernel(a, m.mat_params)
            yielding = np.count_nonzero(a["eps_p"] > state["eps_p"]) / m.n_elem
        out[label] = row
    print(f"one thread, CPU ns per element, state after {args.warm} steps of the bench scene "
          f"({yielding:.0%} of the elements yield in the step):")
    for label, row in out.items():
        print(f"  {label}:")
        for k, t in row.items():
            print(f"    {k:38s} {t:7.1f}")
    return out


if __name__ == "__main__":
    main()
