"""One BLAS thread in the coordinating process while it iterates.

OpenBLAS starts a thread per core by default. The coordinator's dense work is small (Anderson's
least-squares fit of a few thousand values against 30 columns, the coarse fits), and there the
threads cost more than they give: LAPACK gelsy on 4000 x 30 took 9 ms with OpenBLAS's 2 threads
against 1.4 ms with one on an idle 2-core machine, and 45 ms per call (5.1 s of 28 s of the
50-pellet mechanics) on a loaded one, where a busy-waiting BLAS thread competes with the worker
processes. Dask's workers already run with one (its nanny sets OPENBLAS_NUM_THREADS=1).

threadpoolctl (the scikit-learn project's library) finds the BLAS libraries this process has
loaded (numpy's and scipy's wheels each bring one) and sets their thread counts.
"""

from __future__ import annotations

import contextlib

from threadpoolctl import threadpool_limits


@contextlib.contextmanager
def single_threaded():
    """BLAS with one thread inside the block, the previous counts restored after it."""
    with threadpool_limits(1, user_api="blas"):
        yield
