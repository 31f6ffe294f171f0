"""Flyer-plate impacts in uniaxial strain: Hugoniot states of Mie-Grüneisen materials.

Columns of hydrodynamic material (Mie-Grüneisen EOS with a linear U_s-u_p Hugoniot, a yield
stress of 1 MPa so the deviator is negligible next to pressures of 10-20 GPa), every node held
in x and y (uniaxial strain). The Rankine-Hugoniot jump conditions across a steady shock
(e.g. Meyers, Dynamic Behavior of Materials, 1994, sec. 4.2; Forbes, Shock Wave Compression of
Condensed Matter, 2012, ch. 3) with the particle velocity jump u_p give

    U_s = c0 + s u_p,   p = rho0 U_s u_p,   rho = rho0 U_s / (U_s - u_p),   e - e0 = u_p^2 / 2.

Symmetric impact: two identical plates closing at V meet at rest in their centre-of-mass frame;
each takes u_p = V/2. A plate hitting a rigid wall at v = V/2 is the same problem (the wall is
the plane of symmetry), so it is run that way: u_p = v, p = rho0 (c0 + s v) v.

Asymmetric impact (copper flyer onto an aluminium target, two bodies, node-face contact):
impedance matching (Meyers sec. 4.4): the interface velocity u solves
p_Cu(V - u) = p_Al(u) with p_X(u_p) = rho0_X (c0_X + s_X u_p) u_p; both shocks carry that
pressure. Solved with scipy.optimize.brentq (u = 555.6 m/s, p = 9.39 GPa at V = 800 m/s). The
target is meshed at half the flyer's size, 2 x 2 cells across, so the contact surfaces do not
match (a node of one body on an edge, not only on a corner, of the other's faces). Either way
both columns have the same cross-section, so the nodes on their sides lie on the boundary edges
of the faces they hit: a node pushed sideways by a nanometre misses the face.

Shock fronts are where the particle velocity crosses the middle of its jump; speeds come from
front positions at two times (start-up cancels). In the lab frame the target's shock leaves the
initial interface L_TARGET at U_s (the aluminium ahead of it is at rest): at time t it is at
L_TARGET - U_s t, U_s t - u t below the interface L_TARGET - u t; the copper's shock is at
L_TARGET + (U_s,Cu - V) t. Plateau values are taken over the shocked material between the
front and the interface, 5 H (2.5 mm) from each (the node-face contact leaves a disturbed
band a few cells wide at the interface, which is not what is tested here): pressure and energy
as medians over elements; the particle velocity as the momentum of the target's nodes there over their
mass. That is the u_p of the jump conditions (the velocity of all the shocked material) and,
unlike a median, it sees a line of nodes left behind: with a 1 MPa yield stress a vertical line
of nodes sliding past its neighbours meets almost no resistance in these columns, so a node
line that missed the flyer at the interface keeps lagging through the whole target.

The asymmetric run also checks what the scene assumes: no node inside the other body
(the contact's penetration measure) and every node still on its initial x and y (held). This
needs contact impulses that leave prescribed velocity components alone (the boundary-conditions
pass runs before contact; impactsim.contact.impulse): with impulses
along the slightly tilted face normals, held nodes moved 22 um sideways, target nodes on the
edges of the flyer's faces missed them and ended 185 um inside the flyer, and a node line that
missed lagged at 123 m/s (momentum over mass 524 m/s, energy 165 kJ/kg).

Measured at t = 2.965 us (H/2 target, C_cfl = 0.5): penetration 0 and x-y shift 0 at both
snapshots; target momentum over mass -555.4 m/s (impedance match 555.6), pressure 9.393 GPa
(9.394), energy 154.9 kJ/kg (154.3); KE + IE + dissipated within 0.08 % of its start (the
symmetric wall run: 0.36 %).
"""

import numpy as np
import pytest
from scipy.optimize import brentq

from impactsim.case import load_case_text
from impactsim.case.schema import Constraint, NodeSelector
from impactsim.mesh import mesh_body
from impactsim.solver.build import build_model
from impactsim.solver.loop import Simulation
from impactsim.solver.pipeline import build_passes

H = 0.5e-3  # [m] mesh size; columns are one cell across
CU = {"rho": 8930.0, "c0": 3940.0, "s": 1.489}  # ofhc-copper of the library
AL = {"rho": 2785.0, "c0": 5328.0, "s": 1.338}  # al-2024-t3 of the library


def _material(name, library):
    return f"""
[[material]]
name = "{name}"
library = "{library}"
strength = {{ model = "ideal-plastic", yield_stress = "1 MPa" }}
failure = "none"
"""


