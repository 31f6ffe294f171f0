"""Threads that work beside the run on what it hands over (the penetration measure, the frames):
they should take the CPU the run leaves idle, not the run's own.

``idle_thread`` (a ThreadPoolExecutor's initializer) puts the calling thread in Linux's
SCHED_IDLE class, where it runs only on a core no other thread of the machine wants: while the
run's threads compute, its work waits; in the run's serial stretches (one core busy) and at the
end it goes on. Elsewhere (no SCHED_IDLE, or not permitted) the thread keeps its priority."""

from __future__ import annotations

import os


def idle_thread() -> None:
    """Move the calling thread to the SCHED_IDLE scheduling class where there is one."""
    policy = getattr(os, "SCHED_IDLE", None)
    if policy is None:
        return
    try:
        os.sched_setscheduler(0, policy, os.sched_param(0))  # 0: the calling thread (Linux)
    except OSError:
        pass
