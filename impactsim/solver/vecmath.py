"""Logarithm and exponential over rows of a block buffer, as loops LLVM vectorises.

The Johnson-Cook return needs ln and exp (the rate term, eps_p^n, T*^m). numba has no vector
math library here (no SVML), so `math.log` and `math.exp` stay scalar libm calls even in a
vectorised loop; these are written out instead, with the usual reductions:

- log x: x = 2^k m with m in [sqrt(1/2), sqrt(2)) read from the bits of x (an int64 view of the
  same buffer), then ln m = 2 atanh(s), s = (m - 1)/(m + 1), |s| <= 0.172, by its odd series to
  s^23 (truncation below 1e-17 relative), and ln x = k ln 2 + ln m with ln 2 split in two parts;
- exp y: y = k ln 2 + r with k = round(y / ln 2) and |r| <= ln 2 / 2, exp r by its Taylor series
  to r^13 (truncation below 2e-17), times 2^k from a table.
Both are accurate to a few units in the last place (tested against math.log/math.exp) for
positive normal x and for y in [-708, 709]; outside that exp saturates to 0 or 2^1023 (the
callers stay far inside). Each step is its own small function so that LLVM vectorises it:
a loop reads and writes one view of the buffer only (float or int), so no run-time alias check
is needed.
"""

from __future__ import annotations

import math

import numba
import numpy as np

FAST = {"nsz", "arcp", "contract"}  # no "afn", no "reassoc": the reductions must stay exact
B = 32  # lanes (must equal the element kernel's block size)
LN2_HI = 6.93147180369123816490e-01  # ln 2 in two parts (fdlibm): k * LN2_HI is exact
LN2_LO = 1.90821492927058770002e-10
INV_LN2 = 1.4426950408889634
SQRT2 = 1.4142135623730951
MANTISSA = (1 << 52) - 1
ONE_BITS = 1023 << 52
POW2 = 2.0 ** np.arange(-1022, 1024, dtype=np.float64)  # 2^k at POW2[k + 1022]


@numba.njit(cache=True, error_model="numpy")
def _split_exponent(ix, im, kbuf):
    """x = 2^k m, m in [1, 2): k to kbuf, the bits of m to im (int views of B lanes)."""
    for i in range(B):
        bits = ix[i]
        kbuf[i] = (bits >> 52) - 1023
        im[i] = (bits & MANTISSA) | ONE_BITS


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def _log_mantissa(mrow, kbuf):
    """mrow holds m in [1, 2) and kbuf k: replace m by ln(2^k m)."""
    for i in range(B):
        m = mrow[i]
        k = float(kbuf[i])
        big = m > SQRT2
        m = 0.5 * m if big else m
        k = k + 1.0 if big else k
        s = (m - 1.0) / (m + 1.0)
        z = s * s
        p = 1.0 / 23.0
        p = p * z + 1.0 / 21.0
        p = p * z + 1.0 / 19.0
        p = p * z + 1.0 / 17.0
        p = p * z + 1.0 / 15.0
        p = p * z + 1.0 / 13.0
        p = p * z + 1.0 / 11.0
        p = p * z + 1.0 / 9.0
        p = p * z + 1.0 / 7.0
        p = p * z + 1.0 / 5.0
        p = p * z + 1.0 / 3.0
        mrow[i] = k * LN2_HI + (k * LN2_LO + 2.0 * s * (1.0 + z * p))


@numba.njit(cache=True, error_model="numpy", fastmath=FAST)
def _exp_row(yrow, out):
    for i in range(B):
        y = yrow[i]
        y = min(max(y, -708.0), 709.0)
        kf = math.floor(y * INV_LN2 + 0.5)
        r = (y - kf * LN2_HI) - kf * LN2_LO
        p = 1.0 / 6227020800.0  # 1/13!
        p = p * r + 1.0 / 479001600.0
        p = p * r + 1.0 / 39916800.0
        p = p * r + 1.0 / 3628800.0
        p = p * r + 1.0 / 362880.0
        p = p * r + 1.0 / 40320.0
        p = p * r + 1.0 / 5040.0
        p = p * r + 1.0 / 720.0
        p = p * r + 1.0 / 120.0
        p = p * r + 1.0 / 24.0
        p = p * r + 1.0 / 6.0
        p = p * r + 0.5
        p = p * r + 1.0
        p = p * r + 1.0
        out[i] = p * POW2[int(kf) + 1022]


@numba.njit(cache=True, error_model="numpy")
def vexp(buf, src, dst):
    """Row dst = exp(row src) (rows of B lanes, dst != src)."""
    _exp_row(buf[src * B:(src + 1) * B], buf[dst * B:(dst + 1) * B])


@numba.njit(cache=True, error_model="numpy")
def vlog(buf, ibuf, src, dst, kbuf):
    """Row dst = ln(row src) for positive normal values (dst != src); ibuf is buf viewed as
    int64 and kbuf an int64 scratch of B entries."""
    _split_exponent(ibuf[src * B:(src + 1) * B], ibuf[dst * B:(dst + 1) * B], kbuf)
    _log_mantissa(buf[dst * B:(dst + 1) * B], kbuf)
