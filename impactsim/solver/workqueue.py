"""Parts of a parallel loop handed to the threads as they come free (a shared counter).

numba's parallel loops run on OpenMP threads that split a ``prange`` statically: with the
element kernel's parts dealt out in turn (part t, t + T, ... on thread t), a thread that lost
its core for a while (another process, the frame writer's thread) or drew the costlier parts
(the plastic zone) holds up the other at the end of the loop. Here each thread takes the next
part from a counter in memory with one atomic add (``fetch_add``, LLVM's ``atomicrmw``) until
none is left, so the threads finish together.

The results do not depend on which thread runs which part as long as each part's output has
that part as its only writer (the element kernels' force rows, ``scatter.py``, and per-chunk
results): the same bits on any number of threads, in any interleaving.

    for t in numba.prange(threads):  # counter: np.zeros(1, np.int64), made by the caller

        while True:
            part = fetch_add(counter, 1)
            if part >= n_parts:
                break
            ...  # part `part`

The counter is an argument of the parallel kernel, made by its (Python) caller: one the kernel
allocates itself did not reach the threads as one shared array (a test gave every part to one
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
