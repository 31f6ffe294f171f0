"""The hex kernel's vector path (hex8_block.py, full blocks of intact hexes of one material)
against its scalar path (hex8._hex_element, one hex at a time): the same formulas, the same
numbers to round-off. Mixed materials with a boundary inside a block, damaged and fractured
hexes, a partial block, both hourglass forms, a random but physical state (deviators near
the copper's yield surface, plastic strain, heat, compression and tension, hourglass noise on
a distorted mesh)."""

import numba
import numpy as np
import pytest

from impactsim.materials import params as P
from impactsim.model import DAMAGED, FRACTURED
from impactsim.solver import hex8 as H
from impactsim.solver.build import build_model
from impactsim.solver.loop import Simulation
from impactsim.solver.nodal import move
from tests.unit.test_hex8 import _distorted_mesh, _hex_case
from tests.unit.test_element_paths import COPPER


@numba.njit
def _scalar_update(x, v, conn, elem_mat, status, sdev, pressure, q, eps_p, eps_rate,
                   temperature, hard, thermal, energy, vol, elem_mass, hg, hg_visc, hg_stiff,
                   mat_params, dt, cq, cl, rows, force):
    dt_min, worst, qwork, hgwork = np.inf, -1, 0.0, 0.0
    w = np.empty(H.SCRATCH)
    for e in range(conn.shape[0]):
        dte, qw, inv, hw = H._hex_element(e, x, v, conn, elem_mat, status, sdev, pressure, q,
                                          eps_p, eps_rate, temperature, hard, thermal, energy,
                                          vol, elem_mass, hg, hg_visc, hg_stiff, mat_params,
                                          0.5 * dt, dt, cq, cl, rows, force, w)
        qwork += qw
        hgwork += hw
        if dte < dt_min:
            dt_min, worst = dte, e
    return dt_min, worst, qwork, hgwork


def _model(seed=3):
    pts, hexes = _distorted_mesh(h=0.125, amp=0.2, seed=seed)
    hexes = hexes[:-5]  # a partial block at the end
    pts = pts * 1e-3
    model = build_model(_hex_case(COPPER, "viscous", 0.1, size=(1e-3,) * 3, h=0.125e-3),
                        [(pts, hexes)])
    blk = model.blocks[0]
    ne = blk.n_elem
    assert ne % H.B != 0
    row = model.mat_params[0].copy()
    row[[P.STRENGTH, P.JC_A, P.JC_B, P.JC_N, P.JC_C, P.JC_M, P.EPSDOT0, P.T_ROOM, P.T_MELT]] = (
        P.JOHNSON_COOK, 90e6, 292e6, 0.31, 0.025, 1.09, 1.0, 293.0, 1356.0)
    row[[P.EOS, P.C0, P.S, P.GAMMA0, P.TQ]] = (P.MIE_GRUNEISEN, 3940.0, 1.49, 2.02, 0.9)
    steel = row.copy()
    steel[[P.STRENGTH, P.EOS, P.RHO0, P.G, P.K]] = (P.ELASTIC, P.LINEAR, 7850.0, 77e9, 167e9)
    model.mat_params = np.vstack([row, steel])
    blk.elem_mat[7:H.B + 5] = 1  # a material boundary inside blocks 0 and 1
    blk.status[H.B + 9] = DAMAGED
    blk.status[ne - 9] = FRACTURED
    blk.hg_stiff[: ne // 2] = 0.05  # both forms, on some hexes both at once
    blk.hg_visc[ne // 3: ne // 2] = 0.0
    rng = np.random.default_rng(seed)
    grad = rng.normal(size=(3, 3)) * 2e4
    model.v[:] = (model.x - model.x.mean(axis=0)) @ grad.T + rng.normal(size=model.v.shape)
    blk.sdev[:] = rng.normal(size=(ne, 6)) * 40e6
    blk.eps_p[:] = rng.uniform(0.0, 0.3, ne) * (rng.uniform(size=ne) < 0.5)
    blk.temperature[:] = 293.0 + rng.uniform(0.0, 300.0, ne)
    blk.pressure[:] = rng.normal(size=ne) * 1e9
    blk.energy[:] = rng.uniform(0.0, 1e4, ne)
    blk.hg[: ne // 2] = rng.normal(size=(ne // 2, 12)) * 1e-3  # where the stiffness form is
    return model


def test_vector_and_scalar_paths_agree():
    model = _model()
    blk = model.blocks[0]
    sim = Simulation(model, [])
    # the state after __init__'s update at dt = 0, restored for both paths
    dt = 2e-9
    move(model.x, model.v, dt)
    names = ["sdev", "pressure", "q", "eps_p", "eps_rate", "temperature", "energy", "vol", "hg"]
    ep0 = blk.eps_p.copy()
    runner = sim.block_runners[0]
    ref = {k: getattr(blk, k).copy() for k in names}
    ref["hard"], ref["thermal"] = runner.hard.copy(), runner.thermal.copy()
    ref["force"] = np.zeros_like(model.force)
    m = model
    dt_min, worst, qwork, hgwork = _scalar_update(
        m.x, m.v, blk.conn, blk.elem_mat, blk.status, ref["sdev"], ref["pressure"], ref["q"],
        ref["eps_p"], ref["eps_rate"], ref["temperature"], ref["hard"], ref["thermal"],
        ref["energy"], ref["vol"], blk.elem_mass, ref["hg"], blk.hg_visc, blk.hg_stiff,
        m.mat_params, dt, sim.cq, sim.cl, blk.conn, ref["force"])
    hg0 = m.energy_terms["hourglass"]
    sim._update_elements(dt)
    yielding = blk.eps_p != ep0
    assert 10 < yielding.sum() < blk.n_elem // 2
    assert (blk.q > 0).any() and (blk.pressure < 0).any() and (blk.pressure > 0).any()
    for k in names:
        a, b = getattr(blk, k), ref[k]
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * np.abs(b).max(), err_msg=k)
    np.testing.assert_allclose(runner.hard, ref["hard"], rtol=1e-14)
    np.testing.assert_allclose(m.force, ref["force"], rtol=0,
                               atol=1e-11 * np.abs(ref["force"]).max())
    assert sim.dt_stable == pytest.approx(dt_min, rel=1e-13)
    assert sim.worst_element == -(1 + worst)
    assert m.energy_terms["hourglass"] - hg0 == pytest.approx(hgwork, rel=1e-10)
    assert runner.chunk_out[:, H.OUT_QWORK].sum() == pytest.approx(qwork, rel=1e-12)
