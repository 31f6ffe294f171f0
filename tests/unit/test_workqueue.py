"""The shared counter that hands parts of a parallel loop to the threads (solver/workqueue.py):
every part is taken exactly once, whatever the number of threads."""

import numba
import numpy as np

from impactsim.solver.workqueue import fetch_add


@numba.njit(parallel=True)
def _take(n_parts, threads, counter, taken, owner):
    for t in numba.prange(threads):
        while True:
            part = fetch_add(counter, 1)
            if part >= n_parts:
                break
            taken[part] += 1
            owner[part] = t
            s = 0.0
            for k in range(200):  # some work, so that the threads overlap
                s += np.sqrt(k + part)
            if s < 0.0:
                taken[part] += 1


def test_every_part_is_taken_once():
    for threads in (1, numba.get_num_threads(), 3):
        counter = np.zeros(1, np.int64)
        taken = np.zeros(5000, np.int64)
        owner = np.full(5000, -1, np.int64)
        _take(5000, threads, counter, taken, owner)
        assert (taken == 1).all()
        assert owner.min() >= 0 and owner.max() < threads
        # each thread's last fetch finds the parts used up
        assert counter[0] == 5000 + threads


@numba.njit
def _add(counter, inc):
    return fetch_add(counter, inc)


def test_fetch_add_returns_the_value_before():
    c = np.array([7], dtype=np.int64)
    assert _add(c, 5) == 7 and c[0] == 12
    assert _add(c, np.int32(-2)) == 12 and c[0] == 10
