"""The distortion guard's verdicts the tet kernel gives (solver/guard.py) are the criteria's own.

The kernel tests the cells of its full blocks while it has their corners in its buffer: the
blocks of intact tets of one material on its vector path, the others lane by lane in its masked
passes (one per material, damaged, fractured and inverting cells included); the fracture
criteria then take those verdicts instead of gathering the corners again. Asserted on the
screen test's state (cells in runs of one material, damaged, fractured and eroded ones, some
crushed near GUARD_FRACTION of V0), on 1 and 2 threads:
- every verdict the kernel gives on a cell that is not eroded is the full test's, evaluated one
  cell at a time with the criteria's ``_volume6``, except for cells put on the guard's threshold
  (where a verdict turns on the last bit of a volume, and the kernel's fastmath rounding may
  decide otherwise): those may differ only within ROUNDING of the threshold;
- an eroded cell gets PASSED (the criteria pass it by), the mesh's partial last block nothing;
- with the threshold cells moved off it, ``fracture_criteria`` with the given verdicts leaves
  the statuses, actions, damage and counts of the criteria that give their own, bit for bit,
  on the state the kernel's step left (the criteria run right after it).

The kernel also marks each verdict SPALL_CLEAR where the new stress keeps Gershgorin's bound
of the largest principal stress below the spall strength (``guard.spall_marks``), and the
criteria then skip that test: a mark is set only where the bound, taken from the stored stress,
is clear by more than half SPALL_SLACK of the magnitudes, and wherever it is clear by twice that
(no cell of the state lies in between);
marks set everywhere change the criteria's result (the test can fail), and with the patch's
pressure, which the marks do not cover, they change nothing.
"""

import math

import numba
import numpy as np
import pytest

from impactsim.fracture.criteria import (GUARD, GUARD_FRACTION, _volume6, fracture_criteria,
                                         guard_reach)
from impactsim.fracture.spall import SPALL_LESSER, SPALL_PATCH
from impactsim.materials import params as P
from impactsim.model import ERODED, INTACT
from impactsim.solver import element as E
from impactsim.solver.guard import (FLAGGED, NONE_GIVEN, PASSED, SPALL_CLEAR, SPALL_SLACK,
                                    VERDICT)
from impactsim.solver.scatter import force_rows
from tests.unit.test_fracture_screen import MUTATED, _same, _state


ROUNDING = 1e-13  # [-] of the cube of the tet's longest edge: far above a determinant's rounding


def _blocks_intact(s, rng, share=0.7):
    """Make a share of the blocks wholly intact (the kernel's vector blocks, where they are of
    one material); the others keep their damaged, fractured and eroded cells."""
    n_full = s["conn"].shape[0] // E.B * E.B
    blocks = s["status"][:n_full].reshape(-1, E.B)
    blocks[rng.random(blocks.shape[0]) < share] = INTACT


def _on_threshold(s, rng, share=0.05):
    """Put a share of the cells on the guard's threshold: V0 such that 6 GUARD_FRACTION V0 is
    the smaller predicted volume, nudged by -1, 0 or +1 units in the last place."""
    n = s["conn"].shape[0]
    h1, h2 = 1.1 * s["dt"], 2.2 * s["dt"]
    pick = np.flatnonzero(rng.random(n) < share)
    for e in pick:
        t = s["conn"][e]
        v6 = min(_volume6(s["x"], s["v"], h1, *t), _volume6(s["x"], s["v"], h2, *t))
        vol0 = v6 / (6.0 * GUARD_FRACTION)
        s["vol0"][e] = vol0 if v6 <= 0.0 else np.nextafter(
            vol0, (-np.inf, 0.0, np.inf)[int(rng.integers(3))])
    return pick


def _kernel_verdicts(s, plastic=True):
    """The tet kernel's step on a copy of state s (x, v, dt as given), asking for verdicts;
    with plastic False its elastic specialisation. Returns the verdicts and the state the step
    left (its stress, pressure, plastic strain, temperature and volume)."""
    n = s["conn"].shape[0]
    n_node = s["x"].shape[0]
    mp = s["mat_params"]
    elem_mat, status = s["elem_mat"], s["status"]
    sdev, pressure = s["sdev"].copy(), s["pressure"].copy()
    eps_p, temperature = s["eps_p"].copy(), s["temperature"].copy()
    hard, thermal = np.zeros(n), np.zeros(n)
    E.yield_cache(elem_mat, mp, eps_p, temperature, hard, thermal)
    vol = s["vol"].copy()
    rho = mp[elem_mat, 0]
    fr = force_rows(s["conn"], n_node, E.PART)
    chunk_out = np.zeros((E.n_chunks(n), E.N_OUT))
    guard = np.full(n, 99, dtype=np.int8)
    E.element_update(
        s["x"], s["v"], s["conn"], elem_mat, status.copy(), sdev, pressure, np.zeros(n),
        eps_p, np.zeros(n), temperature, hard, thermal, np.zeros(n), vol, vol, s["vol0"],
        rho * np.abs(s["vol0"]), mp, np.ones(n_node), False, s["dt"], 1.5, 0.06,
        np.zeros((n_node, 3)), fr.rows, np.zeros((fr.n_rows, 3)), fr.extra_ptr, fr.extra_rows,
        fr.part_size // E.CHUNK, chunk_out, numba.get_num_threads(),
        E.plastic_kernel(elem_mat, mp) if plastic else None, guard)
    after = dict(s, sdev=sdev, pressure=pressure, eps_p=eps_p, temperature=temperature, vol=vol)
    return guard, after


