"""`impactsim check`: the resolved case and what would run, on stdout, exit 0."""

import tomllib

from click.testing import CliRunner

from impactsim.case import load_case
from impactsim.case.describe import active_passes, describe_case, estimate_elements
from impactsim.cli import main

TWO_BODIES = """\
[run]
name = "sphere-plate"
end_time = "4 us"

[[body]]
name = "sphere"
material = "steel-52100"
shape = "sphere"
radius = "1 cm"
mesh_size = "1 mm"
speed = "2 km/s"
direction = [0, 0, -1]

[[body]]
name = "plate"
material = "al-2024-t3"
shape = "box"
size = ["60 mm", "60 mm", "2 mm"]
mesh_size = "0.5 mm"
mesher = "structured"
[[body.constraint]]
nodes = { outside_radius = "28 mm" }
fixed = true
"""

ONE_ELASTIC_BAR = """\
[run]
end_time = "20 us"

[[body]]
name = "bar"
material = "steel-elastic"
shape = "cylinder"
radius = "5 mm"
height = "100 mm"
mesh_size = "2 mm"
velocity = [0, 0, "-10 m/s"]
position = [0, 0, "50.01 mm"]

[[wall]]
normal = [0, 0, 1]
"""


def run_check(tmp_path, text, *args):
    path = tmp_path / "case.toml"
    path.write_text(text)
    return CliRunner().invoke(main, ["check", str(path), *args]), path


def test_check_prints_resolved_case_and_what_would_run(tmp_path):
    result, path = run_check(tmp_path, TWO_BODIES)
    assert result.exit_code == 0, result.output
    out = result.stdout
    # the resolved case: SI values, defaults filled, the library material written out
    assert "end_time = 4e-06" in out
    assert "cfl = 0.6" in out
    assert 'name = "al-2024-t3"' in out and "spall_strength = 1600000000.0" in out
    assert "velocity = [\n    0.0,\n    0.0,\n    -2000.0,\n]" in out
    # what would run
    # gmsh fit of impactsim.case.estimate: 3.62 V/h^3 + 1.51 S/h^2
    assert "sphere: sphere r 10 mm" in out and "≈ 17,061 tetrahedra" in out
    # structured: 120 x 120 x 4 cells, 6 tets each
    assert "plate: box 60 mm x 60 mm x 2 mm" in out and "≈ 345,600 tetrahedra" in out
    assert ("velocity passes: boundary-conditions, fracture.particles, contact.node-face, "
            "contact.edge-edge") in out
    assert "fracture passes: fracture (spall, loosening)" in out
    assert "end time: 4 us" in out
    assert result.stderr == ""


def test_check_output_is_itself_a_loadable_case(tmp_path):
    result, path = run_check(tmp_path, TWO_BODIES)
    resolved = tmp_path / "resolved.toml"
    resolved.write_text(result.stdout)
    again = load_case(resolved)
    again.source = path
    assert again == load_case(path)


def test_check_applies_overrides(tmp_path):
    result, _ = run_check(tmp_path, TWO_BODIES, "--set", "body.sphere.mesh_size=2 mm",
                          "--set", 'contact.passes=["node-face"]')
    assert result.exit_code == 0, result.output
    assert "mesh_size = 0.002" in result.stdout
    assert ("velocity passes: boundary-conditions, fracture.particles, contact.node-face"
            in result.stdout)


def test_single_body_has_no_contact_and_no_fracture(tmp_path):
    path = tmp_path / "bar.toml"
    path.write_text(ONE_ELASTIC_BAR)
    case = load_case(path)
    assert active_passes(case) == [("velocity", "walls")]
    text = describe_case(case)
    assert "fracture passes: none" in text
    assert "no contact passes: one body" in text
    # the gmsh fit 3.62 V/h^3 + 1.51 S/h^2 (impactsim.case.estimate), all in mm
    volume, area = 3.14159265358979 * 25 * 100, 2 * 3.14159265358979 * 5 * (5 + 100)
    assert estimate_elements(case.bodies[0]) == round(3.62 * volume / 8 + 1.51 * area / 4)
    tomllib.loads(text)  # the summary lines are TOML comments


def test_self_contact_turns_contact_on_for_one_body(tmp_path):
    path = tmp_path / "bar.toml"
    path.write_text(ONE_ELASTIC_BAR + "[contact]\nself_contact = true\npasses = [\"node-face\"]\n")
    assert ("velocity", "contact.node-face") in active_passes(load_case(path))


def test_check_hints_at_a_locking_element(tmp_path):
    """tet4 asked for with a plastic material gets a one-line hint; the default (auto: anp for
    a plastic body on a wall, tet4 with contact between bodies or elastic materials) gets
    none, and the element line says what auto chose and why."""
    case = tmp_path / "c.toml"
    runner = CliRunner()
    case.write_text(ONE_ELASTIC_BAR.replace('"steel-elastic"', '"ofhc-copper"'))
    out = runner.invoke(main, ["check", str(case)]).output
    assert "# hint:" not in out
    assert "element update: anp (auto: plastic material 'ofhc-copper')" in out
    out = runner.invoke(main, ["check", str(case), "--set", 'run.element="tet4"']).output
    hints = [line for line in out.splitlines() if line.startswith("# hint:")]
    assert len(hints) == 1 and "locks" in hints[0] and "anp" in hints[0]
    case.write_text(TWO_BODIES)
    out = runner.invoke(main, ["check", str(case)]).output
    assert "# hint:" not in out and "element update: tet4 (auto: contact between bodies)" in out
    case.write_text(ONE_ELASTIC_BAR)
    out = runner.invoke(main, ["check", str(case), "--set", 'run.element="tet4"']).output
    assert "# hint:" not in out and "element update: tet4" in out
