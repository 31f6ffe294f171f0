"""Freed memory kept for the next step: glibc's malloc told not to hand large blocks back.

A run allocates the same large temporaries every step (the contact surface's compact arrays
after an erosion, the broad phase's rows and pairs, the particle pass's buffers, numpy
temporaries). glibc serves a block above its mmap threshold (128 KiB at first, raised
dynamically up to 32 MiB) with a fresh mapping and trims the top of its heap once more than
twice that threshold is free, so the next step's block of the same size comes back as new
pages: the kernel zeroes each on its first touch (a page fault, about 0.25 us per 4 KiB page
here). Filling 2.5 MB of fresh arrays took 0.73 ms that way against 0.03 ms in memory already
touched (oblique-sphere's surface arrays; docs/performance.md, "Whole scenes, session 12").

``keep_freed_memory`` (called once at the start of ``impactsim run``) raises both thresholds
with mallopt so that blocks up to MMAP_THRESHOLD come from the heap and up to TRIM_THRESHOLD
of free heap is kept: after the first steps the temporaries reuse pages already mapped. The
price is that much memory held between steps that the operating system could otherwise take
back (at most TRIM_THRESHOLD beyond what the run uses at its peak). It does nothing where the
C library is not glibc.
"""

from __future__ import annotations

import ctypes
import ctypes.util

M_TRIM_THRESHOLD = -1  # glibc's mallopt parameters (malloc.h)
M_TOP_PAD = -2
M_MMAP_THRESHOLD = -3
MMAP_THRESHOLD = 64 << 20  # [bytes] blocks above it still get a mapping of their own
TRIM_THRESHOLD = 512 << 20  # [bytes] free heap kept at most
TOP_PAD = 16 << 20  # [bytes] extra asked of the system whenever the heap grows


def keep_freed_memory() -> bool:
    """Raise glibc's mmap and trim thresholds (module docstring); True when it did."""
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)
                and mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD)
                and mallopt(M_TOP_PAD, TOP_PAD))
