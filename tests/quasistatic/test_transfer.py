"""The pressure transfer G_b and the roles across curved contacts: a uniform pressure on A's
patch reaches B whole, where A's closest points lie off B's normals (a pellet in its tube, a
sphere on a block)."""

from __future__ import annotations

import numpy as np

from impactsim.quasistatic import interfaces as setup_mod
from impactsim.quasistatic.build import problem

from tests.quasistatic.helpers import case
from tests.quasistatic.test_hertz import HERTZ

ROD = """
[run]
analysis = "quasistatic"
end_time = 1
[quasistatic]
element = "tet4"
[[contact.pair]]
bodies = ["pellet", "tube"]
gap_tolerance = "0.15 mm"
[[body]]
name = "pellet"
material = "steel-elastic"
shape = "cylinder"
diameter = "8.19 mm"
height = "9.83 mm"
mesh_size = "2.5 mm"
[[body]]
name = "tube"
material = "steel-elastic"
shape = "tube"
diameter = "9.50 mm"
inner_radius = "4.18 mm"
height = "12 mm"
mesh_size = "3 mm"
[[body.boundary]]
plane = { point = [0, 0, "-6 mm"], normal = [0, 0, 1] }
displacement = [0, 0, 0]
"""


def _radial_force(itf, doflocs_b) -> float:
    """B's nodal forces of a unit pressure on A's patch, summed along the outward radius."""
    r = doflocs_b.T.copy()
    r[:, 2] = 0.0
    r /= np.maximum(np.linalg.norm(r, axis=1), 1e-300)[:, None]
    return float((itf.G_b.T @ r.ravel()).sum())


def test_a_uniform_pressure_crosses_a_curved_gap_whole():
    prob = problem(case(ROD))
    spaces, itfs, *_ = setup_mod.setup(prob)
    (itf,) = itfs
    area = float((itf.M_a @ np.ones(len(itf.gap))).sum())  # A's patch: its side, 2 pi r h
    sign = 1.0 if prob.bodies[itf.b].name == "tube" else -1.0
    # the closest-point transfer passed nothing (A's closest points lay off B's normals)
    assert abs(sign * _radial_force(itf, spaces[itf.b].doflocs) / area - 1) < 0.05


def test_a_sphere_held_only_along_its_contact_is_the_kinematic_side_and_loads_the_block():
    prob = problem(case(HERTZ))
    spaces, itfs, *_ = setup_mod.setup(prob)
    (itf,) = itfs
    # held on its symmetry planes, free along z: a force side would drift
    assert prob.bodies[itf.a].name == "sphere"
    # a uniform unit pressure over the sphere's patch pushes the block down by the patch's
    # projected area (the ray transfer; the closest-point one lost all but the pole)
    fz = float(itf.resultant[2] @ np.ones(len(itf.gap)))
    projected = float((itf.M_a @ -itf.normals[:, 2]).sum())
    assert abs(-fz / projected - 1) < 0.05, (fz, projected)
