"""Elastic bar on a rigid wall (verification, ALGORITHMS.md 1-2).

One-dimensional theory of a slender elastic bar of length L, bar speed c = sqrt(E/rho), striking a
rigid wall at speed v (e.g. Graff, Wave Motion in Elastic Solids, 1975, sec. 2.2): the contact
stress is rho c v, the bar stays in contact for 2L/c and then leaves at speed v.
"""

from pathlib import Path

import numpy as np
import pytest

from impactsim.case import load_case
from impactsim.solver.run import run_case
from impactsim.results import history_array

CASE = Path(__file__).parents[2] / "cases" / "elastic-bar-wall.toml"


@pytest.fixture(scope="module")
def bar_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("bar")
    case = load_case(CASE)
    summary = run_case(case, out, progress=False)
    hist = history_array(out / "history.csv")
    return case, summary, hist


def _constants(case):
    mat = case.materials["steel"]
    G, K, rho = mat.shear_modulus, mat.bulk_modulus, mat.density
    E = 9 * K * G / (3 * K + G)
    c = np.sqrt(E / rho)
    size = case.bodies[0].dimensions["size"]
    v = abs(case.bodies[0].velocity[2])
    return rho, c, v, size[0] * size[1], size[2]


def test_contact_stress_and_duration(bar_run):
    case, summary, h = bar_run
    rho, c, v, area, length = _constants(case)
    touching = h["wall_force"] > 0
    t_on = h["time"][touching]
    duration = t_on[-1] - t_on[0]
    assert duration == pytest.approx(2 * length / c, rel=0.05)
    # the plateau of the contact stress (median over the contact) is rho c v
    stress = np.median(h["wall_force"][touching]) / area
    assert stress == pytest.approx(rho * c * v, rel=0.05)


def test_rebound_and_energy_balance(bar_run):
    case, summary, h = bar_run
    rho, c, v, area, length = _constants(case)
    vz = summary["bodies"]["bar"]["mean_velocity"][2]
    assert vz == pytest.approx(v, rel=0.05)  # leaves the wall at the impact speed
    e0 = h["total_energy"][0]
    drift = np.abs(h["total_energy"] - e0).max() / e0
    assert drift < 0.02
    assert summary["stopped"] is None
