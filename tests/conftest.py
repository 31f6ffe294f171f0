"""Test-wide settings: meshes are cached in a per-session folder, never in the user's cache;
every test starts on numba's full thread count."""

import numba
import pytest

from impactsim.kernel_cache import refresh

# Kernels cached from older sources of another file would be loaded as they are (numba keys a
# kernel on its own file only): a test run after an edit compiles them afresh instead.
refresh()


@pytest.fixture(autouse=True, scope="session")
def _mesh_cache(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    mp.setenv("IMPACTSIM_CACHE", str(tmp_path_factory.mktemp("mesh-cache")))
    yield
    mp.undo()


@pytest.fixture(autouse=True)
def _all_threads():
    """Each test on all of numba's threads, whatever the test before it set: a test left on one
    thread made the later tests that compare one thread with two compare one with one, and
    skip the ones that need two."""
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    yield
