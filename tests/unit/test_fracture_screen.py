"""The fracture kernel's screen (fracture/criteria.py ``_screen_chunk``) passes over no cell the
full criteria act on: ``fracture_criteria`` gives the statuses, actions, damage, plastic
strains at the last call, spall accumulators and counts of the full criteria run on every cell
(``_criteria_one``), bit for bit, on states with spall (instant and Tuler-Butcher, cell, patch
and lesser pressures), plastic strain growth and JC damage, every erosion criterion (surface
and anywhere), ductile fracture, melt, one-cell fragments and cells the distortion guard
flags, with the guard's pre-test on, resting and fed a non-finite reach; and the same on 1, 2
and 3 threads."""

import math

import numba
import numpy as np
import pytest

from impactsim.case.schema import Failure, Strength
from impactsim.fracture.criteria import (ERODE, GUARD, MELT, NONE, PARTICLE, _criteria_one,
                                         fracture_criteria, guard_reach)
from impactsim.fracture.spall import SPALL_CELL, SPALL_LESSER, SPALL_PATCH
from impactsim.materials.params import material_table
from impactsim.model import DAMAGED, ERODED, FRACTURED, INTACT
from tests.builders import material


@numba.njit
def _reference(x, v, x0, conn, elem_mat, status, sdev, pressure, vol, vol0, eps_p, eps_p_prev,
               damage, eps_rate, temperature, mat_params, face_flag, adj, surface_only, dt,
               action, spall_mode, pnode, jnode, spall_k, integrate, reach):
    """The full criteria on every cell, in order (the kernel before the screen)."""
    pretest = reach < math.inf
    inv = 1.0 / (2.0 * 10.0 * reach) if reach > 0.0 else math.inf
    n_dam = n_frac = n_act = n_duct = n_guard = n_clear = 0
    for e in range(conn.shape[0]):
        dam, duct, frac, tested, cleared = _criteria_one(
            e, x, v, x0, conn, elem_mat, status, sdev, pressure, vol, vol0, eps_p, eps_p_prev,
            damage, eps_rate, temperature, mat_params, face_flag, adj, surface_only, dt, action,
            spall_mode, pnode, spall_k, integrate, pretest, reach, inv, -1)
        n_dam += dam
        n_duct += duct
        n_frac += frac
        n_guard += tested
        n_clear += cleared
        n_act += 1 if action[e] != NONE else 0
    return n_dam, n_frac, n_act, n_duct, n_guard, n_clear


JC = Strength(model="johnson-cook", A=300e6, B=400e6, n=0.3, C=0.01, m=1.0,
              melt_temperature=1000.0)
D = (0.13, 0.13, -1.5, 0.011, 0.0)
MATERIALS = [
    material(name="elastic"),  # no failure data: no guard
    material(name="jc-erosion", strength=JC, failure=Failure(
        spall_strength=1e9, loosening=0.03, erosion="jc-damage", erosion_value=1.0,
        jc_damage=D)),
    material(name="ductile", strength=JC, failure=Failure(spall_strength=2e9, loosening=0.05,
                                                          jc_damage=D)),
    material(name="plastic-strain", strength=JC, failure=Failure(erosion="plastic-strain",
                                                                 erosion_value=0.5)),
    material(name="principal", strength=JC, failure=Failure(erosion="principal-strain",
                                                            erosion_value=0.2)),
    material(name="tuler-butcher", strength=JC, failure=Failure(spall_strength=1e9,
                                                                spall_time=2e-8)),
    material(name="fractured", strength=JC, failure=Failure(spall_strength=1e9, loosening=0.01,
                                                            erosion="fractured")),
]


