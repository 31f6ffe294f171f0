"""Fracture kernels against hand calculations and invariants (ALGORITHMS.md 4.1-4.2)."""

import numpy as np
import pytest

from impactsim.case.schema import Failure, Fracture
from impactsim.fracture import make_fracture_passes
from impactsim.fracture.principal import max_principal, max_principal_stretch
from impactsim.fracture.removal import remove_elements
from impactsim.fracture.spall import SPALL_CELL, SPALL_LESSER, SPALL_PATCH
from impactsim.model import DAMAGED, ERODED, FRACTURED, INTACT
from impactsim.solver.loop import Simulation
from impactsim.solver.nodal import move
from tests.builders import box_model, material


def test_max_principal_matches_numpy():
    rng = np.random.default_rng(1)
    for _ in range(200):
        a = rng.normal(size=(3, 3)) * 10.0 ** rng.integers(-3, 9)
        a = a + a.T
        got = max_principal(a[0, 0], a[1, 1], a[2, 2], a[0, 1], a[1, 2], a[2, 0])
        assert got == pytest.approx(np.linalg.eigvalsh(a)[-1], rel=1e-9, abs=1e-9 * abs(a).max())
    assert max_principal(-3.0, -3.0, -3.0, 0.0, 0.0, 0.0) == pytest.approx(-3.0)


def test_max_principal_stretch_matches_numpy():
    rng = np.random.default_rng(2)
    x0 = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    for _ in range(50):
        f = np.eye(3) + 0.3 * rng.normal(size=(3, 3))
        x = x0 @ f.T
        got = max_principal_stretch(x, x0, 0, 1, 2, 3)
        assert got == pytest.approx(np.sqrt(np.linalg.eigvalsh(f.T @ f)[-1]), rel=1e-9)


def _one_step(model, grad, status, dt=1e-8):
    model.status[:] = status
    sim = Simulation(model, [])
    model.v[:] = (model.x - model.x.mean(axis=0)) @ np.asarray(grad).T
    move(model.x, model.v, dt)
    sim._update_elements(dt)


def test_damaged_element_carries_no_tension():
    """Stretched: an intact cell goes into tension, a damaged cell has p >= 0 and no deviator."""
    grad = np.diag([3e3, 1e3, -5e2])
    model, _ = box_model(material(), h=0.5)
    _one_step(model, grad, INTACT)
    assert model.pressure.min() < -1e6  # the control: intact cells do carry tension
    model, _ = box_model(material(), h=0.5)
    _one_step(model, grad, DAMAGED)
    assert np.all(model.pressure >= 0.0)
    assert np.all(model.sdev == 0.0)


def test_damaged_element_keeps_bulk_compression_fractured_none():
    grad = -1e3 * np.eye(3)
    model, _ = box_model(material(), h=0.5)
    _one_step(model, grad, DAMAGED)
    assert model.pressure.min() > 1e6
    model, _ = box_model(material(), h=0.5)
    _one_step(model, grad, FRACTURED)
    assert np.all(model.pressure == 0.0)
    assert np.all(model.sdev == 0.0)


def _fracture_model(failure, **frac):
    mat = material(name="m", failure=failure)
    model, case = box_model(mat, h=0.5)
    case.fracture = Fracture(**frac)
    passes = make_fracture_passes(case, model)
    return model, passes


def test_spall_then_loosening_thresholds():
    """sigma_1 of s - p_patch I > sigma* marks DAMAGED (only intact cells), with the pressure
    averaged over the patch of cells around the element's nodes (criteria.patch_fields);
    chi = 1 - V0/V > chi* FRACTURED."""
    model, passes = _fracture_model(Failure(spall_strength=1e9, loosening=0.03))
    frac = passes[-1]
    frac.s.spall_mode = SPALL_PATCH  # [fracture] spall_pressure = "patch"
    n = model.n_elem
    model.pressure[:] = 0.0
    model.sdev[:] = 0.0
    model.sdev[0, 3] = 1.1e9  # pure shear 1.1 GPa: sigma_1 = 1.1 GPa > 1 GPa
    model.sdev[1, 3] = 0.9e9
    frac.run(model, 1e-9)
    assert model.status[0] == DAMAGED
    assert np.all(model.status[1:] == INTACT)
    # one cell in tension 1.2 GPa among unloaded neighbours: a checkerboard mode, not a tensile
    # field, and its patch mean is far below the spall strength
    model.pressure[2] = -1.2e9
    frac.run(model, 1e-9)
    assert model.status[2] == INTACT
    # a tensile field of 1.2 GPa: every cell spalls
    model.pressure[:] = -1.2e9
    frac.run(model, 1e-9)
    assert np.all(model.status == DAMAGED)
    model.pressure[:] = 0.0
    # loosening on the cell's own volume: chi just below and above 0.03
    model.vol[0] = model.vol0[0] / (1 - 0.029)
    model.vol[2] = model.vol0[2] / (1 - 0.031)
    frac.run(model, 1e-9)
    assert model.status[0] == DAMAGED and model.status[2] in (FRACTURED, ERODED)
    assert n == model.n_elem


