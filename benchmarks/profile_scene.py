"""Where a scene's CPU time goes, by function: cProfile with the process CPU clock around
`impactsim run CASE` (one process; set NUMBA_NUM_THREADS=1 for the work of one thread).

    NUMBA_NUM_THREADS=1 python benchmarks/profile_scene.py cases/sphere-plate.toml [-o DIR]
        [--top 40] [--callees NAME ...]

Prints the functions by own time (numba kernels show as one Python call each: their time is
their own), then the callees of each --callees pattern (e.g. ``_fresh_pairs``); the stats are
kept in DIR.prof for pstats.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import sys
import tempfile
import time
from pathlib import Path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("case")
    ap.add_argument("-o", "--out", type=Path, default=None)
    ap.add_argument("--top", type=int, default=40)
    ap.add_argument("--callees", nargs="*", default=[])
    a = ap.parse_args(argv)
    from impactsim.cli import main as cli

    out = a.out or Path(tempfile.mkdtemp(prefix="impactsim-profile-")) / "run"
    prof = cProfile.Profile(time.process_time)
    prof.enable()
    try:
        cli(["run", a.case, "-o", str(out), "--overwrite", "-q"])
    except SystemExit:
        pass
    prof.disable()
    prof.dump_stats(str(out) + ".prof")
    st = pstats.Stats(str(out) + ".prof")
    st.sort_stats("tottime").print_stats(a.top)
    for name in a.callees:
        st.print_callees(name)
    return 0


if __name__ == "__main__":
    sys.exit(main())
