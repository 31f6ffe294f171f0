"""Logarithm and exponential as lane functions that LLVM vectorises inside a loop.

The Johnson-Cook return needs ln and exp (the rate term, eps_p^n, T*^m). numba has no vector
math library here (no SVML), so `math.log` and `math.exp` stay scalar libm calls even in a
vectorised loop, which then stops being vectorised. These are written out instead, with the
usual reductions, from arithmetic, selects and bit casts only, and inlined into the caller:

- `ln(x)`: x = 2^k m with m in [sqrt(1/2), sqrt(2)) read from the bits of x, then
  ln m = 2 atanh(s), s = (m - 1)/(m + 1), |s| <= 0.172, by its odd series to s^23 (truncation
  below 1e-17 relative), and ln x = k ln 2 + ln m with ln 2 split in two parts;
- `exp(y)`: y = k ln 2 + r with k = round(y / ln 2) and |r| <= ln 2 / 2, exp r by its Taylor
  series to r^13 (truncation below 2e-17), times 2^k built from its bits.
Both are accurate to a few units in the last place (tested against math.log/math.exp) for
positive normal x and for y in [-708, 709]; outside that exp saturates to about 2^-1021 or
2^1023 (the callers stay far inside). The bit casts are numba intrinsics (an LLVM bitcast, which
vectorises to nothing), so a loop that calls these needs no integer view of its buffer.
"""

from __future__ import annotations

import math

import numba
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic

FAST = {"nsz", "arcp", "contract"}  # no "afn", no "reassoc": the reductions must stay exact
LN2_HI = 6.93147180369123816490e-01  # ln 2 in two parts (fdlibm): k * LN2_HI is exact
LN2_LO = 1.90821492927058770002e-10
INV_LN2 = 1.4426950408889634
SQRT2 = 1.4142135623730951
MANTISSA = (1 << 52) - 1
ONE_BITS = 1023 << 52


@intrinsic
def as_bits(typingctx, x):
    """The IEEE bits of a float64 as an int64 (a bit cast, no conversion)."""
    if x != types.float64:
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(64))

    return types.int64(types.float64), codegen


@intrinsic
def from_bits(typingctx, i):
    """The float64 whose IEEE bits are the int64 i (a bit cast, no conversion)."""
    if i != types.int64:
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return types.float64(types.int64), codegen


@numba.njit(cache=True, inline="always", error_model="numpy", fastmath=FAST)
def ln(x):
    """Natural logarithm of a positive normal float64, a few ulp from libm."""
    bits = as_bits(x)
    m = from_bits((bits & MANTISSA) | ONE_BITS)  # in [1, 2)
    k = float((bits >> 52) - 1023)
    big = m > SQRT2
    m = 0.5 * m if big else m
    k = k + 1.0 if big else k
    s = (m - 1.0) / (m + 1.0)
    z = s * s
    # 1/3 + z/5 + ... + z^10/23 in Estrin's form: a dependency chain of 4 multiply-adds instead
    # of Horner's 10, so that several lanes' chains overlap in the out-of-order window
    z2 = z * z
    z4 = z2 * z2
    q0 = 1.0 / 3.0 + z * (1.0 / 5.0)
    q1 = 1.0 / 7.0 + z * (1.0 / 9.0)
    q2 = 1.0 / 11.0 + z * (1.0 / 13.0)
    q3 = 1.0 / 15.0 + z * (1.0 / 17.0)
    q4 = 1.0 / 19.0 + z * (1.0 / 21.0)
    p = (q0 + z2 * q1) + z4 * ((q2 + z2 * q3) + z4 * (q4 + z2 * (1.0 / 23.0)))
    return k * LN2_HI + (k * LN2_LO + 2.0 * s * (1.0 + z * p))


@numba.njit(cache=True, inline="always", error_model="numpy", fastmath=FAST)
def exp(y):
    """e^y for y in [-708, 709] (saturates outside), a few ulp from libm."""
    y = min(max(y, -708.0), 709.0)
    kf = math.floor(y * INV_LN2 + 0.5)
    r = (y - kf * LN2_HI) - kf * LN2_LO
    # sum of r^k / k!, k = 0..13, in Estrin's form (a chain of 5 multiply-adds, not 13)
    r2 = r * r
    r4 = r2 * r2
    r8 = r4 * r4
    q0 = 1.0 + r
    q1 = 0.5 + r * (1.0 / 6.0)
    q2 = 1.0 / 24.0 + r * (1.0 / 120.0)
    q3 = 1.0 / 720.0 + r * (1.0 / 5040.0)
    q4 = 1.0 / 40320.0 + r * (1.0 / 362880.0)
    q5 = 1.0 / 3628800.0 + r * (1.0 / 39916800.0)
    q6 = 1.0 / 479001600.0 + r * (1.0 / 6227020800.0)
    p = ((q0 + r2 * q1) + r4 * (q2 + r2 * q3)) + r8 * ((q4 + r2 * q5) + r4 * q6)
    return p * from_bits((int(kf) + 1023) << 52)


