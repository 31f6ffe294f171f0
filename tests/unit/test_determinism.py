"""The same input gives the same bits, whatever the number of threads.

The element kernel adds forces to rows of its own per node and fixed part of elements, and sums
each node's rows in part order (solver/scatter.py), so every node sums its elements in the same
order; reductions (stable time step, viscous work) are summed per fixed chunk in chunk order
(docs/architecture.md), and which path an element takes in the kernel (vector block or scalar)
depends only on its block. So a Johnson-Cook block hitting a wall, a few thousand elements over
several parts, must end bit for bit the same on one thread and on two (and with the one-thread
kernel element_update uses for small meshes, as with the parallel one).
"""

import inspect

import numba
import numpy as np
import pytest

from impactsim.case import load_case_text
from impactsim.materials import params as P
from impactsim.solver import element as E
from impactsim.mesh import mesh_body
from impactsim.solver.build import build_model
from impactsim.solver.loop import Simulation
from impactsim.solver.pipeline import build_passes

CASE = """
[run]
end_time = 1.0
[[body]]
name = "block"
material = "ofhc-copper"
shape = "box"
size = [4e-3, 4e-3, 6e-3]
position = [0, 0, 3.0001e-3]
mesh_size = 0.5e-3
mesher = "structured"
velocity = [0, 0, -300]
[[wall]]
point = [0, 0, 0]
normal = [0, 0, 1]
"""


def _run(threads, steps=60):
    case = load_case_text(CASE)
    model = build_model(case, [mesh_body(case.bodies[0], use_cache=False)])
    previous = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        sim = Simulation(model, build_passes(case, model))
        for _ in range(steps):
            sim.step()
    finally:
        numba.set_num_threads(previous)
    return model, sim


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two numba threads")
def test_one_and_two_threads_give_the_same_bits(monkeypatch):
    a, sa = _run(1)  # below element.PARALLEL_ELEMENTS: the one-thread kernel
    monkeypatch.setattr(E, "PARALLEL_ELEMENTS", 0)
    b, sb = _run(2)  # the parallel kernel on two threads
    assert a.n_elem > 4 * 512  # several chunks, so two threads share the work
    assert np.count_nonzero(a.eps_p) > 100  # the Johnson-Cook return ran
    assert int(a.mat_params[0, P.STRENGTH]) == P.JOHNSON_COOK
    assert a.n_elem > 2 * E.PART  # several parts: each thread runs some, and nodes on their
    assert sa.force_rows.n_rows > a.n_node  # borders add up rows of several parts
    for name in ("x", "v", "force", "sdev", "pressure", "energy", "eps_p", "temperature", "q"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert sa.dt == sb.dt and a.energy_terms == b.energy_terms


@pytest.mark.parametrize("threads", [1, 2, 3, 4])
def test_each_thread_visits_every_part_once_its_own_first(threads):
    # the tet kernel's threads claim parts as they visit them (element._visit): each visits
    # every part once, its own (t, t + T, ...) first in order, then each other thread's from
    # its last, so that it takes another's only once that one has fallen behind
    for n_parts in range(10):
        for t in range(threads):
            seq = [E._visit.py_func(t, k, n_parts, threads) for k in range(n_parts)]
            assert sorted(seq) == list(range(n_parts))
            own = list(range(t, n_parts, threads))
            assert seq[:len(own)] == own
            rest = seq[len(own):]
            for u in range(threads):
                theirs = [p for p in rest if p % threads == u]
                assert theirs == sorted(theirs, reverse=True)


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two numba threads")
def test_parts_taken_from_other_threads_give_the_same_bits(monkeypatch):
    # the kernel told of more threads than run: the loop's extra iterations find their own
    # parts taken by the threads that finished first, which take the other iterations' parts
    # from their last; the bits are those of one thread
    a, _ = _run(1)
    monkeypatch.setattr(E, "PARALLEL_ELEMENTS", 0)
    update = E.element_update

    def with_more_threads(*args, **kw):
        bound = inspect.signature(update).bind(*args, **kw)
        bound.arguments["threads"] = 5
        return update(*bound.args, **bound.kwargs)

    monkeypatch.setattr(E, "element_update", with_more_threads)
    b, _ = _run(2)
    assert a.n_elem > 2 * E.PART  # three parts for five iterations: two own none
    for name in ("x", "v", "force", "sdev", "pressure", "energy", "eps_p", "temperature", "q"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
