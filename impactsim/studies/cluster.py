"""Where the runs of a study go: a Dask cluster (distributed), or this process.

`executor(scheduler, workers)` is a context manager giving an object with `map(fn, args_list)`
that yields `(index, result_or_exception)` as runs finish:
- `scheduler="ADDRESS"` (tcp://host:8786): an existing Dask cluster; its workers must be able to
  import impactsim (the same version) and see the case files and the output folder;
- `workers=N >= 1`: a LocalCluster of N worker processes, one thread each and one numba thread
  each (NUMBA_NUM_THREADS=1 is set in the workers before they start), so that N runs share the
  machine's cores instead of fighting over them;
- `workers=0`: one run after the other in this process (no Dask), the reference in the tests.
"""

from __future__ import annotations

import os
import uuid
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager

WORKER_ENV = {"NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}


def default_workers() -> int:
    """One worker per core this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover (not Linux)
        return max(1, os.cpu_count() or 1)


class _Serial:
    def map(self, fn: Callable, args: Sequence[tuple]) -> Iterator[tuple[int, object]]:
        for i, a in enumerate(args):
            try:
                yield i, fn(*a)
            except Exception as err:  # the study records it and goes on
                yield i, err


class _Dask:
    def __init__(self, client):
        self.client = client

    def map(self, fn: Callable, args: Sequence[tuple]) -> Iterator[tuple[int, object]]:
        from distributed import as_completed

        futures = [self.client.submit(fn, *a, pure=False, key=f"{fn.__name__}-{uuid.uuid4().hex}")
                   for a in args]
        index = {f.key: i for i, f in enumerate(futures)}
        for fut in as_completed(futures):
            i = index[fut.key]
            try:
                yield i, fut.result()
            except Exception as err:  # a worker that died, a result that cannot come back
                yield i, err
            fut.release()


@contextmanager
def executor(scheduler: str | None = None, workers: int | None = None):
    """The runner of a study (module docstring)."""
    if scheduler is None and workers == 0:
        yield _Serial()
        return
    import logging

    import dask
    from distributed import Client, LocalCluster

    # a worker's slow exit at shutdown is not the user's concern
    logging.getLogger("distributed.nanny").setLevel(logging.ERROR)

    if scheduler is not None:
        with Client(scheduler) as client:
            yield _Dask(client)
        return
    n = workers if workers is not None else default_workers()
    before = {k: os.environ.get(k) for k in WORKER_ENV}
    try:
        with dask.config.set({f"distributed.nanny.pre-spawn-environ.{k}": v
                              for k, v in WORKER_ENV.items()}):
            with LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                              dashboard_address=":0", env=dict(WORKER_ENV)) as cluster, \
                    Client(cluster) as client:
                _restore_env(before)  # the nanny sets them in this process to spawn workers
                yield _Dask(client)
    finally:
        _restore_env(before)


def _restore_env(values: dict[str, str | None]) -> None:
    for k, v in values.items():
        if v is None:
            os.environ.pop(k, None)
        else:
            os.environ[k] = v
