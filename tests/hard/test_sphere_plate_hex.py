"""The sphere-plate scene [D19] with hexahedra, both ways: the hex plate of
cases/sphere-plate-hex.toml struck by the tet sphere, and a hex sphere (cube-sphere, stiffness
hourglass control) striking the tet plate of cases/sphere-plate.toml. Hex-tet contact and the
fracture of hexes together: spall, loosening, particles, the free quads and the contact surface
following the hexes that leave.

Fast suite: coarse meshes (1 mm plate, 2.4 mm sphere), as tests/hard/test_fracture_scenes.py.
What must hold: the run reaches its end time, mass to round-off, energy balance within 2 %, the
plate perforated and the sphere through (about 1950 m/s), the momentum of nodes and particles
conserved (no wall, no constraint), and no body inside the other: max_penetration below 2 um
(h / 500) at every step (measured: 1.0 um with the hex plate, 0.4 um with the hex sphere; the
issue's 1 um gate is for contact without fracture, two-cylinders-hex). The full-resolution
hex-plate case is slow (``make hard``)."""

import numpy as np
import pytest

from tests.hard.test_fracture_scenes import CASES, _check_common, _check_sphere_plate, _run

COARSE = ["body.plate.mesh_size=1 mm", "body.sphere.mesh_size=2.4 mm", "output.frames=1",
          "output.history_every=1"]
HEX_SPHERE = ['body.sphere.element="hex8"', 'body.sphere.hourglass="stiffness"',
              "body.sphere.hourglass_coefficient=0.1"]


def _check_hex_scene(s, hist, penetration=2e-6):
    _check_common(s, hist)
    _check_sphere_plate(s)
    assert hist["max_penetration"].max() < penetration
    for ax in "xyz":
        total = hist[f"momentum_{ax}"] + hist[f"particle_momentum_{ax}"]
        assert np.abs(total - total[0]).max() < 1e-9 * abs(hist["momentum_z"][0])
    assert hist["hourglass_energy"][-1] > 0.0


def test_hex_plate_struck_by_tet_sphere_coarse(tmp_path):
    s, hist = _run(tmp_path, "sphere-plate-hex", COARSE)
    _check_hex_scene(s, hist)
    assert s["bodies"]["plate"]["debris"]["particles"] > 0  # hexes became particles


def test_hex_sphere_strikes_tet_plate_coarse(tmp_path):
    s, hist = _run(tmp_path, "sphere-plate", COARSE + HEX_SPHERE)
    _check_hex_scene(s, hist)


@pytest.mark.slow
def test_sphere_plate_hex_full(tmp_path):
    """The bundled case (0.5 mm hex plate, 25,600 hexes; about 30 s). max_penetration measured
    3.7 and 8.3 um in two runs of this chaotic scene (other frame times; the tet plate's full
    case: 3.65 um): bound 10 um = h / 50."""
    s, hist = _run(tmp_path, "sphere-plate-hex", ["output.history_every=1"])
    _check_hex_scene(s, hist, penetration=1e-5)
    assert s["fracture"]["distortion"]["deleted"] > 0  # tangled hexes went (the case's note)
    assert (CASES / "sphere-plate-hex.toml").exists()