def test_cell_spall_reads_the_element_s_own_pressure():
    """spall_pressure = "cell" ([D19]): one cell in tension 1.2 GPa among unloaded neighbours
    spalls, its neighbours do not; under the default "lesser" it does not (its patch is not
    in that tension)."""
    model, passes = _fracture_model(Failure(spall_strength=1e9, loosening=0.03))
    frac = passes[-1]
    assert frac.s.spall_mode == SPALL_LESSER  # the default
    model.pressure[:] = 0.0
    model.sdev[:] = 0.0
    model.pressure[2] = -1.2e9
    frac.run(model, 1e-9)
    assert np.count_nonzero(model.status == DAMAGED) == 0
    frac.s.spall_mode = SPALL_CELL
    model.pressure[:] = 0.0
    model.sdev[:] = 0.0
    model.pressure[2] = -1.2e9
    frac.run(model, 1e-9)
    assert model.status[2] == DAMAGED
    assert np.count_nonzero(model.status == DAMAGED) == 1


def test_molten_surface_cell_becomes_particles():
    """A cell at the melt temperature (or strained past MAX_PLASTIC_STRAIN) on the surface
    leaves the mesh as particles with its mass; one inside stays until it is exposed."""
    from impactsim.case.schema import Strength
    from impactsim.fracture import criteria as C

    mat = material(name="m", failure=Failure(spall_strength=1e12),
                   strength=Strength(model="johnson-cook", A=1e8, B=1e8, n=0.3, C=0.0, m=1.0,
                                     melt_temperature=1000.0, room_temperature=293.0))
    model, case = box_model(mat, h=0.5)
    case.fracture = Fracture()
    passes = make_fracture_passes(case, model)
    frac = passes[-1]
    m0 = model.mass.sum()
    model.temperature[0] = 1000.0
    model.eps_p[1] = C.MAX_PLASTIC_STRAIN * 1.01
    frac.run(model, 1e-9)
    assert model.status[0] == ERODED and model.status[1] == ERODED
    assert np.all(model.status[2:] != ERODED)
    s = frac.summary(model)
    assert s["fracture"]["molten_or_runaway_strain"] == 2 and s["particles"] == 2
    assert s["mass_final"] == pytest.approx(m0, rel=1e-14)


def _random_removal(n_per, seed):
    model, _ = box_model(material(), h=0.25)
    rng = np.random.default_rng(seed)
    model.v[:] = rng.normal(size=model.v.shape) * 100.0
    model.energy[:] = rng.uniform(0, 1e4, model.n_elem)
    m0 = model.mass.sum()
    p0 = model.mass @ model.v
    ke0 = 0.5 * np.sum(model.mass[:, None] * model.v ** 2)
    ie0 = np.sum(model.elem_mass * model.energy)
    node_live = np.bincount(model.conn.ravel(), minlength=model.n_node).astype(np.int32)
    cap = model.n_elem * n_per
    px, pv = np.zeros((cap, 3)), np.zeros((cap, 3))
    pm, pr, pe = np.zeros(cap), np.zeros(cap), np.zeros(cap)
    pb = np.zeros(cap, np.int32)
    ids = rng.permutation(model.n_elem)[: int(0.8 * model.n_elem)].astype(np.int64)
    conv = rng.random(ids.size) < 0.4
    n_p, e_out, n_er, n_conv = remove_elements(ids, conv, model.conn, model.status,
                                               model.elem_mass, model.energy, model.elem_body,
                                               model.x, model.v, model.mass, node_live, n_per,
                                               px, pv, pm, pr, pe, pb, 0)
    return dict(model=model, n_p=n_p, e_out=e_out, n_er=n_er, n_conv=n_conv, m0=m0, p0=p0,
                ke0=ke0, ie0=ie0, pm=pm, pv=pv, pe=pe, pr=pr, node_live=node_live, ids=ids)


