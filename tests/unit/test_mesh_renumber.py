"""Renumbering: a permutation of nodes and elements that keeps the mesh and its volume."""

import numpy as np
import pytest

from impactsim.mesh.orient import signed_volumes
from impactsim.mesh.renumber import _spread_bits, morton_codes, renumber
from impactsim.mesh.structured import structured_box


def tet_set(points, tets):
    """The mesh as a set of tets, each a sorted tuple of its node coordinates."""
    return {tuple(sorted(map(tuple, points[t]))) for t in tets}


def test_bit_spreading_interleaves():
    values = np.array([0, 1, 2, 3, 0x1FFFFF], dtype=np.uint64)
    np.testing.assert_array_equal(_spread_bits(values)[:4], [0, 1, 8, 9])
    assert int(_spread_bits(values)[4]) == int("001" * 21, 2)
    corners = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], dtype=float)
    codes = morton_codes(corners, np.zeros(3), np.ones(3))
    top = int("001" * 21, 2)
    assert [int(c) for c in codes] == [0, top, top << 1, top << 2, 2**63 - 1]


def test_renumber_is_a_volume_preserving_permutation():
    rng = np.random.default_rng(7)
    points, tets = structured_box((0.03, 0.02, 0.01), 0.004)
    node_perm = rng.permutation(len(points))
    shuffled_points = points[node_perm]
    inverse = np.argsort(node_perm)
    shuffled_tets = inverse[tets][rng.permutation(len(tets))]
    extra = np.vstack([shuffled_points, [[5.0, 5.0, 5.0]]])  # one unused node

    new_points, new_tets = renumber(extra, shuffled_tets)
    assert new_tets.dtype == np.int32 and new_points.flags.c_contiguous
    assert len(new_points) == len(points) and len(new_tets) == len(tets)
    # the same nodes and the same tets, only listed in another order
    assert sorted(map(tuple, new_points)) == sorted(map(tuple, points))
    assert tet_set(new_points, new_tets) == tet_set(points, tets)
    new_volumes = signed_volumes(new_points, new_tets)
    assert np.sort(new_volumes) == pytest.approx(np.sort(signed_volumes(points, tets)), rel=1e-14)
    assert new_volumes.min() > 0.0  # node order inside a tet kept: orientation kept
    # nodes and elements now follow the Z-curve
    lo, hi = new_points.min(axis=0), new_points.max(axis=0)
    node_codes = morton_codes(new_points, lo, hi)
    assert np.all(node_codes[1:] >= node_codes[:-1])
    elem_codes = morton_codes(new_points[new_tets].mean(axis=1), lo, hi)
    assert np.all(elem_codes[1:] >= elem_codes[:-1])


def test_renumber_improves_locality():
    rng = np.random.default_rng(1)
    points, tets = structured_box((0.05, 0.05, 0.05), 0.005)
    node_perm = rng.permutation(len(points))
    scrambled = np.argsort(node_perm)[tets]
    spread_before = np.ptp(scrambled, axis=1).mean()
    _, new_tets = renumber(points[node_perm], scrambled)
    assert np.ptp(new_tets, axis=1).mean() < 0.2 * spread_before
