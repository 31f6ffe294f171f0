"""The one-point hex with Flanagan-Belytschko hourglass control (solver/hex8.py, ALGORITHMS.md
7.1): exact volume gradient, gamma vectors, patch test on a distorted mesh, rigid rotation,
hourglass modes under the viscous and the stiffness form with the energy balance, threads."""

import numba
import numpy as np
import pytest

from impactsim.case.schema import Body, Case, Output, Run
from impactsim.mesh.hexes import box_hexes, fix_hex_orientation
from impactsim.solver import hex8 as H
from impactsim.solver.build import build_model
from impactsim.solver.loop import Simulation
from impactsim.solver.nodal import move
from tests.builders import material

CUBE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1],
                 [0, 1, 1]], float)
XI = 2.0 * CUBE - 1.0


def _gauss_volume(p):
    """Exact volume of a trilinear hex by 2x2x2 Gauss quadrature of det J."""
    g = 1.0 / np.sqrt(3.0)
    vol = 0.0
    for a in (-g, g):
        for b in (-g, g):
            for c in (-g, g):
                dn = np.array([XI[:, 0] * (1 + XI[:, 1] * b) * (1 + XI[:, 2] * c),
                               XI[:, 1] * (1 + XI[:, 0] * a) * (1 + XI[:, 2] * c),
                               XI[:, 2] * (1 + XI[:, 0] * a) * (1 + XI[:, 1] * b)]) / 8.0
                vol += np.linalg.det(dn @ p)
    return vol


def _distorted_hex(seed=0):
    rng = np.random.default_rng(seed)
    return CUBE * [2.0, 1.5, 1.0] + 0.2 * rng.standard_normal((8, 3))


def _gammas(p):
    b, vol = H.hex_volume_gradient(p)
    return 0.125 * (H.GAMMA - (H.GAMMA @ p) @ b.T / vol), b, vol


def test_volume_gradient_is_exact():
    """b = dV/dx (FB81 eq. 79) matches central differences of the exactly integrated volume,
    and V = sum x_I b_xI is the exact volume of a distorted (non-planar faces) hex."""
    p = _distorted_hex()
    b, vol = H.hex_volume_gradient(p)
    assert vol == pytest.approx(_gauss_volume(p), rel=1e-13)
    fd = np.zeros((8, 3))
    h = 1e-6
    for i in range(8):
        for d in range(3):
            q, r = p.copy(), p.copy()
            q[i, d] += h
            r[i, d] -= h
            fd[i, d] = (_gauss_volume(q) - _gauss_volume(r)) / (2 * h)
    np.testing.assert_allclose(b, fd, atol=1e-8)
    for i in range(3):
        assert p[:, i] @ b[:, i] == pytest.approx(vol, rel=1e-13)


def test_gamma_orthogonal_to_linear_fields():
    """sum_I gamma_aI = 0 and sum_I gamma_aI x_jI = 0 (FB81 eqs. 52-53) on a distorted hex,
    and the gammas are not zero (they span the four hourglass modes)."""
    p = _distorted_hex(3)
    gam, _, _ = _gammas(p)
    np.testing.assert_allclose(gam.sum(axis=1), 0.0, atol=1e-14)
    np.testing.assert_allclose(gam @ p, 0.0, atol=1e-13)
    assert np.linalg.matrix_rank(gam) == 4


def _hex_case(mat, hourglass="viscous", coef=0.1, size=(1.0, 1.0, 1.0), h=0.25, **run):
    body = Body(name="box", material=mat.name, shape="box", dimensions={"size": size},
                mesh_size=h, element="hex8", hourglass=hourglass, hourglass_coefficient=coef)
    return Case(source=None, run=Run(name="t", end_time=1e-3, **run), materials={mat.name: mat},
                bodies=[body], output=Output())


def _distorted_mesh(h=0.25, amp=0.08, seed=1):
    """A structured hex mesh of the unit cube with its interior nodes moved randomly."""
    pts, hexes = box_hexes((1.0, 1.0, 1.0), h)
    rng = np.random.default_rng(seed)
    inner = np.all(np.abs(pts) < 0.49, axis=1)
    pts = pts.copy()
    pts[inner] += amp * h * rng.uniform(-1, 1, (inner.sum(), 3))
    hexes, _ = fix_hex_orientation(pts, hexes)
    return pts, hexes


