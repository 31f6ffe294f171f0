"""Elastic bar of one-point hexes on a rigid wall (ALGORITHMS.md 7.1 against 1-D theory).

As tests/verification/test_bar_wall.py with element = "hex8": contact stress rho c v, contact
duration 2L/c, rebound at the impact speed, energy balance with the hourglass work in it, and
the frames written as VTK_HEXAHEDRON cells.
"""

from pathlib import Path

import meshio
import numpy as np
import pytest

from impactsim.case import load_case
from impactsim.results import history_array
from impactsim.solver.run import run_case

CASE = Path(__file__).parents[2] / "cases" / "elastic-bar-wall-hex.toml"


@pytest.fixture(scope="module")
def bar_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("barhex")
    case = load_case(CASE)
    summary = run_case(case, out, progress=False)
    hist = history_array(out / "history.csv")
    return case, summary, hist, out


def _constants(case):
    mat = case.materials["steel"]
    G, K, rho = mat.shear_modulus, mat.bulk_modulus, mat.density
    E = 9 * K * G / (3 * K + G)
    size = case.bodies[0].dimensions["size"]
    return rho, np.sqrt(E / rho), abs(case.bodies[0].velocity[2]), size[0] * size[1], size[2]


def test_contact_stress_and_duration(bar_run):
    case, summary, h, _ = bar_run
    rho, c, v, area, length = _constants(case)
    touching = h["wall_force"] > 0
    t_on = h["time"][touching]
    assert t_on[-1] - t_on[0] == pytest.approx(2 * length / c, rel=0.05)
    assert np.median(h["wall_force"][touching]) / area == pytest.approx(rho * c * v, rel=0.05)


def test_rebound_and_energy_balance_with_hourglass(bar_run):
    case, summary, h, _ = bar_run
    rho, c, v, area, length = _constants(case)
    assert summary["bodies"]["bar"]["mean_velocity"][2] == pytest.approx(v, rel=0.05)
    e0 = h["total_energy"][0]
    assert np.abs(h["total_energy"] - e0).max() / e0 < 0.02
    # the hourglass work is booked, positive and small against the energy of the scene
    assert 0.0 < h["hourglass_energy"][-1] < 0.02 * e0
    assert summary["energy"]["hourglass_energy"] == pytest.approx(h["hourglass_energy"][-1])
    assert summary["stopped"] is None
    assert summary["elements"] == 4 * 4 * 40


def test_frames_are_hexahedra(bar_run):
    case, summary, h, out = bar_run
    mesh = meshio.read(sorted(out.glob("frame_*.vtu"))[-1])
    assert [b.type for b in mesh.cells] == ["hexahedron"]
    assert len(mesh.cells[0].data) == summary["elements"]
    assert mesh.cell_data["stress"][0].shape == (summary["elements"], 9)
