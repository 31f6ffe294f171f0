"""The element update against hand calculations (ALGORITHMS.md 2)."""

import math

import numpy as np
import pytest

from impactsim.case.schema import EOS, Strength
from impactsim.materials import params as P
from impactsim.materials.laws import (eos_linear_part, flow_stress, hardening, radial_return,
                                      thermal_factor)
from impactsim.solver.loop import Simulation
from tests.builders import box_model, material


def _impose_velocity_gradient(model, grad):
    """v = grad @ (x - centre) on every node: a homogeneous motion of the patch."""
    model.v[:] = (model.x - model.x.mean(axis=0)) @ np.asarray(grad).T


@pytest.mark.parametrize("element", ["tet4", "anp"])
def test_patch_uniform_stretch_gives_exact_stress(element):
    """A homogeneous velocity gradient gives the same, exact stress in every element, and zero net
    force on interior nodes (the patch test), for both tet formulations."""
    mat = material()
    model, _ = box_model(mat, h=0.25)
    sim = Simulation(model, [], element=element)
    d = np.array([[2.0, 0.3, 0.0], [0.3, -1.0, 0.1], [0.0, 0.1, 0.5]])  # symmetric: no spin
    dt = 1e-7
    _impose_velocity_gradient(model, d)
    # move and update with the kernel alone (the loop's predictor would change v)
    from impactsim.solver.nodal import move
    move(model.x, model.v, dt)
    sim._update_elements(dt)
    G, K = mat.shear_modulus, mat.bulk_modulus
    # the rate is measured on the mid-step configuration: D = d (I + dt/2 d)^-1 exactly
    dmid = d @ np.linalg.inv(np.eye(3) + 0.5 * dt * d)
    dev = dmid - np.trace(dmid) / 3 * np.eye(3)
    s_expected = 2 * G * dt * dev
    vol_ratio = np.linalg.det(np.eye(3) + dt * d)
    p_expected = K * (1.0 / vol_ratio - 1.0)
    s = model.sdev
    for k, (i, j) in enumerate([(0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (2, 0)]):
        np.testing.assert_allclose(s[:, k], s_expected[i, j], rtol=1e-6, atol=1e-9 * G * dt)
    np.testing.assert_allclose(model.pressure, p_expected, rtol=1e-6)
    # interior node of the 4x4x4 patch: the forces of its elements cancel
    interior = np.all(np.abs(model.x0) < 0.49, axis=1)
    assert interior.sum() > 0
    fscale = np.abs(model.force).max()
    # round-off only: the pressure K (V0/V - 1) of a 1e-7 strain keeps about 9 digits
    assert np.abs(model.force[interior]).max() < 1e-7 * fscale


def test_rigid_rotation_gives_no_stress():
    """A rigid spin (v = w x r on the mid-step configuration) leaves a stress-free body stress-free,
    and rotates an existing deviator without changing its invariants (Jaumann rate)."""
    mat = material()
    model, _ = box_model(mat, h=0.5)
    sim = Simulation(model, [])
    w = np.array([0.0, 0.0, 300.0])
    dt = 1e-6
    spin = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    model.sdev[:] = [1e8, -5e7, -5e7, 2e7, 0.0, 0.0]
    j2_before = 0.5 * np.sum(model.sdev[:, :3] ** 2, 1) + np.sum(model.sdev[:, 3:] ** 2, 1)
    # positions at n+1 such that the mid-step configuration is x0 and v = spin @ x_mid
    xmid = model.x0 - model.x0.mean(0)
    model.v[:] = xmid @ spin.T
    model.x[:] = model.x0 + 0.5 * dt * model.v
    sim._update_elements(dt)
    j2_after = 0.5 * np.sum(model.sdev[:, :3] ** 2, 1) + np.sum(model.sdev[:, 3:] ** 2, 1)
    # the Jaumann update is first order in (w dt): invariants change by O((w dt)^2)
    np.testing.assert_allclose(j2_after, j2_before, rtol=5 * (w[2] * dt) ** 2)
    # (W s - s W)_xy = W_xy (s_yy - s_xx) with the spin W_xy = -w_z
    np.testing.assert_allclose(model.sdev[:, 3], 2e7 - w[2] * dt * (-5e7 - 1e8), rtol=1e-6)
    model.sdev[:] = 0.0
    model.x[:] = model.x0 + 0.5 * dt * model.v
    model.vol[:] = model.vol0
    model.pressure[:] = 0.0
    sim._update_elements(dt)
    assert np.abs(model.sdev).max() < 1e-6 * mat.shear_modulus * w[2] * dt


def test_radial_return_lands_on_yield_surface():
    mat = material(strength=Strength(model="johnson-cook", A=90e6, B=292e6, n=0.31, C=0.025, m=1.09,
                                     melt_temperature=1356.0, room_temperature=293.0))
    mp = P.material_row(mat)[None, :]
    G = mat.shear_modulus
    for seq_trial, eps0 in [(5e8, 0.0), (2e9, 0.1), (1e8, 0.5)]:
        deps, sy, hard = radial_return(P.JOHNSON_COOK, mp, 0, G, seq_trial, eps0, 1e3,
                                       hardening(P.JOHNSON_COOK, mp, 0, eps0),
                                       thermal_factor(P.JOHNSON_COOK, mp, 0, 300.0))
        sy_check, _ = flow_stress(P.JOHNSON_COOK, mp, 0, eps0 + deps, 1e3, 300.0)
        assert hard == pytest.approx(hardening(P.JOHNSON_COOK, mp, 0, eps0 + deps), rel=1e-14)
        if deps > 0:
            assert seq_trial - 3 * G * deps == pytest.approx(sy_check, rel=1e-10)
            assert sy == pytest.approx(sy_check, rel=1e-12)
        else:
            assert seq_trial <= sy_check
    # first yield (eps_p = 0), from just above the yield stress to far past it: on the yield
    # surface (the iteration runs in t = d^n, `laws.first_yield_return`)
    rt = thermal_factor(P.JOHNSON_COOK, mp, 0, 300.0) * (1 + 0.025 * math.log(1e3))
    for over in (1e-6, 1e-4, 1e-2, 0.1, 1.0, 5.0):
        seq_trial = 90e6 * rt * (1 + over)
        deps, sy, hard = radial_return(P.JOHNSON_COOK, mp, 0, G, seq_trial, 0.0, 1e3, 90e6,
                                       thermal_factor(P.JOHNSON_COOK, mp, 0, 300.0))
        sy_check, _ = flow_stress(P.JOHNSON_COOK, mp, 0, deps, 1e3, 300.0)
        assert deps > 0.0 and sy == pytest.approx(sy_check, rel=1e-13)
        assert abs(seq_trial - 3 * G * deps - sy_check) <= 1e-12 * seq_trial * 1.01
    # an increment far larger than the plastic strain so far
    for eps0 in (1e-9, 1e-6):
        deps, sy, hard = radial_return(P.JOHNSON_COOK, mp, 0, G, 3e8, eps0, 1e3,
                                       hardening(P.JOHNSON_COOK, mp, 0, eps0),
                                       thermal_factor(P.JOHNSON_COOK, mp, 0, 300.0))
        sy_check, _ = flow_stress(P.JOHNSON_COOK, mp, 0, eps0 + deps, 1e3, 300.0)
        assert deps > 100 * eps0 and sy == pytest.approx(sy_check, rel=1e-13)
        assert hard == pytest.approx(hardening(P.JOHNSON_COOK, mp, 0, eps0 + deps), rel=1e-13)
        assert abs(3e8 - 3 * G * deps - sy_check) <= 1e-12 * 3e8 * 1.01
    # ideal plasticity: exactly Y0
    mp[0, P.STRENGTH] = P.IDEAL_PLASTIC
    mp[0, P.Y0] = 3e8
    deps, sy, _ = radial_return(P.IDEAL_PLASTIC, mp, 0, G, 9e8, 0.0, 0.0, 3e8, 1.0)
    assert sy == 3e8 and deps == pytest.approx(6e8 / (3 * G))


def test_newton_start_is_right_of_the_root_and_third_order():
    """laws.newton_start: the quadratic model's root lies right of the return's solution (the
    model bounds the convex residual from above), and its error is third order in the
    increment: ten times smaller an overstress, about a hundred times smaller a relative
    error (the linearised start's relative error only falls tenfold)."""
    from impactsim.materials.laws import newton_start
    a0, b0, n, g3, rt = 90e6, 292e6, 0.31, 3 * 46e9, 1.1
    for eps in (1e-4, 1e-2, 0.3):
        errors = []
        for over in (1e-1, 1e-2):
            hard = a0 + b0 * eps ** n
            seq = hard * rt * (1 + over)
            d0 = newton_start(seq, hard * rt, hard, a0, rt, n, g3, eps)
            lo, hi = 0.0, (seq - hard * rt) / g3  # the root by bisection
            for _ in range(200):
                mid = 0.5 * (lo + hi)
                if seq - g3 * mid - rt * (a0 + b0 * (eps + mid) ** n) > 0:
                    lo = mid
                else:
                    hi = mid
            assert d0 >= lo * (1 - 1e-15)
            errors.append((d0 - lo) / lo)
        assert errors[1] < 0.02 * errors[0] + 1e-11


def test_plastic_element_stress_on_yield_surface():
    """Uniaxial strain far past yield in the full kernel: von Mises stress equals Y0."""
    mat = material(strength=Strength(model="ideal-plastic", yield_stress=2e8))
    model, _ = box_model(mat, h=0.5)
    sim = Simulation(model, [])
    d = np.diag([-50.0, 0.0, 0.0])
    from impactsim.solver.nodal import move
    for _ in range(20):
        _impose_velocity_gradient(model, d)
        move(model.x, model.v, 1e-5)
        sim._update_elements(1e-5)
    s = model.sdev
    vm = np.sqrt(1.5 * (np.sum(s[:, :3] ** 2, 1) + 2 * np.sum(s[:, 3:] ** 2, 1)))
    np.testing.assert_allclose(vm, 2e8, rtol=1e-9)
    assert np.all(model.eps_p > 0)


def test_mie_gruneisen_reproduces_hugoniot_point():
    """Copper (c0 = 3940 m/s, s = 1.489, Gamma0 = 2.02): at particle velocity up = 1 km/s the
    Hugoniot gives Us = c0 + s up, rho = rho0 Us / (Us - up), p = rho0 Us up and, from rest,
    e = up^2 / 2. The EOS at (rho, e) must give that p."""
    rho0, c0, s, g0 = 8930.0, 3940.0, 1.489, 2.02
    up = 1000.0
    us = c0 + s * up
    rho = rho0 * us / (us - up)
    p_h = rho0 * us * up  # 48.5 GPa
    e_h = 0.5 * up * up
    a, b, _, _ = eos_linear_part(P.MIE_GRUNEISEN, rho, rho0, 0.0, c0, s, g0)
    assert a + b * e_h == pytest.approx(p_h, rel=1e-12)
    assert p_h == pytest.approx(48.48e9, rel=1e-3)
    # off the Hugoniot, Gamma rho = Gamma0 rho0: dp/de at constant rho is Gamma0 rho0
    assert b == pytest.approx(g0 * rho0)
    # at the reference state the sound speed is c0
    _, _, c2a, c2b = eos_linear_part(P.MIE_GRUNEISEN, rho0, rho0, 0.0, c0, s, g0)
    assert math.sqrt(c2a) == pytest.approx(c0, rel=1e-12)


def test_mach_number_warning():
    """ALGORITHMS.md 1: M0 > 0.75 with a linear EOS, and any M0 > 1.5, are flagged."""
    from impactsim.solver.pipeline import mach_warnings
    from tests.builders import box_case

    mat = material(name="m")  # C0 = sqrt(K/rho) = 4.6 km/s
    assert mach_warnings(box_case(mat, velocity=(0, 0, -1000.0))) == []  # no wall, one body
    case = box_case(mat, velocity=(0, 0, -4000.0))
    from impactsim.case.schema import Wall
    case.walls = [Wall()]
    assert "0.75" in mach_warnings(case)[0]
    case.bodies[0].velocity = (0, 0, -8000.0)
    assert "1.5" in mach_warnings(case)[0]