def _body(name, material, z_lo, length, velocity, h=H):
    return f"""
[[body]]
name = "{name}"
material = "{material}"
shape = "box"
size = [{H}, {H}, {length}]
position = [0, 0, {z_lo + length / 2}]
mesh_size = {h}
mesher = "structured"
velocity = [0, 0, {velocity}]
"""


def _confine(case):
    for body in case.bodies:  # uniaxial strain: x and y held, z free
        body.constraints = [Constraint(NodeSelector("all"), (0.0, 0.0, None))]
    return case


def _simulate(case, times):
    model = build_model(case, [mesh_body(b, use_cache=False) for b in case.bodies])
    sim = Simulation(model, build_passes(case, model), cfl=0.5)
    shots = []
    for t in times:
        while model.time < t:
            sim.step(t - model.time)
        shot = _profile(model)
        history = {}
        for p in sim.velocity_passes:
            history.update(p.history(model))
        shot["penetration"] = history.get("max_penetration", 0.0)  # [m], contact's own meter
        shots.append(shot)
    return model, shots


def _profile(model):
    """Mean vz per z level (sorted by initial z) and element centroids, pressure, energy, rho;
    per node: current z, vz, mass, body and the largest x-y distance from the initial place."""
    z0 = np.round(model.x0[:, 2], 9)
    levels = np.unique(z0)
    z = np.array([model.x[z0 == lv, 2].mean() for lv in levels])
    vz = np.array([model.v[z0 == lv, 2].mean() for lv in levels])
    zc = model.x[model.conn, 2].mean(axis=1)
    rho = model.elem_mass / model.vol
    return {"time": model.time, "z": z, "vz": vz, "zc": zc, "p": model.pressure.copy(),
            "e": model.energy.copy(), "rho": rho, "body": model.elem_body.copy(),
            "z_levels": levels, "node_z": model.x[:, 2].copy(), "node_vz": model.v[:, 2].copy(),
            "node_mass": model.mass.copy(), "node_body": model.node_body.copy(),
            "xy_shift": float(np.abs(model.x[:, :2] - model.x0[:, :2]).max())}


def _front(z, vz, level):
    """z of the first crossing of `level` by vz, walking from index 0 (where vz >= level) up."""
    i = np.nonzero(vz < level)[0]
    i = i[i > 0][0]
    return z[i - 1] + (level - vz[i - 1]) / (vz[i] - vz[i - 1]) * (z[i] - z[i - 1])


def _hugoniot(m, up):
    us = m["c0"] + m["s"] * up
    return us, m["rho"] * us * up


# --- symmetric: a copper plate on a rigid wall ------------------------------------------------
V_WALL = 500.0  # [m/s] wall impact = symmetric impact at 1 km/s
LENGTH = 0.03


@pytest.fixture(scope="module")
def symmetric():
    case = _confine(load_case_text(
        "[run]\nend_time = 1.0\n" + _material("cu", "ofhc-copper")
        + _body("flyer", "cu", 1e-7, LENGTH, -V_WALL) + "[[wall]]\n"))
    us, _ = _hugoniot(CU, V_WALL)
    # the shock leaves the wall at us - v: snapshots with it at 8 mm and 18 mm
    return _simulate(case, [0.008 / (us - V_WALL), 0.018 / (us - V_WALL)])


def test_symmetric_impact_shock_speed(symmetric):
    _, (a, b) = symmetric
    us, _ = _hugoniot(CU, V_WALL)
    fa = _front(a["z"], a["vz"], -0.5 * V_WALL)
    fb = _front(b["z"], b["vz"], -0.5 * V_WALL)
    # in the lab frame the front leaves the wall at us - v (material ahead moves at -v)
    assert (fb - fa) / (b["time"] - a["time"]) == pytest.approx(us - V_WALL, rel=0.03)


def test_symmetric_impact_hugoniot_state(symmetric):
    _, (_, b) = symmetric
    us, p = _hugoniot(CU, V_WALL)
    front = _front(b["z"], b["vz"], -0.5 * V_WALL)
    shocked = (b["zc"] > 5 * H) & (b["zc"] < front - 5 * H)
    assert shocked.sum() > 50
    assert np.median(b["p"][shocked]) == pytest.approx(p, rel=0.03)
    assert np.median(b["rho"][shocked]) == pytest.approx(CU["rho"] * us / (us - V_WALL),
                                                         rel=0.01)
    # Rankine-Hugoniot energy jump: e = u_p^2 / 2 per unit mass
    assert np.median(b["e"][shocked]) == pytest.approx(0.5 * V_WALL**2, rel=0.05)
    behind = np.abs(b["vz"][(b["z"] > 5 * H) & (b["z"] < front - 5 * H)])
    assert np.median(behind) < 0.02 * V_WALL  # the shocked copper is at rest


