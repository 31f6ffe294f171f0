"""The coordinator's BLAS runs on one thread while it iterates (quasistatic/blas.py)."""

import numpy as np
import pytest
import scipy.linalg

from impactsim.quasistatic.blas import _openblas_handles, single_threaded


def test_single_threaded_sets_and_restores_openblas_threads():
    scipy.linalg.lstsq(np.eye(3), np.ones(3), lapack_driver="gelsy")  # libraries loaded
    handles = _openblas_handles()
    if not handles:
        pytest.skip("no OpenBLAS loaded in this process")
    before = [int(get()) for get, _ in handles]
    with single_threaded():
        assert [int(get()) for get, _ in handles] == [1] * len(handles)
    assert [int(get()) for get, _ in handles] == before
