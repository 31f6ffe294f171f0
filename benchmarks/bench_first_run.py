"""The user's first wait: compile time, and the time to the first step of every bundled case.

Each figure comes from a fresh process, as a user's run would:

1. cold numba cache (an empty NUMBA_CACHE_DIR), `python -m impactsim.warmup` (what `make setup`
   runs after the install): wall and CPU seconds, kernels compiled: the total compile time;
2. with the cache it left, every bundled case run for a few steps with an empty mesh cache
   (a fresh machine has meshed nothing): seconds to the first step (summary.json, includes
   meshing), wall and CPU seconds of the whole process (imports and the few steps included;
   the CPU time is what a loaded machine does not inflate), kernels compiled (0 when the
   warm-up covered the case);
3. the demo (elastic-bar-wall) with a cold numba cache and no warm-up: what a run costs when
   the warm-up step was skipped.

    python benchmarks/bench_first_run.py [--cases a,b] [--steps 3] [--no-cold-demo] [--own-cache]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from impactsim.case.quasistatic import is_quasistatic

ROOT = Path(__file__).resolve().parents[1]
# every bundled case of the explicit solver (the quasi-static ones compile no numba kernels)
CASES = sorted(p.stem for p in (ROOT / "cases").glob("*.toml") if not is_quasistatic(p))

# runs a case in a fresh interpreter and prints its first-step time and what it compiled
_RUN = """
import json, sys, time
t0 = time.perf_counter()
c0 = time.process_time()
from pathlib import Path
from impactsim.warmup import CompileCounter
from impactsim.case import load_case
from impactsim.solver.run import run_case
with CompileCounter() as c:
    s = run_case(load_case(Path(sys.argv[1]), [f"run.max_steps={sys.argv[3]}"]), Path(sys.argv[2]),
                 progress=False)
print(json.dumps({"first_step": s["seconds_to_first_step"], "kernels": c.kernels,
                  "wall": time.perf_counter() - t0, "cpu": time.process_time() - c0}))
"""


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run_case_fresh(case: str, env: dict, steps: int) -> dict:
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        p = subprocess.run([sys.executable, "-c", _RUN, str(ROOT / "cases" / f"{case}.toml"),
                            out, str(steps)], cwd=ROOT, env=env, check=True,
                           capture_output=True, text=True)
        r = json.loads(p.stdout.strip().splitlines()[-1])
        r["process"] = time.perf_counter() - t0
        return r


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--steps", type=int, default=3)
    ap.add_argument("--no-cold-demo", action="store_true")
    ap.add_argument("--own-cache", action="store_true", help="use the numba cache next to the "
                    "sources (as `make setup` leaves it) instead of an empty one: the warm-up "
                    "then compiles only what is missing")
    args = ap.parse_args(argv)
    out = {}
    with tempfile.TemporaryDirectory() as numba_cache, tempfile.TemporaryDirectory() as meshes:
        env = dict(os.environ, NUMBA_CACHE_DIR=numba_cache, IMPACTSIM_CACHE=meshes,
                   PYTHONPATH=str(ROOT))
        if args.own_cache:
            del env["NUMBA_CACHE_DIR"]
        c0, t0 = _children_cpu(), time.perf_counter()
        p = subprocess.run([sys.executable, "-m", "impactsim.warmup"], cwd=ROOT, env=env,
                           check=True, capture_output=True, text=True)
        wall, cpu = time.perf_counter() - t0, _children_cpu() - c0
        print(p.stdout.strip())
        print(f"warm-up with {'the own' if args.own_cache else 'a cold'} numba cache: "
              f"{wall:.1f} s wall, {cpu:.1f} s CPU")
        out["warmup"] = {"wall": wall, "cpu": cpu}
        print(f"{'case (fresh process, warm numba cache, cold mesh cache)':<56}"
              f"{'first step s':>13}{'process s':>11}{'CPU s':>7}{'compiled':>10}")
        for case in args.cases.split(","):
            r = run_case_fresh(case, env, args.steps)
            out[case] = r
            print(f"{case:<56}{r['first_step']:>13.2f}{r['process']:>11.2f}{r['cpu']:>7.2f}"
                  f"{len(r['kernels']):>10}" + (f"  {r['kernels']}" if r["kernels"] else ""),
                  flush=True)
    if not args.no_cold_demo:
        with tempfile.TemporaryDirectory() as numba_cache:
            env = dict(os.environ, NUMBA_CACHE_DIR=numba_cache, PYTHONPATH=str(ROOT))
            r = run_case_fresh("elastic-bar-wall", env, args.steps)
            print(f"elastic-bar-wall, cold numba cache, no warm-up: first step after "
                  f"{r['first_step']:.1f} s, {len(r['kernels'])} kernels compiled")
            out["cold_demo"] = r
    return out


if __name__ == "__main__":
    main()