@pytest.mark.parametrize("n_per", [1, 4, 6])
def test_removal_conserves_mass_momentum_energy(n_per):
    r = _random_removal(n_per, seed=n_per)
    m, n = r["model"], r["n_p"]
    assert r["n_er"] + r["n_conv"] == r["ids"].size
    assert n == r["n_conv"] * n_per
    mass = m.mass.sum() + r["pm"][:n].sum()
    assert mass == pytest.approx(r["m0"], rel=1e-14)
    mom = m.mass @ m.v + r["pm"][:n] @ r["pv"][:n]
    assert np.allclose(mom, r["p0"], rtol=0, atol=1e-12 * np.abs(r["p0"]).max() * 1e3)
    live = m.status != ERODED
    ke = 0.5 * np.sum(m.mass[:, None] * m.v ** 2) + 0.5 * np.sum(r["pm"][:n, None]
                                                                 * r["pv"][:n] ** 2)
    ie = np.sum(m.elem_mass[live] * m.energy[live]) + r["pe"][:n].sum()
    total0 = r["ke0"] + r["ie0"]
    assert ke + ie + r["e_out"] == pytest.approx(total0, rel=1e-12)
    assert r["e_out"] >= 0.0
    # orphaned nodes carry nothing; nodes of live elements keep at least their live share
    orphan = r["node_live"] == 0
    assert np.all(m.mass[orphan] == 0.0)
    assert np.all(m.mass >= 0.0)
    share = np.zeros(m.n_node)
    np.add.at(share, m.conn[live].ravel(), np.repeat(m.elem_mass[live] / 4, 4))
    assert np.all(m.mass[~orphan] >= share[~orphan] * (1 - 1e-12))
    assert np.all(r["pr"][:n] > 0.0)


def test_particle_sits_in_its_cell_with_the_inscribed_radius():
    model, _ = box_model(material(), h=0.5)
    node_live = np.bincount(model.conn.ravel(), minlength=model.n_node).astype(np.int32)
    px, pv = np.zeros((4, 3)), np.zeros((4, 3))
    pm, pr, pe, pb = np.zeros(4), np.zeros(4), np.zeros(4), np.zeros(4, np.int32)
    model.v[:] = (1.0, 2.0, 3.0)
    e = 0
    pts = model.x[model.conn[e]]
    remove_elements(np.array([e]), np.array([True]), model.conn, model.status, model.elem_mass,
                    model.energy, model.elem_body, model.x, model.v, model.mass, node_live, 1,
                    px, pv, pm, pr, pe, pb, 0)
    assert np.allclose(px[0], pts.mean(axis=0))
    assert np.allclose(pv[0], (1.0, 2.0, 3.0))
    areas = sum(0.5 * np.linalg.norm(np.cross(pts[b] - pts[a], pts[c] - pts[a]))
                for a, b, c in [(1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1)])
    assert pr[0] == pytest.approx(3 * model.vol0[e] / areas)
    assert pm[0] == pytest.approx(model.elem_mass[e])


def test_a_cell_left_without_face_neighbours_becomes_a_particle():
    """Every cell but one is fully fractured: they leave as particles, layer after layer from
    the surface; the intact cell they surrounded becomes a particle once its last face
    neighbour has left (a one-cell fragment), and not before."""
    model, passes = _fracture_model(Failure(spall_strength=1e12, loosening=0.03))
    frac = passes[-1]
    conn = model.conn
    shared = [sum(len(set(conn[e]) & set(conn[f])) == 3 for f in range(model.n_elem))
              for e in range(model.n_elem)]
    e = int(np.argmax(shared))  # the cell with the most face neighbours
    model.status[:] = FRACTURED
    model.status[e] = INTACT
    model.sdev[:] = 0.0
    model.pressure[:] = 0.0
    for _ in range(model.n_elem):
        before = model.status.copy()
        frac.run(model, 1e-9)
        if model.status[e] == ERODED:
            break
        assert np.any(model.status != before), "no progress"
    assert model.status[e] == ERODED
    assert np.all(before[np.arange(model.n_elem) != e] == ERODED)  # it went last
    s = frac.summary(model)
    assert s["particles"] == model.n_elem
    assert s["mass_final"] == pytest.approx(s["mass_initial"], rel=1e-14)


