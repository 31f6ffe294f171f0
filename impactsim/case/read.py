"""Reading one raw TOML table against its spec: names checked, values converted to SI.

A ``Reader`` wraps a raw table (a dict from tomllib), the ``spec.Table`` it should match and its
``KeyPath``. Creating one rejects unknown keys (with a suggestion); ``get`` converts a value by
the kind its ``spec.Key`` declares, or returns the default.
"""

from __future__ import annotations

import math
from pathlib import Path

from impactsim.case.errors import KeyPath, suggest
from impactsim.case.spec import REQUIRED, Key, Table
from impactsim.case.units import describe_dimension, parse_quantity

_TYPE_NAMES = {bool: "a boolean", int: "an integer", float: "a number", str: "a string",
               list: "an array", dict: "a table"}


def type_name(value: object) -> str:
    return _TYPE_NAMES.get(type(value), type(value).__name__)


def check_names(raw: dict, table: Table, path: KeyPath) -> None:
    """Every key of `raw` must be one the spec table knows."""
    for name in raw:
        if table.get(name) is None:
            where = (f"[[{table.name}]]" if table.array else f"[{table.name}]") if table.name \
                else "the top level"
            raise path.key(name).error(
                f"unknown key '{name}' in {where}{suggest(name, table.names)}")


class Reader:
    def __init__(self, raw: dict, table: Table, path: KeyPath):
        if not isinstance(raw, dict):
            raise path.error(f"expected a table, got {type_name(raw)}")
        check_names(raw, table, path)
        self.raw = raw
        self.table = table
        self.path = path

    def has(self, name: str) -> bool:
        self._spec(name)
        return name in self.raw

    def given(self, names: tuple[str, ...] | list[str]) -> list[str]:
        return [n for n in names if self.has(n)]

    def at(self, name: str) -> KeyPath:
        return self.path.key(name)

    def error(self, name: str, message: str):
        return self.at(name).error(message)

    def get(self, name: str, kind: str | None = None):
        """The converted value, or the spec default (None / COMPUTED when not given)."""
        spec = self._spec(name)
        assert isinstance(spec, Key)
        if name not in self.raw:
            if spec.default is REQUIRED:
                raise self.at(name).error(f"missing required key '{name}'")
            return spec.default
        return convert(self.raw[name], spec, self.at(name), kind or spec.kind)

    def require(self, name: str, why: str = "", kind: str | None = None):
        """The converted value of a key that is required in this context."""
        if name not in self.raw:
            raise self.at(name).error(f"missing required key '{name}'{why}")
        return self.get(name, kind)

    def sub(self, name: str) -> Reader | str:
        """The nested table as a Reader (empty if absent), or a shorthand string it allows."""
        spec = self._spec(name)
        assert isinstance(spec, Table) and not spec.array
        raw = self.raw.get(name, {})
        if isinstance(raw, str) and spec.shorthands:
            if raw not in spec.shorthands:
                allowed = " or ".join(f'"{s}"' for s in spec.shorthands)
                raise self.at(name).error(f"expected a table or {allowed}, got {raw!r}"
                                          f"{suggest(raw, spec.shorthands)}")
            return raw
        return Reader(raw, spec, self.at(name))

    def items(self, name: str) -> list[tuple[dict, KeyPath]]:
        """The raw tables of an array of tables, each with its path."""
        spec = self._spec(name)
        assert isinstance(spec, Table) and spec.array
        raw = self.raw.get(name, [])
        if isinstance(raw, dict):
            raise self.at(name).error(f"expected an array of tables ([[{spec.name}]]), "
                                      f"got a single table ([{spec.name}])")
        if not isinstance(raw, list):
            raise self.at(name).error(f"expected an array of tables ([[{spec.name}]]), got "
                                      f"{type_name(raw)}")
        out = []
        for i, item in enumerate(raw):
            where = self.at(name).index(i)
            if not isinstance(item, dict):
                raise where.error(f"expected a table, got {type_name(item)}")
            out.append((item, where))
        return out

    def _spec(self, name: str) -> Key | Table:
        spec = self.table.get(name)
        if spec is None:
            raise KeyError(f"{name!r} is not in the spec of [{self.table.name}]")
        return spec


