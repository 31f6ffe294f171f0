"""The coplanarity cubic and its roots in [0, tau] (ALGORITHMS.md 3.2)."""

import numpy as np
import pytest

from impactsim.contact.cubic import cubic_coefficients, cubic_roots_in


def roots(a, b, c, d, tau):
    n, *r = cubic_roots_in(a, b, c, d, tau)
    return np.array(r[:n])


def from_roots(rs, lead=1.0):
    """Coefficients (a, b, c, d) of lead * prod(t - r)."""
    p = lead * np.poly(rs)
    return tuple(np.concatenate([np.zeros(4 - len(p)), p]))


def test_coefficients_match_the_determinant_at_any_time():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(3, 3))
    B = rng.normal(size=(3, 3))
    a, b, c, d = cubic_coefficients(*A[:, 0], *A[:, 1], *A[:, 2], *B[:, 0], *B[:, 1], *B[:, 2])
    for t in (0.0, 0.3, -1.7, 2.5):
        assert np.isclose(a * t**3 + b * t**2 + c * t + d, np.linalg.det(A + t * B),
                          rtol=1e-12, atol=1e-12)


def test_three_simple_roots_in_order():
    np.testing.assert_allclose(roots(*from_roots([1.0, 2.0, 3.0]), 4.0), [1, 2, 3], rtol=1e-14)
    np.testing.assert_allclose(roots(*from_roots([1.0, 2.0, 3.0]), 2.5), [1, 2], rtol=1e-14)


@pytest.mark.parametrize("r", [1e-15, 1e-12, 1e-9, 1e-6])
def test_root_near_zero(r):
    tau = 1e-6
    got = roots(*from_roots([r * tau, 0.5 * tau, 3 * tau], lead=1e18), tau)
    assert len(got) == 2
    assert abs(got[0] - r * tau) <= 1e-15 * tau and np.isclose(got[1], 0.5 * tau, rtol=1e-12)


@pytest.mark.parametrize("r", [1e-15, 1e-12, 1e-9])
def test_root_near_tau(r):
    tau = 2e-7
    got = roots(*from_roots([(1 - r) * tau, -tau, 5 * tau]), tau)
    assert len(got) == 1 and abs(got[0] - (1 - r) * tau) <= 1e-15 * tau
    # just outside: no root
    assert len(roots(*from_roots([(1 + 1e-9) * tau, -tau, 5 * tau]), tau)) == 0


def test_roots_exactly_at_the_ends():
    np.testing.assert_array_equal(roots(0.0, 0.0, 1.0, 0.0, 1.0), [0.0])
    np.testing.assert_allclose(roots(*from_roots([0.0, 1.0, 7.0]), 1.0), [0.0, 1.0], atol=1e-15)


def test_double_roots():
    # tangency inside the step: (t - 0.4)^2 (t - 3)
    got = roots(*from_roots([0.4, 0.4, 3.0]), 1.0)
    np.testing.assert_allclose(got, [0.4], atol=1e-12)
    # double root at the end of the step and a simple one before
    got = roots(*from_roots([0.2, 1.0, 1.0]), 1.0)
    np.testing.assert_allclose(got, [0.2, 1.0], atol=1e-12)
    # triple root
    np.testing.assert_allclose(roots(*from_roots([0.5, 0.5, 0.5]), 1.0), [0.5], atol=1e-12)
    # a double root that round-off puts a hair above zero still counts
    a, b, c, d = from_roots([0.4, 0.4, 3.0])
    np.testing.assert_allclose(roots(a, b, c, d + 1e-15, 1.0), [0.4], atol=1e-6)


def test_vanishing_leading_coefficients():
    np.testing.assert_allclose(roots(0.0, 1.0, -0.9, 0.2, 1.0), [0.4, 0.5], rtol=1e-14)
    np.testing.assert_allclose(roots(1e-30, 1.0, -0.9, 0.2, 1.0), [0.4, 0.5], rtol=1e-12)
    np.testing.assert_allclose(roots(0.0, 0.0, 2.0, -1.0, 1.0), [0.5], rtol=1e-15)
    assert len(roots(0.0, 0.0, 0.0, 1.0, 1.0)) == 0
    # identically zero (points coplanar during the whole step): the start counts as a root
    np.testing.assert_array_equal(roots(0.0, 0.0, 0.0, 0.0, 1.0), [0.0])


def test_no_nan_for_non_finite_input():
    assert len(roots(np.nan, 1.0, 1.0, 1.0, 1.0)) == 0
    assert len(roots(np.inf, 1.0, 1.0, -1.0, 1.0)) == 0


def test_random_cubics_against_eigenvalue_roots():
    rng = np.random.default_rng(42)
    for _ in range(300):
        a, b, c, d = rng.normal(size=4) * 10.0 ** rng.integers(-3, 4, size=4)
        tau = 10.0 ** rng.uniform(-8, 0)
        a, b, c = a / tau**3, b / tau**2, c / tau
        ref = np.roots([a, b, c, d])
        ref = np.sort(ref[(abs(ref.imag) < 1e-9 * tau) & (ref.real >= 0) & (ref.real <= tau)].real)
        got = roots(a, b, c, d, tau)
        if len(ref) == len(got):
            np.testing.assert_allclose(got, ref, atol=1e-7 * tau)
        else:  # only near-double roots may differ in count
            assert abs(len(ref) - len(got)) <= 2
        p = np.polyval([a, b, c, d], got)
        scale = abs(a) * tau**3 + abs(b) * tau**2 + abs(c) * tau + abs(d)
        assert np.all(abs(p) <= 1e-10 * scale)
