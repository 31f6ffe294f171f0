"""Quasistatic analysis against analytic solutions: a uniform pressure across a contact of
non-matching meshes, a constrained stack of heated layers, steady conduction in series."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from impactsim.case.quasistatic import load_quasistatic
from impactsim.quasistatic.build import problem
from impactsim.quasistatic.solver import solve

from tests.quasistatic.helpers import run, vertex_values

CASES = Path(__file__).parents[2] / "cases"


@pytest.mark.parametrize("element", ["tet4", "tet10"])
def test_blocks_pressed_carry_the_applied_pressure_uniformly(element):
    case = load_quasistatic(CASES / "blocks-pressed.toml",
                            [f"quasistatic.element={element!r}".replace("'", '"')])
    prob = problem(case)
    out = solve(prob)
    assert out.stopped is None
    for i in range(2):
        s = out.fields[i]["stress"]
        # sigma_zz = -10 MPa within 0.5 %, the other components below 0.5 % of it
        assert np.abs(s[2] / -10e6 - 1).max() < 5e-3
        assert np.abs(s[[0, 1, 3, 4, 5]]).max() < 5e-3 * 10e6


PATCH = """
[run]
analysis = "quasistatic"
end_time = 1
[quasistatic]
element = "{element}"
gap_tolerance = 1e-9
pressure_tolerance = 1e-9
[[body]]
name = "lower"
material = "steel-elastic"
shape = "box"
size = [0.01, 0.01, 0.01]
mesh_size = 0.0034
mesher = "structured"
[[body.boundary]]
plane = {{ point = [0, 0, -0.005], normal = [0, 0, 1] }}
displacement = ["free", "free", 0]
[[body.boundary]]
plane = {{ point = [-0.005, 0, 0], normal = [1, 0, 0] }}
displacement = [0, "free", "free"]
[[body.boundary]]
plane = {{ point = [0, -0.005, 0], normal = [0, 1, 0] }}
displacement = ["free", 0, "free"]
[[body]]
name = "upper"
material = "aluminium-elastic"
shape = "box"
size = [0.01, 0.01, 0.01]
position = [0, 0, 0.01]
mesh_size = 0.0027
[[body.boundary]]
plane = {{ point = [0, 0, 0.015], normal = [0, 0, 1] }}
pressure = 7e6
"""


@pytest.mark.parametrize("element", ["tet4", "tet10"])
def test_patch_test_passes_a_uniform_pressure_exactly_across_non_matching_meshes(element):
    prob, out = run(PATCH.format(element=element))
    for i in range(2):
        s = out.fields[i]["stress"]
        assert np.abs(s[2] / -7e6 - 1).max() < 1e-6
        assert np.abs(s[[0, 1, 3, 4, 5]]).max() < 1e-6 * 7e6


STACK = """
[run]
analysis = "quasistatic"
end_time = 1
[quasistatic]
element = "tet4"
gap_tolerance = 1e-9
pressure_tolerance = 1e-9
[[material]]
library = "steel-elastic"
expansion = "12e-6 1/K"
[[material]]
library = "aluminium-elastic"
expansion = "23e-6 1/K"
[[material]]
name = "polymer"
density = 1200
youngs_modulus = "3 GPa"
poisson_ratio = 0.35
expansion = "70e-6 1/K"
[[body]]
name = "steel"
material = "steel-elastic"
shape = "box"
size = [0.01, 0.01, 0.004]
mesh_size = 0.0025
initial_temperature = "393.15 K"
[[body.boundary]]
plane = { point = [0, 0, -0.002], normal = [0, 0, 1] }
displacement = ["free", "free", 0]
[[body]]
name = "aluminium"
material = "aluminium-elastic"
shape = "box"
size = [0.01, 0.01, 0.006]
position = [0, 0, 0.005]
mesh_size = 0.003
initial_temperature = "393.15 K"
[[body]]
name = "polymer"
material = "polymer"
shape = "box"
size = [0.01, 0.01, 0.002]
position = [0, 0, 0.009]
mesh_size = 0.002
initial_temperature = "393.15 K"
[[body.boundary]]
plane = { point = [0, 0, 0.01], normal = [0, 0, 1] }
displacement = ["free", "free", 0]
"""


def test_constrained_thermal_stack_stress():
    prob, out = run(STACK)
    L = np.array([0.004, 0.006, 0.002])
    E = np.array([200e9, 70e9, 3e9])
    alpha = np.array([12e-6, 23e-6, 70e-6])
    sigma = -100.0 * (alpha * L).sum() / (L / E).sum()
    for i in range(3):
        s = out.fields[i]["stress"]
        assert np.abs(s[2] / sigma - 1).max() < 0.01, (i, s[2].min(), s[2].max(), sigma)
        assert np.abs(s[[0, 1]]).max() < 0.01 * abs(sigma)


SERIES = """
[run]
analysis = "quasistatic"
end_time = 1
[quasistatic]
element = "tet4"
heat = "steady"
heat_tolerance = 1e-10
[[material]]
library = "steel-elastic"
conductivity = "50 W/(m K)"
[[material]]
library = "aluminium-elastic"
conductivity = "200 W/(m K)"
[contact]
[[contact.pair]]
bodies = ["a", "b"]
conductance = "20000 W/(m^2 K)"
[[body]]
name = "a"
material = "steel-elastic"
shape = "box"
size = [0.01, 0.01, 0.005]
mesh_size = 0.0025
[[body.boundary]]
plane = { point = [0, 0, -0.0025], normal = [0, 0, 1] }
temperature = "400 K"
displacement = [0, 0, 0]
[[body]]
name = "b"
material = "aluminium-elastic"
shape = "box"
size = [0.01, 0.01, 0.01]
position = [0, 0, 0.0075]
mesh_size = 0.003
[[body.boundary]]
plane = { point = [0, 0, 0.0125], normal = [0, 0, 1] }
temperature = "300 K"
"""


def test_steady_conduction_through_two_bodies_in_contact_is_the_series_resistance():
    prob, out = run(SERIES)
    r = 0.005 / 50 + 1 / 20000 + 0.01 / 200
    q = 100.0 / r
    ta = out.fields[0]["T"]
    tb = out.fields[1]["T"]
    za = prob.bodies[0].points[2]
    zb = prob.bodies[1].points[2]
    nva, nvb = len(za), len(zb)
    # each body: linear in z with the series flux; the jump at the contact is q / h
    np.testing.assert_allclose(ta[:nva], 400 - q * (za + 0.0025) / 50, rtol=0, atol=0.01 * 100)
    np.testing.assert_allclose(tb[:nvb], 300 + q * (0.0125 - zb) / 200, rtol=0, atol=0.01 * 100)
    top_a = ta[:nva][np.isclose(za, 0.0025)].mean()
    bottom_b = tb[:nvb][np.isclose(zb, 0.0025)].mean()
    assert abs((top_a - bottom_b) / (q / 20000) - 1) < 0.01
