"""Ductile fracture: Johnson-Cook damage that breaks a cell (docs/fracture.md, "Ductile
fracture"; `[fracture] ductile_criterion`).

Johnson & Cook (1985, Eng. Fract. Mech. 21:31) accumulate

    D = sum of d eps_p / eps_f,   eps_f = (D1 + D2 exp(D3 eta)) (1 + D4 ln max(eps_dot*, 1))
                                          (1 + D5 T*)

with eta = -p / sigma_eq the stress triaxiality, eps_dot* the plastic strain rate over the
reference rate of the strength model and T* its homologous temperature. For a material with
`failure.jc_damage` (D1..D5) and no erosion criterion of its own, a cell whose D reaches 1
becomes DAMAGED, as spall makes it (criteria.py step 1): it keeps bulk compression only, opens
past the loosening threshold and leaves the mesh as particles on the surface. This is what
separates a plate that a projectile shears or stretches through (plugging, petalling, a doming
plate's membrane tension): the tensions there stay near the flow stress, far below a spall
strength, so spall alone never opens it.

Below the triaxiality eta_c = -1/3 (uniaxial compression) no damage accumulates: Bao &
Wierzbicki (2005, Eng. Fract. Mech. 72:1049) found no fracture there in upsetting tests, where
the exponential of the fit keeps a finite eps_f. The foot of a Taylor bar, pressed far below
eta_c, gains nothing. Above eta = 2/3 (equibiaxial tension, the stretched membrane of a doming
plate) the ductile criterion reads eps_f at 2/3: a larger triaxiality is a near-hydrostatic
tension, where voids grow and the cell spalls (spall.py), and where the fits extrapolate beyond
their notched-bar data into negative strains (6061-T6's D1..D3 give eps_f < 0 above 1.35; the
lateral release behind a Taylor bar's impact face reaches that and broke cells at plastic
strains of 0.07-0.4). The erosion criterion `erosion = "jc-damage"` [R20] (criteria.py step
2b) keeps the fit as it was given up to 1.5 and erodes instead.
"""

from __future__ import annotations

import math

import numba

from impactsim.materials import params as P

TRIAXIALITY_CAP = 1.5  # [-] above it the fit is not used (near-hydrostatic tension)
TRIAXIALITY_CUTOFF = -1.0 / 3.0  # [-] at or below it no ductile damage (Bao & Wierzbicki 2005)
# [-] the ductile criterion reads eps_f at most at equibiaxial tension (a stretched membrane);
# above it the tension is near hydrostatic, the regime of spall (module docstring)
DUCTILE_CAP = 2.0 / 3.0
OFF, JOHNSON_COOK = 0, 1
CRITERIA = {"none": OFF, "johnson-cook": JOHNSON_COOK}


@numba.njit(cache=True, inline="always")
def triaxiality(pressure, seq):
    """eta = -p / sigma_eq, capped at TRIAXIALITY_CAP (a stress-free cell: the cap)."""
    tri = -pressure / seq if seq > 0.0 else TRIAXIALITY_CAP
    return min(tri, TRIAXIALITY_CAP)


@numba.njit(cache=True, inline="always")
def fracture_strain(mat_params, mk, tri, rate, temperature):
    """Johnson-Cook (1985) fracture strain eps_f at triaxiality tri, plastic strain rate
    [1/s] and temperature [K] (module docstring), at least 1e-9."""
    d1 = mat_params[mk, P.JC_D1]
    d2 = mat_params[mk, P.JC_D1 + 1]
    d3 = mat_params[mk, P.JC_D1 + 2]
    d4 = mat_params[mk, P.JC_D1 + 3]
    d5 = mat_params[mk, P.JC_D1 + 4]
    ref = mat_params[mk, P.EPSDOT0]
    rstar = rate / ref if ref > 0.0 else 1.0
    fr = 1.0 + d4 * math.log(rstar) if rstar > 1.0 else 1.0
    tr, tm = mat_params[mk, P.T_ROOM], mat_params[mk, P.T_MELT]
    ts = (temperature - tr) / (tm - tr) if tm > tr else 0.0
    ts = min(max(ts, 0.0), 1.0)
    ef = (d1 + d2 * math.exp(d3 * tri)) * fr * (1.0 + d5 * ts)
    return max(ef, 1e-9)


@numba.njit(cache=True, inline="always")
def damage_increment(mat_params, mk, deps, pressure, seq, rate, temperature, cutoff):
    """d eps_p / eps_f for a plastic strain increment deps; cutoff: none at or below the
    triaxiality TRIAXIALITY_CUTOFF (the ductile criterion; the erosion criterion keeps the fit
    everywhere)."""
    tri = triaxiality(pressure, seq)
    if cutoff:
        if tri <= TRIAXIALITY_CUTOFF:
            return 0.0
        tri = min(tri, DUCTILE_CAP)
    return deps / fracture_strain(mat_params, mk, tri, rate, temperature)


@numba.njit(cache=True, inline="always")
def ductile(mat_params, mk):
    """True for a material whose Johnson-Cook damage breaks cells (params.DUCTILE)."""
    return mat_params[mk, P.DUCTILE] > 0.0