def _criteria(s, given, spall_mode=SPALL_LESSER, pretest=True):
    """fracture_criteria on a copy of state s with the kernel's verdicts ``given`` (or none:
    the criteria's own, with the pre-test unless ``pretest`` is False)."""
    s = {k: (a.copy() if isinstance(a, np.ndarray) else a) for k, a in s.items()}
    action = np.full(s["conn"].shape[0], 99, np.int8)
    reach = (guard_reach(s["x"], s["v"], 2.2 * s["dt"]) if given is NONE_GIVEN and pretest
             else math.inf)
    counts = fracture_criteria(
        s["x"], s["v"], s["x0"], s["conn"], s["elem_mat"], s["status"], s["sdev"],
        s["pressure"], s["vol"], s["vol0"], s["eps_p"], s["eps_p_prev"], s["damage"],
        s["eps_rate"], s["temperature"], s["mat_params"], s["face_flag"], s["adj"], True,
        s["dt"], action, spall_mode, s["pnode"], s["jnode"], s["spall_k"], True, reach,
        given)
    return tuple(int(c) for c in counts), action, {k: s[k] for k in MUTATED}


def _full_test(s, e):
    """(flagged, distance of the smaller predicted 6 V from the limit, rounding scale)."""
    t = s["conn"][e]
    h1, h2 = 1.1 * s["dt"], 2.2 * s["dt"]
    lim = 6.0 * GUARD_FRACTION * s["vol0"][e]
    a, b = _volume6(s["x"], s["v"], h1, *t), _volume6(s["x"], s["v"], h2, *t)
    p = s["x"][t]
    edge = max(np.linalg.norm(p[i] - p[j]) for i in range(4) for j in range(i))
    return a < lim or b < lim, min(a, b) - lim, ROUNDING * edge ** 3


@pytest.mark.parametrize("threads", [1, 2])
def test_the_kernels_verdicts_are_the_full_guards(threads):
    if threads > numba.config.NUMBA_NUM_THREADS:
        pytest.skip(f"NUMBA_NUM_THREADS={numba.config.NUMBA_NUM_THREADS}")
    rng = np.random.default_rng(5)
    s = _state(5, n=12 * E.CHUNK + 17)  # several parts, and a partial last block
    s["v"] *= 40.0  # up to a few km/s: cells that would invert within two steps
    _blocks_intact(s, rng)
    edge = _on_threshold(s, rng)
    before = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        given, _ = _kernel_verdicts(s)
    finally:
        numba.set_num_threads(before)
    n = s["conn"].shape[0]
    n_full = n // E.B * E.B
    assert np.all(given[n_full:] == 99)  # the mesh's last, partial block: not written
    given = given & VERDICT  # the verdicts without the spall marks
    assert np.all(np.isin(given[:n_full], (PASSED, FLAGGED)))  # every full block's cells
    st = s["status"][:n_full].reshape(-1, E.B)
    mats = s["elem_mat"][:n_full].reshape(-1, E.B)
    vector = np.all(st == INTACT, axis=1) & np.all(mats == mats[:, :1], axis=1)
    assert 0 < vector.sum() < vector.shape[0]  # blocks on either path
    eroded = np.flatnonzero(s["status"][:n_full] == ERODED)
    assert eroded.shape[0] > 20 and np.all(given[eroded] == PASSED)
    cells = np.flatnonzero(s["status"][:n_full] != ERODED)
    masked = ~np.repeat(vector, E.B)[cells]
    assert masked.sum() > 1000 and np.unique(s["status"][cells[masked]]).shape[0] == 3
    differ = 0
    for e in cells:
        flag, gap, scale = _full_test(s, e)
        if given[e] != (FLAGGED if flag else PASSED):
            assert e in edge and abs(gap) <= scale, e
            differ += 1
    flagged = given[cells] == FLAGGED
    assert flagged.sum() > 20 and (~flagged).sum() > 1000
    assert flagged[masked].sum() > 5 and (~flagged[masked]).sum() > 500
    # cells on the threshold among the given, on both sides of it
    on_edge = np.isin(cells, edge)
    assert flagged[on_edge].sum() > 5 and (~flagged[on_edge]).sum() > 5
    assert differ < on_edge.sum() // 2


