"""Removed hexes pass the forces left on their orphaned corners to remaining corners
(fracture/hexes.py, ``pass_orphan_forces``), so that the momentum of the mesh is kept when a
cluster of hexes leaves at once and some of them keep no corner of their own (the coarse hex
sphere-plate scene lost 1e-7 kg m/s that way when only directly attached hexes passed them)."""

import numpy as np

from impactsim.fracture.hexes import pass_orphan_forces


def _chain(n_hex):
    """n_hex unit hexes in a row along x: hex i has the nodes of planes x = i and x = i + 1."""
    def plane(i):
        return [4 * i + 0, 4 * i + 1, 4 * i + 2, 4 * i + 3]
    return np.array([plane(i) + plane(i + 1) for i in range(n_hex)], dtype=np.int64)


def test_a_removed_cluster_passes_every_orphan_force_to_the_live_mesh():
    conn = _chain(4)  # hex 0 stays, hexes 1..3 leave: only hex 1 keeps corners (plane x = 1)
    n_node = 4 * 5
    rng = np.random.default_rng(3)
    force = rng.normal(size=(n_node, 3))
    node_live = np.zeros(n_node, np.int64)
    node_live[:8] = 1  # the nodes of the hex that stays
    total = force.sum(axis=0)
    far = force[:4].copy()  # plane x = 0: no corner of a removed hex
    ids = np.array([3, 1, 2], dtype=np.int64)  # any order: hexes 3 and 2 reach hex 1 via 2
    passed = pass_orphan_forces(ids, conn, node_live, force)
    assert passed == 12  # the orphans of planes x = 2, 3 and 4
    assert np.all(force[8:] == 0.0)
    assert np.allclose(force[:8].sum(axis=0), total, rtol=0.0, atol=1e-12)
    assert np.all(force[:4] == far)  # taken by hex 1's remaining corners (plane x = 1) only


def test_a_cluster_without_any_live_corner_keeps_its_forces():
    conn = _chain(2)
    force = np.ones((12, 3))
    node_live = np.zeros(12, np.int64)
    assert pass_orphan_forces(np.array([0, 1], dtype=np.int64), conn, node_live, force) == 0
    assert np.all(force == 1.0)
