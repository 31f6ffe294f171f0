"""Fragments and debris-cloud statistics (fracture/fragments.py)."""

from types import SimpleNamespace

import numpy as np
import pytest

from impactsim.fracture.fragments import cloud_summary, node_components
from impactsim.model import ERODED

TET = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)


def _model(status=(0, 0, 0)):
    # three tets: 0 and 1 share a face, 2 is apart
    x = np.vstack([TET, [[1, 1, 1]], TET + [0, 0, 5]])
    conn = np.array([[0, 1, 2, 3], [1, 2, 3, 4], [5, 6, 7, 8]], np.int32)
    v = np.zeros((9, 3))
    v[:5, 2] = 100.0  # first piece along +z
    v[5:] = [100.0, 0.0, 100.0]  # second piece at 45 degrees
    mass = np.array([1, 1, 1, 1, 1, 2, 2, 2, 2], float)
    return SimpleNamespace(x=x, v=v, mass=mass, conn=conn, status=np.array(status, np.int8),
                           blocks=[], n_node=9)


def test_pieces_particles_and_cloud():
    m = _model()
    pa = SimpleNamespace(n=1, m=np.array([0.5]), x=np.array([[0.0, 0.0, 9.0]]),
                         v=np.array([[0.0, 10.0, 300.0]]))
    n, lab = node_components(m)
    assert n == 2 and lab[0] == lab[4] != lab[5]
    s = cloud_summary(m, [0, 0, 1], pa)
    assert s["count"] == 3 and s["mesh_pieces"] == 2 and s["particles"] == 1
    assert s["largest_mass"] == 8.0 and s["total_mass"] == pytest.approx(13.5)
    assert s["leading_edge"] == 9.0 and s["leading_edge_speed"] == 300.0
    assert s["spread_angle_deg"] == pytest.approx(45.0)
    cum = s["mass_by_size"]["cumulative_mass"]
    assert cum[-1] == pytest.approx(13.5) and cum[0] == pytest.approx(0.5)


def test_eroded_element_splits_a_piece():
    m = _model(status=(0, ERODED, 0))
    n, lab = node_components(m)
    assert n == 2 and lab[4] == -1  # node 4 belongs to no live element


def test_size_histogram_and_png(tmp_path):
    from impactsim.output.fragments import write_fragment_histogram

    m = _model()
    pa = SimpleNamespace(n=1, m=np.array([0.5]), x=np.array([[0.0, 0.0, 9.0]]),
                         v=np.array([[0.0, 10.0, 300.0]]))
    s = cloud_summary(m, [0, 0, 1], pa)
    h = s["size_histogram"]
    assert sum(h["count"]) == 3 and sum(h["mass"]) == pytest.approx(13.5)
    assert write_fragment_histogram(tmp_path / "fragments.png", s, "t")
    assert (tmp_path / "fragments.png").read_bytes()[:4] == b"\x89PNG"


def test_the_cloud_is_what_moves_forward():
    """A plate at rest ahead of the debris is not the leading edge, and a piece drifting
    sideways at 1 % of the cloud's speed does not set the spread angle."""
    m = _model()
    m.x[5:, 2] += 20.0  # the second piece far ahead ...
    m.v[5:] = [5.0, 0.0, 1.0]  # ... nearly at rest, drifting sideways
    s = cloud_summary(m, [0, 0, 1])
    assert s["leading_edge"] == 1.0 and s["leading_edge_speed"] == 100.0
    assert s["spread_angle_deg"] == pytest.approx(0.0)


def _leading_edge_numpy(model, axis, particles=None):
    """The definition in numpy: the foremost point (first on ties) of the cloud, or of every
    point when nothing of the cloud moves forward."""
    from impactsim.fracture.fragments import CLOUD_FRACTION

    a = np.asarray(axis, float) / np.linalg.norm(axis)
    live = model.mass > 0
    s, u = model.x[live] @ a, model.v[live] @ a
    if particles is not None and particles.n:
        s = np.concatenate([s, particles.x[:particles.n] @ a])
        u = np.concatenate([u, particles.v[:particles.n] @ a])
    if s.size == 0:
        return -np.inf, 0.0
    cloud = u >= CLOUD_FRACTION * max(float(u.max()), 0.0)
    if not np.any(cloud & (u > 0.0)):
        cloud = np.ones(s.shape, bool)
    i = int(np.flatnonzero(cloud)[np.argmax(s[cloud])])
    return float(s[i]), float(u[i])


@pytest.mark.parametrize("seed", range(6))
def test_leading_edge_is_the_foremost_point_of_the_cloud(seed):
    """The kernel against the definition: random nodes (some without mass: not material) and
    particles (rows past n unused), a cloud along the axis or all of it moving backwards (then
    the foremost point of all), ties on the position (the first point wins)."""
    from impactsim.fracture.fragments import leading_edge

    rng = np.random.default_rng(seed)
    n, k = 500, 40
    x = np.round(rng.uniform(-1.0, 1.0, (n, 3)), 1)  # many ties
    v = rng.normal(0.0, 100.0, (n, 3)) - (400.0 if seed % 3 == 2 else 0.0)
    mass = rng.uniform(0.0, 1.0, n) * (rng.random(n) > 0.2)
    model = SimpleNamespace(x=x, v=v, mass=mass)
    pa = SimpleNamespace(n=k if seed % 2 else 0, x=np.round(rng.uniform(-1, 1.2, (k + 7, 3)), 1),
                         v=rng.normal(0.0, 300.0, (k + 7, 3)))
    axis = [0.0, 0.0, 1.0] if seed < 3 else rng.normal(size=3)
    got, want = leading_edge(model, axis, pa), _leading_edge_numpy(model, axis, pa)
    assert got == pytest.approx(want, rel=1e-14, abs=1e-14)
    model.mass[:] = 0.0
    assert leading_edge(model, axis, SimpleNamespace(n=0)) == (-np.inf, 0.0)
