"""CPU seconds of a run's own thread against the other threads of its process (the frame writers).

    NUMBA_NUM_THREADS=1 python benchmarks/thread_cpu.py run cases/sphere-plate.toml -o out/sp -q

runs ``impactsim CLI-ARGS`` in this process and prints the process CPU seconds (user + system,
``os.times``), the main thread's (``/proc/self/task/<tid>/stat``, Linux) and their difference:
with one numba thread that is the CPU of the threads that write the frames
(output/series.py), which on a two-thread run compete with the run's own threads for the cores
(docs/performance.md, "Whole scenes, session 9").
"""

from __future__ import annotations

import os
import sys
import threading


def main_thread_cpu() -> float:
    """CPU seconds (user + system) of the calling thread, from /proc (Linux)."""
    with open(f"/proc/self/task/{threading.get_native_id()}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def main(argv=None) -> int:
    from impactsim.cli import main as cli

    try:
        cli(list(sys.argv[1:] if argv is None else argv))
    except SystemExit as err:
        if err.code not in (0, None):
            raise
    t = os.times()
    total = t.user + t.system
    own = main_thread_cpu()
    print(f"process CPU {total:.2f} s, main thread {own:.2f} s, other threads {total - own:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
