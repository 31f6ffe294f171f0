"""Two aluminium cylinders end-on at 1 km/s [D19]: no overlap with both contact passes.

A striker d2 = h2 = 1 cm hits a target d1 = h1 = 2 cm. Where the striker spreads over the
target's face past the contact, edges of one body cut through faces of the other while no node
crosses a face: node-face alone lets cells overlap there (ALGORITHMS.md 6), node-face plus
edge-edge does not. Coarse meshes (2 mm) keep the test short.
"""

from pathlib import Path

import numpy as np
import pytest

from impactsim.case import load_case
from impactsim.solver.run import run_case
from impactsim.results import history_array

CASE = Path(__file__).parents[2] / "cases" / "two-cylinders.toml"
COARSE = ['body.target.mesh_size="2 mm"', 'body.striker.mesh_size="2 mm"']


def run(tmp_path_factory, name, overrides):
    out = tmp_path_factory.mktemp(name)
    summary = run_case(load_case(CASE, COARSE + overrides), out, progress=False)
    return summary, history_array(out / "history.csv")


@pytest.fixture(scope="module")
def both(tmp_path_factory):
    return run(tmp_path_factory, "cylinders", [])


def test_no_overlap_through_12_us(both):
    summary, h = both
    assert summary["stopped"] is None
    assert h["time"][-1] == pytest.approx(12e-6)
    # below a thousandth of the 2 mm mesh size at every step
    assert h["max_penetration"].max() < 2e-6
    assert h["contact_pairs"][1:].min() > 0  # in contact from the first step to the end
    assert np.all(np.isfinite(h["total_energy"]))


def test_node_face_alone_overlaps_where_the_striker_spreads(tmp_path_factory, both):
    summary, h = run(tmp_path_factory, "cylinders-nf",
                     ['contact.passes=["node-face"]', 'run.end_time="7.5 us"',
                      'output.times=["0 us", "7.5 us"]'])
    assert h["max_penetration"].max() > 50e-6
    assert h["max_penetration"].max() > 100 * both[1]["max_penetration"].max()
