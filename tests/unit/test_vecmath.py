"""The vectorisable ln and exp of the element kernel's Johnson-Cook return against libm, and
that a loop calling them is compiled to packed vector instructions."""

import math
import re

import numba
import numpy as np
import pytest

from impactsim.solver import vecmath as V


@numba.njit(error_model="numpy", fastmath=V.FAST)
def _logs(x, out):
    for i in range(x.shape[0]):
        out[i] = V.ln(x[i])


@numba.njit(error_model="numpy", fastmath=V.FAST)
def _exps(y, out):
    for i in range(y.shape[0]):
        out[i] = V.exp(y[i])


@numba.njit(error_model="numpy", fastmath=V.FAST)
def _powers(x, y, out):
    for i in range(x.shape[0]):
        out[i] = V.power(x[i], y)


@numba.njit(error_model="numpy", fastmath=V.FAST)
def _two_thirds(x, out):
    for i in range(x.shape[0]):
        out[i] = V.pow_two_thirds(x[i])


@pytest.mark.parametrize("low, high", [(-700.0, 700.0), (-1.0, 1.0), (-1e-6, 1e-6)])
def test_log_matches_libm_to_a_few_ulp(low, high):
    x = np.exp(np.random.default_rng(1).uniform(low, high, 20000))  # all exponents, and near 1
    out = np.empty_like(x)
    _logs(x, out)
    ref = np.log(x)
    assert np.max(np.abs(out - ref) / np.maximum(np.abs(ref), 1e-300)) < 1e-15
    assert np.max(np.abs(out - ref)) < 4e-16 * max(1.0, np.abs(ref).max())


@pytest.mark.parametrize("low, high", [(-700.0, 700.0), (-3.0, 3.0), (-1e-8, 1e-8)])
def test_exp_matches_libm_to_a_few_ulp(low, high):
    y = np.random.default_rng(2).uniform(low, high, 20000)
    out = np.empty_like(y)
    _exps(y, out)
    assert np.max(np.abs(out - np.exp(y)) / np.exp(y)) < 1e-15


def test_power_matches_libm():
    """exp(y ln x) carries the rounding of y ln x: relative error about |y ln x| 1e-16."""
    x = np.random.default_rng(3).uniform(1e-9, 1.0, 20000)
    out = np.empty_like(x)
    for n in (0.31, 1.09, 2.5):
        _powers(x, n, out)
        bound = 4e-16 * (1.0 + np.abs(n * np.log(x)))
        assert np.all(np.abs(out - x ** n) / x ** n < bound)


def test_two_thirds_power_is_correctly_rounded_to_a_few_ulp():
    """x^(2/3) by Newton steps from a bit-level start, over every exponent (hex volumes are
    about 1e-15 to 1e-3 m^3): against the exact cube of the result, which does not carry the
    rounding of 2/3 that x ** (2 / 3) carries (|ln x| 2^-54 relative, 4e-14 at 1e-300)."""
    x = np.exp(np.random.default_rng(4).uniform(-690.0, 690.0, 20000))
    x = np.concatenate([x, [1.0, 8.0, 0.125, 1e-9, 2.7e-10]])
    out = np.empty_like(x)
    _two_thirds(x, out)
    # out^3 = x^2 exactly would mean no error; compare out^(3/2) with x in long double
    err = np.abs(out.astype(np.longdouble) ** 1.5 / x.astype(np.longdouble) - 1)
    assert err.max() < 2e-15  # 1.5 x the result's relative error: a few ulp
    assert out[-5] == 1.0 and out[-4] == 4.0 and out[-3] == 0.25
    assert np.all(np.abs(out / x ** (2.0 / 3.0) - 1) < 4e-16 * (1.0 + np.abs(np.log(x))))
    asm = _two_thirds.inspect_asm(_two_thirds.signatures[0])
    assert len(re.findall(r"\bv\w+pd\s[^\n]*%[yz]mm", asm)) > 10  # vectorised


def test_exact_values_and_saturation():
    out = np.empty(3)
    _logs(np.array([1.0, 2.0, 0.5]), out)
    assert out[0] == 0.0 and out[1] == pytest.approx(math.log(2.0), rel=1e-16)
    assert out[2] == pytest.approx(-math.log(2.0), rel=1e-16)
    _exps(np.array([0.0, -1e4, 1e4]), out)  # outside the range: tiny and huge, never NaN
    assert out[0] == 1.0 and 0.0 <= out[1] < 1e-300 and out[2] > 1e300


def test_a_loop_of_powers_is_vectorised():
    asm = _powers.inspect_asm(_powers.signatures[0])
    assert len(re.findall(r"\bv\w+pd\s[^\n]*%[yz]mm", asm)) > 50  # packed double arithmetic


def test_prefetch_hints_compile_to_prefetch_instructions_and_change_nothing():
    """`prefetch` / `prefetch_write` / `prefetch_l2` on arrays of two element types in one
    function (each call casts its pointer: a second type once failed to compile), at the last
    element and past it (a hint never faults): the machine code has the three instructions
    and the arrays are intact."""
    @numba.njit(cache=False)
    def touch(a, b):
        n = a.shape[0]
        for i in range(0, n + 64, 8):
            V.prefetch(a, min(i, n - 1))
            V.prefetch_write(b, i)
            V.prefetch_l2(b, i)
        return a.sum() + b.sum()

    a = np.arange(100.0)
    b = np.arange(100, dtype=np.int32)
    assert touch(a, b) == a.sum() + b.sum()
    asm = next(iter(touch.inspect_asm().values())).lower()
    assert "prefetcht0" in asm and "prefetchw" in asm and "prefetcht2" in asm
    assert np.array_equal(a, np.arange(100.0)) and np.array_equal(b, np.arange(100))
