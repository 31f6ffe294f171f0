"""The element kernel's vector path (blocks of intact elements of one material) against its scalar
path (one element at a time, every branch): the same formulas, so the same numbers to round-off.

The model mixes what decides the path: two materials whose boundary falls inside a block
(Johnson-Cook copper with Mie-Grueneisen, elastic steel with the linear EOS), a damaged, a
fractured and eroded elements (the masked passes of `element._block`), and a partial block at
the end of the mesh (`element._tail_block`). Its state is random but
physical: deviators near the copper's yield surface, plastic strain, heated elements,
compression and tension, so the radial return, the yield-floor cache, the bulk viscosity and
both Hugoniot branches all run.
"""

import numba
import numpy as np
import pytest

from impactsim.materials import params as P
from impactsim.model import DAMAGED, ERODED, FRACTURED
from impactsim.solver import element as E
from impactsim.solver.loop import Simulation
from tests.builders import box_model, material

COPPER = material(name="cu", density=8930.0, shear_modulus=46e9, bulk_modulus=137e9,
                  specific_heat=383.0)


@numba.njit
def _scalar_update(x, v, conn, elem_mat, status, sdev, pressure, q, eps_p, eps_rate, temperature,
                   hard, thermal, energy, vol, vol_eos, vol0, elem_mass, mat_params, jnode,
                   use_anp, dt, cq, cl, rows, force):
    """Every element through E._element_scalar, its forces added to rows `rows` of `force`;
    returns (min dt, its element, q work, inverted)."""
    dt_min, worst, qwork, inverted = np.inf, -1, 0.0, 0
    for e in range(conn.shape[0]):
        dte, qw, inv = E._element_scalar(e, x, v, conn, elem_mat, status, sdev, pressure, q,
                                         eps_p, eps_rate, temperature, hard, thermal, energy, vol,
                                         vol_eos, vol0, elem_mass, mat_params, jnode, use_anp,
                                         0.5 * dt, dt, cq, cl, rows, force)
        qwork += qw
        inverted += inv
        if dte < dt_min:
            dt_min, worst = dte, e
    return dt_min, worst, qwork, inverted


def _mixed_model(seed=3):
    model, _ = box_model(COPPER, size=(1e-3, 0.75e-3, 0.75e-3), h=0.25e-3)
    ne = model.n_elem
    assert ne % E.B != 0 and ne > 4 * E.B  # full blocks and a partial one
    row = model.mat_params[0].copy()
    row[[P.STRENGTH, P.JC_A, P.JC_B, P.JC_N, P.JC_C, P.JC_M, P.EPSDOT0, P.T_ROOM, P.T_MELT]] = (
        P.JOHNSON_COOK, 90e6, 292e6, 0.31, 0.025, 1.09, 1.0, 293.0, 1356.0)
    row[[P.EOS, P.C0, P.S, P.GAMMA0, P.TQ]] = (P.MIE_GRUNEISEN, 3940.0, 1.49, 2.02, 0.9)
    steel = row.copy()
    steel[[P.STRENGTH, P.EOS, P.RHO0, P.G, P.K]] = (P.ELASTIC, P.LINEAR, 7850.0, 77e9, 167e9)
    model.mat_params = np.vstack([row, steel])
    model.elem_mat[E.B + 7: 3 * E.B + 5] = 1  # boundaries inside blocks 1 and 3
    model.status[5] = DAMAGED
    model.status[4 * E.B + 3] = FRACTURED  # block 2 (steel) is all intact
    model.status[[5 * E.B + 1, 5 * E.B + 30, ne - 2]] = ERODED  # masked lanes, one in the tail
    rng = np.random.default_rng(seed)
    grad = rng.normal(size=(3, 3)) * 2e4  # [1/s]: a strain increment of ~1e-4 per step
    model.v[:] = (model.x - model.x.mean(axis=0)) @ grad.T + rng.normal(size=model.v.shape)
    model.sdev[:] = rng.normal(size=(ne, 6)) * 40e6
    model.eps_p[:] = rng.uniform(0.0, 0.3, ne) * (rng.uniform(size=ne) < 0.5)
    model.temperature[:] = 293.0 + rng.uniform(0.0, 300.0, ne)
    model.pressure[:] = rng.normal(size=ne) * 1e9
    model.energy[:] = rng.uniform(0.0, 1e4, ne)
    model.x += rng.normal(size=model.x.shape) * 1e-6  # distorted, not inverted
    return model


