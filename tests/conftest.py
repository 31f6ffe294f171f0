"""Test-wide settings: meshes are cached in a per-session folder, never in the user's cache."""

import pytest


@pytest.fixture(autouse=True, scope="session")
def _mesh_cache(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    mp.setenv("IMPACTSIM_CACHE", str(tmp_path_factory.mktemp("mesh-cache")))
    yield
    mp.undo()
