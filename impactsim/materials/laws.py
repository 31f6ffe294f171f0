"""Pointwise material laws (ALGORITHMS.md 2): EOS pressure and yield stress of one element.

Small numba functions over scalars, inlined into the element kernel and tested alone. The one
exception is `radial_return`, which the kernel calls: its scalar path, its block return for
other strength models and its Johnson-Cook fallback each inlined a copy of the iteration, and
the three copies cost about 9 s of the cold compile.
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
    # written with selects, no early return, so that it vectorises inside a loop over elements
    den = max(1.0 - s * max(eta, 0.0), 0.05)
    comp = eta > 0.0
    return (k * eta / (den * den) if comp else k * eta,
            k * (1.0 + s * eta) / (den * den * den) if comp else k)


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
def power(x, y):
    """x ** y for x > 0 as exp(y ln x): about 17 ns against 26 for libm's pow here, within a few
    ulp (the relative error is about |y ln x| 1e-16). The caller handles x <= 0."""
    return math.exp(y * math.log(x))


@numba.njit(cache=True, inline="always", error_model="numpy")
def hardening(code, mp, k, eps_p):
    """The strain-hardening term of the yield stress [Pa]: Johnson-Cook A + B eps_p^n,
    ideal-plastic Y0, elastic +inf (never yields)."""
    if code == P.JOHNSON_COOK:
        if eps_p > 0.0:
            return mp[k, P.JC_A] + mp[k, P.JC_B] * power(eps_p, mp[k, P.JC_N])
        return mp[k, P.JC_A]
    if code == P.IDEAL_PLASTIC:
        return mp[k, P.Y0]
    return math.inf


@numba.njit(cache=True, inline="always", error_model="numpy")
def thermal_factor(code, mp, k, temperature):
    """The Johnson-Cook thermal softening factor 1 - T*^m, T* = (T - T_room)/(T_melt - T_room)
    clamped to [0, 1]; 1 for the other models."""
    if code != P.JOHNSON_COOK:
        return 1.0
    t_room = mp[k, P.T_ROOM]
    t_star = (temperature - t_room) / (mp[k, P.T_MELT] - t_room)
    if t_star >= 1.0:
        return 0.0
    if t_star > 0.0:
        return 1.0 - power(t_star, mp[k, P.JC_M])
    return 1.0


@numba.njit(cache=True, inline="always", error_model="numpy")
def rate_factor(code, mp, k, eps_rate):
    """The Johnson-Cook strain-rate factor 1 + C ln(eps_rate / eps_rate0), floored at 1 (no
    softening below the reference rate); 1 for the other models."""
    if code != P.JOHNSON_COOK:
        return 1.0
    r = eps_rate / mp[k, P.EPSDOT0]
    if r > 1.0:
        return 1.0 + mp[k, P.JC_C] * math.log(r)
    return 1.0


@numba.njit(cache=True, inline="always", error_model="numpy")
def rate_independent_floor(code, mp, k):
    """True when hardening x thermal factor is a lower bound of the yield stress at every rate
    (the rate factor is >= 1: Johnson-Cook with C >= 0, or a rate-independent model)."""
    return code != P.JOHNSON_COOK or mp[k, P.JC_C] >= 0.0


@numba.njit(cache=True, inline="always", error_model="numpy")
def flow_stress(code, mp, k, eps_p, eps_rate, temperature):
    """Yield stress [Pa] and its slope d sigma_y / d eps_p for material row k of table `mp`.

    ideal-plastic: sigma_y = Y0 (Prandtl-Reuss).
    Johnson-Cook:  sigma_y = (A + B eps_p^n)(1 + C ln(eps_rate/eps_rate0))(1 - T*^m), the rate
                   term floored at 1 (no softening below the reference rate), T* clamped to [0, 1]
                   (`hardening`, `rate_factor`, `thermal_factor`).
    elastic:       infinite (never yields).
    """
    if code == P.IDEAL_PLASTIC:
        return mp[k, P.Y0], 0.0
    if code == P.JOHNSON_COOK:
        rt = rate_factor(code, mp, k, eps_rate) * thermal_factor(code, mp, k, temperature)
        hard = hardening(code, mp, k, eps_p)
        slope = 0.0
        if eps_p > 0.0:
            slope = mp[k, P.JC_N] * (hard - mp[k, P.JC_A]) / eps_p
        return hard * rt, slope * rt
    return math.inf, 0.0


@numba.njit(cache=True, inline="always", error_model="numpy")
def newton_step_converged(step, ep, curvature, tol):
    """True when the Newton step `step` from plastic strain ep lands within tol of the root
    without another evaluation. The residual after the step is f''(xi) step^2 / 2 (Taylor);
    with |step| <= 1e-5 ep the curvature |f''| ~ ep^(n-2) at xi is within 0.01 % of its value
    `curvature` at ep, so curvature step^2 <= tol (a factor 2 to spare) bounds it."""
    return abs(step) <= 1e-5 * ep and curvature * step * step <= tol


@numba.njit(cache=True, inline="always", error_model="numpy")
def power_near(pw, x, n):
    """(ep (1 + x))^n from pw = ep^n for |x| <= 1e-5, by the binomial series to x^3 (the next
    term is below 1e-20 relative): the power after an accepted Newton step without a pow."""
    return pw * (1.0 + x * (n + x * (0.5 * n * (n - 1.0) + x * (n * (n - 1.0) * (n - 2.0) / 6.0))))


@numba.njit(cache=True, inline="always", error_model="numpy")
def newton_start(seq_trial, sy, hard, a0, rt, n, g3, eps_p):
    """Start of the Johnson-Cook return's Newton iteration for eps_p > 0: the smaller root of
    the residual's quadratic model at d = 0, y - p d + k d^2 / 2 (y = seq_trial - sy, p = 3G + h
    with the hardening slope h, k = rt B n (1 - n) eps_p^(n-2) its curvature there; B eps_p^n
    is hard - A, so no power is needed). The residual's curvature falls as d grows, so the
    model lies above it and its root right of the solution; its error is third order in the
    increment (relative error x^2 for an increment x eps_p, against x for the linearised start
    y / p), which lets the first Newton step finish (`newton_step_converged`) more often.
    Without a real root (k large), y / p."""
    y = seq_trial - sy
    hb = (hard - a0) * rt  # rt B eps_p^n
    p = g3 + n * hb / eps_p
    k = n * abs(1.0 - n) * hb / (eps_p * eps_p)
    disc = p * p - 2.0 * k * y
    return 2.0 * y / (p + math.sqrt(disc)) if disc > 0.0 else y / p


@numba.njit(cache=True, inline="always", error_model="numpy")
def first_yield_return(seq_trial, a, b, a0, b0, n, g3):
    """The Johnson-Cook return of an element that yields for the first time (eps_p = 0):
    seq_trial - 3G d - (a + b d^n) = 0 solved by Newton's method in t = d^n, i.e.
    y - 3G t^(1/n) - b t = 0 with y = seq_trial - a. In d the hardening slope n b d^(n-1) is
    infinite at d = 0 and Newton crawls from the upper bound (14 to 30 evaluations for a trial
    stress 1e-2 to 1e-4 above yield); in t the residual is smooth, concave and decreasing, and
    Newton from a start right of the root (the smaller of the one-term solutions (y/3G)^n and
    y/b) decreases monotonically onto it in 2 to 5 evaluations. Returns (d, yield stress,
    hardening term) like `radial_return`."""
    y = seq_trial - a
    inv_n = 1.0 / n
    t = power(y / g3, n)
    if b > 0.0:
        t = min(t, y / b)
    tol = 1e-12 * seq_trial
    d = 0.0
    for _ in range(60):
        d = power(t, inv_n)
        f = y - g3 * d - b * t
        tn = t + f / (g3 * d * inv_n / t + b)
        if abs(f) <= tol or not tn < t:  # converged, or no longer decreasing (round-off)
            break
        t = tn
    return d, a + b * t, a0 + b0 * t


@numba.njit(cache=True, error_model="numpy")
def radial_return(code, mp, k, shear, seq_trial, eps_p, eps_rate, hard, thermal):
    """Plastic strain increment of the radial return to the yield surface (ALGORITHMS.md 2).

    Solves seq_trial - 3 G d_eps - sigma_y(eps_p + d_eps) = 0 for d_eps >= 0, with the element's
    hardening term `hard` = hardening(eps_p) and thermal factor `thermal` (the element kernel
    keeps both per element, so neither costs a pow here). Returns (d_eps, sigma_y at the end,
    hardening term at the end); d_eps = 0 when the trial state is elastic
    (seq_trial <= sigma_y(eps_p)).
    ideal-plastic: d_eps = (seq_trial - Y0) / 3G in closed form.
    Johnson-Cook: the rate and thermal factors are constant during the return (eps_rate and T
    are the step's), so Newton's method runs on the hardening term alone,
    (A + B (eps_p + d)^n) rt: one power per iteration. It starts from the root of the
    residual's quadratic model (`newton_start`), is safeguarded with bisection on
    [0, (seq_trial - sigma_y(eps_p)) / 3G], and stops at |residual| <= 1e-12 seq_trial, or one
    evaluation earlier when the Newton step's own residual is bounded below that
    (`newton_step_converged`; the power at the end then from `power_near`). For an increment
    up to a few per cent of eps_p the start is that close, and the return costs one power.
    At the first yield (eps_p = 0) the iteration runs in t = d^n instead
    (`first_yield_return`).
    """
    if code == P.IDEAL_PLASTIC:
        y0 = mp[k, P.Y0]
        if seq_trial <= y0:
            return 0.0, y0, y0
        return (seq_trial - y0) / (3.0 * shear), y0, y0
    if code != P.JOHNSON_COOK:
        return 0.0, math.inf, math.inf
    rt = rate_factor(code, mp, k, eps_rate) * thermal
    a0 = mp[k, P.JC_A]
    b0 = mp[k, P.JC_B]
    n = mp[k, P.JC_N]
    sy = hard * rt
    if seq_trial <= sy:
        return 0.0, sy, hard
    a = a0 * rt
    b = b0 * rt
    g3 = 3.0 * shear
    if eps_p <= 0.0:
        return first_yield_return(seq_trial, a, b, a0, b0, n, g3)
    hi = (seq_trial - sy) / g3
    lo = 0.0
    d = newton_start(seq_trial, sy, hard, a0, rt, n, g3, eps_p)
    tol = 1e-12 * seq_trial
    curv = b * n * abs(1.0 - n)  # |f''| = curv ep^(n-2)
    pw = 0.0
    for _ in range(30):
        ep = eps_p + d
        pw = power(ep, n)
        sy = a + b * pw
        f = seq_trial - g3 * d - sy
        if abs(f) <= tol:
            return d, sy, a0 + b0 * pw
        if f > 0.0:
            lo = d
        else:
            hi = d
        step = f / (g3 + b * n * pw / ep)
        dn = d + step
        if newton_step_converged(step, ep, curv * pw / (ep * ep), tol) and lo < dn < hi:
            pw = power_near(pw, step / ep, n)
            return dn, a + b * pw, a0 + b0 * pw
        if dn <= lo or dn >= hi:
            dn = 0.5 * (lo + hi)
        d = dn
        if hi - lo <= 1e-15 * (1.0 + eps_p):
            break
    pw = power(eps_p + d, n)
    return d, a + b * pw, a0 + b0 * pw
