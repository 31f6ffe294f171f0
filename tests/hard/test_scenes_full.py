"""The fracture scenes of the papers at full resolution (cases/sphere-plate.toml [D19], about
5 min; cases/oblique-sphere.toml [R20], about 12 min on a 2-core machine): the checks of
tests/hard/test_fracture_scenes.py on the bundled cases as they are. Slow: ``make hard``."""

import pytest

from tests.hard.test_fracture_scenes import (_check_common, _check_oblique, _check_sphere_plate,
                                             _run)


@pytest.mark.slow
def test_sphere_plate_full(tmp_path):
    s, hist = _run(tmp_path, "sphere-plate", [])
    _check_common(s, hist)
    _check_sphere_plate(s)
    assert s["checks"] == {} and s["stopped"] is None  # no [checks] entry triggers


@pytest.mark.slow
def test_oblique_sphere_full(tmp_path):
    s, hist = _run(tmp_path, "oblique-sphere", [])
    _check_common(s, hist)
    _check_oblique(s)
    assert s["checks"] == {} and s["stopped"] is None  # no [checks] entry triggers
