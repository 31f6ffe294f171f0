"""The coarse step of the Schwarz iteration (schwarz._coarse_shifts, _coarse_forces) on a
column of identical steel blocks (all but the base heated by 100 K) on frictionless
supports, pressed from the top: it changes how fast the
iteration gets there, not where it gets."""

from __future__ import annotations

import numpy as np
import pytest

from impactsim.quasistatic.build import problem
from impactsim.quasistatic.solver import solve

from tests.quasistatic.helpers import case

H = 0.004  # block height [m]
COLUMN = """
[run]
analysis = "quasistatic"
end_time = 1
[quasistatic]
element = "tet4"
gap_tolerance = 1e-6
pressure_tolerance = 1e-6
aitken = false
relaxation = 0.5
max_iterations = 1000
[[material]]
library = "steel-elastic"
expansion = "12e-6 1/K"
[[body]]
name = "base"
material = "steel-elastic"
shape = "box"
size = [0.01, 0.01, {h}]
mesh_size = 0.0034
mesher = "structured"
[[body.boundary]]
plane = {{ point = [0, 0, {bottom}], normal = [0, 0, 1] }}
displacement = ["free", "free", 0]
[[body.boundary]]
plane = {{ point = [-0.005, 0, 0], normal = [1, 0, 0] }}
displacement = [0, "free", "free"]
[[body.boundary]]
plane = {{ point = [0, -0.005, 0], normal = [0, 1, 0] }}
displacement = ["free", 0, "free"]
[[body]]
name = "block"
material = "steel-elastic"
shape = "box"
size = [0.01, 0.01, {h}]
position = [0, 0, {h}]
copies = {{ count = {middle}, offset = [0, 0, {h}] }}
mesh_size = 0.0034
mesher = "structured"
initial_temperature = "393.15 K"
[[body]]
name = "top"
material = "steel-elastic"
shape = "box"
size = [0.01, 0.01, {h}]
position = [0, 0, {top}]
mesh_size = 0.0034
mesher = "structured"
initial_temperature = "393.15 K"
[[body.boundary]]
plane = {{ point = [0, 0, {surface}], normal = [0, 0, 1] }}
pressure = "10 MPa"
"""


def column(n: int, *overrides: str):
    text = COLUMN.format(h=H, bottom=-H / 2, middle=n - 2, top=(n - 1) * H,
                         surface=(n - 0.5) * H)
    prob = problem(case(text, *overrides))
    out = solve(prob)
    assert out.stopped is None, out.stopped
    return prob, out


def _top_rise(prob, out) -> float:
    i = len(prob.bodies) - 1
    z = prob.bodies[i].points[2]
    u = out.fields[i]["u"].reshape(-1, 3)[:len(z)]
    return float(u[np.isclose(z, z.max()), 2].mean())


def test_the_coarse_step_keeps_the_answer_of_the_plain_iteration():
    n = 8
    prob, coarse = column(n)
    _, plain = column(n, "quasistatic.coarse=false")
    size = max(np.abs(f["u"]).max() for f in plain.fields.values())
    for i in plain.fields:
        assert np.abs(coarse.fields[i]["u"] - plain.fields[i]["u"]).max() < 1e-5 * size
        # every block carries the applied pressure uniformly
        s = coarse.fields[i]["stress"]
        assert np.abs(s[2] / -10e6 - 1).max() < 5e-3, (i, s[2].min(), s[2].max())
    # the top rises by the free thermal growth of the heated blocks less their compression
    # (laterally free: uniaxial stress)
    heated = (n - 1) * H
    expected = heated * 12e-6 * 100.0 - n * H * 10e6 / 200e9
    assert abs(_top_rise(prob, coarse) / expected - 1) < 1e-3


@pytest.mark.slow
def test_the_coarse_step_saves_iterations_on_a_long_column():
    # measured (tet4, omega 0.5, tolerances 1e-6): 4 / 12 / 24 / 48 blocks take 26 / 52 / 81
    # / 131 iterations with the coarse step, 26 / 55 / 95 / 173 without. The gap mismatch
    # falls by 0.5 per iteration whatever the length (to 1e-6 in about 20); what still grows
    # with the column is the pressure mismatch: the shape of the pressure (its edges) moves
    # one block per iteration, the coarse step passes on only its resultant
    its = {}
    for coarse in (True, False):
        _, out = column(48, f"quasistatic.coarse={str(coarse).lower()}")
        its[coarse] = out.steps[-1]["iterations"]
    assert its[True] < 0.85 * its[False], its