def convert(value: object, spec: Key, path: KeyPath, kind: str):
    """One raw TOML value -> its Python value in SI, by kind (see spec.KINDS)."""
    if kind == "quantity":
        return parse_quantity(value, spec.dim, str(path))
    if kind == "number":
        return parse_quantity(value, "dimensionless", str(path))
    if kind == "vector":
        return tuple(_list(value, path, 3, spec.dim, lambda v, p: parse_quantity(v, spec.dim, p)))
    if kind == "length-or-vector":
        raise AssertionError("length-or-vector is read as quantity or vector by the caller")
    if kind == "quantity-list":
        return [parse_quantity(v, spec.dim, f"{path}[{i}]")
                for i, v in enumerate(_list(value, path, 0, spec.dim, None))]
    if kind == "number-list":
        return tuple(_list(value, path, spec.length, "dimensionless",
                           lambda v, p: parse_quantity(v, "dimensionless", p)))
    if kind == "velocity-or-free":
        def one(v, p):
            if v == "free":
                return None
            return parse_quantity(v, "velocity", p)
        return tuple(_list(value, path, 3, "velocity", one))
    if kind == "length-or-free":
        def one_length(v, p):
            return None if v == "free" else parse_quantity(v, "length", p)
        return tuple(_list(value, path, 3, "length", one_length))
    if kind == "int":
        if isinstance(value, float) and value.is_integer():
            return _int64(int(value), path)
        if isinstance(value, bool) or not isinstance(value, int):
            raise path.error(f"expected an integer, got {type_name(value)} {_show(value)}")
        return _int64(value, path)
    if kind == "steps-or-time":  # an int counts steps; a float or "<t> <unit>" is a time
        if isinstance(value, int) and not isinstance(value, bool):
            if value < 0:
                raise path.error(f"expected a number of steps >= 0, got {value}")
            return _int64(value, path)
        t = parse_quantity(value, "time", str(path))
        if t < 0:
            raise path.error(f"expected a time >= 0, got {_show(value)}")
        return t
    if kind == "bool":
        if not isinstance(value, bool):
            raise path.error(f"expected true or false, got {type_name(value)} {_show(value)}")
        return value
    if kind in ("string", "path"):
        if not isinstance(value, str):
            raise path.error(f"expected a string, got {type_name(value)} {_show(value)}")
        if kind == "path":
            return Path(value)
        return value
    if kind == "choice":
        return _choice(value, spec, path)
    if kind == "choice-list":
        return [_choice(v, spec, KeyPath(path.parts[:-1] + (f"{path.parts[-1]}[{i}]",),
                                         path.label), in_list=True)
                for i, v in enumerate(_list(value, path, 0, "", None))]
    if kind == "string-list":
        items = _list(value, path, 0, "", None)
        for i, v in enumerate(items):
            if not isinstance(v, str):
                raise path.error(f"item {i}: expected a string, got {type_name(v)}")
        return list(items)
    raise AssertionError(f"unknown kind {kind}")


def _choice(value: object, spec: Key, path: KeyPath, in_list: bool = False) -> str:
    if not isinstance(value, str):
        raise path.error(f"expected a string (one of {', '.join(spec.choices)}), got "
                         f"{type_name(value)} {_show(value)}")
    if value not in spec.choices:
        what = f"value '{value}' in {spec.name}" if in_list else f"{spec.name} '{value}'"
        raise path.error(f"unknown {what}{suggest(value, spec.choices)}")
    return value


def _list(value: object, path: KeyPath, length: int, dim: str, each) -> list:
    what = f"{length} values" if length else "an array"
    if not isinstance(value, list):
        hint = f" ({describe_dimension(dim)} each)" if dim else ""
        raise path.error(f"expected an array of {what}{hint}, got {type_name(value)} "
                         f"{_show(value)}")
    if length and len(value) != length:
        raise path.error(f"expected {length} values, got {len(value)}")
    if each is None:
        return value
    return [each(v, f"{path}[{i}]") for i, v in enumerate(value)]


def _show(value: object) -> str:
    if isinstance(value, (dict, list)):
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value)


def unit_vector(v: tuple[float, float, float], path: KeyPath) -> tuple[float, float, float]:
    """v / |v|; a zero vector is an error. Already unit vectors are kept bit for bit."""
    norm = math.sqrt(sum(c * c for c in v))
    if norm == 0.0:
        raise path.error("must be a nonzero vector, got [0, 0, 0]")
    if abs(norm - 1.0) <= 1e-14:
        return tuple(float(c) for c in v)
    return tuple(c / norm for c in v)


def _int64(value: int, path: KeyPath) -> int:
    """An integer of the case: TOML's integers are 64-bit (a larger one cannot be represented
    losslessly, the TOML spec says, and the solver counts in 64 bits)."""
    if not -2**63 <= value < 2**63:
        raise path.error(f"expected an integer of at most 19 digits (TOML's 64 bits), got one "
                         f"of {len(str(abs(value)))} digits")
    return value


def positive(value: float, path: KeyPath, what: str = "", unit: str = "") -> float:
    if not value > 0.0:
        raise path.error(f"{what or 'must be'} > 0, got {value:g}{' ' + unit if unit else ''}")
    return value


def in_range(value: float, path: KeyPath, lo: float, hi: float, lo_open: bool = True,
             hi_open: bool = True) -> float:
    ok_lo = value > lo if lo_open else value >= lo
    ok_hi = value < hi if hi_open else value <= hi
    if not (ok_lo and ok_hi):
        interval = f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
        raise path.error(f"must be in {interval}, got {value:g}")
    return value


def non_negative(value: float, path: KeyPath) -> float:
    if value < 0.0:
        raise path.error(f"must be >= 0, got {value:g}")
    return value