# --- asymmetric: copper onto aluminium, node-face contact ------------------------------------
V_FLYER = 800.0  # [m/s]
L_FLYER, L_TARGET = 0.02, 0.03


def _interface_velocity():
    return brentq(lambda u: _hugoniot(CU, V_FLYER - u)[1] - _hugoniot(AL, u)[1], 0.0, V_FLYER)


def _asymmetric_bands(b):
    """(interface, target front, copper front) [m] at the time of snapshot b, lab frame (see the
    module docstring): the target's shock runs from L_TARGET into aluminium at rest at U_s."""
    u = _interface_velocity()
    us_al, _ = _hugoniot(AL, u)
    us_cu, _ = _hugoniot(CU, V_FLYER - u)
    t = b["time"]
    return L_TARGET - u * t, L_TARGET - us_al * t, L_TARGET + (us_cu - V_FLYER) * t


@pytest.fixture(scope="module")
def asymmetric():
    text = ("[run]\nend_time = 1.0\n[contact]\npasses = [\"node-face\"]\n"
            + _material("cu", "ofhc-copper") + _material("al", "al-2024-t3")
            + _body("target", "al", 0.0, L_TARGET, 0.0, h=H / 2)
            + _body("flyer", "cu", L_TARGET + 1e-7, L_FLYER, -V_FLYER))
    case = _confine(load_case_text(text))
    u = _interface_velocity()
    us_al, _ = _hugoniot(AL, u)
    # the target shock (leaving L_TARGET at us_al into aluminium at rest) 8 mm and 18 mm down
    return _simulate(case, [0.008 / us_al, 0.018 / us_al])


def test_contact_holds_the_interface_and_the_columns_stay_uniaxial(asymmetric):
    _, shots = asymmetric
    for s in shots:
        assert s["penetration"] < 1e-6  # [m], as the other contact verification scenes
        assert s["xy_shift"] < 1e-6 * H  # held in x and y: the scene is uniaxial strain


def test_impedance_match_pressure_on_both_sides(asymmetric):
    model, (_, b) = asymmetric
    u = _interface_velocity()
    _, p = _hugoniot(AL, u)
    assert p == pytest.approx(_hugoniot(CU, V_FLYER - u)[1], rel=1e-9)
    interface, target_front, cu_front = _asymmetric_bands(b)
    # the shocked region of each body, away from the fronts and the interface
    al = (b["body"] == 0) & (b["zc"] > target_front + 5 * H) & (b["zc"] < interface - 5 * H)
    cu = (b["body"] == 1) & (b["zc"] > interface + 3 * H) & (b["zc"] < cu_front - 3 * H)
    assert al.sum() > 50 and cu.sum() > 10
    assert np.median(b["p"][al]) == pytest.approx(p, rel=0.04)
    assert np.median(b["p"][cu]) == pytest.approx(p, rel=0.06)  # a short, noisier plateau


def test_impedance_match_particle_velocity_and_energy(asymmetric):
    """The target's particle velocity behind its shock: momentum over mass of the target nodes
    between the shock front and the interface (5 H from each), against -u; and the specific
    internal energy jump u^2 / 2 (median over the elements there)."""
    model, (_, b) = asymmetric
    u = _interface_velocity()
    interface, target_front, _ = _asymmetric_bands(b)
    z = b["node_z"]
    moving = (b["node_body"] == 0) & (z > target_front + 5 * H) & (z < interface - 5 * H)
    assert moving.sum() > 100
    mass = b["node_mass"][moving]
    assert (mass * b["node_vz"][moving]).sum() / mass.sum() == pytest.approx(-u, rel=0.03)
    al = (b["body"] == 0) & (b["zc"] > target_front + 5 * H) & (b["zc"] < interface - 5 * H)
    assert np.median(b["e"][al]) == pytest.approx(0.5 * u**2, rel=0.06)


def test_impedance_match_target_shock_speed(asymmetric):
    model, (a, b) = asymmetric
    u = _interface_velocity()
    us_al, _ = _hugoniot(AL, u)
    target = [(s["z"][s["z_levels"] <= L_TARGET + 1e-9],
               s["vz"][s["z_levels"] <= L_TARGET + 1e-9]) for s in (a, b)]
    # walk up the target from its free end: vz falls from 0 to -u across the shock
    fa = _front(*target[0], -0.5 * u)
    fb = _front(*target[1], -0.5 * u)
    assert (fa - fb) / (b["time"] - a["time"]) == pytest.approx(us_al, rel=0.03)
