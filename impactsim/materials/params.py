"""The flat material parameter table that kernels read: one row per material, columns below.

Kernels cannot take dataclasses, so each resolved `Material` becomes a float64 row of
`mat_params (n_mat, N_PARAM)`. Model codes are stored as floats and compared after int().
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # annotations only: case/material.py imports this module
    from impactsim.case.schema import Material

# strength model codes
ELASTIC, IDEAL_PLASTIC, JOHNSON_COOK = 0, 1, 2
STRENGTH_CODES = {"elastic": ELASTIC, "ideal-plastic": IDEAL_PLASTIC, "johnson-cook": JOHNSON_COOK}
# EOS codes
LINEAR, MIE_GRUNEISEN = 0, 1
EOS_CODES = {"linear": LINEAR, "mie-gruneisen": MIE_GRUNEISEN}
# erosion criterion codes (0 = none)
EROSION_CODES = {None: 0, "plastic-strain": 1, "jc-damage": 2, "principal-strain": 3, "fractured": 4}

# column indices
RHO0 = 0  # [kg/m^3] reference density
G = 1  # [Pa] shear modulus
K = 2  # [Pa] bulk modulus (linear EOS; also the reference tangent of Mie-Grueneisen)
CV = 3  # [J/(kg K)] specific heat
TQ = 4  # [-] Taylor-Quinney factor
T_INIT = 5  # [K] initial temperature
STRENGTH = 6  # strength model code
Y0 = 7  # [Pa] ideal-plastic yield stress
JC_A = 8  # [Pa]
JC_B = 9  # [Pa]
JC_N = 10  # [-]
JC_C = 11  # [-]
JC_M = 12  # [-]
EPSDOT0 = 13  # [1/s]
T_ROOM = 14  # [K]
T_MELT = 15  # [K]
EOS = 16  # EOS code
C0 = 17  # [m/s]
S = 18  # [-]
GAMMA0 = 19  # [-]
SPALL = 20  # [Pa] spall strength, +inf = none
CHI_STAR = 21  # [-] loosening threshold, +inf = none
EROSION = 22  # erosion criterion code
EROSION_VALUE = 23  # threshold of the erosion criterion
JC_D1 = 24  # D1..D5 in columns 24..28
FRACTURE_STRAIN = 29  # [-] node separation, +inf = none
SPALL_TIME = 30  # [s] Tuler-Butcher time tau of spall (fracture/spall.py), 0 = instantaneous
# 1: Johnson-Cook damage D >= 1 damages the cell (fracture/ductile.py): materials with jc_damage,
# no erosion criterion and spall or loosening (the damaged cell's way out of the mesh; node
# separation's materials keep their own criterion), when the case sets [fracture]
# ductile_criterion = "johnson-cook" (solver/build.py zeroes the column otherwise)
DUCTILE = 31
N_PARAM = 32


def material_row(mat: Material) -> np.ndarray:
    """One resolved material as a parameter row (SI)."""
    row = np.zeros(N_PARAM)
    row[RHO0] = mat.density
    row[G] = mat.shear_modulus
    row[K] = mat.bulk_modulus
    row[CV] = mat.specific_heat
    row[TQ] = mat.taylor_quinney
    row[T_INIT] = mat.initial_temperature
    st = mat.strength
    row[STRENGTH] = STRENGTH_CODES[st.model]
    row[Y0] = st.yield_stress
    row[JC_A], row[JC_B], row[JC_N], row[JC_C], row[JC_M] = st.A, st.B, st.n, st.C, st.m
    row[EPSDOT0] = st.strain_rate_ref
    row[T_ROOM] = st.room_temperature
    row[T_MELT] = st.melt_temperature
    eos = mat.eos
    row[EOS] = EOS_CODES[eos.model]
    row[C0] = eos.c0 if eos.c0 > 0 else math.sqrt(mat.bulk_modulus / mat.density)
    row[S] = eos.s
    row[GAMMA0] = eos.gamma0
    fail = mat.failure
    row[SPALL] = fail.spall_strength if fail.spall_strength is not None else np.inf
    row[CHI_STAR] = fail.loosening if fail.loosening is not None else np.inf
    row[EROSION] = EROSION_CODES[fail.erosion]
    row[EROSION_VALUE] = fail.erosion_value if fail.erosion_value is not None else np.inf
    if fail.jc_damage is not None:
        row[JC_D1:JC_D1 + 5] = fail.jc_damage
    row[FRACTURE_STRAIN] = fail.fracture_strain if fail.fracture_strain is not None else np.inf
    row[SPALL_TIME] = fail.spall_time if fail.spall_time is not None else 0.0
    row[DUCTILE] = 1.0 if (fail.jc_damage is not None and fail.erosion is None and (
        fail.spall_strength is not None or fail.loosening is not None)) else 0.0
    return row


def material_table(materials: list[Material]) -> np.ndarray:
    """(n_mat, N_PARAM) float64, rows in the order given."""
    return np.array([material_row(m) for m in materials], dtype=np.float64).reshape(-1, N_PARAM)


def longitudinal_wave_speed(mat: Material) -> float:
    """Elastic dilatational wave speed sqrt((K + 4G/3)/rho0) [m/s] at the reference state."""
    return math.sqrt((mat.bulk_modulus + 4.0 * mat.shear_modulus / 3.0) / mat.density)


def bulk_sound_speed(mat: Material) -> float:
    """C0 of the Mach number M0 = U0/C0 (ALGORITHMS.md 1) [m/s]."""
    return mat.eos.c0 if mat.eos.c0 > 0 else math.sqrt(mat.bulk_modulus / mat.density)
