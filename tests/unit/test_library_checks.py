"""Every library entry carries its source and what it was checked against (issue 17, item 5),
and every entry a bundled case uses is checked by the material-law tests (item 1)."""

import re
import tomllib
from pathlib import Path

import pytest

from impactsim.materials import library
from tests.verification import test_material_laws as laws

ROOT = Path(__file__).parents[2]


@pytest.mark.parametrize("name", library.names())
def test_entry_names_its_source_and_checks(name):
    entry = tomllib.loads(library.LIBRARY_FILE.read_text())[name]
    assert entry.get("source"), "no source"
    checked = library.checked_against(name)
    assert checked, "no checked_against"
    for path in re.findall(r"(?:tests|docs|cases)/[\w/.-]+\.(?:py|md|toml)", checked):
        assert (ROOT / path).exists(), f"{name}: {path} named in checked_against does not exist"
    assert "checked_against" not in library.get(name)  # not a material key of a case


def _library_names_in_cases():
    names = set()
    for case in (ROOT / "cases").glob("*.toml"):
        raw = tomllib.loads(case.read_text())
        for mat in raw.get("material", []):
            if "library" in mat:
                names.add(library.canonical(mat["library"]))
        for body in raw.get("body", []):
            canon = library.canonical(body.get("material", ""))
            if canon:
                names.add(canon)
    return names


def test_entries_of_the_bundled_cases_are_checked_by_the_law_tests():
    used = _library_names_in_cases()
    assert used, "the bundled cases use library entries"
    checked = set(laws.JC_METALS) | set(laws.PRANDTL_REUSS) | set(laws.MG_METALS)
    for name in used:
        entry = library.get(name)
        plastic = entry.get("strength", {}).get("model") in ("johnson-cook", "ideal-plastic")
        mg = entry.get("eos", {}).get("model") == "mie-gruneisen"
        if plastic or mg:
            assert name in checked, f"{name} (used by a bundled case) is not in the law tests"
