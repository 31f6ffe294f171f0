"""`impactsim materials`: the library's entries as a table with their sources, or one entry."""

from __future__ import annotations

from impactsim.materials import library


class MaterialError(Exception):
    """An unknown material name."""


def _models(entry: dict) -> str:
    strength = entry.get("strength", {}).get("model", "elastic")
    eos = entry.get("eos", {}).get("model", "linear")
    fail = ", ".join(k for k in entry.get("failure", {}))
    return f"{strength} / {eos}" + (f" / failure: {fail}" if fail else "")


def listing() -> str:
    """One block per entry: name (aliases), density, models, source."""
    lines = []
    for name in library.names():
        entry = library.get(name)
        aliases = [a for a, n in library.aliases().items() if n == name]
        head = name + (f" (also: {', '.join(aliases)})" if aliases else "")
        lines.append(f"{head}\n    density {entry.get('density', '?')}; {_models(entry)}\n"
                     f"    source: {entry.get('source', 'not given')}")
    lines.append("Use one in a case: material = \"<name>\" on a body, or library = \"<name>\" in a "
                 "[[material]] table (its keys override the entry's). impactsim materials NAME "
                 "shows every value.")
    return "\n".join(lines)


def describe(name: str) -> str:
    """Every key of one entry, as TOML."""
    import tomli_w

    try:
        entry = library.get(name)
    except KeyError:
        raise MaterialError(f"no material {name!r} in the library; it has: "
                            f"{', '.join(library.names())}") from None
    return f"[{library.canonical(name)}]\n" + tomli_w.dumps(entry)
