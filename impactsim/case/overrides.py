"""``--set key.path=value`` overrides, applied to the raw TOML tables before validation.

The value is read as a TOML value (``run.cfl=0.5``, ``body.0.velocity=[0, 0, -100]``,
``run.end_time="80 us"``); when it is not valid TOML it is taken as a bare string
(``run.end_time=80 us``). Key paths name tables and keys as in the file; an element of an array
of tables is addressed by its 0-based index (``body.0`` or ``body[0]``) or its name
(``body.bar``, ``material.copper``). Every name is checked against the case spec, so a typo
gets the same "did you mean" as a typo in the file.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Sequence

from impactsim.case.errors import CaseError, KeyPath, suggest
from impactsim.case.read import type_name
from impactsim.case.spec import ROOT, Key, Table

_SEGMENT = re.compile(r"([^.\[\]]+)|\[(\d+)\]")


def parse_value(text: str) -> object:
    """A TOML value, or the text itself (stripped) when it is not one."""
    try:
        return tomllib.loads("v = " + text)["v"]
    except (tomllib.TOMLDecodeError, ValueError):  # ValueError: an integer of 4300+ digits
        return text.strip()


def split_key(key: str) -> list[str | int]:
    """'body[0].velocity' / 'body.0.velocity' -> ['body', 0, 'velocity']."""
    parts: list[str | int] = []
    pos = 0
    key = key.strip()
    while pos < len(key):
        if key[pos] == "." and parts:
            pos += 1
        m = _SEGMENT.match(key, pos)
        if not m:
            raise CaseError(f"cannot read the key path {key!r}")
        if m.group(2) is not None:
            parts.append(int(m.group(2)))
        else:
            seg = m.group(1).strip()
            parts.append(int(seg) if seg.isdigit() else seg)
        pos = m.end()
    if not parts:
        raise CaseError("empty key path")
    return parts


def apply_overrides(raw: dict, overrides: Sequence[str], root: Table = ROOT) -> None:
    """Set each 'key.path=value' in the raw case tables (in place); `root` is the key table
    the paths are checked against (the quasistatic cases have their own)."""
    for item in overrides:
        if "=" not in item:
            raise CaseError(f"--set {item}: expected KEY=VALUE, e.g. --set run.cfl=0.5")
        key, text = item.split("=", 1)
        try:
            _set(raw, split_key(key), parse_value(text), root)
        except CaseError as err:
            raise CaseError(f"{err} (from --set {item})") from None
        except ValueError as err:  # an index of 4300+ digits
            raise CaseError(f"--set {item}: {err}") from None


def _set(raw: dict, parts: list[str | int], value: object, root: Table = ROOT) -> None:
    node: dict | list = raw
    spec: Table = root
    path = KeyPath()
    for i, part in enumerate(parts):
        last = i == len(parts) - 1
        if isinstance(node, list):  # an array of tables: pick an element
            idx = _element(node, part, spec, path)
            path = path.index(idx)
            if last:
                if not isinstance(value, dict):
                    raise path.error(f"expected a table, got {type_name(value)}")
                node[idx] = value
                return
            node = node[idx]
            continue
        if isinstance(part, int):
            raise path.error(f"[{spec.name}] is a table, not an array: no element {part}")
        child = spec.get(part)
        path = path.key(part)
        if child is None:
            where = (f"[[{spec.name}]]" if spec.array else f"[{spec.name}]") if spec.name \
                else "the top level"
            raise path.error(f"unknown key '{part}' in {where}{suggest(part, spec.names)}")
        if last:
            node[part] = value
            return
        if isinstance(child, Key):
            raise path.error(f"'{part}' is a value, not a table: set it whole")
        spec = child
        if child.array:
            node = node.setdefault(part, [])
            if not isinstance(node, list):
                raise path.error(f"expected an array of tables, got {type_name(node)}")
        else:
            if not isinstance(node.get(part), dict):  # absent, or a shorthand like "all"
                node[part] = {}
            node = node[part]


def _element(items: list, part: str | int, spec: Table, path: KeyPath) -> int:
    if isinstance(part, int):
        if not 0 <= part < len(items):
            raise path.error(f"no element {part}: the case has {len(items)} [[{spec.name}]] "
                             "tables (indices from 0)")
        return part
    names = [_name_of(t) or (f"body{i}" if spec.name == "body" else "")
             for i, t in enumerate(items)]
    if part in names:
        return names.index(part)
    known = [n for n in names if n]
    raise path.error(f"no [[{spec.name}]] named '{part}'{suggest(part, known)}")


def _name_of(table: object) -> str:
    if not isinstance(table, dict):
        return ""
    name = table.get("name", table.get("library", ""))
    return name if isinstance(name, str) else ""
