"""Elastic-plastic waves in uniaxial strain: the elastic precursor and the plastic wave.

A laterally confined column (every node held in x and y: uniaxial strain) of an ideally plastic
(Prandtl-Reuss, yield stress Y0) material with a linear EOS is driven at one end at speed v,
beyond the elastic limit. Theory (von Kármán & Duwez 1950, in the uniaxial-strain form of e.g.
Meyers, Dynamic Behavior of Materials, 1994, sec. 7.1-7.2; Zukas et al., Impact Dynamics, 1982,
ch. 4), with K the bulk and G the shear modulus:

- the elastic precursor runs at c_L = sqrt((K + 4G/3)/rho) with the amplitude of the Hugoniot
  elastic limit sigma_HEL = (K + 4G/3)/(2G) Y0 = (1 - nu)/(1 - 2 nu) Y0, particle velocity
  u_HEL = sigma_HEL / (rho c_L);
- the plastic wave behind it runs at the bulk speed c_p = sqrt(K/rho) (ideal plasticity: the
  deviator stays on the yield surface, only the pressure grows), and raises the stress to
  sigma = sigma_HEL + rho c_p (v - u_HEL).

Fronts are where the particle velocity crosses the middle of its jump; speeds come from the
front positions at two times, so the start-up of the fronts cancels.
"""

import numpy as np
import pytest

from impactsim.case.schema import Constraint, NodeSelector, Strength
from impactsim.mesh.structured import structured_box
from impactsim.solver.build import build_model
from impactsim.solver.loop import Simulation
from impactsim.solver.pipeline import build_passes
from tests.builders import box_case, material

RHO, E, NU, Y0 = 2700.0, 70e9, 0.33, 300e6
K, G = E / (3 * (1 - 2 * NU)), E / (2 * (1 + NU))
V_DRIVE = 100.0  # [m/s], about three times u_HEL
LENGTH, H = 0.4, 0.0025


def _column():
    mat = material(density=RHO, bulk_modulus=K, shear_modulus=G,
                   strength=Strength(model="ideal-plastic", yield_stress=Y0))
    case = box_case(mat, size=(H, H, LENGTH), h=H, end=1.0)
    case.bodies[0].constraints = [
        Constraint(NodeSelector("all"), (0.0, 0.0, None)),
        Constraint(NodeSelector("plane", {"point": (0, 0, -LENGTH / 2), "normal": (0, 0, 1),
                                          "tolerance": 1e-9}), (0.0, 0.0, V_DRIVE)),
    ]
    model = build_model(case, [structured_box((H, H, LENGTH), H)])
    return model, Simulation(model, build_passes(case, model), cfl=0.5)


def _profile(model):
    """(distance from the driven end of each z level, mean vz, mean sigma_zz of elements)."""
    z0 = model.x0[:, 2] + LENGTH / 2
    levels = np.unique(np.round(z0, 9))
    vz = np.array([model.v[np.isclose(z0, z), 2].mean() for z in levels])
    zc = model.x0[model.conn, 2].mean(axis=1) + LENGTH / 2
    szz = model.sdev[:, 2] - model.pressure
    return levels, vz, zc, szz


def _front(levels, vz, level):
    """Farthest position where vz still exceeds `level` (linear between z levels)."""
    i = np.nonzero(vz >= level)[0].max()
    return levels[i] + (vz[i] - level) / (vz[i] - vz[i + 1]) * (levels[i + 1] - levels[i])


@pytest.fixture(scope="module")
def snapshots():
    model, sim = _column()
    c_l = np.sqrt((K + 4 * G / 3) / RHO)
    shots = []
    for t in (0.16 / c_l, 0.34 / c_l):  # precursor 0.16 m and 0.34 m from the driven end
        while model.time < t:
            sim.step(t - model.time)
        shots.append((model.time, *_profile(model)))
    return shots


def test_elastic_precursor_speed_and_hugoniot_elastic_limit(snapshots):
    c_l = np.sqrt((K + 4 * G / 3) / RHO)
    hel = (K + 4 * G / 3) / (2 * G) * Y0
    assert hel == pytest.approx((1 - NU) / (1 - 2 * NU) * Y0)
    u_hel = hel / (RHO * c_l)
    (t1, l1, v1, _, _), (t2, l2, v2, zc, szz) = snapshots
    speed = (_front(l2, v2, 0.5 * u_hel) - _front(l1, v1, 0.5 * u_hel)) / (t2 - t1)
    assert speed == pytest.approx(c_l, rel=0.03)
    # the plateau between the two fronts carries the HEL
    c_p = np.sqrt(K / RHO)
    plateau = (zc > c_p * t2 + 0.02) & (zc < c_l * t2 - 0.02)
    assert plateau.sum() > 50
    assert -np.median(szz[plateau]) == pytest.approx(hel, rel=0.03)
    u_plateau = np.median(v2[(l2 > c_p * t2 + 0.02) & (l2 < c_l * t2 - 0.02)])
    assert u_plateau == pytest.approx(u_hel, rel=0.05)


def test_plastic_wave_at_bulk_speed_with_the_jump_of_stress(snapshots):
    c_l, c_p = np.sqrt((K + 4 * G / 3) / RHO), np.sqrt(K / RHO)
    hel = (K + 4 * G / 3) / (2 * G) * Y0
    u_hel = hel / (RHO * c_l)
    mid = 0.5 * (u_hel + V_DRIVE)
    (t1, l1, v1, _, _), (t2, l2, v2, zc, szz) = snapshots
    speed = (_front(l2, v2, mid) - _front(l1, v1, mid)) / (t2 - t1)
    assert speed == pytest.approx(c_p, rel=0.03)
    behind = (zc > 0.03) & (zc < c_p * t2 - 0.03)
    sigma = hel + RHO * c_p * (V_DRIVE - u_hel)
    assert -np.median(szz[behind]) == pytest.approx(sigma, rel=0.03)
