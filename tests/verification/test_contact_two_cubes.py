"""Two 12-tet cubes meeting edge to edge [D19]: the edge-edge pass is what keeps them apart.

With mutually perpendicular edges no node of either cube meets a face of the other; only the
edges cut through the faces. ALGORITHMS.md 6: with the edge-edge pass there is no penetration at
0, 10 and 20 us; with node-face alone the cubes pass into each other.
"""

from pathlib import Path

import numpy as np
import pytest

from impactsim.case import load_case
from impactsim.solver.run import run_case
from impactsim.results import history_array

CASE = Path(__file__).parents[2] / "cases" / "two-cubes.toml"


def run(tmp_path_factory, name, overrides=()):
    out = tmp_path_factory.mktemp(name)
    summary = run_case(load_case(CASE, overrides), out, progress=False)
    return summary, history_array(out / "history.csv"), out


@pytest.fixture(scope="module")
def both(tmp_path_factory):
    return run(tmp_path_factory, "cubes")


@pytest.fixture(scope="module")
def node_face_only(tmp_path_factory):
    return run(tmp_path_factory, "cubes-nf", ['contact.passes=["node-face"]'])


def test_no_penetration_with_both_passes(both):
    summary, h, out = both
    assert summary["stopped"] is None
    assert h["time"][-1] == pytest.approx(20e-6)
    assert np.all(h["max_penetration"] < 1e-6)  # metres, every step through 20 us
    assert summary["passes"] == ["contact.node-face", "contact.edge-edge"]
    assert summary["contact.edge-edge"]["corrected_pairs"] > 0
    assert len(list(out.glob("frame_*.vtu"))) == 3  # 0, 10, 20 us


def test_node_face_alone_lets_the_cubes_pass_into_each_other(both, node_face_only):
    summary, h, _ = node_face_only
    assert summary["passes"] == ["contact.node-face"]
    assert h["max_penetration"].max() > 1e-3  # millimetres of overlap: the paper's point
    assert h["max_penetration"].max() > 1e3 * both[1]["max_penetration"].max()


def test_momentum_is_conserved(both):
    _, h, _ = both
    p0 = np.array([h["momentum_x"][0], h["momentum_y"][0], h["momentum_z"][0]])
    p = np.stack([h["momentum_x"], h["momentum_y"], h["momentum_z"]], axis=1)
    assert np.abs(p - p0).max() <= 1e-12 * np.abs(p0).max()
