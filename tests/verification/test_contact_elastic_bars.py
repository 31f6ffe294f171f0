"""Two identical elastic bars end-on: the contact passes against one-dimensional theory.

Bars of length L, bar speed c = sqrt(E/rho), the striker at v, the target at rest (e.g. Graff,
Wave Motion in Elastic Solids, 1975, sec. 2.2): the interface moves at v/2, so the contact stress
is rho c v / 2, contact lasts 2L/c, and then the bars have exchanged velocities: the striker is
at rest and the target leaves at v. Momentum is conserved to round-off.
"""

from pathlib import Path

import numpy as np
import pytest

from impactsim.case import load_case
from impactsim.solver.run import run_case
from impactsim.results import history_array

CASE = Path(__file__).parents[2] / "cases" / "elastic-bars.toml"


@pytest.fixture(scope="module")
def bars(tmp_path_factory):
    out = tmp_path_factory.mktemp("bars")
    case = load_case(CASE)
    summary = run_case(case, out, progress=False)
    return case, summary, history_array(out / "history.csv")


def constants(case):
    mat = case.materials["steel"]
    G, K, rho = mat.shear_modulus, mat.bulk_modulus, mat.density
    E = 9 * K * G / (3 * K + G)
    size = case.bodies[0].dimensions["size"]
    return rho, np.sqrt(E / rho), abs(case.bodies[0].velocity[2]), size[0] * size[1], size[2]


def test_contact_stress_and_duration(bars):
    case, summary, h = bars
    rho, c, v, area, length = constants(case)
    force = h["contact_impulse"] / np.where(h["dt"] > 0, h["dt"], np.inf)
    touching = force > 0
    t_on = h["time"][touching]
    assert t_on[-1] - t_on[0] == pytest.approx(2 * length / c, rel=0.05)
    assert np.median(force[touching]) / area == pytest.approx(rho * c * v / 2, rel=0.05)


def test_bars_exchange_velocities(bars):
    case, summary, h = bars
    v = abs(case.bodies[0].velocity[2])
    striker = summary["bodies"]["striker"]["mean_velocity"]
    target = summary["bodies"]["target"]["mean_velocity"]
    assert abs(striker[2]) < 0.05 * v  # nearly at rest
    assert target[2] == pytest.approx(v, rel=0.05)
    assert summary["stopped"] is None


def test_momentum_conserved_to_round_off(bars):
    case, summary, h = bars
    p0 = h["momentum_z"][0]
    assert np.abs(h["momentum_z"] - p0).max() <= 1e-12 * abs(p0)
    assert np.abs(h["momentum_x"]).max() <= 1e-12 * abs(p0)
    assert np.abs(h["momentum_y"]).max() <= 1e-12 * abs(p0)
    assert h["max_penetration"].max() < 1e-6
