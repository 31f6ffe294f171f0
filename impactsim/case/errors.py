"""Case errors and key paths: every message names the file and the key it is about."""

from __future__ import annotations

import difflib
from collections.abc import Iterable


class CaseError(Exception):
    """A case file that cannot be read or is not valid; the message starts with ``<file>: ``."""


def suggest(word: str, candidates: Iterable[str]) -> str:
    """'; did you mean 'x'?' for a near match among candidates, else the list of allowed names."""
    candidates = sorted(set(candidates))
    close = difflib.get_close_matches(word, candidates, n=1, cutoff=0.6)
    if close:
        return f"; did you mean '{close[0]}'?"
    if not candidates:
        return ""
    return "; expected one of: " + ", ".join(candidates)


class KeyPath:
    """Where a value sits in the case, printed like ``body[0].constraint[1].nodes (body "bar")``.

    Array indices are 0-based, as in ``--set body.0.mesh_size=...``. ``label`` names the body or
    material the path lies in, when its name is known.
    """

    __slots__ = ("parts", "label")

    def __init__(self, parts: tuple[str, ...] = (), label: str = ""):
        self.parts = parts
        self.label = label

    def key(self, name: str) -> KeyPath:
        return KeyPath(self.parts + (name,), self.label)

    def index(self, i: int) -> KeyPath:
        last = self.parts[-1] if self.parts else ""
        return KeyPath(self.parts[:-1] + (f"{last}[{i}]",), self.label)

    def labelled(self, label: str) -> KeyPath:
        return KeyPath(self.parts, label)

    def __str__(self) -> str:
        text = ".".join(self.parts) or "(top level)"
        return f"{text} ({self.label})" if self.label else text

    def error(self, message: str) -> CaseError:
        """A CaseError for this key; the file name is prefixed by the loader."""
        return CaseError(f"{self}: {message}")
