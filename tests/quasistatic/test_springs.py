"""The weak springs of a body held only by its contacts (elastic.ElasticBody._springs)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from impactsim.quasistatic.build import problem
from impactsim.quasistatic.elastic import ElasticBody
from impactsim.quasistatic.space import Space
from tests.quasistatic.helpers import case

PELLET = """
[run]
analysis = "quasistatic"
end_time = 1
[quasistatic]
element = "tet4"
[[body]]
name = "pellet"
material = "uo2"
shape = "cylinder"
diameter = "8.19 mm"
height = "9.83 mm"
position = [0, 0, "4.915 mm"]
mesh_size = "2.5 mm"
initial_temperature = "580 K"
centering_axis = [0, 0, 1]
"""


def _pellet(axis=None):
    text = PELLET if axis is None else PELLET.replace("[0, 0, 1]", axis)
    model = problem(case(text)).bodies[0]
    space = Space(model.mesh(), model.order)
    x = model.points
    nv = x.shape[1]
    # the tied rows of a kinematic anchor on the bottom face: the normal (z) displacement of
    # its nodes; a tilt prescribed on them
    bottom = np.nonzero(np.abs(x[2]) < 1e-9)[0]
    P = sp.csr_matrix((np.ones(len(bottom)), (np.arange(len(bottom)), 3 * bottom + 2)),
                      shape=(len(bottom), 3 * nv))
    g = 2e-6 + 1e-4 * x[0, bottom] - 3e-5 * x[1, bottom]
    # hot core, cool rim: the pellet's thermal load
    r2 = x[0] ** 2 + x[1] ** 2
    T = 580.0 + 600.0 * (1.0 - r2 / r2.max())
    return model, space, P, g, T


def test_tied_rows_and_a_centering_axis_hold_a_pellet_without_proximal_springs():
    # the pellets of a tied column: what the springs pulled to (the previous iterate, along
    # the axis) is state the accelerated Schwarz iteration does not see; the tied rows fix
    # the modes they held (100 pellets: 563 -> 311 iterations, docs/quasistatic.md)
    model, space, P, g, T = _pellet()
    e = ElasticBody(model, space, 1e-4, tied_rows=P)
    assert not e.proximal and e.tied_rows is not None
    f = e.load(T, 1.0)
    u, lam = e.solve(f, e.prescribed(1.0), P, g, np.ones(len(g), bool), g)
    # the exactly constrained solve: [K + S, P^T; P, 0] [u; lam] = [f; g] (no dof prescribed)
    assert len(e.D) == 0
    A = sp.bmat([[e.K + e.springs, P.T], [P, None]]).tocsc()
    x = sla.spsolve(A, np.concatenate([f, g]))
    size = np.abs(x[:len(u)]).max()
    assert np.abs(u - x[:len(u)]).max() < 1e-8 * size
    assert np.abs(P @ u - g).max() < 1e-10 * size
    np.testing.assert_allclose(lam, x[len(u):], rtol=1e-6, atol=1e-8 * np.abs(lam).max())
    # the springs pull across the axis only, to the reference position: a rigid motion along
    # the axis costs them nothing
    along = np.zeros(e.ndof)
    along[2::3] = 1.0
    assert np.abs(e.springs @ along).max() == 0.0
    assert e.spring_rhs() == 0.0


def test_a_body_its_conditions_leave_free_keeps_the_proximal_springs():
    # without the tied rows (an anchor that may open) or with the axis across the tied face
    # (the rows and the springs leave a mode free) the springs still pull to the previous
    # iterate
    model, space, P, g, T = _pellet()
    assert ElasticBody(model, space, 1e-4).proximal
    model, space, P, g, T = _pellet("[0, 1, 0]")
    e = ElasticBody(model, space, 1e-4, tied_rows=P)
    assert e.proximal and e.tied_rows is None
