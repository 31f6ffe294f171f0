"""The vectorisable ln and exp of the element kernel's Johnson-Cook return against libm."""

import math

import numpy as np
import pytest

from impactsim.solver import vecmath as V

B = V.B


def _rows(n):
    buf = np.zeros(n * B)
    return buf, buf.view(np.int64), np.zeros(B, np.int64)


@pytest.mark.parametrize("low, high", [(-700.0, 700.0), (-1.0, 1.0), (-1e-6, 1e-6)])
def test_log_matches_libm_to_a_few_ulp(low, high):
    rng = np.random.default_rng(1)
    buf, ibuf, kbuf = _rows(2)
    worst = 0.0
    for _ in range(200):
        x = np.exp(rng.uniform(low, high, B))  # across the exponent range, and near 1
        buf[:B] = x
        V.vlog(buf, ibuf, 0, 1, kbuf)
        ref = np.array([math.log(v) for v in x])
        worst = max(worst, np.max(np.abs(buf[B:] - ref) / np.maximum(np.abs(ref), 1e-300)))
    assert worst < 1e-15


@pytest.mark.parametrize("low, high", [(-700.0, 700.0), (-3.0, 3.0), (-1e-8, 1e-8)])
def test_exp_matches_libm_to_a_few_ulp(low, high):
    rng = np.random.default_rng(2)
    buf, _, _ = _rows(2)
    worst = 0.0
    for _ in range(200):
        y = rng.uniform(low, high, B)
        buf[:B] = y
        V.vexp(buf, 0, 1)
        ref = np.array([math.exp(v) for v in y])
        worst = max(worst, np.max(np.abs(buf[B:] - ref) / ref))
    assert worst < 1e-15


def test_exact_values_and_saturation():
    buf, ibuf, kbuf = _rows(2)
    buf[:B] = 1.0
    buf[1] = 2.0
    buf[2] = 0.5
    V.vlog(buf, ibuf, 0, 1, kbuf)
    assert buf[B] == 0.0 and buf[B + 1] == pytest.approx(math.log(2.0), rel=1e-16)
    assert buf[B + 2] == pytest.approx(-math.log(2.0), rel=1e-16)
    buf[:B] = 0.0
    buf[1], buf[2] = -1e4, 1e4  # outside the range: 0-ish and huge, never NaN
    V.vexp(buf, 0, 1)
    assert buf[B] == 1.0 and 0.0 <= buf[B + 1] < 1e-300 and buf[B + 2] > 1e300