def test_fractured_elements_set_no_time_step_limit():
    """A fractured cell carries no stress and adds no force, so it sets no stable step: the
    cells around a node pushed deep into its neighbours are by far the smallest, and made
    fractured they leave the stable step where removing them would; a body of fractured
    cells only has none (the step is then bounded by its growth limit alone)."""
    steps = {}
    for status in (FRACTURED, ERODED):
        model, _ = box_model(material(), h=0.5)
        model.x[0] += 0.4  # a corner node pushed in: its cells are flat, the smallest by far
        sim = Simulation(model, [])
        around = np.nonzero((model.conn == 0).any(axis=1))[0]
        assert sim.worst_element in around
        smallest = sim.dt_stable
        model.status[around] = status
        sim._update_elements(0.0)
        steps[status] = sim.dt_stable
        assert sim.worst_element not in around
    assert steps[FRACTURED] == steps[ERODED] > 2.0 * smallest
    model.status[:] = FRACTURED
    sim._update_elements(0.0)
    assert sim.dt_stable == np.inf
    assert np.all(model.force == 0.0)


def test_hole_is_measured_on_the_plates_largest_piece():
    """A plug still in the plate's plane (a ring of cells around it eroded, the plug itself
    intact and flying with the plate) is not plate: the hole is the whole opening, the ring
    and the plug together, not the ring alone."""
    from impactsim.fracture.measures import HOLE_DEFINITION, body_measures

    model, _ = box_model(material(), size=(20e-3, 20e-3, 2e-3), h=1e-3)
    c = model.x[model.conn].mean(axis=1)
    r = np.hypot(c[:, 0], c[:, 1])
    model.status[(r >= 3e-3) & (r < 5e-3)] = ERODED
    info = body_measures(model)["box"]
    assert info["fragments"] == 2
    hole = info["hole"]
    assert hole["definition"] == HOLE_DEFINITION
    # the ring alone would be pi (5^2 - 3^2) = 50 mm^2; the opening is pi 5^2 = 79 mm^2
    assert np.pi * 4.5e-3 ** 2 < hole["area"] < np.pi * 5.5e-3 ** 2


def test_tuler_butcher_spall_integrates_the_tension_over_time():
    """spall_criterion = "tuler-butcher" (the default) with spall_time tau: a uniform tension
    of 2 sigma_0 (integrand sigma_1 / sigma_0 - 1 = 1) damages after tau, not one step before;
    1.5 sigma_0 after 2 tau; below sigma_0 nothing accumulates (each cell's own pressure).
    "instant" damages at once."""
    tau, dt = 0.2e-6, 1e-9
    model, passes = _fracture_model(Failure(spall_strength=1e9, loosening=0.03, spall_time=tau),
                                    spall_pressure="cell")
    frac = passes[-1]
    assert Fracture().spall_criterion == "tuler-butcher" and frac.s.spall_integrate
    model.sdev[:] = 0.0
    model.pressure[:] = -2e9
    model.pressure[0] = -1.5e9
    model.pressure[1] = -0.99e9
    steps = round(tau / dt)
    for _ in range(steps - 1):
        frac.run(model, dt)
    assert np.count_nonzero(model.status == DAMAGED) == 0
    frac.run(model, dt)
    frac.run(model, dt)  # tau reached (within the rounding of the sum)
    damaged = model.status == DAMAGED
    assert damaged[2:].all() and not damaged[:2].any()
    for _ in range(steps + 2):
        frac.run(model, dt)
    assert model.status[0] == DAMAGED and model.status[1] == INTACT
    assert frac.s.spall_k[1] == 0.0
    # the same material under the instantaneous criterion of [D19]
    model, passes = _fracture_model(Failure(spall_strength=1e9, loosening=0.03, spall_time=tau),
                                    spall_criterion="instant")
    frac = passes[-1]
    model.sdev[:] = 0.0
    model.pressure[:] = -1.01e9
    frac.run(model, dt)
    assert np.all(model.status == DAMAGED)