@numba.njit(cache=True, inline="always", error_model="numpy", fastmath=FAST)
def power(x, y):
    """x ** y for positive normal x, as exp(y ln x) (relative error about |y ln x| 1e-16)."""
    return exp(y * ln(x))


# x^(-1/3) within 3.5 % from the bits of x (the exponent and mantissa divided by 3, the
# constant of the known inverse-cube-root start), for `pow_two_thirds`
CBRT_MAGIC = 0x553EF0FF289DD796


@numba.njit(cache=True, inline="always", error_model="numpy", fastmath=FAST)
def pow_two_thirds(x):
    """x^(2/3) for positive normal x, as x y with y = x^(-1/3) by four Newton steps
    y <- y (4 - x y^3) / 3 from a start within 3.5 % read from the bits of x (the relative
    error squares at each step: 3.4e-2, 2.4e-3, 1.1e-5, 2.6e-10, then round-off, a few ulp).
    No logarithm, exponential or division: about 20 operations a lane against the ~60 of
    `power(x, 2/3)`, which it replaces in the hex kernel's viscous hourglass coefficient. The
    bits are divided by 3 in floating point (an int64 division does not vectorise)."""
    y = from_bits(CBRT_MAGIC - int(float(as_bits(x)) * (1.0 / 3.0)))
    y = y * (4.0 - x * y * y * y) * (1.0 / 3.0)
    y = y * (4.0 - x * y * y * y) * (1.0 / 3.0)
    y = y * (4.0 - x * y * y * y) * (1.0 / 3.0)
    y = y * (4.0 - x * y * y * y) * (1.0 / 3.0)
    return x * y


def _prefetch_codegen(rw, locality=3):
    def codegen(context, builder, signature, args):
        ary = context.make_array(signature.args[0])(context, builder, args[0])
        ptr = builder.bitcast(builder.gep(ary.data, [args[1]]), ir.IntType(8).as_pointer())
        i32 = ir.IntType(32)
        fnty = ir.FunctionType(ir.VoidType(), [ptr.type, i32, i32, i32])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.prefetch.p0")
        builder.call(fn, [ptr, ir.Constant(i32, rw), ir.Constant(i32, locality),
                           ir.Constant(i32, 1)])
        return context.get_dummy_value()

    return codegen


@intrinsic
def prefetch(typingctx, arr, i):
    """Hint the caches to fetch the line of arr[i] (`llvm.prefetch`, for reading, kept in all
    levels): no load, no bounds check, no fault (i is an index into the flat data).

    The element kernels fetch some element arrays a few blocks ahead (`element.PF_AHEAD`): the
    yield-floor caches, read only after the kinematics, and the arrays the block writes without
    reading (q, eps_rate); the hardware prefetchers lose those streams among the kernel's
    twenty others, and each then cost a stall of its own per block (docs/performance.md, "The
    hex step, session 10")."""
    if not isinstance(arr, types.Array) or not isinstance(i, types.Integer):
        return None
    return types.void(arr, types.intp), _prefetch_codegen(0)


@intrinsic
def prefetch_write(typingctx, arr, i):
    """`prefetch` of a line about to be written (PREFETCHW: fetched for ownership)."""
    if not isinstance(arr, types.Array) or not isinstance(i, types.Integer):
        return None
    return types.void(arr, types.intp), _prefetch_codegen(1)


@intrinsic
def prefetch_l2(typingctx, arr, i):
    """`prefetch` with the lowest locality hint (PREFETCHT2): on this Zen 4 the line is fetched
    into L2 and not into L1, where the hex kernel's block buffer (about 50 kB of rows in use)
    already overflows the 32 kB: the element arrays fetched four blocks ahead into L1 evicted
    the buffer's rows and made the kernel slower (+10 ns per hex), fetched into L2 faster
    (-5 ns; docs/performance.md, "The hex step, session 11")."""
    if not isinstance(arr, types.Array) or not isinstance(i, types.Integer):
        return None
    return types.void(arr, types.intp), _prefetch_codegen(0, 1)
