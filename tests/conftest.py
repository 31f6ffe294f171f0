"""Test-wide settings: meshes are cached in a per-session folder, never in the user's cache."""

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
