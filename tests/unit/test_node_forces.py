"""Nodal forces added by the element kernel itself (no corner-force array).

The kernel runs fixed parts of elements, and every corner adds its force to the row of its
(node, part) pair; each node's rows are then summed (solver/scatter.py). These tests check that
every row has one writer part (else two threads would race on it) and that summing the rows
gives each node's sum, that the kernel's forces equal the per-node sum of every element's
-V sigma grad N computed independently, and that removing elements takes their forces off
their nodes.
"""

import numba
import numpy as np
import pytest

from impactsim.model import ERODED
from impactsim.solver import element as E
from impactsim.solver.loop import Simulation
from impactsim.solver.scatter import force_rows, take_node
from tests.builders import box_model, material

COPPER = material(name="cu", density=8930.0, shear_modulus=46e9, bulk_modulus=137e9,
                  specific_heat=383.0)


def _loaded_model(part=E.CHUNK):
    """A 1.5k-tet box with random velocities, after two updates: every stress component and
    the bulk viscosity are non-zero. Parts of `part` elements (three of one chunk each by
    default, so that nodes on their borders sum rows of two or three parts)."""
    model, _ = box_model(COPPER, size=(2e-3, 1e-3, 1e-3), h=0.2e-3)
    rng = np.random.default_rng(7)
    model.v[:] = rng.normal(size=model.v.shape) * 5.0
    sim = Simulation(model, [])
    sim.set_parts(part)
    for _ in range(2):
        sim.step()
    return model, sim


@pytest.mark.parametrize("part", [1, 8, 64, 512])
def test_force_rows_have_one_writer_and_sum_per_node(part):
    """Every row of fext is written by one part only, each node's first row is its own index,
    and summing each node's rows gives the per-node sum of its corners."""
    model, _ = box_model(COPPER, size=(2e-3, 1e-3, 1e-3), h=0.2e-3)
    conn, nn = model.conn, model.n_node
    fr = force_rows(conn, nn, part)
    part_of_corner = np.repeat(np.arange(model.n_elem) // part, 4)
    rows = fr.rows.ravel()
    writers = np.full(fr.n_rows, -1)
    writers[rows] = part_of_corner
    assert np.array_equal(writers[rows], part_of_corner)  # one part per row
    # a node's rows: its own, then one per further part that touches it, in part order
    for i in (0, nn // 2, nn - 1):
        mine = np.concatenate(([i], fr.extra_rows[fr.extra_ptr[i]:fr.extra_ptr[i + 1]]))
        assert set(mine) == set(rows[conn.ravel() == i])
        assert np.all(np.diff(writers[mine]) > 0)
    assert fr.n_rows - nn == fr.extra_rows.shape[0]
    if part >= model.n_elem:
        assert fr.n_rows == nn  # one part: no extra rows
    rng = np.random.default_rng(1)
    corner_force = rng.normal(size=(model.n_elem * 4, 3))
    fext = np.zeros((fr.n_rows, 3))
    np.add.at(fext, rows, corner_force)
    expected = np.zeros((nn, 3))
    np.add.at(expected, conn.ravel(), corner_force)
    got = np.zeros((nn, 3))
    _gather_all(fext, fr.extra_ptr, fr.extra_rows, got)
    np.testing.assert_allclose(got, expected, rtol=1e-13, atol=1e-13)
    assert not fext.any()  # every row is some node's: all left zero for the next step


@numba.njit
def _gather_all(fext, extra_ptr, extra_rows, force):
    for i in range(force.shape[0]):
        force[i, 0], force[i, 1], force[i, 2] = take_node(i, fext, extra_ptr, extra_rows)


@pytest.mark.parametrize("part", [E.CHUNK, E.PART])
def test_kernel_forces_equal_the_per_node_sum(part):
    model, sim = _loaded_model(part)
    assert model.n_elem > 2 * E.CHUNK and np.abs(model.q).max() > 0.0
    every = np.arange(model.n_node)
    expected = np.zeros_like(model.force)
    E.node_forces(every, model.x, model.conn, model.status, model.sdev, model.pressure, model.q,
                  model.n2e_ptr, model.n2e, expected)
    scale = np.abs(expected).max()
    assert scale > 0.0
    np.testing.assert_allclose(model.force, expected, rtol=0, atol=1e-12 * scale)
    # internal forces are self-equilibrated: no net force, no net moment about the origin
    assert np.abs(model.force.sum(axis=0)).max() < 1e-11 * scale * model.n_node
    moment = np.cross(model.x, model.force).sum(axis=0)
    assert np.abs(moment).max() < 1e-11 * scale * model.n_node * np.abs(model.x).max()


def test_removed_elements_leave_their_nodes():
    model, sim = _loaded_model()
    corner = np.argmin(model.x.sum(axis=1))  # a corner node: removing its elements orphans it
    around = model.n2e[model.n2e_ptr[corner]:model.n2e_ptr[corner + 1]] // 4
    removed = np.union1d(np.arange(100, 160), around)
    model.status[removed] = ERODED
    sim.refresh_forces(removed)
    expected = np.zeros_like(model.force)
    E.node_forces(np.arange(model.n_node), model.x, model.conn, model.status, model.sdev,
                  model.pressure, model.q, model.n2e_ptr, model.n2e, expected)
    scale = np.abs(expected).max()
    np.testing.assert_allclose(model.force, expected, rtol=0, atol=1e-12 * scale)
    # a node whose elements are all gone carries no force at all
    live = np.zeros(model.n_node, bool)
    live[model.conn[model.status != ERODED].ravel()] = True
    orphans = np.unique(model.conn[removed])[~live[np.unique(model.conn[removed])]]
    assert corner in orphans
    assert np.all(model.force[orphans] == 0.0)
    # the next step's kernel agrees with the refreshed forces
    sim.step()
    E.node_forces(np.arange(model.n_node), model.x, model.conn, model.status, model.sdev,
                  model.pressure, model.q, model.n2e_ptr, model.n2e, expected)
    np.testing.assert_allclose(model.force, expected, rtol=0,
                               atol=1e-12 * np.abs(expected).max())