def _state(seed, n=6000):
    """Tets with their own nodes (each a distorted regular tet of 1 mm; a few crushed against
    their reference volume), in runs of one material (as bodies are), with every kind of cell."""
    rng = np.random.default_rng(seed)
    ref = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]]) * 1e-3
    centre = rng.uniform(-0.05, 0.05, (n, 1, 3))
    x0 = (centre + ref[None] + 1e-4 * rng.standard_normal((n, 4, 3))).reshape(-1, 3)
    x = x0 + 1e-5 * rng.standard_normal(x0.shape)
    v = 30.0 * rng.standard_normal(x0.shape)
    dt = 1e-8
    conn = np.arange(4 * n, dtype=np.int32).reshape(n, 4)
    a, b, c = (x.reshape(n, 4, 3)[:, k] - x.reshape(n, 4, 3)[:, 0] for k in (1, 2, 3))
    vol = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0
    vol0 = vol * rng.choice([1.0, 1.0, 1.0, 0.9], n)  # some opened (loosening)
    # some crushed to below GUARD_FRACTION of V0, some right at it (the guard's threshold)
    crush = rng.random(n) < 0.02
    vol0[crush] = vol[crush] * rng.choice([120.0, 100.0 * (1.0 + 1e-4), 100.0 * (1.0 - 1e-4)],
                                          crush.sum())
    elem_mat = np.repeat(rng.integers(0, len(MATERIALS), n // 100 + 1), 100)[:n].astype(np.int32)
    status = rng.choice(np.array([INTACT, DAMAGED, FRACTURED, ERODED], np.int8), n,
                        p=[0.9, 0.04, 0.03, 0.03])
    sdev = 1e8 * rng.standard_normal((n, 6))
    pressure = 3e8 * rng.standard_normal(n)
    hot = rng.random(n) < 0.03  # far in tension: spall
    pressure[hot] = -2.5e9 * rng.random(hot.sum())
    eps_p = rng.choice([0.0, 0.1, 0.4, 0.6], n)
    eps_p_prev = eps_p.copy()
    grow = rng.random(n) < 0.1
    eps_p[grow] += rng.uniform(0.0, 0.3, grow.sum())
    damage = rng.uniform(0.0, 1.2, n) * (rng.random(n) < 0.3)
    eps_rate = 10.0 ** rng.uniform(0, 6, n)
    temperature = 293.15 + 700.0 * rng.random(n) * (rng.random(n) < 0.5)
    temperature[rng.random(n) < 0.05] = 999.0  # molten (MELT_SHARE of the 1000 K melt)
    face_flag = rng.random(4 * n) < 0.08
    lone = rng.random(n) < 0.01
    face_flag.reshape(n, 4)[lone] = True
    adj = np.where(rng.random((n, 4)) < 0.5, rng.integers(0, n, (n, 4)), -1).astype(np.int32)
    pnode = 3e8 * rng.standard_normal(x.shape[0])
    pnode.reshape(n, 4)[hot] = -2.5e9  # the hot cells' patches in tension too
    spall_k = 1e-8 * rng.random(n) * (rng.random(n) < 0.2)
    return dict(x=x, v=v, x0=x0, conn=conn, elem_mat=elem_mat, status=status, sdev=sdev,
                pressure=pressure, vol=vol, vol0=vol0, eps_p=eps_p, eps_p_prev=eps_p_prev,
                damage=damage, eps_rate=eps_rate, temperature=temperature,
                mat_params=material_table(MATERIALS), face_flag=face_flag, adj=adj, dt=dt,
                pnode=pnode, jnode=np.ones(x.shape[0]), spall_k=spall_k)


MUTATED = ("status", "eps_p_prev", "damage", "spall_k")


def _run(kernel, s, surface_only, spall_mode, integrate, reach):
    s = {k: (a.copy() if isinstance(a, np.ndarray) else a) for k, a in s.items()}
    action = np.full(s["conn"].shape[0], 99, np.int8)
    given = () if kernel is _reference else (np.empty(0, np.int8),)  # no kernel's verdicts
    counts = kernel(s["x"], s["v"], s["x0"], s["conn"], s["elem_mat"], s["status"], s["sdev"],
                    s["pressure"], s["vol"], s["vol0"], s["eps_p"], s["eps_p_prev"], s["damage"],
                    s["eps_rate"], s["temperature"], s["mat_params"], s["face_flag"], s["adj"],
                    surface_only, s["dt"], action, spall_mode, s["pnode"], s["jnode"],
                    s["spall_k"], integrate, reach, *given)
    return tuple(int(c) for c in counts), action, {k: s[k] for k in MUTATED}


def _same(a, b):
    """Equal to the bit (floats through their integer views)."""
    (ca, act_a, st_a), (cb, act_b, st_b) = a, b
    assert ca == cb
    assert np.array_equal(act_a, act_b)
    for k in MUTATED:
        x, y = st_a[k], st_b[k]
        if x.dtype.kind == "f":
            x, y = x.view(np.int64), y.view(np.int64)
        assert np.array_equal(x, y), k


@pytest.mark.parametrize("surface_only", [True, False])
@pytest.mark.parametrize("spall_mode,integrate", [(SPALL_CELL, False), (SPALL_LESSER, True),
                                                  (SPALL_PATCH, True)])
@pytest.mark.parametrize("pretest", ["on", "resting", "nan"])
def test_screened_kernel_is_the_full_criteria(surface_only, spall_mode, integrate, pretest):
    s = _state(7 + spall_mode)
    reach = {"on": guard_reach(s["x"], s["v"], 2.2 * s["dt"]), "resting": math.inf,
             "nan": math.nan}[pretest]
    ref = _run(_reference, s, surface_only, spall_mode, integrate, reach)
    got = _run(fracture_criteria, s, surface_only, spall_mode, integrate, reach)
    _same(got, ref)
    # the state has what the screen must pass on: every action, new damage and fractures,
    # and the guard tested (and, with the pre-test on, cleared) cells
    counts, action, after = ref
    n_dam, n_frac, n_act, n_duct, n_guard, n_clear = counts
    kinds = set(np.unique(action).tolist())
    assert {NONE, PARTICLE, ERODE, GUARD, MELT} <= kinds
    assert n_dam > 0 and n_frac > 0 and n_duct > 0 and n_guard > 1000
    assert (n_clear > 1000) if pretest == "on" else n_clear == 0
    assert np.any(after["damage"] != s["damage"])
    if integrate:
        assert np.any(after["spall_k"] != s["spall_k"])


def test_nearly_quiet_state():
    """Far from an impact (what the screen is for): all intact, no surface, nothing growing;
    the few cells that are not quiet still get the full criteria."""
    s = _state(3)
    n = s["conn"].shape[0]
    s["status"][:] = INTACT
    s["face_flag"][:] = False
    s["eps_p_prev"][:] = s["eps_p"]
    s["pressure"][:] = np.abs(s["pressure"])
    s["damage"][:] = 0.0
    s["eps_p"][::97] += 0.01
    s["pressure"][::89] = -3e9
    s["face_flag"][4 * np.arange(0, n, 83)] = True
    reach = guard_reach(s["x"], s["v"], 2.2 * s["dt"])
    for surface_only in (True, False):
        ref = _run(_reference, s, surface_only, SPALL_CELL, False, reach)
        _same(_run(fracture_criteria, s, surface_only, SPALL_CELL, False, reach), ref)
        assert ref[0][0] > 0 and ref[0][5] > 0.6 * n  # new damage; most cells cleared


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_screened_kernel_the_same_on_any_thread_count(threads):
    if threads > numba.config.NUMBA_NUM_THREADS:
        pytest.skip(f"NUMBA_NUM_THREADS={numba.config.NUMBA_NUM_THREADS}")
    s = _state(11, n=20000)
    reach = guard_reach(s["x"], s["v"], 2.2 * s["dt"])
    ref = _run(_reference, s, True, SPALL_LESSER, True, reach)
    before = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        got = _run(fracture_criteria, s, True, SPALL_LESSER, True, reach)
    finally:
        numba.set_num_threads(before)
    _same(got, ref)
