"""Wave arrival in a long bar at the analytic speed.

A velocity step at one end of a laterally confined bar (uniaxial strain) travels at the
longitudinal speed c_L = sqrt((K + 4G/3)/rho) (e.g. Kolsky, Stress Waves in Solids, 1963, ch. 1).
The arrival time at a station is taken where the particle velocity there reaches half the step.
"""

import numpy as np
import pytest

from impactsim.case.schema import Constraint, NodeSelector
from impactsim.mesh.structured import structured_box
from impactsim.solver.build import build_model
from impactsim.solver.loop import Simulation
from impactsim.solver.pipeline import build_passes
from tests.builders import box_case, material


def test_longitudinal_wave_arrives_at_analytic_speed():
    mat = material()
    length, h = 0.2, 0.0025
    case = box_case(mat, size=(h, h, length), h=h, end=1.0)
    body = case.bodies[0]
    # uniaxial strain: lateral faces held in x and y, the end z = -L/2 driven at 1 m/s
    body.constraints = [
        Constraint(NodeSelector("all"), (0.0, 0.0, None)),
        Constraint(NodeSelector("plane", {"point": (0, 0, -length / 2), "normal": (0, 0, 1),
                                          "tolerance": 1e-9}), (0.0, 0.0, 1.0)),
    ]
    model = build_model(case, [structured_box((h, h, length), h)])
    sim = Simulation(model, build_passes(case, model), cfl=0.5)
    c_l = np.sqrt((mat.bulk_modulus + 4 * mat.shear_modulus / 3) / mat.density)
    stations = [0.05, 0.1]  # distance from the driven end [m]
    nodes = [np.nonzero(np.isclose(model.x0[:, 2], -length / 2 + s))[0] for s in stations]
    arrival = [None, None]
    while model.time < 0.16 / c_l:
        sim.step()
        for k, idx in enumerate(nodes):
            if arrival[k] is None and model.v[idx, 2].mean() >= 0.5:
                arrival[k] = model.time
    assert None not in arrival
    speed = (stations[1] - stations[0]) / (arrival[1] - arrival[0])
    assert speed == pytest.approx(c_l, rel=0.03)
