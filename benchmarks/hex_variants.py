"""Variants of the hex kernel from edited source, timed against each other in one process.

hex_ab.py compares two committed versions, but every edit of hex8.py or hex8_block.py costs a
recompilation of the kernel (and, through kernel_cache.refresh in the tests and the warm-up, of
the whole cache). Here an idea is tried in seconds: `variant` compiles `hex8.hex_update`
(serial, `prange` as `range`: the same time on one thread) from its source with text edits,
`block_fn` one of hex8_block's functions likewise, `blocks` a stand-in for the hex8_block module
whose block functions the variant calls; `run` builds the hex bench scene (bench_hex.py), freezes
its state after `warm` steps, checks every variant's forces and stresses against the first, and
prints the minimum CPU ns per hex of alternating calls, one thread.

Compare like with like: a function compiled in this process can be inlined into its caller (its
LLVM IR is at hand), one loaded from the cache cannot, and that alone moved a variant by 3 ns
per hex (session 9). `blocks()` therefore compiles all four block functions afresh, edited or
not; include an unedited `variant([], {"HB": blocks()})` and a copy of it (e.g. with
`("half = 0.5 * dt", "half = dt * 0.5")`) to see the noise. A gain seen here is confirmed with
hex_ab.py on the committed change (in both orders) before it is believed.

    from hex_variants import variant, block_fn, blocks, run
    zero = block_fn("load_block", [("    if stiff:", "    if True:")])
    run({"base": variant([], {"HB": blocks()}),
         "edit": variant([], {"HB": blocks(load_block=zero)}),
         "base again": variant([("half = 0.5 * dt", "half = dt * 0.5")], {"HB": blocks()})})

    python benchmarks/hex_variants.py    # that noise check alone
"""

from __future__ import annotations

import inspect
import math
import sys
import time
import types
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import hex_parts  # noqa: E402

from impactsim.solver import hex8 as H  # noqa: E402
from impactsim.solver import hex8_block as HB  # noqa: E402

BLOCK_FUNCTIONS = ("load_block", "kinematics_block", "forces_block", "store_block")


def _compile(fn, module, edits, replace=()):
    src = inspect.getsource(fn)
    for a, b in tuple(replace) + tuple(edits):
        if a not in src:
            raise ValueError(f"not in {fn.__name__}'s source: {a!r}")
        src = src.replace(a, b)
    ns = dict(vars(module))
    return src, ns


def variant(edits, names=None):
    """hex_update compiled serially from its source with `edits` ((old, new) text pairs), its
    globals those of hex8.py updated with `names` (e.g. {"HB": blocks(...)})."""
    src, ns = _compile(H.hex_update, H, edits, [
        ("@numba.njit(cache=True, parallel=True, nogil=True",
         "@numba.njit(cache=False, nogil=True"), ("numba.prange", "range")])
    ns.update(names or {})
    exec(src, ns)
    return ns["hex_update"]


def block_fn(name, edits):
    """hex8_block's function `name` compiled afresh from its source with `edits`."""
    src, ns = _compile(getattr(HB, name), HB, edits, [("@numba.njit(cache=True",
                                                       "@numba.njit(cache=False")])
    exec(src, ns)
    return ns[name]


_FRESH: dict = {}

#: element.py's Johnson-Cook return, leaves first (each compiled into the ones after it)
JC_FUNCTIONS = ("_jc_start", "_jc_newton", "_jc_finish", "_jc_load", "_jc_store", "_jc_lanes",
                "_jc_return_block")


