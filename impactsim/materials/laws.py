"""Pointwise material laws (ALGORITHMS.md 2): EOS pressure and yield stress of one element.

Small numba functions over scalars, inlined into the element kernel and tested alone.
"""

from __future__ import annotations

import math

import numba

from impactsim.materials import params as P


@numba.njit(cache=True, inline="always", error_model="numpy")
def hugoniot_pressure(eta, rho0, c0, s):
    """Pressure on the principal Hugoniot of a linear Us-up material and its slope dp_H/deta.

    eta = 1 - rho0/rho (compression > 0). With Us = c0 + s up and mass/momentum jumps
    (eta = up/Us, p_H = rho0 Us up): p_H = rho0 c0^2 eta / (1 - s eta)^2. In tension the
    Hugoniot is continued linearly, p_H = rho0 c0^2 eta. The denominator is kept away from the
    Hugoniot's limit compression 1/s (where p_H diverges) so an overrun element stays finite.
    """
    k = rho0 * c0 * c0
    if eta <= 0.0:
        return k * eta, k
    den = 1.0 - s * eta
    if den < 0.05:
        den = 0.05
    return k * eta / (den * den), k * (1.0 + s * eta) / (den * den * den)


@numba.njit(cache=True, inline="always", error_model="numpy")
def eos_linear_part(code, rho, rho0, bulk, c0, s, gamma0):
    """Pressure as p = a + b e (e specific internal energy [J/kg]) and the isentropic sound speed
    squared at that state as c2 = c2a + c2b p.

    linear:        p = K (rho/rho0 - 1), c^2 = K/rho0 (b = 0).
    Mie-Grueneisen (Gamma rho = Gamma0 rho0, referenced to the Hugoniot):
                   p = p_H(eta) (1 - Gamma0 eta / 2) + Gamma0 rho0 e,
                   c^2 = dp/drho|_s = [dp_H/deta (1 - Gamma0 eta/2) - Gamma0 p_H/2] rho0/rho^2
                         + Gamma0 rho0 p / rho^2.
    """
    if code == P.MIE_GRUNEISEN:
        eta = 1.0 - rho0 / rho
        ph, dph = hugoniot_pressure(eta, rho0, c0, s)
        a = ph * (1.0 - 0.5 * gamma0 * eta)
        b = gamma0 * rho0
        r2 = rho0 / (rho * rho)
        c2a = (dph * (1.0 - 0.5 * gamma0 * eta) - 0.5 * gamma0 * ph) * r2
        c2b = gamma0 * r2
        return a, b, c2a, c2b
    return bulk * (rho / rho0 - 1.0), 0.0, bulk / rho0, 0.0


@numba.njit(cache=True, inline="always", error_model="numpy")
def jc_rate_thermal(mp, k, eps_rate, temperature):
    """The Johnson-Cook factor (1 + C ln(eps_rate/eps_rate0))(1 - T*^m) of material row k.

    The rate term is floored at 1 (no softening below the reference rate), T* is clamped to
    [0, 1]. Neither depends on eps_p, so a radial return computes this once (one log, one pow).
    """
    rate = 1.0
    r = eps_rate / mp[k, P.EPSDOT0]
    if r > 1.0:
        rate = 1.0 + mp[k, P.JC_C] * math.log(r)
    t_room = mp[k, P.T_ROOM]
    t_star = (temperature - t_room) / (mp[k, P.T_MELT] - t_room)
    if t_star >= 1.0:
        return 0.0
    if t_star > 0.0:
        return rate * (1.0 - t_star ** mp[k, P.JC_M])
    return rate


@numba.njit(cache=True, inline="always", error_model="numpy")
def flow_stress(code, mp, k, eps_p, eps_rate, temperature):
    """Yield stress [Pa] and its slope d sigma_y / d eps_p for material row k of table `mp`.

    ideal-plastic: sigma_y = Y0 (Prandtl-Reuss).
    Johnson-Cook:  sigma_y = (A + B eps_p^n)(1 + C ln(eps_rate/eps_rate0))(1 - T*^m), the rate
                   term floored at 1 (no softening below the reference rate), T* clamped to [0, 1]
                   (`jc_rate_thermal`).
    elastic:       infinite (never yields).
    """
    if code == P.IDEAL_PLASTIC:
        return mp[k, P.Y0], 0.0
    if code == P.JOHNSON_COOK:
        rt = jc_rate_thermal(mp, k, eps_rate, temperature)
        hard = mp[k, P.JC_A]
        slope = 0.0
        if eps_p > 0.0:
            n = mp[k, P.JC_N]
            epn = eps_p ** n
            hard += mp[k, P.JC_B] * epn
            slope = mp[k, P.JC_B] * n * epn / eps_p
        return hard * rt, slope * rt
    return math.inf, 0.0