def test_patch_test_distorted_mesh():
    """A linear velocity field on a distorted hex mesh gives the exact uniform stress in every
    element, zero hourglass force (the net force on every interior node vanishes) and no
    hourglass work, with both hourglass forms (Schwer et al. 2005 patch test)."""
    mat = material()
    for form in ("viscous", "stiffness"):
        case = _hex_case(mat, form, 0.1)
        model = build_model(case, [_distorted_mesh()])
        blk = model.blocks[0]
        sim = Simulation(model, [])
        d = np.array([[2.0, 0.3, 0.0], [0.3, -1.0, 0.1], [0.0, 0.1, 0.5]])
        dt = 1e-7
        model.v[:] = (model.x - model.x.mean(axis=0)) @ d.T
        move(model.x, model.v, dt)
        sim._update_elements(dt)
        G = mat.shear_modulus
        dmid = d @ np.linalg.inv(np.eye(3) + 0.5 * dt * d)
        dev = dmid - np.trace(dmid) / 3 * np.eye(3)
        s_expected = 2 * G * dt * dev
        for k, (i, j) in enumerate([(0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (2, 0)]):
            np.testing.assert_allclose(blk.sdev[:, k], s_expected[i, j], rtol=1e-6,
                                       atol=1e-9 * G * dt)
        p_expected = mat.bulk_modulus * (1.0 / np.linalg.det(np.eye(3) + dt * d) - 1.0)
        np.testing.assert_allclose(blk.pressure, p_expected, rtol=1e-6)
        np.testing.assert_allclose(blk.hg, 0.0, atol=1e-9 * np.abs(blk.sdev).max())
        interior = np.all(np.abs(model.x0) < 0.49, axis=1)
        assert interior.sum() > 0
        assert np.abs(model.force[interior]).max() < 1e-7 * np.abs(model.force).max()
        assert abs(model.energy_terms["hourglass"]) < 1e-12 * sim.energies()["internal_energy"]


def test_rigid_rotation_gives_no_stress():
    """A rigid spin about the mid-step configuration of a distorted hex mesh: no stress, no
    pressure beyond the second-order volume change of the linearised spin, no hourglass
    resultant."""
    mat = material()
    model = build_model(_hex_case(mat, "stiffness", 0.05), [_distorted_mesh()])
    blk = model.blocks[0]
    sim = Simulation(model, [])
    w = np.array([100.0, -200.0, 300.0])
    spin = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    dt = 1e-6
    xmid = model.x0 - model.x0.mean(0)
    model.v[:] = xmid @ spin.T
    model.x[:] = model.x0 + 0.5 * dt * model.v
    blk.vol[:] = H.hex_volumes(model.x, blk.conn)  # the volume does not change over the step
    sim._update_elements(dt)
    scale = mat.shear_modulus * np.linalg.norm(w) * dt
    assert np.abs(blk.sdev).max() < 1e-6 * scale
    assert np.abs(blk.hg).max() < 1e-9 * scale
    # x = x0 + dt/2 w x r is a rotation to first order: the volume changes by O((w dt)^2)
    assert np.abs(blk.pressure).max() < mat.bulk_modulus * (np.linalg.norm(w) * dt) ** 2


def _hourglass_run(form, coef, steps=400, cfl=0.1):
    """One free cube-shaped hex in the mode Gamma_3 (xi eta), nothing else moving.

    The kinetic energy is measured with the half-step velocities of the leapfrog, so that
    kinetic + hourglass energy of an oscillator (or of a mode damped within a few steps)
    wobbles by O(omega dt) around its true value: a small Courant number keeps that wobble
    below the 2 % the tests allow (0.6 gives about 6 %)."""
    mat = material()
    pts, hexes = box_hexes((0.01, 0.01, 0.01), 0.01)
    hexes, _ = fix_hex_orientation(pts, hexes)
    model = build_model(_hex_case(mat, form, coef, size=(0.01,) * 3, h=0.01, cfl=cfl),
                        [(pts, hexes)])
    conn = model.blocks[0].conn[0]
    amp = 0.1
    # nodal velocities along x in the hourglass pattern Gamma_3 of the element's own corners
    model.v[conn, 0] = amp * H.GAMMA[2]
    sim = Simulation(model, [], cfl=cfl)
    e0 = sim.energies()["total_energy"]
    ke, tot = [], []
    for _ in range(steps):
        sim.step()
        en = sim.energies()
        ke.append(en["kinetic_energy"])
        tot.append(en["total_energy"])
    return np.array(ke), np.array(tot), e0, sim


def test_hourglass_viscous_mode_decays_energy_balance_closes():
    """An hourglass mode alone under the viscous form loses its kinetic energy to the hourglass
    dissipation, with total energy (kinetic + internal + hourglass) conserved."""
    ke, tot, e0, sim = _hourglass_run("viscous", 0.1, steps=1500)
    assert ke[-1] < 0.05 * e0  # decays (the undamped mode would keep it all: see below)
    assert sim.model.energy_terms["hourglass"] > 0.9 * e0
    assert np.abs(tot - e0).max() < 0.02 * e0


def test_hourglass_stiffness_mode_stays_bounded_energy_balance_closes():
    """Under the stiffness form the mode oscillates: kinetic energy goes into the hourglass
    spring and comes back, bounded, with the energy balance closing."""
    ke, tot, e0, sim = _hourglass_run("stiffness", 0.05, steps=3000)
    assert ke.max() <= 1.001 * e0  # bounded: never above the initial energy
    assert ke.min() < 0.2 * e0  # the spring takes the energy ...
    late = ke[len(ke) // 2:]
    assert late.max() > 0.8 * e0  # ... and gives it back, undamped
    assert np.abs(tot - e0).max() < 0.02 * e0


def test_without_control_the_mode_is_free():
    """Sanity of the two tests above: with no hourglass control the mode costs no energy at
    all (one-point integration does not see it), so it neither decays nor oscillates."""
    ke, tot, e0, sim = _hourglass_run("viscous", 0.0, steps=100)
    assert ke[-1] == pytest.approx(e0, rel=1e-6)


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two numba threads")
def test_one_and_two_threads_give_the_same_bits():
    """A hex mesh over several parts, compressed against a wall, ends bit for bit the same on
    one and on two threads."""
    from impactsim.case.schema import Wall
    from impactsim.solver.pipeline import build_passes

    mat = material()

    def run(threads):
        prev = numba.get_num_threads()
        numba.set_num_threads(threads)
        try:
            case = _hex_case(mat, "stiffness", 0.03, size=(0.12, 0.1, 0.2), h=0.01)
            case.bodies[0].velocity = (0.0, 0.0, -50.0)
            case.walls = [Wall(point=(0.0, 0.0, -0.1), normal=(0.0, 0.0, 1.0))]
            from impactsim.mesh import mesh_body

            model = build_model(case, [mesh_body(case.bodies[0])])
            assert model.blocks[0].n_elem > 2 * H.PART
            sim = Simulation(model, build_passes(case, model))
            for _ in range(40):
                sim.step()
            return model
        finally:
            numba.set_num_threads(prev)

    a, b = run(1), run(2)
    assert np.array_equal(a.x, b.x) and np.array_equal(a.v, b.v)
    assert np.array_equal(a.blocks[0].sdev, b.blocks[0].sdev)
    assert np.array_equal(a.blocks[0].hg, b.blocks[0].hg)
    assert a.energy_terms["hourglass"] == b.energy_terms["hourglass"]


def test_hourglass_warning_above_a_tenth_of_the_internal_energy():
    from impactsim.solver.blocks import hourglass_warning

    assert hourglass_warning({"hourglass_energy": 1.0, "internal_energy": 20.0}) == ""
    msg = hourglass_warning({"hourglass_energy": 3.0, "internal_energy": 20.0})
    assert "15 %" in msg and "hourglass_coefficient" in msg
    assert hourglass_warning({"kinetic_energy": 1.0}) == ""  # tets only: nothing to say
