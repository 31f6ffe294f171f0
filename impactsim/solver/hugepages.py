"""The large state arrays of a model moved onto 2 MB pages (Linux transparent huge pages).

The kernels stream some twenty arrays per element step (the element state, conn, the force
rows, x, v and fext of the nodes), 30-40 MB for the hex bench's 110,592 hexes. numpy asks the
kernel for huge pages only for allocations of 4 MB or more (`madvise(MADV_HUGEPAGE)`), so the
many arrays of 1-3.5 MB (one double per element, x, v and force of the nodes, conn, the force
rows) sit on 4 kB pages: about 10,000 pages against the 3,072 entries of this Zen 4's second-level
data TLB, so every step walks the page tables for most of them again. `pack` copies the arrays
of an object into one anonymous mapping advised for huge pages, each at a 64-byte boundary and
at another offset in its 4 kB page than the one before (`SKEW`): the
hex kernel alone ran 6 % faster on its state so placed, the whole hex step 1-2 % (the tets'
step: no change measured; docs/performance.md, "The hex step, session 12").

Only the memory changes: the values are copied, the arrays keep their dtype, shape and
C order (numba compiles the same kernels), so every result is the same, bit for bit. Where the
system has no transparent huge pages (`/sys/kernel/mm/transparent_hugepage/enabled` set to
`never`, another OS) the advice is ignored and the arrays are as before.
"""

from __future__ import annotations

import mmap
import weakref

import numpy as np

HUGE = 2 << 20  # bytes of a huge page
MIN_TOTAL = 4 << 20  # below this the arrays are left where they are
MIN_ARRAY = 1 << 16  # arrays smaller than this are left where they are
ALIGN = 64
SKEW = 7 * ALIGN  # 1 % faster hex and tet steps than no gaps (docs/performance.md, session 12)
_ARENAS: list = []  # weak references to the live arenas (the uint8 arrays over the mappings)


def _candidates(objs: list, names) -> list[tuple[list, np.ndarray]]:
    """(owners, array) for the C-contiguous, writeable arrays of at least MIN_ARRAY bytes that
    own their data and share it with no other attribute of `objs` (of those in `names`, when
    given); owners: the (object, attribute) pairs that hold the array."""
    found, seen, viewed = [], {}, set()
    for obj in objs:  # the arrays others are views of stay where they are (the views too)
        for a in vars(obj).values():
            while isinstance(a, np.ndarray) and a.base is not None:
                a = a.base
                viewed.add(id(a))
    for obj in objs:
        for name, a in vars(obj).items():
            if names is not None and name not in names:
                continue
            if not isinstance(a, np.ndarray) or a.nbytes < MIN_ARRAY:
                continue
            if (a.base is not None or id(a) in viewed or not a.flags.c_contiguous
                    or not a.flags.writeable):
                continue
            if id(a) in seen:  # one array under two names: moved once, both names updated
                seen[id(a)].append((obj, name))
                continue
            seen[id(a)] = [(obj, name)]
            found.append(a)
    return [(owners, a) for a in found for owners in [seen[id(a)]]]


def pack(*objs, names=None) -> int:
    """Move the large arrays that are attributes of `objs` (a Model, its ElementBlocks, a
    runner's buffers; only the attributes in `names`, when given) into one mapping advised for
    huge pages; returns the bytes moved (0 when there are too few to matter or the platform
    cannot advise). Call it before anything else holds a reference to those arrays: a
    reference taken earlier (an attribute of an object not passed, a local) keeps the old
    copy, which the kernels would then no longer update."""
    cands = _candidates(list(objs), names)
    offsets, total = [], 0
    for _, a in cands:
        offsets.append(total)
        # and a gap of k * SKEW bytes (mod 4 kB) after the k-th array: the one-double-per-element
        # arrays are multiples of 4 kB long (110,592 or 202,752 doubles), so laid end to end the
        # same element of every array would share its offset in the page, and so its L1 set
        total += -(-a.nbytes // ALIGN) * ALIGN + (len(offsets) - 1) * SKEW % 4096
    if total < MIN_TOTAL or not hasattr(mmap, "MADV_HUGEPAGE"):
        return 0
    # private: an anonymous shared mapping is shmem, whose huge pages are a separate setting
    mm = mmap.mmap(-1, total + HUGE, flags=mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS)
    try:
        mm.madvise(mmap.MADV_HUGEPAGE)
    except OSError:
        mm.close()
        return 0
    raw = np.frombuffer(mm, dtype=np.uint8)
    _ARENAS.append(weakref.ref(raw))
    start = (-raw.ctypes.data) % HUGE  # the first byte on a huge-page boundary
    for (owners, a), off in zip(cands, offsets):
        b = raw[start + off:start + off + a.nbytes].view(a.dtype).reshape(a.shape)
        b[...] = a
        for obj, name in owners:
            setattr(obj, name, b)
    return total


def arena_bytes() -> int:
    """Bytes of the arrays now held in arenas (outside numpy's own allocations, so outside
    its tracemalloc domain: solver/footprint.py's test adds them)."""
    _ARENAS[:] = [r for r in _ARENAS if r() is not None]
    return sum(r().nbytes - HUGE for r in _ARENAS)