def elements(edits=None, **names):
    """A stand-in for the element module (`E` in hex8.py) whose Johnson-Cook return functions
    (JC_FUNCTIONS) are compiled afresh from their sources, with `edits` {function name: [(old,
    new), ...]}; `names` are set in their globals first (e.g. a laws function of your own).
    Pass it as variant(..., {"E": elements(...)}); compare against elements() unedited (the
    inlining trap above applies to these functions as to the block functions)."""
    from impactsim.solver import element as E
    edits = edits or {}
    mod = types.ModuleType(f"element_variant_{len(_FRESH)}")
    for k in dir(E):
        if not k.startswith("__"):
            setattr(mod, k, getattr(E, k))
    ns = dict(vars(E))
    ns.update(names)
    for name in JC_FUNCTIONS:
        src, _ = _compile(getattr(E, name), E, edits.get(name, ()),
                          [("@numba.njit(cache=True", "@numba.njit(cache=False")])
        exec(src, ns)
        setattr(mod, name, ns[name])
    _FRESH[mod.__name__] = mod
    return mod


def blocks(**fns):
    """A stand-in for the hex8_block module: its block functions those given, the others
    compiled afresh (unedited), everything else hex8_block's."""
    mod = types.ModuleType(f"hex8_block_variant_{len(_FRESH)}_{'_'.join(sorted(fns))}")
    for k in dir(HB):
        if not k.startswith("__"):
            setattr(mod, k, getattr(HB, k))
    for k in BLOCK_FUNCTIONS:
        if k not in fns and k not in _FRESH:
            _FRESH[k] = block_fn(k, [])
        setattr(mod, k, fns.get(k) or _FRESH[k])
    return mod


def run(variants: dict, warm: int = 30, rounds: int = 15, hourglass: str = "viscous",
        cold: bool = False) -> dict:
    """Minimum CPU ns per hex of each variant over `rounds` alternating calls on copies of the
    bench scene's state after `warm` steps, one thread; prints them with each variant's largest
    force and stress difference from the first variant's."""
    numba.set_num_threads(1)
    model, sim, state = hex_parts.frozen(warm, hourglass)
    m, blk, rn = model, model.blocks[0], sim.block_runners[0]
    fr, n = rn.rows, blk.n_elem

    def bind(fn):
        def call(a):
            fn(m.x, m.v, blk.conn, blk.elem_mat, blk.status, a["sdev"], a["pressure"], a["q"],
               a["eps_p"], a["eps_rate"], a["temperature"], a["hard"], a["thermal"],
               a["energy"], a["vol"], blk.elem_mass, a["hg"], blk.hg_visc, blk.hg_stiff,
               m.mat_params, sim.dt, sim.cq, sim.cl, m.force, fr.rows, rn.fext, fr.extra_ptr,
               fr.extra_rows, fr.part_size // H.CHUNK, rn.chunk_out, 1, False)
        return call

    calls = {k: bind(f) for k, f in variants.items()}
    outs = {}
    for k, call in calls.items():  # the first call compiles
        a = {s: v.copy() for s, v in state.items()}
        m.force[:] = 0.0
        t0 = time.perf_counter()
        call(a)
        outs[k] = (a["sdev"], m.force.copy())
        print(f"compiled {k} in {time.perf_counter() - t0:.1f} s", flush=True)
    ref = next(iter(outs.values()))
    best = {k: math.inf for k in calls}
    junk = np.zeros(32 << 20) if cold else None
    for _ in range(rounds):
        for k, call in calls.items():
            a = {s: v.copy() for s, v in state.items()}
            if junk is not None:
                junk += 1.0
            t0 = time.process_time()
            call(a)
            best[k] = min(best[k], 1e9 * (time.process_time() - t0) / n)
    print(f"{hourglass} hourglass, state after {warm} steps, one thread, min CPU ns per hex of "
          f"{rounds} calls (max |force|, |sdev| difference from the first)")
    for k, t in best.items():
        sd, f = outs[k]
        print(f"  {k:24s} {t:7.1f}   {np.abs(f - ref[1]).max():.2e} N  "
              f"{np.abs(sd - ref[0]).max():.2e} Pa")
    return best


if __name__ == "__main__":
    run({"base": variant([], {"HB": blocks()}),
         "base again": variant([("half = 0.5 * dt", "half = dt * 0.5")], {"HB": blocks()})})
