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
def test_hertz_contact_radius_and_peak_pressure():
    prob, out = run(HERTZ)
    itf = out.interfaces[0]
    assert prob.bodies[itf.a].name == "sphere"  # held only by the contact: the kinematic side
    from impactsim.quasistatic.space import Space
    space = Space(prob.bodies[itf.a].mesh(), 2)
    # the load on the meshed top face (its polygonal rim has 1.5 % less area than the
    # quarter disc), times 4: the force of the full model
    (top,) = [c for c in prob.bodies[itf.a].conditions if c.kind == "pressure"]
    x, _ = space.facet_geometry(top.facets)
    area = 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1).sum()
    force = 4 * PRESSURE * area
    p = out.state.p[0]
    act = out.state.active[0]
    xy = space.doflocs[:, itf.nodes]
    r2 = xy[0] ** 2 + xy[1] ** 2
    a = (3 * force * R / (4 * E_STAR)) ** (1 / 3)
    p0 = 3 * force / (2 * np.pi * a ** 2)
    total = (itf.M_a @ p).sum()
    assert abs(total / (force / 4) - 1) < 0.01, total / (force / 4)
    # p = p0 sqrt(1 - r^2 / a^2) fitted in the norm of A's surface mass matrix (the L2 norm of
    # the pressure field): the nodal values M^-1 lambda of tet10 alternate between corner and
    # mid-side nodes by +-40 %, which a pointwise fit of p^2 against r^2 takes for shape
    # (13-17 % on the peak), while their field integrates right
    M = itf.M_a

    def misfit(scale):
        shape = np.sqrt(np.clip(1 - r2 / (scale * a) ** 2, 0.0, None))
        c = (shape @ M @ p) / (shape @ M @ shape)
        e = p - c * shape
        return e @ M @ e, c

    from scipy.optimize import minimize_scalar

    best = minimize_scalar(lambda s: misfit(s)[0], bounds=(0.7, 1.3), method="bounded",
                           options={"xatol": 1e-5})
    a_fit = best.x * a
    p0_fit = misfit(best.x)[1]
    # the contact ends where Hertz says, to within an element (1.5e-4 m here)
    edge = np.sqrt(r2[act].max())
    print(f"a_fit/a {a_fit / a:.4f} p0_fit/p0 {p0_fit / p0:.4f} edge/a {edge / a:.4f} "
          f"force {total / (force / 4):.4f} iterations {out.steps[-1]['iterations']}")
    assert abs(edge - a) < 1.5e-4, (edge, a)
    assert abs(a_fit / a - 1) < 0.05, (a_fit, a)
    assert abs(p0_fit / p0 - 1) < 0.05, (p0_fit, p0)
