"""`make bench`: every benchmark, one after the other, in one process so ratios share a run.

Each benchmark module has a main() that prints its own table. Set BENCH=element,contact to run
a subset (names are the bench_<name>.py files of this folder).
"""

from __future__ import annotations

import importlib
import os
import sys
import time
from pathlib import Path

HERE = Path(__file__).parent


def main() -> int:
    sys.path.insert(0, str(HERE.parent))
    from impactsim.kernel_cache import refresh

    refresh()  # kernels cached from older sources go first, as the CLI does
    names = sorted(p.stem[len("bench_"):] for p in HERE.glob("bench_*.py"))
    wanted = os.environ.get("BENCH")
    if wanted:
        names = [n for n in names if n in wanted.split(",")]
    for name in names:
        print(f"\n== {name} ==", flush=True)
        t0 = time.perf_counter()
        importlib.import_module(f"benchmarks.bench_{name}").main()
        print(f"({time.perf_counter() - t0:.1f} s)", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