@numba.njit(cache=True, inline="always", error_model="numpy")
def yield_floor(code, mp, k, eps_p, temperature):
    """A lower bound [Pa] of the yield stress at (eps_p, temperature) over all strain rates.

    A trial stress at or below it is elastic whatever the rate, so the element kernel caches it
    per element (it changes only when eps_p or the temperature does, i.e. in a plastic step) and
    skips the rate term's log and the other pows of `radial_return` for such elements.
    ideal-plastic: Y0. Johnson-Cook: (A + B eps_p^n)(1 - T*^m), the rate factor being >= 1
    (floored); 0 (no bound) when C < 0. elastic: +inf.
    """
    if code == P.IDEAL_PLASTIC:
        return mp[k, P.Y0]
    if code != P.JOHNSON_COOK:
        return math.inf
    if mp[k, P.JC_C] < 0.0:
        return 0.0
    hard = mp[k, P.JC_A]
    if eps_p > 0.0:
        hard += mp[k, P.JC_B] * eps_p ** mp[k, P.JC_N]
    t_room = mp[k, P.T_ROOM]
    t_star = (temperature - t_room) / (mp[k, P.T_MELT] - t_room)
    if t_star >= 1.0:
        return 0.0
    if t_star > 0.0:
        return hard * (1.0 - t_star ** mp[k, P.JC_M])
    return hard


@numba.njit(cache=True, inline="always", error_model="numpy")
def radial_return(code, mp, k, shear, seq_trial, eps_p, eps_rate, temperature):
    """Plastic strain increment of the radial return to the yield surface (ALGORITHMS.md 2).

    Solves seq_trial - 3 G d_eps - sigma_y(eps_p + d_eps) = 0 for d_eps >= 0. Returns (d_eps,
    sigma_y at the end); d_eps = 0 when the trial state is elastic (seq_trial <= sigma_y(eps_p)).
    ideal-plastic: d_eps = (seq_trial - Y0) / 3G in closed form.
    Johnson-Cook: the rate and thermal factors are constant during the return (eps_rate and T
    are the step's), so they are evaluated once and Newton's method runs on the hardening term
    alone, (A + B (eps_p + d)^n) rt: one pow per iteration. It starts from the linearised
    return d = (seq_trial - sigma_y) / (3G + h) (h the hardening slope at eps_p, or from the
    upper bound (seq_trial - sigma_y) / 3G when eps_p = 0 where h is infinite), is safeguarded
    with bisection on [0, (seq_trial - sigma_y(eps_p)) / 3G], and stops at |residual| <=
    1e-12 seq_trial.
    """
    if code == P.IDEAL_PLASTIC:
        y0 = mp[k, P.Y0]
        if seq_trial <= y0:
            return 0.0, y0
        return (seq_trial - y0) / (3.0 * shear), y0
    if code != P.JOHNSON_COOK:
        return 0.0, math.inf
    rt = jc_rate_thermal(mp, k, eps_rate, temperature)
    a = mp[k, P.JC_A] * rt
    b = mp[k, P.JC_B] * rt
    n = mp[k, P.JC_N]
    epn = eps_p ** n if eps_p > 0.0 else 0.0
    sy = a + b * epn
    if seq_trial <= sy:
        return 0.0, sy
    g3 = 3.0 * shear
    hi = (seq_trial - sy) / g3
    lo = 0.0
    d = hi
    if eps_p > 0.0:
        d = (seq_trial - sy) / (g3 + b * n * epn / eps_p)
    tol = 1e-12 * seq_trial
    for _ in range(30):
        ep = eps_p + d
        pw = ep ** n
        sy = a + b * pw
        f = seq_trial - g3 * d - sy
        if abs(f) <= tol:
            return d, sy
        if f > 0.0:
            lo = d
        else:
            hi = d
        dn = d + f / (g3 + b * n * pw / ep)
        if dn <= lo or dn >= hi:
            dn = 0.5 * (lo + hi)
        d = dn
        if hi - lo <= 1e-15 * (1.0 + eps_p):
            break
    return d, a + b * (eps_p + d) ** n
