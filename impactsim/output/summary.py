"""summary.json (run facts, timings, versions) and case.resolved.toml (the case as run).

Both are written atomically. Values are converted to plain Python first: numpy scalars and
arrays, tuples, sets and paths become numbers, lists and strings.
- JSON: a float that is not finite (nan, inf) becomes null, keeping the file standard JSON;
  dates and times become ISO 8601 strings.
- TOML: a None is dropped from its table (TOML has no null); a None inside an array is an error,
  since dropping it would shift the other entries.
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import math
import os
from pathlib import PurePath

import numpy as np
import tomli_w

from impactsim.output.atomic import write_text


def write_summary(path: str | os.PathLike, data: dict) -> None:
    """Write `data` as indented JSON to `path`."""
    text = json.dumps(_plain(data, "", _json_float), indent=2, allow_nan=False, default=_iso_date)
    write_text(path, text + "\n")


def write_resolved_case(path: str | os.PathLike, case_dict: dict) -> None:
    """Write the resolved case `case_dict` as TOML to `path`."""
    plain = _plain(case_dict, "", float, drop_none=True)
    header = "# The case as run: defaults filled in, SI units.\n"
    write_text(path, header + tomli_w.dumps(plain))


def _iso_date(value: datetime.date | datetime.time) -> str:
    return value.isoformat()


def _json_float(x: float) -> float | None:
    return x if math.isfinite(x) else None


def _plain(value, where: str, on_float, drop_none: bool = False):
    """`value` as dicts, lists, str, int, float, bool, datetime (and None unless drop_none)."""
    if isinstance(value, dict):
        out = {}
        for key, item in value.items():
            key = _key(key, where)
            if drop_none and item is None:
                continue
            out[key] = _plain(item, f"{where}.{key}" if where else key, on_float, drop_none)
        return out
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return _plain(dataclasses.asdict(value), where, on_float, drop_none)
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (set, frozenset)):
        value = sorted(value)
    if isinstance(value, (list, tuple)):
        items = []
        for i, item in enumerate(value):
            if drop_none and item is None:
                raise ValueError(f"{where}[{i}]: None inside an array has no TOML form")
            items.append(_plain(item, f"{where}[{i}]", on_float, drop_none))
        return items
    if isinstance(value, np.generic):
        value = value.item()
    if value is None or isinstance(value, (bool, str, int, datetime.date, datetime.time)):
        return value
    if isinstance(value, float):
        return on_float(value)
    if isinstance(value, PurePath):
        return str(value)
    raise TypeError(f"{where or 'value'}: cannot write a {type(value).__name__}")


def _key(key, where: str) -> str:
    if isinstance(key, np.generic):
        key = key.item()
    if isinstance(key, (str, int, PurePath)) and not isinstance(key, bool):
        return str(key)
    raise TypeError(f"{where or 'value'}: key {key!r} is not a string")
