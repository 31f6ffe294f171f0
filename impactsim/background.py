"""Threads that work beside the run on what it hands over (the penetration measure, the frames):
they should take the CPU the run leaves idle rather than the run's own.

``background_thread`` (a ThreadPoolExecutor's initializer) lowers the calling thread's priority
to nice NICE (its own: Linux keeps a nice value per thread). Where a core is idle (the run's
serial stretches, its end) the thread runs at full speed; where it meets the run's threads on a
core, the scheduler gives it about a tenth of their share (weight 110 against 1024), so it
slows them little. A tenth is still several times what the penetration measure needs of the
run's CPU (1.5-4.5 % in the bundled scenes), so on a machine loaded by other processes it keeps
up instead of starving, as a SCHED_IDLE thread would. Elsewhere (no per-thread nice value, not
permitted) the thread keeps its priority."""

from __future__ import annotations

import os
import threading

NICE = 10


def background_thread() -> None:
    """Lower the calling thread's priority to nice NICE where that is possible."""
    try:
        os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), NICE)
    except (AttributeError, OSError):
        pass
