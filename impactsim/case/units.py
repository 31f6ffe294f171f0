"""Quantities with units: "2 km/s", "7.9 mm", "293 K" -> SI floats.

A small table-driven parser (no pint): a value is a plain number (taken as SI) or a string
``"<number> <unit>"``. Every unit belongs to one dimension; a key expects one dimension, and a
unit of another dimension is an error naming the key and the units it accepts.
"""

from __future__ import annotations

import math
import re
from fractions import Fraction

from impactsim.case.errors import CaseError

# dimension -> (SI unit shown in messages and docs, human name)
DIMENSIONS: dict[str, tuple[str, str]] = {
    "dimensionless": ("", "number"),
    "length": ("m", "length"),
    "time": ("s", "time"),
    "velocity": ("m/s", "velocity"),
    "pressure": ("Pa", "stress"),
    "density": ("kg/m^3", "density"),
    "temperature": ("K", "temperature"),
    "specific_heat": ("J/(kg K)", "specific heat"),
    "specific_energy": ("J/kg", "specific energy"),
    "angle": ("rad", "angle"),
    "rate": ("1/s", "rate"),
    "angular_velocity": ("rad/s", "angular velocity"),
    "conductivity": ("W/(m K)", "thermal conductivity"),
    "heat_transfer": ("W/(m^2 K)", "heat-transfer coefficient"),
    "heat_flux": ("W/m^2", "heat flux"),
    "power_density": ("W/m^3", "volumetric heat source"),
    "expansion": ("1/K", "thermal expansion coefficient"),
}

# Magnitudes beyond these are impossible in an impact simulation (a typo, a wrong unit, a fuzzer):
# 1000 km, 100 km/s, 1e15 Pa (a thousand times the pressure at Earth's centre), a day, ...
PLAUSIBLE: dict[str, float] = {
    "length": 1e6, "time": 86400.0, "velocity": 1e5, "pressure": 1e15, "density": 1e6,
    "temperature": 1e6, "specific_heat": 1e6, "specific_energy": 1e12, "angle": 1e3,
    "rate": 1e15, "angular_velocity": 1e9,
}

# Factors are exact fractions, so "80 us" is exactly the float nearest 8e-5 (one rounding).
_F = Fraction
_LENGTH = {"m": _F(1), "mm": _F("1e-3"), "cm": _F("1e-2"), "um": _F("1e-6"), "km": _F(1000),
           "nm": _F("1e-9"), "in": _F("0.0254")}
_TIME = {"s": _F(1), "ms": _F("1e-3"), "us": _F("1e-6"), "ns": _F("1e-9")}
_DEG = _F(math.pi / 180.0)


def _build() -> tuple[dict[str, tuple[str, Fraction, Fraction]], dict[str, list[str]]]:
    """unit (normalised spelling) -> (dimension, factor, offset): SI = value * factor + offset;
    and dimension -> the units as they are shown in messages and docs."""
    units: dict[str, tuple[str, Fraction, Fraction]] = {}
    shown: dict[str, list[str]] = {}

    def add(dim: str, spellings: dict[str, Fraction | int | str], offset: str = "0") -> None:
        for name, factor in spellings.items():
            units[_normalise(name)] = (dim, _F(factor), _F(offset))
            shown.setdefault(dim, []).append(name)

    add("length", _LENGTH)
    add("time", _TIME)
    add("velocity", {f"{l}/{t}": _LENGTH[l] / _TIME[t] for l, t in (
        ("m", "s"), ("km", "s"), ("mm", "us"), ("mm", "ms"), ("mm", "s"), ("cm", "s"),
        ("cm", "us"), ("m", "ms"))})
    add("velocity", {"km/h": _F(1000, 3600)})
    add("pressure", {"Pa": 1, "kPa": 1000, "MPa": 10**6, "GPa": 10**9, "TPa": 10**12,
                     "bar": 10**5, "kbar": 10**8, "Mbar": 10**11, "N/m^2": 1, "N/mm^2": 10**6,
                     "psi": "6894.757293168361", "ksi": "6894757.293168361"})
    add("density", {"kg/m^3": 1, "g/cm^3": 1000, "g/cc": 1000, "t/m^3": 1000})
    add("temperature", {"K": 1})
    add("temperature", {"degC": 1, "°C": 1}, offset="273.15")
    add("specific_heat", {"J/(kg K)": 1, "J/kg/K": 1, "J/(kg degC)": 1,
                          "kJ/(kg K)": 1000, "kJ/kg/K": 1000, "J/(g K)": 1000, "J/g/K": 1000})
    add("specific_energy", {"J/kg": 1, "kJ/kg": 1000, "MJ/kg": 10**6})
    add("angle", {"rad": 1, "mrad": "1e-3", "deg": _DEG, "°": _DEG})
    add("rate", {"1/s": 1, "/s": 1, "s^-1": 1, "1/ms": 1000, "/ms": 1000, "1/us": 10**6,
                 "/us": 10**6})
    add("angular_velocity", {"rad/s": 1, "deg/s": _DEG, "rpm": _F(math.pi / 30.0)})
    add("conductivity", {"W/(m K)": 1, "W/m/K": 1, "W/(cm K)": 100})
    add("heat_transfer", {"W/(m^2 K)": 1, "W/m^2/K": 1, "kW/(m^2 K)": 1000})
    add("heat_flux", {"W/m^2": 1, "kW/m^2": 1000, "MW/m^2": 10**6, "W/cm^2": 10**4})
    add("power_density", {"W/m^3": 1, "kW/m^3": 1000, "MW/m^3": 10**6, "W/cm^3": 10**6})
    add("expansion", {"1/K": 1, "/K": 1, "K^-1": 1, "1/degC": 1})
    return units, shown


