"""Chunks of a parallel loop handed to the threads as they come free (a shared counter).

numba's parallel loops run on OpenMP threads that split a ``prange`` statically. For a loop
whose chunks cost what their data make them cost (the broad-phase query's chunks of query rows,
contact/broadphase.py: 1.84 s against 3.73 with the static split over oblique-sphere's first
1,500 steps), a thread that drew the costlier chunks, or lost its core for a while, holds the other up at the
loop's end. Here each thread takes the next chunk from a counter in memory with one atomic add
(``fetch_add``, LLVM's ``atomicrmw``) until none is left, so the threads finish together.

The results do not depend on which thread runs which chunk as long as each chunk's output has
that chunk as its only writer: the same bits on any number of threads, in any interleaving.

The tet kernel keeps its fixed cyclic parts (part t, t + T, ... on thread t) first: with parts
taken from the counter, the tet bench (202,752 tets, two threads, quiet) ran 31-33 ns per
element-step in five runs of eight and 39-42 in three, where the fixed parts gave 32-34 in all
eight. A thread that keeps its parts from step to step finds their state in the caches it
filled the step before; parts that change threads do not (docs/performance.md, "Whole scenes,
session 12 (the lead)"). Only when its own parts are done does a thread take the other
threads' parts not begun yet, from their last: a flag per part, claimed with ``fetch_add``
(solver/element.py ``_visit``), so a thread that lost its core for a while is not waited for.

    for t in numba.prange(threads):  # counter: np.zeros(1, np.int64), made by the caller
        while True:
            chunk = fetch_add(counter, 1)
            if chunk >= n_chunks:
                break
            ...  # chunk `chunk`

The counter is an argument of the parallel kernel, made by its (Python) caller: one the kernel
allocates itself did not reach the threads as one shared array (a test gave every chunk to one
thread and read 0 back).
"""

from __future__ import annotations

from numba import types
from numba.core import cgutils
from numba.extending import intrinsic


@intrinsic
def fetch_add(typingctx, counter, inc):
    """counter[0] += inc as one atomic operation; returns the value before (int64). ``counter``
    a one-element int64 array shared by the threads of a parallel loop. Monotonic ordering: the
    counter only hands out numbers; what a part writes is seen by the caller after the loop's
    barrier."""
    if not (isinstance(counter, types.Array) and counter.dtype == types.int64
            and isinstance(inc, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        ary = context.make_array(sig.args[0])(context, builder, args[0])
        ptr = cgutils.get_item_pointer(context, builder, sig.args[0], ary,
                                       [context.get_constant(types.intp, 0)])
        val = context.cast(builder, args[1], sig.args[1], types.int64)
        return builder.atomic_rmw("add", ptr, val, "monotonic")

    return types.int64(counter, inc), codegen
