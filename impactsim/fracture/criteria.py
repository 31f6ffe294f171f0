"""Per-element fracture criteria (ALGORITHMS.md 4.1 and 4.2): one kernel over all elements.

Per live element e, after the element update of the step:

1. Spall (fracture/spall.py): an intact element whose tension damages it becomes DAMAGED (the
   element kernel then keeps only bulk compression: zero deviator, p >= 0). The tension is the
   largest principal stress of sigma = s - p I with p from `[fracture] spall_pressure`: the
   larger (less tensile) of the element's own pressure and p_patch ("lesser", the default),
   the element's own ("cell", as [D19]) or p_patch ("patch"); p_patch is the pressure
   averaged over the patch of live elements around the element's nodes (`patch_fields`:
   volume-weighted nodal means, then the mean of the element's nodes). The criterion is the
   Tuler-Butcher impulse integral for materials with a spall time (`[fracture]
   spall_criterion = "tuler-butcher"`, the default) or the instantaneous threshold of [D19].
   The linear tet's own pressure carries the checkerboard mode of volumetric locking: single
   tets of a Taylor bar's foot sit far in tension inside a compressed foot, for tens of
   microseconds (a 4340 bar at 343 m/s: 12 GPa, 27 us), which no time integral filters; their
   patch is not in that tension. A tension both the cell and its patch carry that lasts only
   a fraction of a microsecond (the lateral release converging on a fast 6061-T6 bar's axis)
   is filtered by the time integral. docs/fracture.md has the measurements.
2. Loosening: a damaged element with chi = 1 - V0/V > chi* becomes FRACTURED (zero pressure):
   the cell's own opening, as in [D19] (a crack opens one cell, not a patch).
2b. Johnson-Cook damage (fracture/ductile.py), for materials with erosion = "jc-damage" or
   with failure.jc_damage and the ductile criterion (params.DUCTILE): D += d eps_p / eps_f
   with eps_f = (D1 + D2 exp(D3 s*)) (1 + D4 ln max(eps_dot*, 1)) (1 + D5 T*), s* = -p /
   sigma_eq the stress triaxiality (capped at 1.5 as usual, where the fit is unreliable), T*
   the homologous temperature of the strength model. Under the ductile criterion no damage
   accumulates at s* <= -1/3, and an intact cell whose D reaches 1 becomes DAMAGED (then
   loosening, step 2, as after spall); it runs before loosening so that such a cell that has
   opened loosens in the same step.
3b. Melt and runaway strain (materials with failure data): a cell within 1 % of the melt
   temperature of its strength model (T* >= MELT_SHARE; no strength left: the Johnson-Cook law
   ends there, and heating stops short of T_melt as the strength vanishes) or
   with a plastic strain above MAX_PLASTIC_STRAIN is no longer a solid the tet can represent;
   on the surface it becomes particles (mass, momentum and energy kept) like a fractured cell
   (``MELT``, counted apart). Left in the mesh such cells at a Taylor bar's rim were stretched
   into slivers that set the step to 0.6 ns.
4. What leaves the mesh this step (``action``):
   PARTICLE  a FRACTURED element with a face on the body surface (4.1: one or several particles),
             unless the material's erosion criterion is "fractured" (then it erodes); also an
             element of a material with failure data whose face neighbours have all left the
             mesh (a one-cell fragment). [D19] do not say what becomes of such a cell. Kept as a
             tet, nothing holds it any more: the spread of its four nodes' velocities stretches
             it into a sliver (plastic strain 10-20 in sphere-plate) whose smallest altitude
             throttled the time step of the whole run to about 1 ns, a quarter of what the
             rest of the mesh allowed. As particles it keeps its mass, momentum and energy
             (removal.py) and flies as the debris around it does;
   ERODE     the material's erosion criterion holds (plastic strain, JC damage D >= value,
             maximum principal strain, or the fractured state) in an element on the surface
             (``surface_only``, as [R20] does) or anywhere;
   GUARD     distortion guard (materials with failure data only): the element would invert
             (volume below GUARD_FRACTION of V0) within about two steps at the current
             velocities. It is eroded like ERODE; without it, a fractured cell (no pressure)
             crushed between its neighbours stops the run.
Only one layer leaves per step: an element exposed by this step's deletions is judged next step
(a disturbance spreads one cell per step, as in the contact passes).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from impactsim.fracture.ductile import damage_increment, ductile, fracture_strain, triaxiality
from impactsim.fracture.principal import max_principal, max_principal_stretch
from impactsim.fracture.spall import SPALL_CELL, SPALL_PATCH, spall_pressure, spalls
from impactsim.materials import params as P
from impactsim.model import DAMAGED, ERODED, FRACTURED, INTACT
from impactsim.solver.guard import (CLEARED, FLAGGED, GUARD_FRACTION, LANES, PASSED,
                                    SPALL_CLEAR, UNKNOWN, VERDICT, gershgorin_max, volume6_lane,
                                    volume6_of)

NONE, PARTICLE, ERODE, GUARD, MELT = 0, 1, 2, 3, 4
MAX_PLASTIC_STRAIN = 200.0  # [-] a cell strained beyond this leaves the mesh (3b)
# [-] homologous temperature T* at which a cell counts as molten (3b): adiabatic heating is
# beta sigma_y d eps_p and sigma_y vanishes as T* -> 1, so the melt temperature is approached,
# never reached (sphere-plate: rim cells at 774.99... K of 775 K with plastic strains of 66-166
# set the step to 0.24 ns)
MELT_SHARE = 0.99


@numba.njit(cache=True, inline="always")
def _volume6(x, v, h, i0, i1, i2, i3):
    """Six times the volume of the tet at positions x + h v."""
    return volume6_of(x[i0, 0], x[i0, 1], x[i0, 2], x[i1, 0], x[i1, 1], x[i1, 2],
                       x[i2, 0], x[i2, 1], x[i2, 2], x[i3, 0], x[i3, 1], x[i3, 2],
                       v[i0, 0], v[i0, 1], v[i0, 2], v[i1, 0], v[i1, 1], v[i1, 2],
                       v[i2, 0], v[i2, 1], v[i2, 2], v[i3, 0], v[i3, 1], v[i3, 2], h)


# Margins of the guard's pre-test (``guard_clear``) over the rounding of the full test: the
# node-velocity spread is inflated by GUARD_SPREAD_SLACK (relative) plus GUARD_POSITION_SLACK
# times the largest coordinate (the full test rounds x + h v at that scale), and the bound
# by GUARD_ROUND_SLACK times the cube of the (grown) longest edge (the rounding of a 3x3
# determinant is a few 1e-16 of it). Each is a thousand times or more what it covers.
GUARD_SPREAD_SLACK = 1e-6
GUARD_POSITION_SLACK = 1e-12
GUARD_ROUND_SLACK = 1e-10


@numba.njit(cache=True)
def guard_reach(x, v, h):
    """How far [m] two nodes of a tet can move relative to each other within time h at the
    velocities v, inflated by the pre-test's margins (``guard_clear``): 2 R h with R the
    radius of the bounding box of all node velocities (|v_i - w| <= R with w its centre), plus
    the rounding scale of the positions x + h v. nan when a velocity or position is not finite (then every
    pre-test fails and the full guard runs). One serial pass over the nodes (exact: min and max
    only, the same on any thread count)."""
    n = v.shape[0]
    if n == 0:
        return 0.0
    lo0, lo1, lo2 = v[0, 0], v[0, 1], v[0, 2]
    hi0, hi1, hi2 = lo0, lo1, lo2
    xa = 0.0
    va = 0.0
    bad = 0.0
    for i in range(n):
        a, b, c = v[i, 0], v[i, 1], v[i, 2]
        lo0 = min(lo0, a)
        lo1 = min(lo1, b)
        lo2 = min(lo2, c)
        hi0 = max(hi0, a)
        hi1 = max(hi1, b)
        hi2 = max(hi2, c)
        xa = max(xa, max(abs(x[i, 0]), max(abs(x[i, 1]), abs(x[i, 2]))))
        va = max(va, max(abs(a), max(abs(b), abs(c))))
        bad += (a + b + c + x[i, 0] + x[i, 1] + x[i, 2]) * 0.0
    r0, r1, r2 = 0.5 * (hi0 - lo0), 0.5 * (hi1 - lo1), 0.5 * (hi2 - lo2)
    reach = (2.0 * math.sqrt(r0 * r0 + r1 * r1 + r2 * r2) * h * (1.0 + GUARD_SPREAD_SLACK)
             + GUARD_POSITION_SLACK * (xa + h * va))
    return reach + bad


GUARD_K = 10.0  # [-] the length scale K * reach of the pre-test's square-root-free bounds


@numba.njit(cache=True, inline="always")
def guard_clear(x, i0, i1, i2, i3, reach, inv, lim):
    """The distortion guard's pre-test: True only when the full test (``_volume6`` at
    positions x + h v, h = 1.1 dt and 2.2 dt, below lim) cannot flag the tet; ``inv`` is
    1 / (2 GUARD_K reach). With edges a, b, c from node i0, each moving by at most
    r = ``reach`` (``guard_reach`` for h = 2.2 dt), six times the volume changes by at most
    (expanding the determinant by multilinearity)
        r (|b x c| + |c x a| + |a x b|) + r^2 (|a| + |b| + |c|) + r^3.
    Square-root free: the first sum is at most sqrt(3 F), F the sum of the three squared
    face vectors (Cauchy-Schwarz; nearly tight on a well-shaped tet), compared squared; the
    second, by |a| <= |a|^2 / (2k) + k / 2 with k = GUARD_K r, at most E / (2k) + 3 k / 2, E
    the sum of the squared edges; the rounding of both tests is covered by GUARD_ROUND_SLACK
    (E + r^2)^(3/2), bounded the same way. Reads the four nodes' positions only (the full test
    also reads their velocities and evaluates two determinants): far from inversion, as
    nearly every cell is, one gather and one determinant decide. False for a non-finite or
    zero reach."""
    ax = x[i1, 0] - x[i0, 0]
    ay = x[i1, 1] - x[i0, 1]
    az = x[i1, 2] - x[i0, 2]
    bx = x[i2, 0] - x[i0, 0]
    by = x[i2, 1] - x[i0, 1]
    bz = x[i2, 2] - x[i0, 2]
    cx = x[i3, 0] - x[i0, 0]
    cy = x[i3, 1] - x[i0, 1]
    cz = x[i3, 2] - x[i0, 2]
    return _clear_bound(ax, ay, az, bx, by, bz, cx, cy, cz, reach, inv, lim)


@numba.njit(cache=True, inline="always")
def _clear_bound(ax, ay, az, bx, by, bz, cx, cy, cz, reach, inv, lim):
    """``guard_clear`` on the edges a, b, c of a tet from its first corner (no branch)."""
    bcx = by * cz - bz * cy
    bcy = bz * cx - bx * cz
    bcz = bx * cy - by * cx
    cax = cy * az - cz * ay
    cay = cz * ax - cx * az
    caz = cx * ay - cy * ax
    abx = ay * bz - az * by
    aby = az * bx - ax * bz
    abz = ax * by - ay * bx
    v6 = ax * bcx + ay * bcy + az * bcz
    f2 = (bcx * bcx + bcy * bcy + bcz * bcz + cax * cax + cay * cay + caz * caz
          + abx * abx + aby * aby + abz * abz)
    e2 = ax * ax + ay * ay + az * az + bx * bx + by * by + bz * bz + cx * cx + cy * cy + cz * cz
    r = reach
    k = GUARD_K * r
    g2 = e2 + r * r
    rest = (r * r * (e2 * inv + 1.5 * k) + r * r * r
            + GUARD_ROUND_SLACK * g2 * (g2 * inv + 0.5 * k))
    d = v6 - lim - rest
    return (d > 0.0) & (d * d > 3.0000001 * r * r * f2)


@numba.njit(cache=True, inline="always")
def jc_fracture_strain(mat_params, mk, pressure, seq, rate, temperature):
    """Johnson-Cook (1985) fracture strain eps_f at triaxiality -p/seq (capped at 1.5), rate
    and temperature (fracture/ductile.py)."""
    return fracture_strain(mat_params, mk, triaxiality(pressure, seq), rate, temperature)


@numba.njit(cache=True, parallel=True)
def patch_fields(vol, vol0, pressure, status, n2e_ptr, n2e, pnode, jnode, corners):
    """Nodal means over the live elements around each node: pressure pnode_i = sum V_e p_e /
    sum V_e and volume ratio jnode_i = sum V_e / sum V0_e (1 and 0 at a node without any).
    n2e: entries e * corners + local corner (4 for tets, 8 for a hex block)."""
    for i in numba.prange(pnode.shape[0]):
        vs = 0.0
        v0s = 0.0
        ps = 0.0
        for k in range(n2e_ptr[i], n2e_ptr[i + 1]):
            e = n2e[k] // corners
            if status[e] != ERODED:
                vs += vol[e]
                v0s += vol0[e]
                ps += vol[e] * pressure[e]
        pnode[i] = ps / vs if vs > 0.0 else 0.0
        jnode[i] = vs / v0s if v0s > 0.0 else 1.0


@numba.njit(cache=True, inline="always")
def element_state(e, mk, st, p, sdev, vol, vol0, eps_p, eps_p_prev, damage, eps_rate,
                  temperature, mat_params, dt, spall_k, integrate):
    """Steps 1-3 of the module docstring for live element e of any type (the per-element
    arrays of the tets and of a hex block have one layout): spall with the pressure p
    (``spall.spalls``: the Tuler-Butcher integral spall_k[e] when integrate), loosening,
    Johnson-Cook damage (updates damage[e] and eps_p_prev[e]). Returns (status, newly damaged:
    0, 1 by spall or 2 by the ductile criterion, newly fractured 0/1)."""
    dam = 0
    frac = 0
    sxx, syy, szz = sdev[e, 0], sdev[e, 1], sdev[e, 2]
    sxy, syz, szx = sdev[e, 3], sdev[e, 4], sdev[e, 5]
    spall = mat_params[mk, P.SPALL]
    # Gershgorin's bound on the largest principal stress first: most cells are far below
    # the spall strength and skip the closed-form eigenvalue
    if st == INTACT and gershgorin_max(sxx, syy, szz, sxy, syz, szx) - p > spall:
        if spalls(e, mk, max_principal(sxx - p, syy - p, szz - p, sxy, syz, szx), dt, spall_k,
                  mat_params, integrate):
            st = DAMAGED
            dam = 1
    code = int(mat_params[mk, P.EROSION])
    duct = ductile(mat_params, mk)
    deps = eps_p[e] - eps_p_prev[e]
    eps_p_prev[e] = eps_p[e]
    if (code == 2 or duct) and deps > 0.0:
        seq = math.sqrt(1.5 * (sxx * sxx + syy * syy + szz * szz)
                        + 3.0 * (sxy * sxy + syz * syz + szx * szx))
        damage[e] += damage_increment(mat_params, mk, deps, p, seq, eps_rate[e],
                                      temperature[e], duct)
    if duct and st == INTACT and damage[e] >= 1.0:
        st = DAMAGED  # ductile fracture (fracture/ductile.py): as spall damages it
        dam = 2
    if st == DAMAGED and 1.0 - vol0[e] / vol[e] > mat_params[mk, P.CHI_STAR]:
        st = FRACTURED
        frac = 1
    return st, dam, frac


@numba.njit(cache=True, inline="always")
def failing_material(mat_params, mk):
    """True for a material with failure data (an erosion criterion, spall or loosening)."""
    return (int(mat_params[mk, P.EROSION]) != 0 or mat_params[mk, P.SPALL] < math.inf
            or mat_params[mk, P.CHI_STAR] < math.inf)


@numba.njit(cache=True, inline="always")
def element_action(e, mk, st, on_surface, lone, surface_only, eps_p, damage, temperature,
                   mat_params, stretch):
    """Step 4 of the module docstring but the distortion guard, for element e of any type:
    PARTICLE, MELT, ERODE or NONE. on_surface: a face of it is free; lone: every face is free
    and it had a face neighbour at t = 0 (a one-cell fragment); stretch: its largest principal
    stretch (read only for erosion = "principal-strain")."""
    code = int(mat_params[mk, P.EROSION])
    failing = failing_material(mat_params, mk)
    act = NONE
    if st == FRACTURED and on_surface and code != 4:
        act = PARTICLE
    elif failing and on_surface and (
            temperature[e] >= mat_params[mk, P.T_ROOM] + MELT_SHARE * (
                mat_params[mk, P.T_MELT] - mat_params[mk, P.T_ROOM])
            or eps_p[e] > MAX_PLASTIC_STRAIN):
        act = MELT  # molten or runaway strain (3b): particles
    elif failing and lone:
        act = PARTICLE  # a one-cell fragment: every face neighbour has left the mesh
    elif code != 0 and (on_surface or not surface_only):
        val = mat_params[mk, P.EROSION_VALUE]
        if code == 1:
            hit = eps_p[e] >= val
        elif code == 2:
            hit = damage[e] >= val
        elif code == 3:
            hit = stretch - 1.0 >= val
        else:
            hit = st == FRACTURED
        if hit:
            act = ERODE
    return act


# The guard of ``fracture_criteria`` runs on blocks of GB cells: their corners are copied into a
# buffer of GUARD_ROWS x GB doubles (6.6 kB, in the first-level cache), on which one loop
# evaluates the guard for every lane in SIMD instructions (``_guard_clear_block``,
# ``_guard_full_block``: separate kernels, since LLVM vectorises a loop whose only memory is
# the buffer and whose trip count is a constant, as in solver/element.py)
GB = LANES  # the tet kernel's blocks (solver/guard.py gives its verdicts on them)
R_LIM = 24  # row of 6 GUARD_FRACTION V0
R_OK = 25  # row of a block kernel's verdict: 1.0 it clears (passes) the cell, else 0.0
R_CLEAR = 26  # the pre-test's verdict, kept while the full test runs on the block
GUARD_ROWS = 27
GROUP_BLOCKS = 64  # blocks per task of the threads (one buffer each)


@numba.njit(cache=True, inline="always")
def _gather_block(x, v, conn, vol0, e0, buf, with_x, with_v):
    """Copy the corners' positions (with_x, and the limit row R_LIM) and velocities (with_v) of
    the cells e0 .. e0 + GB - 1 into buf: row 3k + d the coordinate d of corner k, row
    12 + 3k + d its velocity. Through views of the block and unsigned node indices (no
    negative-index wraparound: solver/element.py's _load_block)."""
    cn = conn[e0:e0 + GB]
    if with_x:
        v0 = vol0[e0:e0 + GB]
        for i in range(GB):
            buf[R_LIM * GB + i] = 6.0 * GUARD_FRACTION * v0[i]
            for k in range(4):
                n = np.uint64(cn[i, k])
                for d in range(3):
                    buf[(3 * k + d) * GB + i] = x[n, d]
    if with_v:
        for i in range(GB):
            for k in range(4):
                n = np.uint64(cn[i, k])
                for d in range(3):
                    buf[(12 + 3 * k + d) * GB + i] = v[n, d]


# the guard's verdict on a cell (solver/guard.py: UNKNOWN, CLEARED, PASSED, FLAGGED), as
# ``fracture_criteria`` keeps it in ``action`` for ``_criteria_one`` (UNKNOWN: the full
# criteria work it out); a verdict the tet kernel gave may carry its SPALL_CLEAR mark, which
# the second loop takes off


@numba.njit(cache=True, inline="always")
def _all_given(given, e0):
    """True when the kernel gave the guard's verdict on every cell of block e0."""
    known = True
    for i in range(GB):
        known &= given[e0 + i] != UNKNOWN
    return known


@numba.njit(cache=True, inline="always")
def _guard_verdicts(x, v, conn, vol0, e0, buf, pretest, reach, inv, h1, h2, out):
    """The guard's verdicts (CLEARED, PASSED, FLAGGED) on the cells e0 .. e0 + GB - 1 into out:
    with the pre-test, on the positions alone, and where it leaves a lane the full test on the
    whole block; without, the full test."""
    left = GB
    if not pretest:
        _gather_block(x, v, conn, vol0, e0, buf, True, True)
    else:
        _gather_block(x, v, conn, vol0, e0, buf, True, False)
        left = _guard_clear_block(buf, reach, inv)
        if left:
            for i in range(GB):
                buf[R_CLEAR * GB + i] = buf[R_OK * GB + i]
            _gather_block(x, v, conn, vol0, e0, buf, False, True)
        else:
            for i in range(GB):
                out[i] = CLEARED
    if left:
        _guard_full_block(buf, h1, h2)
        for i in range(GB):
            full = PASSED if buf[R_OK * GB + i] != 0.0 else FLAGGED
            out[i] = CLEARED if pretest and buf[R_CLEAR * GB + i] != 0.0 else full


@numba.njit(cache=True)
def _guard_clear_block(buf, reach, inv):
    """The pre-test ``guard_clear`` on every lane of buf (same operations, same bits): R_OK
    1.0 where it clears the cell. Returns how many lanes it does not clear."""
    left = 0
    for i in range(GB):
        x0x, x0y, x0z = buf[0 * GB + i], buf[1 * GB + i], buf[2 * GB + i]
        ok = _clear_bound(buf[3 * GB + i] - x0x, buf[4 * GB + i] - x0y, buf[5 * GB + i] - x0z,
                          buf[6 * GB + i] - x0x, buf[7 * GB + i] - x0y, buf[8 * GB + i] - x0z,
                          buf[9 * GB + i] - x0x, buf[10 * GB + i] - x0y,
                          buf[11 * GB + i] - x0z, reach, inv, buf[R_LIM * GB + i])
        buf[R_OK * GB + i] = 1.0 if ok else 0.0
        left += 0 if ok else 1
    return left


@numba.njit(cache=True)
def _guard_full_block(buf, h1, h2):
    """The full guard (``_volume6`` at h1 = 1.1 dt and h2 = 2.2 dt against the limit) on every
    lane of buf: R_OK 1.0 where it does not flag the cell."""
    for i in range(GB):
        lim = buf[R_LIM * GB + i]
        ok = ((not (volume6_lane(buf, i, h1) < lim))
              & (not (volume6_lane(buf, i, h2) < lim)))
        buf[R_OK * GB + i] = 1.0 if ok else 0.0


# columns of the per-material table of ``_quiet`` (``_quiet_table``)
Q_SPALL, Q_VAL, Q_FAIL, Q_DUCT, Q_ERO_IN, Q_ERO_SURF, Q_MELT = 0, 1, 2, 3, 4, 5, 6
Q_COLS = 7


@numba.njit(cache=True, inline="always")
def _quiet_table(mat_params, surface_only, mq):
    """Fill mq (n_mat, Q_COLS): spall strength, erosion value, failure data (1.0/0.0), ductile
    criterion (1.0/0.0), the erosion criterion's code inside the body and on its surface (0
    where it cannot hold for an intact cell: none, or "fractured"), the melt temperature of
    step 3b (as ``element_action`` computes it)."""
    for m in range(mat_params.shape[0]):
        code = int(mat_params[m, P.EROSION])
        code = 0 if code == 4 else code
        mq[m, Q_SPALL] = mat_params[m, P.SPALL]
        mq[m, Q_VAL] = mat_params[m, P.EROSION_VALUE]
        mq[m, Q_FAIL] = 1.0 if failing_material(mat_params, m) else 0.0
        mq[m, Q_DUCT] = 1.0 if ductile(mat_params, m) else 0.0
        mq[m, Q_ERO_IN] = 0.0 if surface_only else code
        mq[m, Q_ERO_SURF] = code
        mq[m, Q_MELT] = mat_params[m, P.T_ROOM] + MELT_SHARE * (
            mat_params[m, P.T_MELT] - mat_params[m, P.T_ROOM])


@numba.njit(cache=True, inline="always")
def _quiet(e, mk, status, sdev, pressure, spall_mode, conn, pnode, eps_p, eps_p_prev, damage,
           temperature, face_flag, mq, guard_ok, spall_clear):
    """True only for a cell on which the full criteria (``_criteria_one``) change nothing and
    take no action: intact, its plastic strain unchanged since the last call (no damage
    increment; eps_p_prev already equal), Gershgorin's spall bound (with the pressure spall
    reads) not above the spall strength, no erosion criterion met where it applies, for the
    ductile criterion damage below 1, and for a material with failure data a guard that does
    not flag it (guard_ok: the block's verdict) and, on the surface, neither molten nor
    strained beyond MAX_PLASTIC_STRAIN nor with all four faces free (a possible one-cell
    fragment: the full criteria decide). spall_clear: the tet kernel found the bound clear
    (solver/guard.py ``spall_marks``), and the stress and pressure are not read. mq:
    ``_quiet_table``. The tests in the order that rejects a cell soonest."""
    if status[e] != INTACT:
        return False
    ep = eps_p[e]
    if not ep == eps_p_prev[e]:
        return False
    fail = mq[mk, Q_FAIL] != 0.0
    if fail and not guard_ok:
        return False
    if not spall_clear:
        p = pressure[e]
        if spall_mode != SPALL_CELL:
            p = spall_pressure(spall_mode, p, 0.25 * (
                pnode[conn[e, 0]] + pnode[conn[e, 1]] + pnode[conn[e, 2]] + pnode[conn[e, 3]]))
        sxx, syy, szz = sdev[e, 0], sdev[e, 1], sdev[e, 2]
        sxy, syz, szx = sdev[e, 3], sdev[e, 4], sdev[e, 5]
        if gershgorin_max(sxx, syy, szz, sxy, syz, szx) - p > mq[mk, Q_SPALL]:
            return False
    f0, f1 = face_flag[4 * e], face_flag[4 * e + 1]
    f2, f3 = face_flag[4 * e + 2], face_flag[4 * e + 3]
    surf = f0 or f1 or f2 or f3
    ero = mq[mk, Q_ERO_SURF] if surf else mq[mk, Q_ERO_IN]
    if ero == 3.0 or (ero == 1.0 and ep >= mq[mk, Q_VAL]):
        return False
    duct = mq[mk, Q_DUCT] != 0.0
    if ero == 2.0 or duct:
        d = damage[e]
        if (ero == 2.0 and d >= mq[mk, Q_VAL]) or (duct and d >= 1.0):
            return False
    if surf and fail:
        if temperature[e] >= mq[mk, Q_MELT] or ep > MAX_PLASTIC_STRAIN or (f0 and f1 and f2
                                                                           and f3):
            return False
    return True


@numba.njit(cache=True, inline="always")
def _criteria_one(e, x, v, x0, conn, elem_mat, status, sdev, pressure, vol, vol0, eps_p,
                  eps_p_prev, damage, eps_rate, temperature, mat_params, face_flag, adj,
                  surface_only, dt, action, spall_mode, pnode, spall_k, integrate, pretest,
                  reach, inv, verdict):
    """The full criteria on element e (module docstring): sets status[e] and action[e];
    returns (newly damaged 0/1, by the ductile criterion 0/1, newly fractured 0/1, guard
    tested 0/1, cleared by the pre-test 0/1). verdict: the guard's (``_guard_verdicts``:
    CLEARED, PASSED or FLAGGED) when known, else -1."""
    action[e] = NONE
    st = status[e]
    if st == ERODED:
        return 0, 0, 0, 0, 0
    mk = elem_mat[e]
    i0, i1, i2, i3 = conn[e, 0], conn[e, 1], conn[e, 2], conn[e, 3]
    p = pressure[e]
    if spall_mode != SPALL_CELL:
        p = spall_pressure(spall_mode, p, 0.25 * (pnode[i0] + pnode[i1] + pnode[i2]
                                                 + pnode[i3]))
    st, dam, frac = element_state(e, mk, st, p, sdev, vol, vol0, eps_p, eps_p_prev, damage,
                                  eps_rate, temperature, mat_params, dt, spall_k, integrate)
    status[e] = st
    on_surface = (face_flag[4 * e] or face_flag[4 * e + 1] or face_flag[4 * e + 2]
                  or face_flag[4 * e + 3])
    lone = (face_flag[4 * e] and face_flag[4 * e + 1] and face_flag[4 * e + 2]
            and face_flag[4 * e + 3] and (adj[e, 0] >= 0 or adj[e, 1] >= 0
                                          or adj[e, 2] >= 0 or adj[e, 3] >= 0))
    stretch = 1.0
    if int(mat_params[mk, P.EROSION]) == 3:
        stretch = max_principal_stretch(x, x0, i0, i1, i2, i3)
    act = element_action(e, mk, st, on_surface, lone, surface_only, eps_p, damage,
                         temperature, mat_params, stretch)
    tested = 0
    cleared = 0
    if act == NONE and failing_material(mat_params, mk):
        lim = 6.0 * GUARD_FRACTION * vol0[e]
        tested = 1
        if pretest and (verdict == CLEARED if verdict >= 0
                        else guard_clear(x, i0, i1, i2, i3, reach, inv, lim)):
            cleared = 1
        elif (verdict == FLAGGED if verdict >= 0
              else (_volume6(x, v, 1.1 * dt, i0, i1, i2, i3) < lim
                    or _volume6(x, v, 2.2 * dt, i0, i1, i2, i3) < lim)):
            act = GUARD
    action[e] = act
    return 1 if dam > 0 else 0, 1 if dam == 2 else 0, frac, tested, cleared


# parfor fusion off: its two loops run over different ranges (blocks, cells) and never fuse,
# but numba's fusion pass over this large inlined body took 7.6 of its 30 s of compiling (the
# warm-up's longest kernel; docs/performance.md "First run"); the code and results are the same
@numba.njit(cache=True, parallel={"fusion": False})
def fracture_criteria(x, v, x0, conn, elem_mat, status, sdev, pressure, vol, vol0, eps_p,
                      eps_p_prev, damage, eps_rate, temperature, mat_params, face_flag, adj,
                      surface_only, dt, action, spall_mode, pnode, jnode, spall_k, integrate,
                      reach, given):
    """Apply spall and loosening to ``status`` and decide ``action (e,) int8`` (module docstring).

    face_flag (4e,) bool free faces and adj (e,4) face neighbours at t = 0 (-1: none)
    (impactsim.fracture.boundary.Boundary). spall_mode (spall.PRESSURE_CODES): the pressure
    spall reads, from the element's own and p_patch from pnode (n_node,), the nodal means of
    `patch_fields` (not read for "cell"; jnode is not read). spall_k (e,) the Tuler-Butcher
    accumulators, integrate: `[fracture] spall_criterion = "tuler-butcher"` (spall.py).
    eps_p_prev (e,) plastic strain at the previous call (updated here). ``reach``: the guard's
    pre-test reach (``guard_reach`` for h = 2.2 dt), or inf to run the full guard alone.
    ``given`` (e,) int8, or empty: the guard's verdicts the tet kernel gave in this step's
    element update (solver/guard.py, on the same x, v and dt), UNKNOWN where it gave none.
    Returns (newly damaged, newly fractured, elements with an action, newly damaged by the
    ductile criterion, cells the guard tested, of them cleared by the pre-test).

    Two passes. Per block of GB elements the guard's verdict on every cell: the kernel's, where
    it gave them for the whole block, else in SIMD instructions here (``_guard_verdicts``: the
    pre-test, and where it leaves a lane or rests the full test on the whole block); then per
    cell: one on which the full criteria would change nothing and take no action (``_quiet``:
    far from the impact, nearly all) costs a few tests (the spall bound's from the kernel's
    mark, ``guard.spall_marks``, where it gave one and the spall pressure is the cell's or the
    lesser one), the others run the full criteria with the verdict (``_criteria_one``), whose
    pointwise steps (``element_state``, ``element_action``) are shared with the hexes' kernel
    (impactsim.fracture.hexes). The same statuses, actions, accumulators and counts as the full
    criteria on every cell (tests/unit/test_fracture_screen.py).
    """
    n_elem = conn.shape[0]
    mq = np.empty((mat_params.shape[0], Q_COLS))
    _quiet_table(mat_params, surface_only, mq)
    pretest = reach < math.inf  # the guard's pre-test (guard_clear); nan: it clears nothing
    inv = 1.0 / (2.0 * GUARD_K * reach) if reach > 0.0 else math.inf
    h1, h2 = 1.1 * dt, 2.2 * dt
    n_dam = 0
    n_frac = 0
    n_act = 0
    n_duct = 0
    n_guard = 0
    n_clear = 0
    # first the guard's verdict on every cell of the full blocks, in SIMD instructions, kept in
    # action until the cell's own action replaces it (UNKNOWN: the mesh's last block), the
    # tet kernel's where it gave them for a whole block
    n_blk = n_elem // GB
    n_grp = (n_blk + GROUP_BLOCKS - 1) // GROUP_BLOCKS
    has_given = given.shape[0] != 0
    for grp in numba.prange(n_grp):
        buf = np.empty(GUARD_ROWS * GB)
        for blk in range(grp * GROUP_BLOCKS, min(n_blk, (grp + 1) * GROUP_BLOCKS)):
            e0 = blk * GB
            if has_given and _all_given(given, e0):
                for i in range(GB):
                    action[e0 + i] = given[e0 + i]
            else:
                _guard_verdicts(x, v, conn, vol0, e0, buf, pretest, reach, inv, h1, h2,
                                action[e0:e0 + GB])
    for e in range(n_blk * GB, n_elem):
        action[e] = UNKNOWN
    # the kernel's mark of a clear spall bound holds for the cell's own pressure and for the
    # larger of it and the patch's ("cell", "lesser"), not for the patch's alone
    marks = spall_mode != SPALL_PATCH
    for e in numba.prange(n_elem):
        verdict = int(action[e])
        mk = elem_mat[e]
        clear = False
        if verdict >= 0:
            clear = marks and (verdict & SPALL_CLEAR) != 0
            verdict &= VERDICT
        if verdict >= 0 and _quiet(e, mk, status, sdev, pressure, spall_mode, conn, pnode,
                                   eps_p, eps_p_prev, damage, temperature, face_flag, mq,
                                   verdict != FLAGGED, clear):
            action[e] = NONE
            if mq[mk, Q_FAIL] != 0.0:
                n_guard += 1
                n_clear += 1 if verdict == CLEARED else 0
            continue
        dam, duct, frac, tested, cleared = _criteria_one(
            e, x, v, x0, conn, elem_mat, status, sdev, pressure, vol, vol0, eps_p, eps_p_prev,
            damage, eps_rate, temperature, mat_params, face_flag, adj, surface_only, dt, action,
            spall_mode, pnode, spall_k, integrate, pretest, reach, inv, verdict)
        n_dam += dam
        n_duct += duct
        n_frac += frac
        n_guard += tested
        n_clear += cleared
        n_act += 1 if action[e] != NONE else 0
    return n_dam, n_frac, n_act, n_duct, n_guard, n_clear


class GuardPretest:
    """Whether the distortion guard's pre-test (``guard_clear``, ``hexes.hex_clear``) runs.

    Its bound grows with the spread of all node velocities: where that is large against the
    cells (a 2 km/s projectile through 0.5 mm cells, sphere-plate) it clears few cells, which
    then pay for it and for the full test. So the pre-test runs while it clears at least
    MIN_SHARE of the cells the guard tests in a step; below that it rests for PROBE steps and is
    tried again. The actions are the full guard's either way (the pre-test only skips cells
    the full test cannot flag), so this decides cost only, never a result; the counts, and so
    the decisions, are the same on any number of threads."""

    MIN_SHARE = 0.5
    PROBE = 50

    def __init__(self):
        self.on = True
        self.idle = 0
        self.tested = 0
        self.cleared = 0

    def reach(self, model, dt) -> float:
        """The reach for a kernel about to run (``guard_reach`` for h = 2.2 dt, from the
        velocities as they are then: a removal before it may have changed some), inf while the
        pre-test rests."""
        return float(guard_reach(model.x, model.v, 2.2 * dt)) if self.on else math.inf

    def count(self, tested: int, cleared: int) -> None:
        """Add a kernel's counts of cells the guard tested and the pre-test cleared."""
        self.tested += int(tested)
        self.cleared += int(cleared)

    def end_step(self) -> None:
        """After the step's kernels: keep the pre-test, rest it, or try it again."""
        if self.on:
            if self.tested and self.cleared < self.MIN_SHARE * self.tested:
                self.on = False
                self.idle = 0
        else:
            self.idle += 1
            self.on = self.idle >= self.PROBE
        self.tested = self.cleared = 0


@numba.njit(cache=True)
def action_ids(action, out):
    """Ascending indices of the elements with an action, written to ``out``; returns how many."""
    k = 0
    for e in range(action.shape[0]):
        if action[e] != NONE:
            out[k] = e
            k += 1
    return k
