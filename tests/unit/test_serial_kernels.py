"""Kernels that run on one thread below a size and on all threads above it (nodal.predict and
move, element.node_forces): both versions give the same bits, whatever the number of threads,
so the size threshold never changes a result."""

import numba
import numpy as np

from impactsim.solver import element as E
from impactsim.solver import nodal
from tests.unit.test_node_forces import _loaded_model


def test_node_forces_one_thread_and_all_threads_equal():
    model, _ = _loaded_model()
    nodes = np.arange(model.n_node)
    args = (model.x, model.conn, model.status, model.sdev, model.pressure, model.q,
            model.n2e_ptr, model.n2e)
    serial = np.zeros_like(model.force)
    E._node_forces_serial(nodes, *args, serial)
    assert np.abs(serial).max() > 0.0
    for threads in (1, numba.config.NUMBA_NUM_THREADS):
        numba.set_num_threads(threads)
        par = np.zeros_like(model.force)
        E._node_forces_parallel(nodes, *args, par)
        np.testing.assert_array_equal(par, serial)
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    # the dispatching function gives the same on a few nodes (one thread) and on all
    few = np.zeros_like(model.force)
    E.node_forces(nodes[:50], *args, few)
    np.testing.assert_array_equal(few[:50], serial[:50])


def test_predict_and_move_one_thread_and_all_threads_equal():
    rng = np.random.default_rng(5)
    n = 5000
    force, v, x = rng.normal(size=(n, 3)), rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    mass = rng.random(n) + 0.1
    mass[::7] = 0.0  # massless nodes are left alone
    out = {}
    for name, pred, mov in (("serial", nodal._predict_serial, nodal._move_serial),
                            ("parallel", nodal._predict_parallel, nodal._move_parallel)):
        vv, xx = v.copy(), x.copy()
        pred(force, mass, vv, 1.3e-7)
        mov(xx, vv, 1.1e-7)
        out[name] = (vv, xx)
    np.testing.assert_array_equal(out["serial"][0], out["parallel"][0])
    np.testing.assert_array_equal(out["serial"][1], out["parallel"][1])
    np.testing.assert_array_equal(out["serial"][0][::7], v[::7])


def test_fused_predict_wall_move_equals_the_three_passes():
    """constraints.predict_walls_move (the time loop's one pass over the nodes when the scene's
    only velocity pass is one wall, or none) gives the bits of predict, apply_walls and move,
    with and without friction, nodes hitting the wall and massless nodes, and the same wall
    work, touched count and impulse."""
    from impactsim.solver import constraints as C

    rng = np.random.default_rng(7)
    n = 4000
    force, mass = rng.normal(size=(n, 3)), rng.uniform(1e-6, 2e-6, n)
    mass[::11] = 0.0
    x0, v0 = rng.normal(size=(n, 3)) * 1e-3, rng.normal(size=(n, 3)) * 100.0
    dt, dtv = 1e-7, 1.2e-7
    for walls in (np.array([[0.0, 0.0, 0.0, 0.0, 0.6, 0.8, 0.0]]),
                  np.array([[0.0, 0.0, 1e-4, 0.0, 0.6, 0.8, 0.3]]), np.zeros((0, 7))):
        x, v = x0.copy(), v0.copy()
        nodal.predict(force, mass, v, dtv)
        three = C.apply_walls(x, v, mass, force, dtv, walls, dt)
        nodal.move(x, v, dt)
        xf, vf = x0.copy(), v0.copy()
        fused = C.predict_walls_move(force, mass, vf, xf, dtv, walls, dt)
        assert fused == three
        assert len(walls) == 0 or three[1] > 100  # the wall acted on many nodes
        np.testing.assert_array_equal(vf, v)
        np.testing.assert_array_equal(xf, x)
        np.testing.assert_array_equal(vf[::11], v0[::11])  # massless: velocity kept, moved