def _normalise(unit: str) -> str:
    """One spelling per unit: micro sign -> u, no spaces, '*', '·' or '^'."""
    unit = unit.replace("µ", "u").replace("μ", "u")
    for ch in (" ", "*", "·", "^"):
        unit = unit.replace(ch, "")
    return unit


UNITS, _SHOWN = _build()
MAX_EXPONENT = 400  # decimal exponents beyond this are out of a double's range (1e308, 5e-324)
_NUMBER = re.compile(r"^\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*(.*?)\s*$")


def units_of(dimension: str) -> list[str]:
    """The units accepted for a dimension, as shown in messages and docs."""
    return list(_SHOWN.get(dimension, []))


def describe_dimension(dimension: str) -> str:
    """'a length (a number in m, or a string with a unit: m, mm, ...)' for messages."""
    si, name = DIMENSIONS[dimension]
    if dimension == "dimensionless":
        return "a number"
    return f"a {name} (a number in {si}, or a string with a unit: {', '.join(units_of(dimension))})"


def parse_quantity(value: object, dimension: str, key: str) -> float:
    """A plain number (SI) or '<number> <unit>' of the given dimension, as an SI float.

    Raises CaseError('<key>: ...') when the value is not a number, the unit is unknown, or the
    unit is of another dimension than the key expects.
    """
    if dimension not in DIMENSIONS:
        raise ValueError(f"unknown dimension {dimension!r}")
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise CaseError(f"{key}: expected {describe_dimension(dimension)}, got {_show(value)}")
    if isinstance(value, (int, float)):
        try:
            result = float(value)
        except OverflowError:  # an integer beyond 1.8e308
            result = math.inf
    else:
        result = _parse_string(value, dimension, key)
    if not math.isfinite(result):
        raise CaseError(f"{key}: expected a finite value, got {_show(value)}")
    limit = PLAUSIBLE.get(dimension)
    if limit is not None and abs(result) > limit:
        si, name = DIMENSIONS[dimension]
        raise CaseError(f"{key}: {result:g} {si} is beyond any plausible {name} of an impact "
                        f"simulation (at most {limit:g} {si} in magnitude)")
    return result


def _parse_string(text: str, dimension: str, key: str) -> float:
    match = _NUMBER.match(text)
    if not match:
        raise CaseError(f"{key}: cannot read {text!r} as {describe_dimension(dimension)}: "
                        "expected '<number> <unit>'")
    text_number, unit = match.group(1), match.group(2)
    try:
        number = _exact(text_number)
    except (ValueError, OverflowError):  # more digits than int() takes, or out of range
        number = None
    if number is None:
        raise CaseError(f"{key}: expected a finite value, got {_clip(text)}")
    if not unit:
        return _to_float(number, text, key)
    norm = _normalise(unit)
    if norm not in UNITS:
        raise CaseError(f"{key}: unknown unit {unit!r} in {text!r}{_near_unit(norm, dimension)}; "
                        f"expected {describe_dimension(dimension)}")
    dim, factor, offset = UNITS[norm]
    if dim != dimension:
        raise CaseError(f"{key}: {text!r} is a {DIMENSIONS[dim][1]}, but this key expects "
                        f"{describe_dimension(dimension)}")
    return _to_float(number * factor + offset, text, key)


def _exact(text_number: str) -> Fraction | None:
    """The exact value of a decimal number, or None when it is beyond a double's range. An exact
    Fraction of 1e99999999 would take minutes to build, so a large exponent is judged first."""
    exponent = text_number.lower().partition("e")[2]
    if exponent and abs(int(exponent)) > MAX_EXPONENT:
        return Fraction(0) if float(text_number) == 0.0 else None
    return Fraction(text_number)


def _clip(text: str, width: int = 40) -> str:
    """repr of `text`, shortened in the middle when long (a message stays one readable line)."""
    if len(text) <= width:
        return repr(text)
    return repr(text[: width // 2] + "..." + text[-width // 2:])


def _to_float(value: Fraction, text: str, key: str) -> float:
    try:
        return float(value)
    except OverflowError:
        raise CaseError(f"{key}: expected a finite value, got {_clip(text)}") from None


def _near_unit(norm: str, dimension: str) -> str:
    lower = [u for u in units_of(dimension) if _normalise(u).lower() == norm.lower()]
    if lower:
        return f" (did you mean '{lower[0]}'?)"
    return ""


def _show(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return "an array"
    return repr(value)


def format_quantity(value: float, dimension: str) -> str:
    """A readable '80 us' / '0.8 mm' / '1.6 GPa' for summaries (not for re-reading exactly)."""
    # (unit, factor, smallest magnitude shown in that unit)
    pick = {
        "length": [("km", 1e3, 1e3), ("m", 1.0, 1.0), ("mm", 1e-3, 1e-4), ("um", 1e-6, 0.0)],
        "time": [("s", 1.0, 1.0), ("ms", 1e-3, 1e-3), ("us", 1e-6, 1e-7), ("ns", 1e-9, 0.0)],
        "pressure": [("GPa", 1e9, 1e9), ("MPa", 1e6, 1e6), ("kPa", 1e3, 1e3), ("Pa", 1.0, 0.0)],
        "velocity": [("km/s", 1e3, 1e4), ("m/s", 1.0, 0.0)],
    }.get(dimension)
    if not pick:
        return f"{value:.4g} {DIMENSIONS[dimension][0]}".strip()
    for unit, factor, smallest in pick:
        if abs(value) >= smallest:
            return f"{value / factor:.4g} {unit}"
    unit, factor, _ = pick[-1]
    return f"{value / factor:.4g} {unit}"