@pytest.mark.parametrize("threads", [1, 2])
def test_the_criteria_with_the_kernels_verdicts_act_as_with_their_own(threads):
    if threads > numba.config.NUMBA_NUM_THREADS:
        pytest.skip(f"NUMBA_NUM_THREADS={numba.config.NUMBA_NUM_THREADS}")
    rng = np.random.default_rng(6)
    s = _state(6, n=12 * E.CHUNK + 17)
    s["v"] *= 40.0
    _blocks_intact(s, rng)
    edge = _on_threshold(s, rng)
    s["vol0"][edge] *= rng.choice([1.0 - 1e-6, 1.0 + 1e-6], edge.shape[0])  # off the threshold
    before = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        given, after = _kernel_verdicts(s)
        got = _criteria(after, given)
        ref = _criteria(after, NONE_GIVEN)
    finally:
        numba.set_num_threads(before)
    assert np.count_nonzero((given & VERDICT) == FLAGGED) > 20
    _same(got, ref)
    counts, action, _ = got
    assert counts[2] > 0 and np.count_nonzero(action == GUARD) > 20


def _bound(s):
    """Gershgorin's bound of the largest principal stress with the cell's own pressure, and the
    sum of the magnitudes it is made of."""
    sxx, syy, szz, sxy, syz, szx = s["sdev"].T
    a, b, c = np.abs(sxy), np.abs(syz), np.abs(szx)
    p = s["pressure"]
    bound = np.maximum(sxx + a + c, np.maximum(syy + a + b, szz + b + c)) - p
    return bound, np.abs(sxx) + np.abs(syy) + np.abs(szz) + a + b + c + np.abs(p)


@pytest.mark.parametrize("threads", [1, 2])
def test_the_kernels_spall_marks(threads):
    if threads > numba.config.NUMBA_NUM_THREADS:
        pytest.skip(f"NUMBA_NUM_THREADS={numba.config.NUMBA_NUM_THREADS}")
    rng = np.random.default_rng(8)
    s = _state(8, n=12 * E.CHUNK + 17)  # slow: many cells stay elastic, so are quiet but
    _blocks_intact(s, rng)              # for the spall test
    # a third of the cells opened against V0 (the EOS then gives tension), and spall strengths
    # of that order, so that the new stress of many cells is on either side of them
    opened = rng.random(s["vol0"].shape[0]) < 0.3
    s["vol0"][opened] *= 0.97
    s["mat_params"] = s["mat_params"].copy()
    spall = s["mat_params"][:, P.SPALL]
    spall[np.isfinite(spall)] = 3e8
    before = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        given, after = _kernel_verdicts(s)
        got = _criteria(after, given)
        ref = _criteria(after, NONE_GIVEN, pretest=False)  # the full guard: PASSED, FLAGGED
        everywhere = np.where(given >= 0, given | SPALL_CLEAR, given).astype(np.int8)
        spoilt = _criteria(after, everywhere)
        patch = (_criteria(after, everywhere, SPALL_PATCH),
                 _criteria(after, NONE_GIVEN, SPALL_PATCH, pretest=False))
    finally:
        numba.set_num_threads(before)
    n_full = s["conn"].shape[0] // E.B * E.B
    bound, size = _bound(after)
    strength = s["mat_params"][s["elem_mat"], P.SPALL]
    live = np.flatnonzero(s["status"][:n_full] != ERODED)
    marked = (given[live] & SPALL_CLEAR) != 0
    margin = (strength - bound)[live]
    assert np.all(margin[marked] > 0.5 * SPALL_SLACK * size[live][marked])
    clear = margin > 2.0 * SPALL_SLACK * size[live]
    inverted = after["vol"][live] <= 0.0  # stored nowhere: no mark
    assert np.array_equal(marked[~inverted], clear[~inverted])
    assert marked.sum() > 1000 and (~clear & np.isfinite(strength[live])).sum() > 200
    _same(got, ref)
    counts = got[0]
    assert counts[0] > 20  # cells spalled
    with pytest.raises(AssertionError):
        _same(spoilt, ref)  # marks where the bound is not clear: spall passed over
    _same(*patch)


def test_the_elastic_kernel_gives_no_verdicts():
    """The guard's loop is compiled into the plastic specialisation only: the elastic kernel
    (the demo's) leaves the array as it was, and the criteria then gather every block."""
    rng = np.random.default_rng(7)
    s = _state(7, n=4 * E.CHUNK)
    _blocks_intact(s, rng)
    assert np.all(_kernel_verdicts(s, plastic=False)[0] == 99)
    given, _ = _kernel_verdicts(s)
    assert np.count_nonzero((given & VERDICT) == PASSED) > 0
