"""Node separation's refreshes in place (fracture/separation_refresh.py) against rebuilds: the
free faces (tets' and hex quads), live-corner counts, force rows and node-to-element indices
(the model's and a hex block's) after every release step equal those built afresh,
and a run gives the same bits either way (tets and hexes, one and two threads)."""

import numba
import numpy as np
import pytest

from impactsim.fracture.boundary import Boundary
from impactsim.fracture.hexes import HexBoundary
from impactsim.fracture.separation import SeparationPass
from impactsim.model import ERODED
from impactsim.solver.build import node_to_element
from impactsim.solver.scatter import force_rows
from tests.verification.test_node_separation import BAR, TEAR, _sim


def _node_sums(fr, conn, n_node):
    """For every node, the (part, corner) order in which its rows are summed: the rows of the
    node's corners grouped as take_node reads them (own row, then extra rows in order)."""
    part = np.repeat(np.arange(conn.shape[0]) // fr.part_size, conn.shape[1])
    rows = fr.rows.reshape(-1).astype(np.int64)
    node = conn.reshape(-1).astype(np.int64)
    out = {}
    for i in np.unique(node):
        seq = [i] + list(fr.extra_rows[fr.extra_ptr[i]:fr.extra_ptr[i + 1]])
        mine = rows[node == i]
        parts = part[node == i]
        # every corner of node i writes one of its rows; each row has one part
        assert set(mine) <= set(seq), i
        out[int(i)] = [sorted(set(parts[mine == r].tolist())) for r in seq if np.any(mine == r)]
    return out


@pytest.mark.parametrize("text,steps", [
    (BAR.format(fs=0.25, element="tet", speed=300, measure="mean"), 160),
    (TEAR, 60),
    # a spall strength it never reaches: the criteria run, and with them the hex block's
    # patch-pressure index, which must follow the releases too
    (BAR.format(fs=0.25, element="hex8", speed=300, measure="max").replace(
        "fracture_strain = 0.25", 'fracture_strain = 0.25, spall_strength = "50 GPa"'), 160)])
def test_refreshes_in_place_equal_rebuilds(text, steps):
    runs = []
    for incremental in (True, False):
        sim, model = _sim(text)
        sp = next(p for p in sim.fracture_passes if isinstance(p, SeparationPass))
        sp.incremental = incremental
        checked = 0
        hexes_indexed = 0
        for _ in range(steps):
            sim.step()
            if not (incremental and sp.sep.moved):
                continue
            checked += 1
            fs = sp.s
            if model.n_elem:
                fresh = Boundary.from_model(model)
                b = fs.boundary
                assert b.n == fresh.n
                for name in ("faces", "face_slot", "face_body"):  # the rows, in slot order
                    assert np.array_equal(getattr(b, name)[:b.n], getattr(fresh, name)[:b.n])
                assert np.array_equal(b.pos, fresh.pos)
                assert np.array_equal(fs.boundary.face_flag, fresh.face_flag)
                assert np.array_equal(fs.boundary.adj, fresh.adj)
                fr = force_rows(model.conn, model.n_node, sim.force_rows.part_size)
                assert _node_sums(sim.force_rows, model.conn, model.n_node) == \
                    _node_sums(fr, model.conn, model.n_node)
                assert sim.fext.shape[0] == sim.force_rows.n_rows
                ptr, n2e = node_to_element(model.conn, model.n_node)  # summation order
                assert np.array_equal(model.n2e_ptr, ptr) and np.array_equal(model.n2e, n2e)
            for hf in fs.hexes:  # the free quads and the patch pressure's index
                blk = hf.blk
                fresh = HexBoundary(blk.conn, blk.elem_body, blk.status != ERODED)
                b = hf.boundary
                assert b.n == fresh.n
                for name in ("faces", "face_slot", "face_body"):
                    assert np.array_equal(getattr(b, name)[:b.n], getattr(fresh, name)[:b.n])
                for name in ("pos", "face_flag", "adj", "alive", "conn"):
                    assert np.array_equal(getattr(b, name), getattr(fresh, name)), name
                if hf._n2e is not None:
                    assert hf._n2e[2] is blk.conn
                    ptr, n2e = node_to_element(blk.conn, model.n_node)
                    assert np.array_equal(hf._n2e[0], ptr) and np.array_equal(hf._n2e[1], n2e)
                    hexes_indexed += 1
            for r in sim.block_runners:
                fr = force_rows(r.block.conn, model.n_node, r.rows.part_size)
                assert _node_sums(r.rows, r.block.conn, model.n_node) == \
                    _node_sums(fr, r.block.conn, model.n_node)
                assert r.fext.shape[0] == r.rows.n_rows
            live = np.bincount(model.conn[model.status != ERODED].reshape(-1),
                               minlength=model.n_node)
            for blk in model.blocks:
                live += np.bincount(blk.conn[blk.status != ERODED].reshape(-1),
                                    minlength=model.n_node)
            assert np.array_equal(fs.node_live, live)
        runs.append((model.x.copy(), model.v.copy(), sp.sep.counts["new_nodes"], checked,
                     hexes_indexed))
    assert runs[0][3] >= 2 and runs[0][2] > 0
    if "hex8" in text:  # the patch pressure's index followed releases (spall patch mode)
        assert runs[0][4] >= 2
    assert np.array_equal(runs[0][0], runs[1][0]) and np.array_equal(runs[0][1], runs[1][1])


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two numba threads")
def test_rows_in_place_same_bits_on_two_threads():
    """The force rows updated in place keep one writer per row: two threads give the bits of
    one (the torn block, 60 steps)."""
    out = []
    for threads in (1, 2):
        sim, model = _sim(TEAR, threads=threads)
        from impactsim.solver import element

        old = element.PARALLEL_FORCE_NODES
        element.PARALLEL_FORCE_NODES = 0
        try:
            for _ in range(60):
                sim.step()
        finally:
            element.PARALLEL_FORCE_NODES = old
        out.append((model.x.copy(), model.v.copy()))
    numba.set_num_threads(1)
    assert np.array_equal(out[0][0], out[1][0]) and np.array_equal(out[0][1], out[1][1])
