"""The material laws checked alone (issue 17, item 1): the element kernel on a small homogeneous
patch, driven by prescribed nodal velocities, against an independent integration of the
constitutive equations with scipy's ODE solvers.

Strength (the deviator): a homogeneous motion v = L x with a constant velocity gradient L, the
nodal velocities set every step so that the kernel's mid-step gradient is exactly L
((I - dt/2 L) v = L x^n, since the kernel differentiates v on x^{n+1} - dt/2 v). Every element of
the patch then sees the same constant rate of deformation D and spin W. The reference integrates

    ds/dt = 2G (D' - lambda 3s/(2 sigma_eq)) + W s - s W       (Prandtl-Reuss, Jaumann rate)
    sigma_eq = sigma_y(eps_p, rate, T) while plastic            (consistency)
    dT/dt = beta sigma_y lambda / (rho c_v),  rho = rho0 exp(-tr D t)   (adiabatic heating)

with sigma_y the Johnson-Cook law written out here again (not imported), the rate term at the
effective total deviatoric strain rate sqrt(2/3 D':D') (docs/physics.md says why). The
plastic strain is carried as the hardening term h = B eps_p^n, in which the consistency
condition is regular at first yield (d sigma_y / d eps_p is infinite at eps_p = 0 for n < 1):
dh/dt [R Theta + eps_p'(h) (3G + R (A + h) Theta'(T) beta sigma_y / (rho c_v))] =
3G s:D' / sigma_eq, lambda = eps_p'(h) dh/dt. Isothermal runs set beta = 0.

EOS: the Mie-Grueneisen pressure on its principal Hugoniot against the Rankine-Hugoniot jump
conditions of the linear Us-up fit, and off it: the kernel's energy integration along an
isentropic compression and release of one element (no viscosity) against de/dv = -p(v, e)
integrated by scipy with the pressure written out here again.

The kernel's errors are 1e-8 (isothermal uniaxial strain, where the return is exact) to 1e-4
(adiabatic shear: the temperature, hence the thermal factor, lags one step) at the step counts
used here. Agreement required: 0.5 % (of the largest stress of the path for stress components, which pass
through zero; of the temperature rise; relative for the plastic strain and the pressure).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from impactsim.case.material import library_material
from impactsim.case.schema import Material, Strength
from impactsim.materials import params as P
from impactsim.materials.laws import eos_linear_part
from impactsim.solver.loop import Simulation
from impactsim.solver.nodal import move
from tests.builders import box_model

TOL = 5e-3
VOIGT = [(0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (2, 0)]


def uniaxial_strain(rate):
    """Compression along z at true strain rate `rate` [1/s]: D = diag(0, 0, -rate)."""
    return np.diag([0.0, 0.0, -rate])


def simple_shear(rate):
    """v_x = rate y: D_xy = rate / 2, spin W_xy = rate / 2."""
    L = np.zeros((3, 3))
    L[0, 1] = rate
    return L


# --- the element kernel, driven --------------------------------------------------------------

def drive_kernel(mat: Material, L, t_end, n_steps, element="tet4", temperature=None,
                 samples=40):
    """Run the element kernel on a 48-tet cube (one block of 32 on the vector path, 16 on the
    scalar path) under v = L x; returns (times, deviator (k, 6), eps_p, T, pressure, energy)
    sampled `samples` times, after checking that every element has the same state."""
    model, _ = box_model(mat, size=(1e-3, 1e-3, 1e-3), h=0.5e-3)
    assert model.n_elem == 48
    if temperature is not None:
        model.temperature[:] = temperature
    sim = Simulation(model, [], element=element, cq=0.0, cl=0.0)
    dt = t_end / n_steps
    a = np.eye(3) - 0.5 * dt * L
    every = n_steps // samples
    out = []
    for k in range(1, n_steps + 1):
        model.v[:] = np.linalg.solve(a, L @ model.x.T).T
        move(model.x, model.v, dt)
        sim._update_elements(dt)
        if k % every == 0:
            s = model.sdev
            assert np.ptp(s, axis=0).max() <= 1e-9 * np.abs(s).max() + 1.0, "not homogeneous"
            out.append((k * dt, s[0].copy(), model.eps_p[0], model.temperature[0],
                        model.pressure[0], model.energy[0]))
    t = np.array([o[0] for o in out])
    return (t, np.array([o[1] for o in out]), np.array([o[2] for o in out]),
            np.array([o[3] for o in out]), np.array([o[4] for o in out]),
            np.array([o[5] for o in out]))


# --- the reference: the constitutive equations, integrated by scipy -------------------------

class JohnsonCook:
    """sigma_y = (A + h) R Theta(T), h = B eps_p^n, written from the definition (MATERIALS.md)."""

    def __init__(self, mat: Material, rate):
        st = mat.strength
        self.ideal = st.model == "ideal-plastic"
        self.A, self.B, self.n = (st.yield_stress, 0.0, 1.0) if self.ideal else (st.A, st.B, st.n)
        self.m = st.m
        self.tr, self.tm = st.room_temperature, st.melt_temperature
        self.R = 1.0 if self.ideal else 1.0 + st.C * math.log(max(rate / st.strain_rate_ref,
                                                                  1.0))

    def theta(self, T):
        if self.ideal:
            return 1.0, 0.0
        ts = (T - self.tr) / (self.tm - self.tr)
        if ts <= 0.0:
            return 1.0, 0.0
        if ts >= 1.0:
            return 0.0, 0.0
        return 1.0 - ts ** self.m, -self.m * ts ** (self.m - 1.0) / (self.tm - self.tr)

    def eps(self, h):
        """eps_p(h) and d eps_p / dh."""
        if self.ideal:
            return h, 1.0  # the state variable is eps_p itself
        x = max(h, 0.0) / self.B
        if x <= 0.0:
            return 0.0, 0.0 if self.n < 1.0 else 1.0 / self.B
        e = x ** (1.0 / self.n)
        return e, e / (self.n * max(h, 1e-300))

    def sigma_y(self, h, T):
        hard = self.A if self.ideal else self.A + max(h, 0.0)
        return hard * self.R * self.theta(T)[0]


def reference(mat: Material, L, times, temperature=None, isothermal=False):
    """(deviator (k, 6), eps_p, T) at `times` from the rate equations of the module docstring."""
    G, rho0, cv = mat.shear_modulus, mat.density, mat.specific_heat
    beta = 0.0 if isothermal else mat.taylor_quinney
    D = 0.5 * (L + L.T)
    W = 0.5 * (L - L.T)
    trd = np.trace(D)
    Dd = D - trd / 3.0 * np.eye(3)
    rate = math.sqrt(2.0 / 3.0 * np.sum(Dd * Dd))
    jc = JohnsonCook(mat, rate)
    T0 = mat.initial_temperature if temperature is None else temperature

    def unpack(y):
        s = np.array([[y[0], y[3], y[5]], [y[3], y[1], y[4]], [y[5], y[4], y[2]]])
        return s, y[6], y[7]

    def pack(ds, dh, dT):
        return [ds[0, 0], ds[1, 1], ds[2, 2], ds[0, 1], ds[1, 2], ds[2, 0], dh, dT]

    def elastic(t, y):
        s, h, T = unpack(y)
        return pack(2.0 * G * Dd + W @ s - s @ W, 0.0, 0.0)

    def plastic(t, y):
        s, h, T = unpack(y)
        seq = math.sqrt(1.5 * np.sum(s * s))
        rho = rho0 * math.exp(-trd * t)
        th, dth = jc.theta(T)
        _, de = jc.eps(h)
        sy = jc.sigma_y(h, T)
        load = 3.0 * G * np.sum(s * Dd) / seq
        hard = jc.A if jc.ideal else jc.A + h
        heat = beta * sy / (rho * cv)
        if jc.ideal:  # the state is eps_p: 3G lambda = load (theta = 1)
            dh = load / (3.0 * G)
            lam = dh
        else:
            dh = load / (jc.R * th + de * (3.0 * G + jc.R * hard * dth * heat))
            lam = de * dh
        ds = 2.0 * G * (Dd - lam * 1.5 * s / seq) + W @ s - s @ W
        return pack(ds, dh, heat * lam)

    def yields(t, y):
        s, h, T = unpack(y)
        return math.sqrt(1.5 * np.sum(s * s)) - jc.sigma_y(h, T)

    yields.terminal = True
    yields.direction = 1
    y0 = np.zeros(8)
    y0[7] = T0
    t_end = times[-1]
    kw = dict(method="LSODA", rtol=1e-10, atol=1e-12, dense_output=True)
    # the elastic stretch is short at these strains: its own solve with the yield event
    first = solve_ivp(elastic, (0.0, t_end), y0, events=yields, **kw)
    ty = first.t_events[0][0]
    second = solve_ivp(plastic, (ty, t_end), first.y_events[0][0],
                       **dict(kw, atol=np.r_[np.full(6, 1.0), 1.0, 1e-9]))
    assert second.success, second.message
    ys = np.array([first.sol(t) if t <= ty else second.sol(t) for t in times])
    s = ys[:, :6]
    eps = np.array([jc.eps(h)[0] for h in ys[:, 6]])
    return s, eps, ys[:, 7]


def _compare(mat, L, t_end, n_steps, temperature=None, isothermal=False, element="tet4"):
    if isothermal:
        mat = dataclasses.replace(mat, taylor_quinney=0.0)
    t, s, eps, T, _, _ = drive_kernel(mat, L, t_end, n_steps, element, temperature)
    s_ref, eps_ref, T_ref = reference(mat, L, t, temperature, isothermal)
    peak = np.abs(s_ref).max()
    err_s = np.abs(s - s_ref).max() / peak
    assert err_s < TOL, f"deviator off by {err_s:.2e} of its peak"
    plastic = eps_ref > 1e-2
    assert plastic.any()
    err_e = np.max(np.abs(eps[plastic] - eps_ref[plastic]) / eps_ref[plastic])
    assert err_e < TOL, f"plastic strain off by {err_e:.2e}"
    rise = T_ref[-1] - T_ref[0]
    if not isothermal:
        assert np.abs(T - T_ref).max() < TOL * rise, "temperature"
    else:
        assert np.all(T == T[0])
    return err_s, err_e


COPPER = library_material("ofhc-copper")
RATES = [1e-3, 1.0, 1e3, 1e5]


@pytest.mark.parametrize("rate", RATES)
@pytest.mark.parametrize("isothermal", [True, False], ids=["isothermal", "adiabatic"])
def test_johnson_cook_uniaxial_strain(rate, isothermal):
    """OFHC copper (C = 0.025: the rate factor spans 1 .. 1.29 over these rates; below the
    reference rate 1/s it is floored at 1), compressed to 25 % true strain."""
    _compare(COPPER, uniaxial_strain(rate), 0.25 / rate, 300, isothermal=isothermal)


@pytest.mark.parametrize("rate", RATES)
@pytest.mark.parametrize("isothermal", [True, False], ids=["isothermal", "adiabatic"])
def test_johnson_cook_simple_shear(rate, isothermal):
    """Simple shear to gamma = 2: the Jaumann rate turns the deviator (normal stresses s_xx =
    -s_yy appear), which the reference integrates with the same objective rate."""
    _compare(COPPER, simple_shear(rate), 2.0 / rate, 600, isothermal=isothermal)


JC_METALS = ["ofhc-copper", "al-2024-t3", "al-6061-t6", "steel-4340", "steel-42crmo4"]


@pytest.mark.parametrize("name", JC_METALS)
def test_adiabatic_shear_softens_to_melt(name):
    """Every Johnson-Cook library metal, in adiabatic simple shear at 1e4 1/s to gamma = 12
    from T* = 0.8 until T* > 0.9 (the aluminium alloys above 0.98, where their yield stress
    has fallen to 1-10 % of its peak): heating, hardening and thermal softening together."""
    mat = library_material(name)
    st = mat.strength
    T0 = st.room_temperature + 0.8 * (st.melt_temperature - st.room_temperature)
    rate = 1e4
    t, s, eps, T, _, _ = drive_kernel(mat, simple_shear(rate), 12.0 / rate, 1500,
                                      temperature=T0)
    s_ref, eps_ref, T_ref = reference(mat, simple_shear(rate), t, T0)
    peak = np.abs(s_ref).max()
    assert np.abs(s - s_ref).max() < TOL * peak
    tstar = (T_ref[-1] - st.room_temperature) / (st.melt_temperature - st.room_temperature)
    assert tstar > 0.9, "the path must reach close to melt"
    seq = np.sqrt(1.5 * (np.sum(s_ref[:, :3] ** 2, 1) + 2 * np.sum(s_ref[:, 3:] ** 2, 1)))
    assert seq[-1] < 0.7 * seq.max(), "the path must soften"
    assert np.abs(T - T_ref).max() < TOL * (T_ref[-1] - T0)
    plastic = eps_ref > 1e-2
    assert np.max(np.abs(eps[plastic] - eps_ref[plastic]) / eps_ref[plastic]) < TOL


PRANDTL_REUSS = ["steel-52100", "al-ideal-plastic"]


@pytest.mark.parametrize("name", PRANDTL_REUSS)
@pytest.mark.parametrize("path", ["uniaxial-strain", "simple-shear"])
def test_prandtl_reuss(path, name):
    """Ideal plasticity (steel-52100: Y0 = 2 GPa; al-ideal-plastic: 345 MPa), rate- and
    temperature-independent."""
    mat = library_material(name)
    L = uniaxial_strain(1e3) if path == "uniaxial-strain" else simple_shear(1e3)
    _compare(mat, L, 0.2e-3 if path == "uniaxial-strain" else 2e-3, 500)


def test_anp_element_gives_the_same_material_response():
    """The averaged-nodal-pressure tet changes only the EOS volume: a homogeneous patch must
    follow the same constitutive path."""
    _compare(COPPER, simple_shear(1e3), 2e-3, 600, element="anp")


# --- Mie-Grueneisen ---------------------------------------------------------------------------

MG_METALS = ["ofhc-copper", "al-2024-t3", "al-6061-t6", "steel-4340", "steel-52100",
             "steel-generic", "al-ideal-plastic"]


def mg_pressure(mat: Material, rho, e):
    """p = p_H (1 - Gamma0 eta / 2) + Gamma0 rho0 e (Gamma rho = Gamma0 rho0), p_H of the linear
    Us-up Hugoniot in compression, rho0 c0^2 eta in tension; written out again here."""
    rho0, c0, s, g0 = mat.density, mat.eos.c0, mat.eos.s, mat.eos.gamma0
    eta = 1.0 - rho0 / rho
    ph = rho0 * c0 ** 2 * eta / (1.0 - s * eta) ** 2 if eta > 0 else rho0 * c0 ** 2 * eta
    return ph * (1.0 - 0.5 * g0 * eta) + g0 * rho0 * e


@pytest.mark.parametrize("name", MG_METALS)
def test_mie_gruneisen_on_its_hugoniot(name):
    """Shock states from rest (Rankine-Hugoniot with Us = c0 + s up): rho = rho0 Us/(Us - up),
    p = rho0 Us up, e = up^2/2. The pointwise law must give p at (rho, e)."""
    mat = library_material(name)
    rho0, c0, s = mat.density, mat.eos.c0, mat.eos.s
    for up in (50.0, 300.0, 1000.0, 2000.0, 4000.0):
        us = c0 + s * up
        rho = rho0 * us / (us - up)
        a, b, _, _ = eos_linear_part(P.MIE_GRUNEISEN, rho, rho0, mat.bulk_modulus, c0, s,
                                     mat.eos.gamma0)
        assert a + b * 0.5 * up * up == pytest.approx(rho0 * us * up, rel=1e-12)


def _isentrope_reference(mat, rho_path, e0=0.0):
    """e(rho) along an isentrope, de/drho = p(rho, e) / rho^2, by scipy (Radau)."""
    sol = solve_ivp(lambda r, e: [mg_pressure(mat, r, e[0]) / r ** 2],
                    (rho_path[0], rho_path[-1]), [e0], method="Radau", rtol=1e-11, atol=1e-6,
                    dense_output=True)
    assert sol.success
    return sol.sol(rho_path)[0]


@pytest.mark.parametrize("name", ["ofhc-copper", "al-6061-t6", "steel-4340"])
def test_mie_gruneisen_isentrope_off_the_hugoniot(name):
    """One patch compressed isotropically at a constant rate to 25 % volume strain and released
    to 2 % expansion, no viscosity: the kernel's energy (trapezoidal p dV, implicit in e)
    and pressure against the isentrope integrated by scipy. The isentrope leaves the Hugoniot
    (its energy at a given density is below e_H, by a third-order amount in eta): checked
    too, so that the test sees states off the Hugoniot."""
    mat = library_material(name)
    mat = dataclasses.replace(mat, strength=Strength())  # no deviator: L is isotropic anyway
    rate = 1e4
    n = 500
    t_c = -math.log(0.75) / (3 * rate)  # J = exp(-3 rate t) = 0.75
    t, _, _, _, p, e = drive_kernel(mat, -rate * np.eye(3), t_c, n, samples=30)
    rho = mat.density / np.exp(-3 * rate * t)
    e_ref = _isentrope_reference(mat, np.r_[mat.density, rho])[1:]
    p_ref = np.array([mg_pressure(mat, r, x) for r, x in zip(rho, e_ref)])
    assert np.max(np.abs(p - p_ref) / p_ref) < TOL
    assert np.max(np.abs(e - e_ref)) < TOL * e_ref[-1]
    # off the Hugoniot: e_H(rho) = p_H eta / (2 rho0)... the isentrope's energy is lower
    eta = 1 - mat.density / rho[-1]
    c0, s = mat.eos.c0, mat.eos.s
    e_h = 0.5 * (mat.density * c0 ** 2 * eta / (1 - s * eta) ** 2) * eta / mat.density
    assert e_ref[-1] < 0.9 * e_h
    # release along the same isentrope into tension (J from 0.75 to 1.02)
    model, _ = box_model(mat, size=(1e-3, 1e-3, 1e-3), h=0.5e-3)
    sim = Simulation(model, [], cq=0.0, cl=0.0)
    rho_end = []
    for L, tt in ((-rate * np.eye(3), t_c), (rate * np.eye(3), math.log(1.02 / 0.75) / (3 * rate))):
        dt = tt / n
        a = np.eye(3) - 0.5 * dt * L
        for _ in range(n):
            model.v[:] = np.linalg.solve(a, L @ model.x.T).T
            move(model.x, model.v, dt)
            sim._update_elements(dt)
        rho_end.append(model.elem_mass[0] / model.vol[0])
    e_ref = _isentrope_reference(mat, np.array([mat.density, rho_end[0], rho_end[1]]))
    assert model.energy[0] == pytest.approx(e_ref[2], rel=TOL, abs=TOL * e_ref[1])
    p_ref = mg_pressure(mat, rho_end[1], e_ref[2])
    assert p_ref < 0.0  # in tension: the linear continuation of the Hugoniot
    assert model.pressure[0] == pytest.approx(p_ref, rel=TOL)
