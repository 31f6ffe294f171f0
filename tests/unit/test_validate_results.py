"""The validation ladder's stored results (benchmarks/validation_results.json) and the partial
rerun (`python benchmarks/validate.py --rungs X`): a rerun of some rungs replaces only their
records, and the report written after it keeps every other rung's section, whatever this
machine's out/validation/ holds (a fresh clone has none)."""

import json
import sys
from pathlib import Path

ROOT = Path(__file__).parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))

import validate  # noqa: E402

SECTIONS = ("## Taylor bars", "## The 6061-T6 strength law", "## Symmetric plate impact",
            "## Perforation under the defaults", "## Perforation: oblique sphere",
            "## Perforation: residual velocity", "## Code to code")


def _keys(results):
    return {(r["rung"], r["element"], r["h_mm"]) for r in results}


def test_merge_replaces_only_the_rerun_records():
    old = [{"rung": "a", "element": "tet4", "h_mm": 1.0, "v": 1},
           {"rung": "a", "element": "anp", "h_mm": 1.0, "v": 2},
           {"rung": "b", "element": "tet4", "h_mm": 0.5, "v": 3}]
    new = [{"rung": "a", "element": "anp", "h_mm": 1.0, "v": 20},
           {"rung": "c", "element": "tet4", "h_mm": 1.0, "v": 4}]
    merged = validate.merge_results(old, new)
    assert _keys(merged) == _keys(old) | _keys(new)
    assert {r["v"] for r in merged} == {1, 20, 3, 4}


def test_stored_results_hold_every_rung_of_the_ladder():
    """Each rung, element and mesh the ladder runs has a record in git, so the report can be
    rewritten from them alone (--report-only) on any machine."""
    stored = _keys(json.loads(validate.RESULTS.read_text()))
    want = {(t[0], e, t[3]) for t in validate.TAYLORS for e in validate.ELEMENTS}
    want |= {("taylor-42crmo4-287", f, h) for f in validate.CRMO_FORMULATIONS
             for h in validate.CRMO_SIZES}
    want |= {(f"perforation-{v:.0f}", "tet4", hp) for v in validate.PERFORATION_SPEEDS
             for _hs, hp in validate.PERFORATION_MESHES}
    want |= {(p, e, 0.1) for p in ("plate-6061-500", "plate-6061-500-d19")
             for e in validate.ELEMENTS}
    want |= {("oblique-sphere-1001", e, 1.4) for e in validate.ELEMENTS}
    want |= {("taylor-6061-373-rate", "anp", c) for c in validate.TAYLOR_RATE_C}
    assert not want - stored, sorted(want - stored)


def test_partial_rerun_keeps_every_section(tmp_path, monkeypatch):
    """`--rungs flow-6061` (the strength law against flow curves, no FE run) on a machine
    without out/validation/: the report still has every section and the stored results every
    other record."""
    results = tmp_path / "validation_results.json"
    results.write_text(validate.RESULTS.read_text())
    before = json.loads(results.read_text())
    monkeypatch.setattr(validate, "RESULTS", results)
    monkeypatch.setattr(validate, "OUT", tmp_path / "out")
    monkeypatch.setattr(validate, "DOC", tmp_path / "validation.md")
    monkeypatch.setattr(validate, "FIG", tmp_path / "fig")
    monkeypatch.setattr(validate, "STORED", tmp_path / "reference.json")
    assert validate.main(["--rungs", "flow-6061"]) == 0
    doc = (tmp_path / "validation.md").read_text()
    for section in SECTIONS:
        assert section in doc, section
    after = json.loads(results.read_text())
    assert _keys(after) == _keys(before)
    other = [r for r in before if r["rung"] != "flow-6061"]
    assert all(r in after for r in other)
