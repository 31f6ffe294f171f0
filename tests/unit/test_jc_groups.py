"""The vector Johnson-Cook return (`element._jc_lanes`) skips a group of JG lanes that has no
lane above its yield floor, no lane still iterating, or no lane to update: every lane of a
block must still come out as the scalar return (`laws.radial_return`) gives it, and a lane of
a skipped group unchanged to the bit. The buffer starts as NaN, so a row a skipped group
leaves unwritten and a later step reads would show."""

import numpy as np

from impactsim.materials import params as P
from impactsim.materials.laws import radial_return, thermal_factor
from impactsim.solver import element as E

B, JG = E.B, E.JG
G = 46e9


def _params():
    mp = np.zeros((1, P.N_PARAM))
    mp[0, [P.STRENGTH, P.JC_A, P.JC_B, P.JC_N, P.JC_C, P.JC_M, P.EPSDOT0, P.T_ROOM,
           P.T_MELT, P.TQ, P.CV, P.G]] = (P.JOHNSON_COOK, 90e6, 292e6, 0.31, 0.025, 1.09, 1.0,
                                          293.0, 1356.0, 0.9, 383.0, G)
    return mp


def _block(yielding_groups, rng):
    """A block buffer whose lanes in `yielding_groups` are 0-40 % above their yield stress (some
    at their first yield), the others below their yield floor."""
    mp = _params()
    buf = np.full(E.TET_ROWS * B, np.nan)
    ep = rng.uniform(0.01, 0.5, B) * (rng.uniform(size=B) < 0.85)  # some first yields
    temp = 293.0 + rng.uniform(0.0, 400.0, B)
    hard = 90e6 + 292e6 * ep ** 0.31
    therm = np.array([thermal_factor(P.JOHNSON_COOK, mp, 0, t) for t in temp])
    rate = 10.0 ** rng.uniform(-1.0, 5.0, B)
    above = np.zeros(B, bool)
    for g in yielding_groups:
        above[g * JG:(g + 1) * JG] = True
    factor = np.where(above, 1.0 + 0.25 * np.log(np.maximum(rate, 1.0)) * 0.025 + rng.uniform(
        0.0, 0.4, B), rng.uniform(0.5, 0.999, B))
    seq = hard * therm * factor
    sn = rng.normal(size=(6, B))
    sn *= seq / np.sqrt(1.5 * ((sn[:3] - sn[:3].mean(0)) ** 2).sum(0) + 3.0 * (sn[3:] ** 2).sum(0))
    rows = {E.R_SEQ: seq, E.R_RATE: rate, E.R_EP: ep, E.R_TEMP: temp, E.R_HARD: hard,
            E.R_THERM: therm, E.R_MASS: np.full(B, 8930.0 * 1e-9), E.R_DET: np.full(B, 6e-9)}
    for r, val in rows.items():
        buf[r * B:(r + 1) * B] = val
    for c in range(6):
        buf[(E.R_SN + c) * B:(E.R_SN + c + 1) * B] = sn[c]
    return mp, buf, above


def test_skipped_groups_unchanged_and_yielding_lanes_as_the_scalar_return():
    rng = np.random.default_rng(7)
    for groups in ([1], [0, 3], [2, 3], [0, 1, 2, 3]):
        mp, buf, above = _block(groups, rng)
        before = buf.copy()
        assert E._jc_lanes(buf, mp, 0, G)
        row = lambda r: buf[r * B:(r + 1) * B]  # noqa: E731
        old = lambda r: before[r * B:(r + 1) * B]  # noqa: E731
        for r in (E.R_EP, E.R_TEMP, E.R_HARD, E.R_THERM, *range(E.R_SN, E.R_SN + 6)):
            assert np.array_equal(row(r)[~above], old(r)[~above]), r
        yielded = 0
        for i in np.flatnonzero(above):
            deps, sy, hnew = radial_return(P.JOHNSON_COOK, mp, 0, G, old(E.R_SEQ)[i],
                                           old(E.R_EP)[i], old(E.R_RATE)[i], old(E.R_HARD)[i],
                                           old(E.R_THERM)[i])
            if deps <= 0.0:
                continue  # elastic at the step's rate
            yielded += 1
            rho = 8930.0
            temp = old(E.R_TEMP)[i] + 0.9 / 383.0 * sy * deps / rho
            assert abs(row(E.R_EP)[i] - (old(E.R_EP)[i] + deps)) <= 1e-12 * (old(E.R_EP)[i] + deps)
            assert abs(row(E.R_HARD)[i] - hnew) <= 1e-12 * hnew
            assert abs(row(E.R_TEMP)[i] - temp) <= 1e-12 * temp
            th = thermal_factor(P.JOHNSON_COOK, mp, 0, temp)
            assert abs(row(E.R_THERM)[i] - th) <= 1e-12
            for c in range(6):
                s = old(E.R_SN + c)[i] * sy / old(E.R_SEQ)[i]
                assert abs(row(E.R_SN + c)[i] - s) <= 1e-12 * old(E.R_SEQ)[i]
        assert yielded >= len(groups) * JG // 2  # the test returns lanes, not only skips
