"""One BLAS thread in the coordinating process while it iterates.

OpenBLAS starts a thread per core by default. The coordinator's dense work is small (Anderson's
least-squares fit of a few thousand values against 30 columns, the coarse fits), and there the
threads cost more than they give: LAPACK gelsy on 4000 x 30 took 9 ms with OpenBLAS's 2 threads
against 1.4 ms with one on an idle 2-core machine, and 45 ms per call (5.1 s of 28 s of the
50-pellet mechanics) on a loaded one, where a busy-waiting BLAS thread competes with the worker
processes. Dask's workers already run with one (its nanny sets OPENBLAS_NUM_THREADS=1).

threadpoolctl does this when installed; otherwise the OpenBLAS libraries this process has
loaded (numpy's and scipy's wheels each bring one) are found in /proc/self/maps and called
through ctypes. Anything that fails leaves the threads as they were: only speed depends on it.
"""

from __future__ import annotations

import contextlib
import ctypes


def _openblas_handles() -> list:
    """(get, set) function pairs of the OpenBLAS libraries loaded in this process."""
    try:
        with open("/proc/self/maps") as f:
            last = (line.split()[-1] for line in f if line.strip())
            paths = sorted({p for p in last if "openblas" in p and ".so" in p})
    except OSError:
        return []
    out = []
    for path in paths:
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for suffix in ("", "64_", "_"):
            names = [f"{p}openblas_{{}}_num_threads{suffix}" for p in ("scipy_", "")]
            for name in names:
                get = getattr(lib, name.format("get"), None)
                put = getattr(lib, name.format("set"), None)
                if get is not None and put is not None:
                    get.restype = ctypes.c_int
                    out.append((get, put))
                    break
            else:
                continue
            break
    return out


@contextlib.contextmanager
def single_threaded():
    """BLAS with one thread inside the block, the previous counts restored after it."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        threadpool_limits = None
    if threadpool_limits is not None:
        with threadpool_limits(1, user_api="blas"):
            yield
        return
    import numpy  # noqa: F401  (load the libraries before looking for them)
    import scipy.linalg  # noqa: F401

    handles = _openblas_handles()
    before = []
    for get, put in handles:
        try:
            before.append((put, int(get())))
            put(ctypes.c_int(1))
        except Exception:  # noqa: BLE001  (speed only)
            pass
    try:
        yield
    finally:
        for put, n in before:
            try:
                put(ctypes.c_int(n))
            except Exception:  # noqa: BLE001
                pass
