"""Coulomb friction in the Schwarz iteration (impactsim/quasistatic/friction.py): stick below
mu p, slip at mu p, no tangential load carried without friction, the monolithic solve, and the
independence of the number of workers."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from impactsim.quasistatic import friction
from impactsim.quasistatic import interfaces as setup_mod
from impactsim.quasistatic.body import BodyState
from impactsim.quasistatic.build import problem
from impactsim.quasistatic.monolithic import solve_monolithic
from impactsim.quasistatic.solver import solve

from tests.quasistatic.helpers import case

# two steel blocks, non-matching meshes: the lower one clamped at its bottom, the upper one
# pressed by 10 MPa on its top; TOP is the rest of the upper block's top condition. The upper
# block is thin: a sideways traction on its top tilts it by a moment (2 mm x the force), which
# moves the pressure from one edge to the other (with a 5 mm block the trailing edge carried
# 0.2 MPa and slipped at 2 MPa of traction)
BLOCKS = """
[run]
analysis = "quasistatic"
end_time = 1
[quasistatic]
element = "tet4"
gap_tolerance = 1e-7
pressure_tolerance = 1e-6
max_iterations = 600
[[body]]
name = "lower"
material = "steel-elastic"
shape = "box"
size = [0.01, 0.01, 0.005]
mesh_size = 0.0025
mesher = "structured"
[[body.boundary]]
plane = { point = [0, 0, -0.0025], normal = [0, 0, 1] }
displacement = [0, 0, 0]
[[body]]
name = "upper"
material = "steel-elastic"
shape = "box"
size = [0.01, 0.01, 0.002]
position = [0, 0, 0.0035]
mesh_size = 0.0015
[[body.boundary]]
plane = { point = [0, 0, 0.0045], normal = [0, 0, 1] }
pressure = "10 MPa"
TOP
[[contact.pair]]
bodies = ["lower", "upper"]
friction = MU
"""

P, AREA = 10e6, 1e-4

@functools.lru_cache(maxsize=4)
def blocks(mu: float, top: str, *overrides: str):
    """(problem, setup, outcome): cached, the tests only read them."""
    text = BLOCKS.replace("TOP", top).replace("MU", "inf" if mu == np.inf else repr(mu))
    prob = problem(case(text, *overrides))
    setup = setup_mod.setup(prob)
    return prob, setup, solve(prob, setup=setup)


def _interface(out):
    itf, = out.interfaces
    fs = out.state.friction[0]
    act = out.state.active[0]
    normal, tangential = friction.resultants(itf, fs, out.state.p[0], act)
    return itf, fs, act, normal, tangential


def _slip(out, itf, act):
    T = itf.tangential
    w = T.C_t @ out.fields[itf.a]["u"] - T.I_t @ out.fields[itf.b]["u"]
    return w.reshape(2, -1).T[act]


def test_below_mu_p_the_blocks_stick():
    # the floating upper block, pushed by 1 MPa sideways: 0.1 p < mu p = 0.5 p (the moment of
    # the push moves the pressure to 6-14 MPa across the face, the local |q| / p stays below
    # 0.3; at 2 MPa the trailing edge's nodes carry 2.4 MPa and slip)
    prob, setup, out = blocks(0.5, 'traction = ["1 MPa", 0, 0]')
    assert out.stopped is None, out.stopped
    itf, fs, act, normal, tangential = _interface(out)
    assert act.all() and fs.stick[act].all()
    # equilibrium: the interface carries the applied loads (the transfer is exact here)
    assert abs(-normal[2] / (P * AREA) - 1) < 1e-3
    assert abs(tangential[0] / (0.1 * P * AREA) - 1) < 1e-3
    q = np.linalg.norm(fs.q.reshape(2, -1).T, axis=1)
    assert (q < 0.5 * out.state.p[0]).all()
    # no slip: the relative tangential displacement is zero to the iteration's tolerance,
    # while the upper block moves sideways by shearing the lower one
    ux = np.abs(out.fields[1]["u"].reshape(-1, 3)[:, 0]).max()
    assert ux > 1e-7
    assert np.abs(_slip(out, itf, act)).max() < 1e-4 * ux


@pytest.mark.parametrize("mu", [0.3])
def test_above_mu_p_the_blocks_slip_and_the_friction_is_mu_p(mu):
    # the upper block's top is moved 10 um sideways (held in y, free in z under 10 MPa): the
    # shear that would keep it stuck (~150 MPa) is far above mu p, so every node slips
    prob, setup, out = blocks(mu, 'displacement = ["10 um", 0, "free"]')
    assert out.stopped is None, out.stopped
    itf, fs, act, normal, tangential = _interface(out)
    assert act.all() and not fs.stick[act].any()
    assert abs(-normal[2] / (P * AREA) - 1) < 1e-3
    # the traction on the interface is mu times the pressure (in total: the nodal values are
    # q = mu max(p, 0) d by construction; a few edge nodes' M^-1 lambda are negative)
    assert abs(np.hypot(*tangential[:2]) / (mu * -normal[2]) - 1) < 0.01
    # it drags the lower block along the motion of the upper one (+x), and the upper block
    # slides over it: every node's slip is along +x
    assert tangential[0] > 0.999 * np.hypot(*tangential[:2])
    w = _slip(out, itf, act) @ itf.tangential.frame[0]  # (nodes, 3): flat face, one frame
    assert (w[:, 0] > 0.9 * 10e-6).all() and (np.abs(w[:, 1]) < 0.01 * w[:, 0]).all()


def test_without_friction_a_tangential_load_is_not_carried():
    # the same sideways motion, frictionless: the upper block slides rigidly by 10 um and the
    # lower block is not dragged; with friction 0.3 it is
    _, _, free = blocks(0.0, 'displacement = ["10 um", 0, "free"]')
    _, _, fric = blocks(0.3, 'displacement = ["10 um", 0, "free"]')
    assert free.stopped is None and fric.stopped is None
    # the upper block slides by 10 um (on average: Poisson's expansion under the pressure moves
    # its faces by +-0.1 um)
    up = free.fields[1]["u"].reshape(-1, 3)[:, 0].mean()
    assert abs(up / 10e-6 - 1) < 1e-3
    # the clamped lower block carries the friction as shear: mean sigma_xz = mu p (measured
    # 3.0004 MPa), and nothing without it (measured 0.059 MPa, as sigma_yz: the shear of the
    # clamp's own Poisson constraint, the same in both)
    shear_fric = fric.fields[0]["stress"][4].mean()
    shear_free = free.fields[0]["stress"][4].mean()
    assert abs(shear_fric / (0.3 * P) - 1) < 0.01
    assert abs(shear_free) < 0.03 * 0.3 * P


@pytest.mark.parametrize("mu, top, stick", [
    (0.5, 'traction = ["1 MPa", 0, 0]', True),
    pytest.param(0.3, 'displacement = ["10 um", 0, "free"]', False, marks=pytest.mark.slow)])
def test_schwarz_equals_the_monolithic_solve_with_friction(mu, top, stick):
    # measured: 2.2e-7 stuck, 3.8e-7 slipping (of the largest displacement; 5.7e-4 before
    # the monolithic's slip tractions left out the edge nodes with p < 0 as the iteration does)
    prob, (spaces, itfs, specs, route, t), out = blocks(mu, top)
    assert out.stopped is None, out.stopped
    states = {s.index: BodyState(s) for s in specs}
    fm = []
    u, active = solve_monolithic(states, itfs, friction_states=fm)
    size = max(np.abs(u[i]).max() for i in u)
    for i in u:
        assert np.abs(out.fields[i]["u"] - u[i]).max() < 1e-5 * size
    assert (active[0] == out.state.active[0]).all()
    assert (fm[0].stick == out.state.friction[0].stick).all()
    assert fm[0].stick[active[0]].all() == stick


@pytest.mark.slow
def test_friction_gives_the_same_answer_with_one_and_two_workers():
    # bit for bit between worker counts (Dask's workers run their BLAS on one thread; in
    # this process it may use more, and the Schur complements' sums then differ in the last
    # bits: 1e-11 relative, measured)
    prob, setup, local = blocks(0.3, 'displacement = ["10 um", 0, "free"]')
    one = solve(prob, 1, setup=setup)
    two = solve(prob, 2, setup=setup)
    assert (one.workers, two.workers) == (1, 2)
    assert one.stopped is None and two.stopped is None
    its = {r.steps[-1]["iterations"] for r in (local, one, two)}
    assert len(its) == 1
    for i in local.fields:
        np.testing.assert_array_equal(one.fields[i]["u"], two.fields[i]["u"])
        np.testing.assert_allclose(local.fields[i]["u"], two.fields[i]["u"], rtol=0,
                                   atol=1e-9 * np.abs(local.fields[i]["u"]).max())
