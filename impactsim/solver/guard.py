"""The distortion guard's full test, on a block of tets whose corners are already at hand.

The guard (fracture/criteria.py, step 4 of its docstring) flags a cell of a failing material
that would invert within about two steps at the current velocities: six times the volume of
the tet at the positions x + h v, for h = 1.1 dt and 2.2 dt, below 6 GUARD_FRACTION V0. Its
cost is the gather of the four corners' positions and velocities, which the element update
has just made for the same cells with the same x and v (the fracture passes run right after
it; solver/loop.py). So the tet kernel gives the verdicts while the corners are in its
buffer: on each of its vector blocks (``block_verdicts``, solver/element.py's ``_chunk``) and
on the lanes of each masked pass (``masked_verdicts``, ``element._masked_blocks``: damaged,
fractured and mixed blocks), and the criteria gather only the mesh's last, partial block.

``block_verdicts`` is the criteria' full test (``volume6_of``) with the edges and their
velocities taken once for both steps ahead, under the tet kernel's fastmath flags, which it
would take anyway: numba rewrites every floating-point instruction linked into a fastmath
kernel, a callee compiled without them included (measured: the same function, written as
``volume6_of``, gave other bits called from the kernel than from a plain one). So its volumes
may differ from the criteria's own in the last bits, and a verdict may differ only for a cell
within that of the guard's threshold (1 % of V0 two steps ahead: a margin, not a physical
limit). A cell's verdict is the same on any number of threads (each block's arithmetic is).
It is compiled into the kernel's plastic specialisation only (element.element_update). This
module is below both (the solver never imports the fracture passes).

After storing a block the kernel also marks each verdict SPALL_CLEAR where the new stress
keeps Gershgorin's bound of the largest principal stress below the material's spall strength
(``spall_marks``): the criteria's quiet test (fracture/criteria.py ``_quiet``) then need not
read the cell's stress and pressure (56 bytes), nor, for the "lesser" spall pressure, its
nodes' patch pressures. The mark is set with a margin (SPALL_SLACK) far above the difference
the fastmath rounding can make, so a cell the criteria would not pass as quiet is never
marked: the marks change what the criteria read, never what they decide.
"""

from __future__ import annotations

import numba
import numpy as np

GUARD_FRACTION = 0.01  # [-] predicted V / V0 below which the distortion guard removes a cell

# the guard's verdict on a cell (``fracture_criteria`` keeps it in its action array until the
# cell's own action replaces it)
UNKNOWN = -1  # not given: the criteria work it out
CLEARED = 1  # the criteria' pre-test clears the cell
PASSED = 2  # the full test does not flag it (the pre-test, if it ran, did not clear it)
FLAGGED = 3  # the full test flags it

# no verdicts: element_update's guard=None, fracture_criteria's given when the kernel gave none
NONE_GIVEN = np.empty(0, dtype=np.int8)

# a bit the tet kernel adds to a verdict (``spall_marks``): the cell's new stress is clear of
# its material's spall strength, so the criteria need not read it (fracture/criteria.py
# ``_quiet``); VERDICT keeps the verdict itself
SPALL_CLEAR = 8
VERDICT = 7
# the margin of ``spall_marks`` over the rounding of the criteria' own bound, relative to the
# sum of the magnitudes it is made of (their rounding is a few 1e-16 of it)
SPALL_SLACK = 1e-10

LANES = 32  # lanes of a block: the tet kernel's and the criteria' (element.B, criteria.GB)


@numba.njit(cache=True, inline="always")
def volume6_of(x0x, x0y, x0z, x1x, x1y, x1z, x2x, x2y, x2z, x3x, x3y, x3z,
               v0x, v0y, v0z, v1x, v1y, v1z, v2x, v2y, v2z, v3x, v3y, v3z, h):
    """Six times the volume of the tet whose corners are at x_k + h v_k."""
    ax = x1x + h * v1x - x0x - h * v0x
    ay = x1y + h * v1y - x0y - h * v0y
    az = x1z + h * v1z - x0z - h * v0z
    bx = x2x + h * v2x - x0x - h * v0x
    by = x2y + h * v2y - x0y - h * v0y
    bz = x2z + h * v2z - x0z - h * v0z
    cx = x3x + h * v3x - x0x - h * v0x
    cy = x3y + h * v3y - x0y - h * v0y
    cz = x3z + h * v3z - x0z - h * v0z
    return ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)


