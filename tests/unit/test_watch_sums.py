"""The watch's per-step sums (solver/watch.py ``state_sums``): the same bits on one and two
threads, the kinetic energy and force power summed in fixed chunks, the internal energy in
element order, and a non-finite value in any watched array of a live node or element caught;
a non-finite stress or pressure of a live tet caught through the forces of the step."""

import numba
import numpy as np
import pytest

from impactsim.model import ERODED
from impactsim.solver.watch import CHUNK, state_sums


def _state(seed=0, n=3 * CHUNK + 123, ne=5 * CHUNK + 77):
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((n, 3))
    v = 100.0 * rng.standard_normal((n, 3))
    force = 1e3 * rng.standard_normal((n, 3))
    mass = rng.uniform(0.0, 1e-3, n)
    mass[::17] = 0.0  # nodes without mass (no force power)
    energy = rng.uniform(0.0, 1e5, ne)
    elem_mass = rng.uniform(0.0, 1e-4, ne)
    status = np.zeros(ne, np.int8)
    status[rng.choice(ne, ne // 10, replace=False)] = ERODED
    return [x, v, force, mass, energy, elem_mass, status]


def _reference(x, v, force, mass, energy, elem_mass, status):
    """The sums in the kernel's order: nodes per chunk of CHUNK, chunk partials added in order;
    elements one after the other."""
    ke = power = ie = 0.0
    for c in range(0, mass.shape[0], CHUNK):
        s = p = 0.0
        for i in range(c, min(mass.shape[0], c + CHUNK)):
            s += mass[i] * (v[i, 0] * v[i, 0] + v[i, 1] * v[i, 1] + v[i, 2] * v[i, 2])
            if mass[i] > 0.0:
                p += force[i, 0] * v[i, 0] + force[i, 1] * v[i, 1] + force[i, 2] * v[i, 2]
        ke += s
        power += p
    for e in range(energy.shape[0]):
        if status[e] != ERODED:
            ie += elem_mass[e] * energy[e]
    return 0.5 * ke, ie, power


def test_sums_are_the_same_on_any_thread_count():
    args = _state()
    ke, ie, power = _reference(*args)
    live = args[6] != ERODED
    assert ie == pytest.approx(float(np.sum(args[5][live] * args[4][live])), rel=1e-13)
    got = []
    for threads in sorted({1, min(2, numba.config.NUMBA_NUM_THREADS)}):
        numba.set_num_threads(threads)
        got.append(state_sums(*args))
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    for g in got:
        assert (g[0], g[1], g[3]) == (ke, ie, power)
        assert g[2] == 0.0
    assert all(g == got[0] for g in got)


@pytest.mark.parametrize("name,index", [(0, (CHUNK + 5, 1)), (1, (7, 2)), (2, (3 * CHUNK + 100, 0)),
                                        (4, (4 * CHUNK + 3,)), (4, (5 * CHUNK + 76,))])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_value_is_caught(name, index, bad):
    """Positions, velocities, forces, specific energy: one non-finite value in a live node or
    element makes the finiteness sum nan (on any chunk, the last partial one too); in an
    eroded element it is not read."""
    args = _state(seed=1)
    if name == 4:
        args[6][index[0]] = 0
    args[name][index] = bad
    assert np.isnan(state_sums(*args)[2])
    if name == 4:
        args[6][index[0]] = ERODED
        assert state_sums(*args)[2] == 0.0


@pytest.mark.parametrize("field,index", [("sdev", (17, 3)), ("pressure", 40), ("sdev", (0, 0))])
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_a_non_finite_stress_stops_the_run_in_its_step(field, index, bad):
    """The watch reads no stress: a non-finite deviator component or pressure of a live tet
    makes the step's forces non-finite (the tet kernel computes them from it), and the watch
    after that step raises NonFinite naming a node's force; an eroded tet's stress is not
    read by the kernel, and the run goes on."""
    from tests.builders import box_model, material
    from impactsim.solver.loop import Simulation
    from impactsim.solver.watch import NonFinite, Watch

    for eroded in (False, True):
        model, case = box_model(material(), size=(2e-3, 2e-3, 2e-3), h=0.5e-3,
                                velocity=(0.0, 0.0, -50.0))
        sim = Simulation(model, [], cfl=0.5)
        watch = Watch(sim)
        sim.step()
        watch.after_step()
        getattr(model, field)[index] = bad
        if eroded:
            e = index[0] if isinstance(index, tuple) else index
            model.status[e] = ERODED
        sim.step()
        if eroded:
            watch.after_step()
            assert np.isfinite(model.force).all()
        else:
            with pytest.raises(NonFinite, match="force"):
                watch.after_step()
