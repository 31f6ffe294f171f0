"""The coordinator's BLAS runs on one thread while it iterates (quasistatic/blas.py)."""

import numpy as np
import pytest
import scipy.linalg
from threadpoolctl import threadpool_info

from impactsim.quasistatic.blas import single_threaded


def _blas_threads():
    return [(i["filepath"], i["num_threads"]) for i in threadpool_info()
            if i["user_api"] == "blas"]


def test_single_threaded_sets_and_restores_blas_threads():
    scipy.linalg.lstsq(np.eye(3), np.ones(3), lapack_driver="gelsy")  # libraries loaded
    before = _blas_threads()
    if not before:
        pytest.skip("no BLAS library found in this process")
    with single_threaded():
        assert [n for _p, n in _blas_threads()] == [1] * len(before)
    assert _blas_threads() == before