@numba.njit(cache=True, inline="always")
def volume6_lane(buf, i, h):
    """``volume6_of`` of lane i of a block buffer: row 3k + d (of LANES lanes) the coordinate d
    of corner k, row 12 + 3k + d its velocity (the layout of element.R_X and R_V)."""
    L = LANES
    return volume6_of(
        buf[0 * L + i], buf[1 * L + i], buf[2 * L + i], buf[3 * L + i], buf[4 * L + i],
        buf[5 * L + i], buf[6 * L + i], buf[7 * L + i], buf[8 * L + i], buf[9 * L + i],
        buf[10 * L + i], buf[11 * L + i], buf[12 * L + i], buf[13 * L + i],
        buf[14 * L + i], buf[15 * L + i], buf[16 * L + i], buf[17 * L + i],
        buf[18 * L + i], buf[19 * L + i], buf[20 * L + i], buf[21 * L + i],
        buf[22 * L + i], buf[23 * L + i], h)


# the tet kernel's flags (element.FAST), under which this runs there anyway (module docstring)
FAST = {"nsz", "arcp", "contract", "afn", "reassoc"}


@numba.njit(cache=True, inline="always", fastmath=FAST)
def block_verdicts(buf, vol0, e0, dt, out):
    """The full guard on the LANES cells e0, e0 + 1, ... of a block buffer (rows as
    ``volume6_lane`` reads them) with rest volumes ``vol0``: ``out`` PASSED or FLAGGED. One
    loop over the lanes in SIMD instructions, about 2 ns per tet in the kernel
    (bench_kernel.py, "JC + guard"); unsigned indices, so that numba adds no negative-index
    wraparound."""
    h1, h2 = 1.1 * dt, 2.2 * dt
    for i in range(LANES):
        j = np.uint64(e0 + i)
        out[j] = PASSED if _passes(buf, i, 6.0 * GUARD_FRACTION * vol0[j], h1, h2) else FLAGGED


@numba.njit(cache=True, inline="always", fastmath=FAST)
def masked_verdicts(buf, vol0, e0, dt, out, live):
    """``block_verdicts`` on the lanes of a masked pass of the tet kernel (element._masked_blocks:
    row ``live`` of the buffer 1.0 on the pass's lanes; the other lanes hold another lane's
    corners and keep the verdict they have)."""
    h1, h2 = 1.1 * dt, 2.2 * dt
    for i in range(LANES):
        j = np.uint64(e0 + i)
        if buf[live * LANES + i] != 0.0:
            out[j] = (PASSED if _passes(buf, i, 6.0 * GUARD_FRACTION * vol0[j], h1, h2)
                      else FLAGGED)


@numba.njit(cache=True, inline="always", fastmath=FAST)
def _passes(buf, i, lim, h1, h2):
    """Lane i's full test: six times its volume h1 and h2 ahead both at least ``lim``. The
    edges and their velocities are taken once for both steps ahead (``_volume6_ahead``: the same
    volumes up to rounding, and a quarter less compile time than ``volume6_of`` written out
    twice)."""
    L = LANES
    x0, y0, z0 = buf[0 * L + i], buf[1 * L + i], buf[2 * L + i]
    u0, v0, w0 = buf[12 * L + i], buf[13 * L + i], buf[14 * L + i]
    ax, ay, az = buf[3 * L + i] - x0, buf[4 * L + i] - y0, buf[5 * L + i] - z0
    bx, by, bz = buf[6 * L + i] - x0, buf[7 * L + i] - y0, buf[8 * L + i] - z0
    cx, cy, cz = buf[9 * L + i] - x0, buf[10 * L + i] - y0, buf[11 * L + i] - z0
    dax, day, daz = buf[15 * L + i] - u0, buf[16 * L + i] - v0, buf[17 * L + i] - w0
    dbx, dby, dbz = buf[18 * L + i] - u0, buf[19 * L + i] - v0, buf[20 * L + i] - w0
    dcx, dcy, dcz = buf[21 * L + i] - u0, buf[22 * L + i] - v0, buf[23 * L + i] - w0
    return ((not (_volume6_ahead(ax, ay, az, bx, by, bz, cx, cy, cz, dax, day, daz, dbx, dby,
                                 dbz, dcx, dcy, dcz, h1) < lim))
            & (not (_volume6_ahead(ax, ay, az, bx, by, bz, cx, cy, cz, dax, day, daz, dbx, dby,
                                   dbz, dcx, dcy, dcz, h2) < lim)))


