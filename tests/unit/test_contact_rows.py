"""Projected rounds over the contact rows (impactsim.contact.rows) on hand-built tables."""

import numpy as np
import pytest

from impactsim.contact.rows import row_partners, rows_round


def table(rows):
    """rows: [(nodes (4,), coefficients (4,), normal (3,), target, lam)] -> the table arrays."""
    idx = np.array([r[0] for r in rows], np.int64)
    coef = np.array([r[1] for r in rows], float)
    nrm = np.array([r[2] for r in rows], float)
    tgt = np.array([r[3] for r in rows], float)
    lam = np.array([r[4] for r in rows], float)
    return idx, coef, nrm, tgt, lam


def solve(rows, v, mass, rounds=1):
    idx, coef, nrm, tgt, lam = table(rows)
    diag = np.zeros(len(rows))
    partner = np.zeros(len(rows), np.int64)
    row_partners(idx, coef, nrm, mass, diag, partner)
    stamp = np.zeros(len(v), np.int64)
    out = [rows_round(idx, coef, nrm, tgt, lam, diag, partner, v, mass, stamp, k + 1)
           for k in range(rounds)]
    u = np.einsum("rk,rkd,rd->r", coef, v[idx], nrm)
    return partner, lam, u, out


def test_mirror_rows_are_solved_together_in_one_round():
    # node 0 (body A) falls on node 1 (body B): row 0 is node 0 on a face of B at vertex 1,
    # row 1 node 1 on a face of A at vertex 0 (nodes 2..5: the faces' other vertices, weight 0)
    v = np.zeros((6, 3))
    v[0, 2] = -1.0
    mass = np.ones(6)
    rows = [((0, 1, 2, 3), (1, -1, 0, 0), (0, 0, 1), 0.0, 0.0),
            ((1, 0, 4, 5), (1, -1, 0, 0), (0, 0, -1), 0.0, 0.0)]
    partner, lam, u, out = solve(rows, v, mass, rounds=2)
    assert list(partner) == [1, 0]
    np.testing.assert_allclose(u, 0.0, atol=1e-15)  # equal normal velocities
    assert np.all(lam >= 0.0) and lam.sum() == 0.5  # the impulse of one row, not two
    np.testing.assert_allclose(v[:2, 2], -0.5)
    assert out[1][0] == 0  # nothing left for a second round


def test_rows_with_opposite_demands_are_not_paired():
    # the second row wants node 1 above node 0: a pair of them has no compressive solution but
    # two huge cancelling impulses, so each is updated alone
    v = np.zeros((6, 3))
    mass = np.ones(6)
    rows = [((0, 1, 2, 3), (1, -1, 0, 0), (0, 0, 1), 0.0, 0.0),
            ((1, 0, 4, 5), (1, -1, 0, 0), (0, 0, 1), 0.0, 0.0)]
    partner, *_ = solve(rows, v, mass)
    assert list(partner) == [-1, -1]


def test_a_row_pushed_apart_gives_its_impulse_back_but_never_pulls():
    # row 0 holds 0.25 N s while its nodes separate at 2 m/s: taken back to 0, not beyond
    v = np.zeros((6, 3))
    v[0, 2] = 2.0
    mass = np.ones(6)
    rows = [((0, 1, 2, 3), (1, -1, 0, 0), (0, 0, 1), 0.0, 0.25)]
    _, lam, u, out = solve(rows, v, mass)
    assert lam[0] == 0.0 and out[0][1] == -0.25
    np.testing.assert_allclose(v[0, 2] + v[1, 2], 2.0)  # momentum
    assert u[0] == 2.0 - 0.5  # still opening: the rest would need a pull


def test_a_round_reports_the_decrease_of_its_objective():
    """rows_round's last value is the change of kinetic energy minus sum t_r lam_r over the
    round (what the projection's convergence test reads): equal to the change computed from the
    velocities and impulses, and never positive, round after round."""
    rng = np.random.default_rng(3)
    rows = []
    for r in range(12):
        nodes = rng.choice(8, 4, replace=False)
        w = rng.dirichlet(np.ones(3))
        n = rng.normal(size=3)
        rows.append((tuple(nodes), (1.0, -w[0], -w[1], -w[2]), tuple(n / np.linalg.norm(n)),
                     rng.uniform(-0.1, 0.1), rng.uniform(0.0, 0.2)))
    idx, coef, nrm, tgt, lam = table(rows)
    mass = rng.uniform(0.5, 2.0, 8)
    v = rng.normal(size=(8, 3))
    diag = np.zeros(len(rows))
    partner = np.zeros(len(rows), np.int64)
    row_partners(idx, coef, nrm, mass, diag, partner)
    stamp = np.zeros(8, np.int64)

    def objective():
        return 0.5 * (mass[:, None] * v ** 2).sum() - (tgt * lam).sum()

    for k in range(5):
        before = objective()
        dphi = rows_round(idx, coef, nrm, tgt, lam, diag, partner, v, mass, stamp, k + 1)[3]
        assert dphi == pytest.approx(objective() - before, rel=1e-9, abs=1e-12)
        assert dphi <= 1e-12


def test_rows_are_grouped_by_node_in_the_merge_sort_order():
    """row_partners' counting sort gives the stable order np.argsort's merge sort gives."""
    from impactsim.contact.rows import _stable_order

    rng = np.random.default_rng(2)
    for n in (0, 1, 4, 400, 12000):
        flat = rng.integers(0, 900, n).astype(np.int64)
        assert np.array_equal(_stable_order(flat), np.argsort(flat, kind="mergesort"))
