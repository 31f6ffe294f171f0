"""The built-in material library: named materials with their sources and the tests or experiments
they were checked against (library.toml).

An entry is a raw [[material]] table (values as written, units as strings); the case reader
merges it with the keys a case gives and validates the result. ``get`` answers to an entry's
name or any of its aliases.
"""

from __future__ import annotations

import copy
import functools
import tomllib
from pathlib import Path

LIBRARY_FILE = Path(__file__).with_name("library.toml")


@functools.lru_cache(maxsize=1)
def _entries() -> tuple[dict[str, dict], dict[str, str]]:
    with LIBRARY_FILE.open("rb") as f:
        raw = tomllib.load(f)
    aliases: dict[str, str] = {}
    for name, entry in raw.items():
        for alias in entry.get("aliases", []):
            aliases[alias] = name
    return raw, aliases


def names() -> list[str]:
    """The entries' names, in file order (aliases not included)."""
    return list(_entries()[0])


def aliases() -> dict[str, str]:
    """alias -> entry name."""
    return dict(_entries()[1])


def canonical(name: str) -> str | None:
    """The entry name for a name or alias, None if the library has neither."""
    entries, alias_map = _entries()
    if name in entries:
        return name
    return alias_map.get(name)


def get(name: str) -> dict:
    """A copy of the entry (a raw [[material]] table without `aliases` and `checked_against`);
    KeyError if unknown."""
    entries, _ = _entries()
    key = canonical(name)
    if key is None:
        raise KeyError(f"no material {name!r} in the library")
    entry = copy.deepcopy(entries[key])
    entry.pop("aliases", None)
    entry.pop("checked_against", None)
    return entry


def checked_against(name: str) -> str:
    """The tests and experiments an entry was checked against (its `checked_against`)."""
    entries, _ = _entries()
    return entries[canonical(name)].get("checked_against", "")