@pytest.mark.parametrize("element", ["tet4", "anp"])
def test_vector_and_scalar_paths_agree(element):
    model = _mixed_model()
    sim = Simulation(model, [], element=element)  # one update at dt = 0
    dt = 2e-9
    from impactsim.solver.nodal import move
    move(model.x, model.v, dt)
    if sim.use_anp:
        from impactsim.solver.nodal import element_volumes, nodal_volume_ratio
        element_volumes(model.x, model.conn, model.status, sim.vol_now)
        nodal_volume_ratio(sim.vol_now, model.vol0, model.status, model.n2e_ptr, model.n2e,
                           sim.jnode)
    names = ["sdev", "pressure", "q", "eps_p", "eps_rate", "temperature", "energy", "vol"]
    ep0 = model.eps_p.copy()
    ref = {k: getattr(model, k).copy() for k in names}
    state0 = {k: v.copy() for k, v in ref.items()}
    ref["hard"], ref["thermal"] = sim.hardening.copy(), sim.thermal.copy()
    ref["vol_eos"] = sim.vol_eos.copy() if sim.use_anp else ref["vol"]
    ref["force"] = np.zeros_like(model.force)
    m = model
    dt_min, worst, qwork, inverted = _scalar_update(
        m.x, m.v, m.conn, m.elem_mat, m.status, ref["sdev"], ref["pressure"], ref["q"],
        ref["eps_p"], ref["eps_rate"], ref["temperature"], ref["hard"], ref["thermal"],
        ref["energy"],
        ref["vol"], ref["vol_eos"], m.vol0, m.elem_mass, m.mat_params, sim.jnode, sim.use_anp,
        dt, sim.cq, sim.cl, m.conn, ref["force"])  # rows = conn: straight onto the nodes
    sim._update_elements(dt)
    yielding = m.eps_p != ep0
    assert 20 < yielding.sum() < m.n_elem // 2  # the return map ran, and not everywhere
    assert (m.q > 0).any() and (m.pressure < 0).any() and (m.pressure > 0).any()
    for k in names:
        a, b = getattr(m, k), ref[k]
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * np.abs(b).max(), err_msg=k)
    np.testing.assert_allclose(sim.hardening, ref["hard"], rtol=1e-14)
    np.testing.assert_allclose(sim.thermal, ref["thermal"], rtol=1e-14)
    np.testing.assert_allclose(m.force, ref["force"], rtol=0,
                               atol=1e-12 * np.abs(ref["force"]).max())
    assert sim.dt_stable == pytest.approx(dt_min, rel=1e-13)
    assert sim.worst_element == worst
    assert inverted == 0
    eroded = m.status == ERODED
    for k in names:  # an eroded element's state is left as it was, bit for bit
        assert np.array_equal(getattr(m, k)[eroded], state0[k][eroded]), k
    out = sim.chunk_out
    assert out[:, E.OUT_QWORK].sum() == pytest.approx(qwork, rel=1e-12)


def test_yield_caches_stay_current():
    """After plastic steps the kernel's cached hardening term and thermal factor of every element
    equal laws.hardening and laws.thermal_factor at its current plastic strain and temperature
    (the caches never go stale, so the skip below them never misses a return that was due),
    and their product is a lower bound of the yield stress at any rate."""
    from impactsim.materials.laws import flow_stress, hardening, thermal_factor

    model = _mixed_model(seed=5)
    ep0 = model.eps_p.copy()
    sim = Simulation(model, [])
    for _ in range(3):
        sim._update_elements(2e-9)
    mp = model.mat_params
    cu = np.nonzero(model.elem_mat == 0)[0]
    assert (model.eps_p[cu] > ep0[cu]).sum() > 20
    for e in cu:
        ep, temp = model.eps_p[e], model.temperature[e]
        hard = hardening.py_func(P.JOHNSON_COOK, mp, 0, ep)
        thermal = thermal_factor.py_func(P.JOHNSON_COOK, mp, 0, temp)
        assert sim.hardening[e] == pytest.approx(hard, rel=1e-14)
        assert sim.thermal[e] == pytest.approx(thermal, rel=1e-14)
        for rate in (0.0, 1.0, 1e3, 1e6):
            sy, _ = flow_stress.py_func(P.JOHNSON_COOK, mp, 0, ep, rate, temp)
            assert hard * thermal <= sy * (1 + 1e-14)


def test_inverted_element_is_counted_and_left_alone():
    """Inverted elements among intact ones: the kernel counts them, stores nothing for them and
    adds no force from them; their neighbours in the block are updated as the scalar path
    updates them."""
    model = _mixed_model(seed=7)
    model.status[:] = 0
    model.elem_mat[:] = 0
    sim = Simulation(model, [])
    e = 2 * E.B + 9
    a, b = model.conn[e, 0], model.conn[e, 1]
    model.x[[a, b]] = model.x[[b, a]]  # two corners swapped: negative volume
    names = ["sdev", "pressure", "q", "eps_p", "eps_rate", "temperature", "energy", "vol"]
    m = model
    ref = {k: getattr(m, k).copy() for k in names}
    ref["hard"], ref["thermal"] = sim.hardening.copy(), sim.thermal.copy()
    ref["force"] = np.zeros_like(m.force)
    before = {k: v.copy() for k, v in ref.items()}
    dt = 2e-9
    *_, inverted_ref = _scalar_update(
        m.x, m.v, m.conn, m.elem_mat, m.status, ref["sdev"], ref["pressure"], ref["q"],
        ref["eps_p"], ref["eps_rate"], ref["temperature"], ref["hard"], ref["thermal"],
        ref["energy"], ref["vol"], ref["vol"], m.vol0, m.elem_mass, m.mat_params, sim.jnode,
        False, dt, sim.cq, sim.cl, m.conn, ref["force"])
    fr = sim.force_rows
    E.element_update(m.x, m.v, m.conn, m.elem_mat, m.status, m.sdev, m.pressure, m.q, m.eps_p,
                     m.eps_rate, m.temperature, sim.hardening, sim.thermal, m.energy, m.vol,
                     m.vol, m.vol0, m.elem_mass, m.mat_params, sim.jnode, False, dt, sim.cq,
                     sim.cl, m.force, fr.rows, sim.fext, fr.extra_ptr, fr.extra_rows,
                     fr.part_size // E.CHUNK, sim.chunk_out, 1, True)
    # the swap inverts e and the other tets sharing both nodes
    assert inverted_ref >= 1 and sim.chunk_out[:, E.OUT_INVERTED].sum() == inverted_ref
    for k in names:
        assert np.array_equal(getattr(m, k)[e], before[k][e]), k
        np.testing.assert_allclose(getattr(m, k), ref[k], rtol=0,
                                   atol=1e-12 * np.abs(ref[k]).max(), err_msg=k)
    np.testing.assert_allclose(m.force, ref["force"], rtol=0,
                               atol=1e-12 * np.abs(ref["force"]).max())
