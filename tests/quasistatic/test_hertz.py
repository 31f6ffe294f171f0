"""Static Hertz contact: a steel sphere pressed on a steel block (quarter model, tet10)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.quasistatic.helpers import run

R = 0.01  # sphere radius [m]
E, NU = 200e9, 0.3
A_TARGET = 0.8e-3  # contact radius the load is chosen for
E_STAR = E / (2 * (1 - NU ** 2))
FORCE = 4 * E_STAR * A_TARGET ** 3 / (3 * R)  # full sphere
PRESSURE = FORCE / (np.pi * R ** 2)  # on the flat equatorial face

HERTZ = f"""
[run]
analysis = "quasistatic"
end_time = 1
[quasistatic]
element = "tet10"
gap_tolerance = 1e-5
pressure_tolerance = 1e-4
max_iterations = 400
[[contact.pair]]
bodies = ["sphere", "block"]
gap_tolerance = 1.5e-4
[[body]]
name = "sphere"
material = "steel-elastic"
shape = "sphere"
radius = {R}
position = [0, 0, {R}]
clip = {{ lo = [0, 0, {-R}], hi = [{R}, {R}, 0] }}
refine = {{ point = [0, 0, {-R}], size = 1.5e-4, radius = 1.6e-3 }}
mesh_size = 0.003
[[body.boundary]]
plane = {{ point = [0, 0, {R}], normal = [0, 0, 1] }}
pressure = {PRESSURE}
[[body.boundary]]
plane = {{ point = [0, 0, 0], normal = [1, 0, 0] }}
displacement = [0, "free", "free"]
[[body.boundary]]
plane = {{ point = [0, 0, 0], normal = [0, 1, 0] }}
displacement = ["free", 0, "free"]
[[body]]
name = "block"
material = "steel-elastic"
shape = "box"
size = [0.016, 0.016, 0.01]
position = [0, 0, -0.005]
clip = {{ lo = [0, 0, -0.005], hi = [0.008, 0.008, 0.005] }}
refine = {{ point = [0, 0, 0.005], size = 1.5e-4, radius = 1.6e-3 }}
mesh_size = 0.003
[[body.boundary]]
plane = {{ point = [0, 0, -0.01], normal = [0, 0, 1] }}
displacement = [0, 0, 0]
[[body.boundary]]
plane = {{ point = [0, 0, 0], normal = [1, 0, 0] }}
displacement = [0, "free", "free"]
[[body.boundary]]
plane = {{ point = [0, 0, 0], normal = [0, 1, 0] }}
displacement = ["free", 0, "free"]
"""


@pytest.mark.slow
@pytest.mark.xfail(reason="the active set converges too slowly: it starts with every matched node "
                          "and sheds the tensile ones once per settled state (docs/quasistatic.md, "
                          "Known limits)", strict=False)
def test_hertz_contact_radius_and_peak_pressure():
    prob, out = run(HERTZ)
    itf = out.interfaces[0]
    assert prob.bodies[itf.a].name == "sphere"  # held only by the contact: the kinematic side
    p = out.state.p[0]
    from impactsim.quasistatic.space import Space
    xy = Space(prob.bodies[itf.a].mesh(), 2).doflocs[:, itf.nodes]
    r2 = xy[0] ** 2 + xy[1] ** 2
    a = (3 * FORCE * R / (4 * E_STAR)) ** (1 / 3)
    p0 = 3 * FORCE / (2 * np.pi * a ** 2)
    # the quarter model carries a quarter of the force
    total = (itf.M_a @ p).sum()
    assert abs(total / (FORCE / 4) - 1) < 0.01
    # p^2 = p0^2 (1 - r^2 / a^2): a straight line in r^2 over the loaded part
    sel = p > 0.3 * p.max()
    slope, icpt = np.polyfit(r2[sel], p[sel] ** 2, 1)
    p0_fit = np.sqrt(icpt)
    a_fit = np.sqrt(-icpt / slope)
    assert abs(a_fit / a - 1) < 0.05, (a_fit, a)
    assert abs(p0_fit / p0 - 1) < 0.05, (p0_fit, p0)
