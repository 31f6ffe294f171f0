"""Quantities with units -> SI floats, and the errors for bad ones."""

import math

import pytest

from impactsim.case import CaseError
from impactsim.case.units import format_quantity, parse_quantity


@pytest.mark.parametrize("text, dimension, si", [
    (0.0127, "length", 0.0127),
    (3, "length", 3.0),
    ("7.9 mm", "length", 0.0079),
    ("7.9mm", "length", 0.0079),
    ("12 cm", "length", 0.12),
    ("25 um", "length", 25e-6),
    ("25 µm", "length", 25e-6),
    ("25 μm", "length", 25e-6),
    ("1.5 km", "length", 1500.0),
    ("80 us", "time", 8e-5),
    ("80 µs", "time", 8e-5),
    ("2 ms", "time", 2e-3),
    ("10 ns", "time", 1e-8),
    ("2 km/s", "velocity", 2000.0),
    ("-190 m/s", "velocity", -190.0),
    ("5.5 mm/us", "velocity", 5500.0),
    ("3 mm/ms", "velocity", 3.0),
    ("1.6 GPa", "pressure", 1.6e9),
    ("90 MPa", "pressure", 9e7),
    ("100 kPa", "pressure", 1e5),
    ("1 bar", "pressure", 1e5),
    ("0.5 Mbar", "pressure", 5e10),
    ("8930 kg/m^3", "density", 8930.0),
    ("8930 kg/m3", "density", 8930.0),
    ("8.93 g/cm^3", "density", 8930.0),
    ("2.7 g/cc", "density", 2700.0),
    ("293 K", "temperature", 293.0),
    ("20 degC", "temperature", 293.15),
    ("-273.15 degC", "temperature", 0.0),
    ("383 J/(kg K)", "specific_heat", 383.0),
    ("383 J/kg/K", "specific_heat", 383.0),
    ("1e6 J/kg", "specific_energy", 1e6),
    ("60 deg", "angle", math.pi / 3),
    ("0.5 rad", "angle", 0.5),
    ("1 /s", "rate", 1.0),
    ("1e3 1/s", "rate", 1e3),
    ("0.6", "dimensionless", 0.6),
    (1e-3, "dimensionless", 1e-3),
])
def test_parses_to_si(text, dimension, si):
    assert parse_quantity(text, dimension, "k") == pytest.approx(si, rel=1e-15, abs=1e-300)


def test_decimal_prefixes_round_once():
    """'80 us' is the float nearest 8e-5, as a number written 8e-5 would be."""
    assert parse_quantity("80 us", "time", "k") == 8e-5
    assert parse_quantity("3.81 mm", "length", "k") == 0.00381
    assert parse_quantity("5.5 mm/us", "velocity", "k") == 5500.0


def test_wrong_dimension_names_key_and_expected_unit():
    with pytest.raises(CaseError) as err:
        parse_quantity("3 GPa", "length", "body[0].mesh_size")
    msg = str(err.value)
    assert msg.startswith("body[0].mesh_size: ")
    assert "'3 GPa' is a stress" in msg and "expects a length" in msg and "mm" in msg


def test_unknown_unit_suggests_case_fix():
    with pytest.raises(CaseError, match=r"run.end_time: unknown unit 'US'.*did you mean 'us'"):
        parse_quantity("80 US", "time", "run.end_time")


@pytest.mark.parametrize("value, fragment", [
    ("fast", "cannot read 'fast' as a velocity"),
    ("mm 3", "cannot read"),
    (True, "expected a velocity"),
    ([1, 2], "expected a velocity"),
    ("nan m/s", "cannot read"),
    (float("inf"), "finite"),
])
def test_bad_values(value, fragment):
    with pytest.raises(CaseError) as err:
        parse_quantity(value, "velocity", "body[1].velocity[2]")
    assert str(err.value).startswith("body[1].velocity[2]: ")
    assert fragment in str(err.value)


def test_unknown_dimension_is_a_programming_error():
    with pytest.raises(ValueError):
        parse_quantity(1.0, "furlongs", "k")


def test_format_quantity_for_summaries():
    assert format_quantity(8e-5, "time") == "80 us"
    assert format_quantity(0.0008, "length") == "0.8 mm"
    assert format_quantity(1.6e9, "pressure") == "1.6 GPa"
    assert format_quantity(190.0, "velocity") == "190 m/s"
