"""Two elastic steel spheres in a slow head-on collision against Hertz theory.

Identical spheres of radius R, mass m, closing speed v (e.g. Johnson, Contact Mechanics, 1985,
sec. 11.4): with R* = R/2, m* = m/2, E* = E / (2 (1 - nu^2)) the largest approach is
delta = (15 m* v^2 / (16 E* sqrt(R*)))^(2/5), the peak force F = (4/3) E* sqrt(R*) delta^(3/2)
and the contact time 2.94 delta / v (quasi-static: here about ten wave transits of a sphere).
The force is the contact impulse per step averaged over a twentieth of the contact time (one
node touching at a time on a 1 mm mesh makes the step-by-step force chatter).
"""

from pathlib import Path

import numpy as np
import pytest

from impactsim.case import load_case
from impactsim.solver.run import run_case
from impactsim.results import history_array

CASE = Path(__file__).parents[2] / "cases" / "hertz-spheres.toml"


@pytest.fixture(scope="module")
def spheres(tmp_path_factory):
    out = tmp_path_factory.mktemp("hertz")
    case = load_case(CASE)
    summary = run_case(case, out, progress=False)
    return case, summary, history_array(out / "history.csv")


def hertz(case):
    mat = case.materials["steel"]
    G, K, rho = mat.shear_modulus, mat.bulk_modulus, mat.density
    E = 9 * K * G / (3 * K + G)
    nu = (3 * K - 2 * G) / (2 * (3 * K + G))
    R = case.bodies[0].dimensions["radius"]
    v = abs(case.bodies[0].velocity[2] - case.bodies[1].velocity[2])
    m_star = rho * 4.0 / 3.0 * np.pi * R**3 / 2
    E_star = E / (2 * (1 - nu**2))
    delta = (15 * m_star * v**2 / (16 * E_star * np.sqrt(R / 2))) ** 0.4
    return 4.0 / 3.0 * E_star * np.sqrt(R / 2) * delta**1.5, 2.9432 * delta / v, m_star * v


def test_contact_time_and_peak_force(spheres):
    case, summary, h = spheres
    force, duration, _ = hertz(case)
    t = h["time"]
    on = h["contact_impulse"] > 0
    assert t[on][-1] - t[on][0] == pytest.approx(duration, rel=0.10)
    impulse = np.cumsum(h["contact_impulse"])
    w = duration / 20
    tt = np.linspace(w, t[-1] - w, 2000)
    mean_force = (np.interp(tt + w / 2, t, impulse) - np.interp(tt - w / 2, t, impulse)) / w
    assert mean_force.max() == pytest.approx(force, rel=0.10)


def test_rebound_and_momentum(spheres):
    case, summary, h = spheres
    _, _, p = hertz(case)
    # nearly elastic: the momentum exchanged is close to 2 m* v
    assert h["contact_impulse"].sum() == pytest.approx(2 * p, rel=0.05)
    assert summary["stopped"] is None
    p0 = np.abs(case.bodies[0].velocity[2]) * summary["bodies"]["lower"]["mass"]
    assert abs(h["momentum_z"][-1] - h["momentum_z"][0]) <= 1e-12 * p0
    assert h["max_penetration"].max() < 1e-6
