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
