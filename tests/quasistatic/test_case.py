"""Quasistatic case files through the CLI: check, run outputs, and one-line errors (exit 2)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from impactsim.cli import main

CASES = Path(__file__).parents[2] / "cases"

SMALL = """
[run]
analysis = "quasistatic"
end_time = "1 s"
steps = 2
[quasistatic]
element = "tet4"
[[body]]
name = "lower"
material = "steel-elastic"
shape = "box"
size = ["10 mm", "10 mm", "10 mm"]
mesh_size = "5 mm"
mesher = "structured"
[[body.boundary]]
name = "base"
plane = { point = [0, 0, "-5 mm"], normal = [0, 0, 1] }
displacement = [0, 0, 0]
[[body]]
name = "upper"
material = "steel-elastic"
shape = "box"
size = ["10 mm", "10 mm", "10 mm"]
position = [0, 0, "10 mm"]
mesh_size = "5 mm"
mesher = "structured"
[[body.boundary]]
name = "top"
plane = { point = [0, 0, "15 mm"], normal = [0, 0, 1] }
pressure = "5 MPa"
ramp = true
"""


def _write(tmp_path, text):
    path = tmp_path / "case.toml"
    path.write_text(text)
    return path


def test_check_prints_what_would_be_solved(tmp_path):
    res = CliRunner().invoke(main, ["check", str(_write(tmp_path, SMALL))])
    assert res.exit_code == 0, res.output
    assert "quasistatic" in res.output and "load steps: 2" in res.output
    assert "top (plane): pressure" in res.output


def test_run_writes_the_series_convergence_summary_and_resolved_case(tmp_path):
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", str(_write(tmp_path, SMALL)), "-o", str(out), "-q"])
    assert res.exit_code == 0, res.output
    for name in ("series.pvd", "step_00000.vtu", "step_00001.vtu", "convergence.csv",
                 "convergence.png", "summary.json", "case.resolved.toml"):
        assert (out / name).exists(), name
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] and len(summary["iterations_per_step"]) == 2
    # the deepest node left out of the contact, per load step (m)
    assert all(0.0 <= s["max_penetration"] < 1e-7 for s in summary["load_steps"])
    import meshio
    m = meshio.read(out / "step_00001.vtu")
    szz = m.point_data["stress"].reshape(-1, 3, 3)[:, 2, 2]
    assert abs(szz.mean() / -5e6 - 1) < 0.01  # full load at the last step (ramp)
    m0 = meshio.read(out / "step_00000.vtu")
    assert abs(m0.point_data["stress"].reshape(-1, 3, 3)[:, 2, 2].mean() / -2.5e6 - 1) < 0.01


def test_a_run_that_does_not_converge_exits_3_and_keeps_its_files(tmp_path):
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", str(_write(tmp_path, SMALL)), "-o", str(out), "-q",
                                    "--set", "quasistatic.max_iterations=1"])
    assert res.exit_code == 3
    assert "no convergence in 1 iterations" in res.output
    assert json.loads((out / "summary.json").read_text())["converged"] is False
    assert (out / "step_00000.vtu").exists()


@pytest.mark.parametrize("change, message", [
    (("steps = 2", "steps = 0"), "run.steps: must be > 0"),
    (('shape = "box"\nsize = ["10 mm", "10 mm", "10 mm"]\nmesh_size = "5 mm"\nmesher = "structured"\n[[body.boundary]]\nname = "base"',
      'shape = "box"\nsize = ["10 mm", "10 mm", "10 mm"]\nmesh_size = "5 mm"\nmesher = "structured"\n[[body.boundary]]\nname = "base"\nbox = { lo = [0, 0, 0], hi = [1, 1, 1] }'),
     "give exactly one of plane, box, cylinder, group (got plane, box)"),
    (('pressure = "5 MPa"', 'pressure = "5 mm"'), "body[1].boundary[0].pressure"),
    (('element = "tet4"', 'element = "tet8"'), "quasistatic.element"),
    (('[quasistatic]', '[quasistatic]\nrelaxtion = 0.5'), "did you mean 'relaxation'"),
    (('material = "steel-elastic"', 'material = "unobtainium"'), "unknown material"),
    (('[quasistatic]', '[[contact.pair]]\nbodies = ["lower", "upper"]\nfriction = -0.3\n[quasistatic]'),
     "contact.pair[0].friction: must be >= 0"),
])
def test_bad_input_is_one_line_naming_file_and_key(tmp_path, change, message):
    text = SMALL.replace(*change, 1)
    assert text != SMALL
    path = _write(tmp_path, text)
    res = CliRunner().invoke(main, ["check", str(path)])
    assert res.exit_code == 2, res.output
    line = res.output.strip()
    assert "\n" not in line and str(path) in line and message in line, line


def test_a_boundary_that_selects_nothing_is_reported_when_the_run_starts(tmp_path):
    text = SMALL.replace('plane = { point = [0, 0, "15 mm"]', 'plane = { point = [0, 0, "25 mm"]')
    res = CliRunner().invoke(main, ["run", str(_write(tmp_path, text)), "-o",
                                    str(tmp_path / "o"), "-q"])
    assert res.exit_code == 2
    assert "body[1].boundary[0]" in res.output and "selects no boundary facet" in res.output


def test_bundled_quasistatic_cases_check():
    for name in ("blocks-pressed", "thermal-stack", "pellet-stack"):
        res = CliRunner().invoke(main, ["check", str(CASES / f"{name}.toml")])
        assert res.exit_code == 0, (name, res.output)
