"""Distortion erosion [Z] (ALGORITHMS.md 4.3, fracture/distortion.py): each criterion fires on a
hand-built element, and none fires on a merely large-strain or rotated one."""

import numpy as np
import pytest

from impactsim.fracture.distortion import EXTENT, PIERCING, VOLUME, DistortionCheck
from impactsim.model import ERODED, INTACT
from impactsim.solver.hex8 import hex_volumes

TET = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
CUBE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                 [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)


def _which(x0, x, r1=3.0, r2=8.0):
    conn = np.arange(len(x0), dtype=np.int32)[None, :]
    chk = DistortionCheck(x0, conn, r1, r2)
    ids = chk.check(np.asarray(x, float), conn, np.zeros(1, np.int8))
    return int(chk.which[0]) if ids.shape[0] else 0


def _rotation(axis, angle):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


@pytest.mark.parametrize("x0", [TET, CUBE], ids=["tet", "hex"])
def test_large_strain_rotation_is_not_distortion(x0):
    """Stretch 2 with volume kept, simple shear 1, and any rotation: nothing fires."""
    stretch = x0 * np.array([2.0, 1 / np.sqrt(2), 1 / np.sqrt(2)])
    shear = x0 + np.outer(x0[:, 1], [1.0, 0, 0])
    assert _which(x0, stretch) == 0
    assert _which(x0, shear) == 0
    for ax in ([0, 0, 1], [1, 1, 1], [1, -2, 0.5]):
        for ang in (0.3, 0.9, 2.0):
            assert _which(x0, x0 @ _rotation(ax, ang).T + 5.0) == 0


@pytest.mark.parametrize("x0", [TET, CUBE], ids=["tet", "hex"])
def test_extent(x0):
    x = x0.copy()
    x[1, 0] = 3.5  # one corner drawn out to 3.5 L_ch along x
    assert _which(x0, x) == EXTENT
    x[1, 0] = 2.9
    assert _which(x0, x) in (0, VOLUME)  # below r1 the extent criterion is silent
    assert _which(x0, x, r2=100.0) == 0


def test_volume_tet():
    x = TET.copy()
    x[1, 0], x[2, 1], x[3, 2] = 2.5, 2.5, 1.5  # box 2.5 x 2.5 x 1.5 = 9.4 > 8, extents < 3
    assert _which(TET, x) == VOLUME
    assert _which(TET, x, r2=9.5) == 0


def test_volume_hex():
    x = CUBE * np.array([2.5, 2.0, 2.0])  # box 10 > 8, extents < 3
    assert _which(CUBE, x) == VOLUME
    assert _which(CUBE, x, r2=10.5) == 0


def test_piercing_tet_is_inversion():
    x = TET.copy()
    x[3] = [0.2, 0.2, -0.3]  # the apex through the base
    assert _which(TET, x) == PIERCING


def test_piercing_hex_with_positive_volume():
    """A corner pushed through the opposite face while the hex's volume stays positive: only
    the corner Jacobian sees it."""
    x = CUBE.copy()
    x[6] = [0.3, 0.3, 0.35]  # the far corner pushed in past the three faces at corner 0
    conn = np.arange(8, dtype=np.int32)[None, :]
    assert hex_volumes(x, conn)[0] > 0.0
    assert _which(CUBE, x) == PIERCING


def test_eroded_and_inactive_elements_are_skipped():
    x = TET.copy()
    x[1, 0] = 5.0
    conn = np.arange(4, dtype=np.int32)[None, :]
    chk = DistortionCheck(TET, conn, 3.0, 8.0)
    assert chk.check(x, conn, np.array([ERODED], np.int8)).shape[0] == 0
    chk.active[:] = False
    assert chk.check(x, conn, np.array([INTACT], np.int8)).shape[0] == 0
