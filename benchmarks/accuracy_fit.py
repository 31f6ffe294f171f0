"""Errors and observed orders of convergence for `make accuracy` (benchmarks/accuracy.py).

Plain numpy functions over the values of one series of runs (one study, one element formulation),
ordered from the coarsest run to the finest:

- ``relative_error(value, reference)``: |value - reference| / |reference|.
- ``order_vs_finest(h, f)``: least-squares fit of |f_i - f_finest| = C h_i^p over the coarser
  runs, the finest run standing in for the converged value. |f_i - f_finest| = C (h_i^p -
  h_finest^p) falls faster than the true error as h_i nears h_finest, so the fitted p is on the
  high side when the finest run is not much finer than the others.
- ``fit_power(x, err)``: least-squares fit of err = C x^p in log-log coordinates (exact values,
  errors against the wall time).
- ``richardson_order(h, f)``: the order observed on the three finest runs, for ratios of mesh
  size that need not be equal (Celik et al. 2008, "Procedure for estimation and reporting of
  uncertainty due to discretization in CFD applications", J. Fluids Eng. 130, 078001, eqs. 3-4):
  p = |ln|e32/e21| + q(p)| / ln r21, q(p) = ln((r21^p - s)/(r32^p - s)), s = sign(e32/e21),
  solved by fixed-point iteration; with it the extrapolated value f1 + (f1 - f2)/(r21^p - 1).
  None when the three values do not change monotonically (oscillatory convergence has no order).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np


def relative_error(value: float, reference: float) -> float:
    """|value - reference| / |reference| (absolute when reference is 0)."""
    if reference == 0:
        return abs(value)
    return abs(value - reference) / abs(reference)


def fit_power(x: Sequence[float], err: Sequence[float]) -> tuple[float, float] | None:
    """(p, C) of the least-squares line log err = log C + p log x through the points with
    err > 0 and x > 0; None with fewer than two such points."""
    x = np.asarray(x, dtype=float)
    err = np.asarray(err, dtype=float)
    ok = np.isfinite(x) & np.isfinite(err) & (x > 0) & (err > 0)
    if np.count_nonzero(ok) < 2 or np.ptp(np.log(x[ok])) == 0:
        return None
    p, log_c = np.polyfit(np.log(x[ok]), np.log(err[ok]), 1)
    return float(p), float(math.exp(log_c))


def errors_vs_finest(f: Sequence[float]) -> list[float]:
    """Relative difference of each value from the last (finest) one; 0 for the finest."""
    ref = float(f[-1])
    return [relative_error(float(v), ref) for v in f]


def order_vs_finest(h: Sequence[float], f: Sequence[float]) -> tuple[float, float] | None:
    """(p, C) of |f_i - f_finest| / |f_finest| = C h_i^p over the runs coarser than the finest
    (h and f from coarse to fine)."""
    if len(f) < 3:
        return None
    return fit_power(list(h)[:-1], errors_vs_finest(f)[:-1])


def richardson_order(h: Sequence[float], f: Sequence[float], tol: float = 1e-10,
                     max_iter: int = 200) -> tuple[float, float] | None:
    """(p, extrapolated value) from the three finest runs (h and f from coarse to fine), or None
    when their differences change sign or vanish. See the module docstring for the formula."""
    if len(f) < 3:
        return None
    h3, h2, h1 = (float(v) for v in list(h)[-3:])  # 1 = finest, as in Celik et al.
    f3, f2, f1 = (float(v) for v in list(f)[-3:])
    e21, e32 = f2 - f1, f3 - f2
    if e21 == 0 or e32 == 0 or e32 / e21 <= 0:
        return None
    r21, r32 = h2 / h1, h3 / h2
    if r21 <= 1 or r32 <= 1:
        return None
    s = 1.0  # monotone: e32 / e21 > 0
    ratio = math.log(abs(e32 / e21))
    p = abs(ratio) / math.log(r21)
    for _ in range(max_iter):
        num, den = r21 ** p - s, r32 ** p - s
        if num <= 0 or den <= 0:
            return None
        p_new = abs(ratio + math.log(num / den)) / math.log(r21)
        if abs(p_new - p) < tol:
            p = p_new
            break
        p = p_new
    if not math.isfinite(p) or p <= 0:
        return None
    return p, f1 + (f1 - f2) / (r21 ** p - 1.0)