@numba.njit(cache=True, inline="always")
def _volume6_ahead(ax, ay, az, bx, by, bz, cx, cy, cz, dax, day, daz, dbx, dby, dbz, dcx, dcy,
                   dcz, h):
    """Six times the volume of the tet with edges a + h da, b + h db, c + h dc."""
    ax, ay, az = ax + h * dax, ay + h * day, az + h * daz
    bx, by, bz = bx + h * dbx, by + h * dby, bz + h * dbz
    cx, cy, cz = cx + h * dcx, cy + h * dcy, cz + h * dcz
    return ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)


@numba.njit(cache=True, inline="always")
def gershgorin_max(sxx, syy, szz, sxy, syz, szx):
    """Gershgorin's bound of the largest eigenvalue of the symmetric tensor (xx, yy, zz, xy, yz,
    zx): max_i (s_ii + sum_j!=i |s_ij|). The spall tests' (``spall_marks``, and the fracture
    criteria's quiet test and spall pre-check) with the pressure taken off."""
    return max(sxx + abs(sxy) + abs(szx), syy + abs(sxy) + abs(syz), szz + abs(syz) + abs(szx))


@numba.njit(cache=True, inline="always", fastmath=FAST)
def spall_marks(buf, r_s, r_p, spall, e0, out, live):
    """Add SPALL_CLEAR to the verdicts ``out`` of the cells e0, e0 + 1, ... of a block buffer
    whose new deviatoric stress (rows r_s .. r_s + 5: xx, yy, zz, xy, yz, zx) and pressure (row
    r_p) keep Gershgorin's bound of the largest principal stress, max_i (s_ii + sum_j!=i
    |s_ij|) - p, below ``spall`` (the material's spall strength) by SPALL_SLACK of the
    magnitudes: the bound the criteria' quiet test (fracture/criteria.py ``_quiet``) computes
    from the stored stress, which it may then skip. The pressure is the cell's own: the bound
    holds for the spall pressures "cell" and "lesser" (the larger of the cell's and its
    patch's), not for "patch". ``live`` -1: every lane (a full block), else the buffer row that
    is 1.0 on the lanes of a masked pass (the others are left alone). A lane whose bound is
    not finite gets no mark. One loop over the lanes in SIMD instructions."""
    L = LANES
    for i in range(LANES):
        sxx, syy, szz = buf[r_s * L + i], buf[(r_s + 1) * L + i], buf[(r_s + 2) * L + i]
        sxy, syz, szx = buf[(r_s + 3) * L + i], buf[(r_s + 4) * L + i], buf[(r_s + 5) * L + i]
        p = buf[r_p * L + i]
        bound = gershgorin_max(sxx, syy, szz, sxy, syz, szx) - p
        size = abs(sxx) + abs(syy) + abs(szz) + abs(sxy) + abs(syz) + abs(szx) + abs(p)
        clear = bound + SPALL_SLACK * size < spall
        if live >= 0:
            clear &= buf[live * L + i] != 0.0
        j = np.uint64(e0 + i)
        out[j] = out[j] | SPALL_CLEAR if clear else out[j]
