"""The on-disk mesh cache: hits, keys, placement after loading, corrupt files, switching off."""

import numpy as np
import pytest

import impactsim.mesh as mesh
from impactsim.case.schema import Body
from impactsim.mesh import cache, mesh_body


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("IMPACTSIM_CACHE", str(folder))
    return folder


def box(**kw):
    base = dict(name="b", material="al", shape="box", dimensions={"size": (0.02, 0.01, 0.01)},
                mesh_size=0.005, mesher="structured")
    base.update(kw)
    return Body(**base)


def forbid_meshing(monkeypatch):
    def fail(body):
        raise AssertionError("meshed although cached")
    monkeypatch.setattr(mesh, "_raw_mesh", fail)


def test_second_call_is_a_hit_and_placement_is_applied_after_loading(cache_dir, monkeypatch):
    p1, t1 = mesh_body(box())
    assert len(list(cache_dir.glob("*.npz"))) == 1
    forbid_meshing(monkeypatch)
    p2, t2 = mesh_body(box(position=(1.0, 0.0, 0.0), rotation=(0.0, 0.0, 0.5)))
    np.testing.assert_array_equal(t1, t2)
    np.testing.assert_allclose(p2.mean(axis=0), [1.0, 0.0, 0.0], atol=1e-12)
    assert not np.allclose(p1 + [1.0, 0.0, 0.0], p2)  # rotated too


def test_key_depends_on_what_changes_the_mesh(cache_dir, tmp_path):
    base = cache.cache_key(box())
    assert cache.cache_key(box(position=(1.0, 2.0, 3.0), name="other")) == base
    assert cache.cache_key(box(mesh_size=0.004)) != base
    assert cache.cache_key(box(mesher="gmsh")) != base
    assert cache.cache_key(box(dimensions={"size": (0.02, 0.01, 0.011)})) != base
    path = tmp_path / "m.vtu"
    path.write_bytes(b"one")
    file_body = Body("f", "al", "file", {"path": path, "scale": 1.0})
    first = cache.cache_key(file_body)
    path.write_bytes(b"two")
    assert cache.cache_key(file_body) != first


def test_corrupt_cache_file_is_ignored_and_rewritten(cache_dir, monkeypatch):
    points, tets = mesh_body(box())
    (entry,) = cache_dir.glob("*.npz")
    entry.write_bytes(b"not a zip file")
    assert cache.load(entry.stem) is None
    again_points, again_tets = mesh_body(box())
    assert again_points.tobytes() == points.tobytes() and again_tets.tobytes() == tets.tobytes()
    assert cache.load(entry.stem) is not None
    assert not list(cache_dir.glob("*.tmp"))


def test_cache_off_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.setenv("IMPACTSIM_CACHE", "off")
    monkeypatch.setenv("HOME", str(tmp_path))
    mesh_body(box())
    assert cache.cache_dir() is None and not list(tmp_path.rglob("*.npz"))
