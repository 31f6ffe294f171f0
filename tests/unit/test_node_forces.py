"""Nodal forces added by the element kernel itself (no corner-force array, no gather pass).

The kernel runs its chunks of elements colour by colour and adds each element's forces to its
four nodes. These tests check that the colouring really keeps chunks of one colour apart (else
two threads would race on a node), that the forces it adds equal the per-node sum of every
element's -V sigma grad N computed independently, and that removing elements takes their forces
off their nodes.
"""

import numpy as np
import pytest

from impactsim.model import ERODED
from impactsim.solver import element as E
from impactsim.solver.loop import Simulation
from tests.builders import box_model, material

COPPER = material(name="cu", density=8930.0, shear_modulus=46e9, bulk_modulus=137e9,
                  specific_heat=383.0)


def _loaded_model():
    """A 1.5k-tet box with random velocities, after two updates: every stress component and
    the bulk viscosity are non-zero."""
    model, _ = box_model(COPPER, size=(2e-3, 1e-3, 1e-3), h=0.2e-3)
    rng = np.random.default_rng(7)
    model.v[:] = rng.normal(size=model.v.shape) * 5.0
    sim = Simulation(model, [])
    for _ in range(2):
        sim.step()
    return model, sim


@pytest.mark.parametrize("chunk", [1, 8, 64])
def test_chunks_of_one_colour_share_no_node(chunk):
    model, _ = box_model(COPPER, size=(2e-3, 1e-3, 1e-3), h=0.2e-3)
    conn = model.conn
    order, ptr = E.chunk_colours(conn, chunk)
    nch = (conn.shape[0] + chunk - 1) // chunk
    assert np.array_equal(np.sort(order), np.arange(nch))  # every chunk once
    assert ptr[0] == 0 and ptr[-1] == nch and np.all(np.diff(ptr) > 0)
    for c in range(ptr.shape[0] - 1):
        chunks = order[ptr[c]:ptr[c + 1]]
        assert np.all(np.diff(chunks) > 0)  # chunk order within a colour
        seen = np.zeros(model.n_node, np.int64)
        for ch in chunks:
            nodes = np.unique(conn[ch * chunk:(ch + 1) * chunk])
            seen[nodes] += 1
        assert seen.max() == 1, f"colour {c}: two chunks share a node"
    assert ptr.shape[0] - 1 < min(nch, 63)  # far fewer colours than chunks


def test_kernel_forces_equal_the_per_node_sum():
    model, sim = _loaded_model()
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
