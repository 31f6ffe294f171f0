"""Spall: when a cell's tension damages it (criteria.py step 1; docs/fracture.md).

Two criteria, chosen by `[fracture] spall_criterion`, on the maximum principal stress sigma_1
of s - p I, with p the pressure `[fracture] spall_pressure` names (``SPALL_LESSER``, the
default: the larger of the cell's own pressure and its patch mean, i.e. the smaller tension):

- instantaneous ([D19] after Fomin et al.): damaged as soon as sigma_1 > sigma_0, the
  material's spall strength;
- Tuler-Butcher (Tuler & Butcher 1968, Int. J. Fract. Mech. 4:431), in its impulse form
  (lambda = 1) and scaled by sigma_0: the cell accumulates
      K = integral of (sigma_1 / sigma_0 - 1) dt   over the time sigma_1 > sigma_0
  and is damaged when K >= tau, the material's spall time (failure.spall_time). A tension
  held above the threshold must last; a brief excursion of one cell (the tet4 pressure
  checkerboard, the converging lateral release behind a Taylor bar's impact face) does not
  break it. A tension of 2 sigma_0 spalls after tau. Materials without a spall time spall at
  the threshold under either criterion.
"""

from __future__ import annotations

import numba

from impactsim.materials import params as P

SPALL_LESSER, SPALL_CELL, SPALL_PATCH = 0, 1, 2
PRESSURE_CODES = {"lesser": SPALL_LESSER, "cell": SPALL_CELL, "patch": SPALL_PATCH}


@numba.njit(cache=True, inline="always")
def spall_pressure(mode, p_cell, p_patch):
    """The pressure spall reads for the mode of `[fracture] spall_pressure`."""
    if mode == SPALL_CELL:
        return p_cell
    if mode == SPALL_PATCH:
        return p_patch
    return max(p_cell, p_patch)  # the smaller tension: the cell and its patch both carry it


@numba.njit(cache=True, inline="always")
def spalls(e, mk, sigma1, dt, spall_k, mat_params, integrate):
    """Whether intact element e spalls this step with maximum principal stress sigma1 [Pa]
    (module docstring); integrate: the Tuler-Butcher criterion for materials with a spall
    time. Updates the accumulator spall_k[e] [s] (it keeps what it has gained while the
    tension is below the threshold)."""
    s0 = mat_params[mk, P.SPALL]
    if sigma1 <= s0:
        return False
    tau = mat_params[mk, P.SPALL_TIME]
    if not integrate or tau <= 0.0:
        return True
    spall_k[e] += (sigma1 / s0 - 1.0) * dt
    return spall_k[e] >= tau
