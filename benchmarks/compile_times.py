"""Which numba kernels a run compiles with a cold cache, and how long each takes.

Runs a case in this process with numba's cache in an empty folder and records numba's compile
events: per kernel the seconds from the start to the end of its compilation, which include the
kernels it calls and compiles on the way (so the times nest: element_update's includes
_chunk's, which includes the block functions'), in wall time and in the process's CPU time (the
figure to compare on a machine other work shares). Prints the run's seconds to the first step,
the CPU seconds of all compilation (the outermost compilations summed) and the kernels that
took longest.

    python benchmarks/compile_times.py [CASE] [--top 20]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> list[tuple[str, float]]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case", nargs="?", default=str(ROOT / "cases" / "elastic-bar-wall.toml"))
    ap.add_argument("--top", type=int, default=20)
    args = ap.parse_args(argv)
    cache = tempfile.mkdtemp(prefix="impactsim-numba-cache-")
    os.environ["NUMBA_CACHE_DIR"] = cache  # before numba reads its configuration
    sys.path.insert(0, str(ROOT))
    from numba.core import event

    from impactsim.case import load_case
    from impactsim.solver.run import run_case

    started: dict[int, tuple[float, float]] = {}
    took: dict[str, list[float]] = {}
    total = [0.0]  # CPU seconds of the outermost compilations

    class Compiles(event.Listener):
        def on_start(self, ev):
            started[id(ev.data["dispatcher"])] = (time.perf_counter(), time.process_time())

        def on_end(self, ev):
            d = ev.data["dispatcher"]
            name = f"{d.py_func.__module__}.{d.py_func.__qualname__}"
            w0, c0 = started.pop(id(d))
            t = took.setdefault(name, [0.0, 0.0])
            t[0] += time.perf_counter() - w0
            t[1] += time.process_time() - c0
            if not started:
                total[0] += time.process_time() - c0

    event.register("numba:compile", Compiles())
    with tempfile.TemporaryDirectory() as out:
        summary = run_case(load_case(args.case), Path(out), progress=False)
    rows = sorted(took.items(), key=lambda kv: -kv[1][1])
    print(f"{Path(args.case).name}: {summary['seconds_to_first_step']:.1f} s to the first step "
          f"with a cold cache, {len(rows)} kernels compiled in {total[0]:.1f} CPU s; the "
          "longest (nested times):")
    print("     wall s    CPU s  kernel")
    for name, (wall, cpu) in rows[:args.top]:
        print(f"  {wall:9.2f} {cpu:8.2f}  {name}")
    return rows


if __name__ == "__main__":
    main()
