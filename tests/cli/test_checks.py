"""A wrong run never ends quietly, and [checks] act as the case says (issue 16 reproducers).

Each check is triggered by a hand-made case here; tests/cli/test_check.py::
test_bundled_cases_trigger_no_check shows the bundled cases trigger none at t = 0.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from impactsim.case import load_case_text
from impactsim.checks import CheckFailed, CheckLog
from impactsim.cli import main
from impactsim.solver import run as run_module
from impactsim.solver.passes import Pass

BAR = """
[run]
name = "tiny-bar"
end_time = "20 us"
[[body]]
name = "bar"
material = "steel-elastic"
shape = "box"
size = ["4 mm", "4 mm", "20 mm"]
position = [0, 0, "{z}"]
mesh_size = "2 mm"
mesher = "structured"
velocity = [0, 0, "-50 m/s"]
[[wall]]
point = [0, 0, 0]
normal = [0, 0, 1]
[output]
frames = 4
"""


def _run(tmp_path, text, *args):
    case = tmp_path / "case.toml"
    case.write_text(text)
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["run", str(case), "-o", str(out), "-q", *args])
    summary = json.loads((out / "summary.json").read_text()) if (out / "summary.json").exists() \
        else None
    return result, summary


def test_body_starting_under_one_element_inside_a_wall_is_refused(tmp_path):
    """Issue 16: 0.5 mm inside the wall (elements of 2 mm) ran with energy growing 7,700x."""
    result, _ = _run(tmp_path, BAR.format(z="9.5 mm"))
    assert result.exit_code == 2, result.output
    assert "checks.initial_penetration" in result.output
    assert "body 'bar' and wall[0] overlap by 0.5 mm" in result.output
    check = CliRunner().invoke(main, ["check", str(tmp_path / "case.toml")])
    assert check.exit_code == 2 and "overlap by 0.5 mm" in check.output


def test_wall_penetration_with_warn_is_stopped_by_the_energy_balance(tmp_path):
    text = BAR.format(z="9.5 mm") + '[checks]\ninitial_penetration = "warn"\n'
    result, summary = _run(tmp_path, text)
    assert result.exit_code == 3, result.output
    assert summary["checks"]["initial_penetration"]["action"] == "warn"
    assert summary["stop"]["kind"] == "check" and "energy_balance" in summary["stopped"]
    assert summary["energy_balance_error_max"] > 0.05
    assert summary["time"] < summary["end_time"]
    # the warning is printed once
    assert result.output.count("check initial_penetration (warn)") == 1


def test_two_bodies_overlapping_by_30_mm_are_named_with_the_depth(tmp_path):
    text = """
[run]
end_time = "10 us"
[[body]]
name = "block"
material = "steel-elastic"
shape = "box"
size = ["60 mm", "60 mm", "40 mm"]
mesh_size = "10 mm"
mesher = "structured"
[[body]]
name = "puck"
material = "steel-elastic"
shape = "box"
size = ["20 mm", "20 mm", "40 mm"]
position = [0, 0, "10 mm"]
mesh_size = "5 mm"
mesher = "structured"
velocity = [0, 0, "-100 m/s"]
"""
    path = tmp_path / "case.toml"
    path.write_text(text)
    result = CliRunner().invoke(main, ["check", str(path)])
    assert result.exit_code == 2
    # the depth is the deepest node's distance to the other body's surface: the puck's nodes
    # at the block's mid-plane are 20 mm from its faces
    assert "body 'block' and body 'puck' overlap by 20 mm" in result.output, result.output


def _nan_at_step(step: int, node: int):
    class Poison(Pass):
        name = "poison"
        stage = "velocity"

        def run(self, model, dt):
            if model.step == step:
                model.v[node, 1] = np.nan

    return Poison()


def test_a_nan_stops_the_run_in_the_step_it_appears_naming_node_body_time(tmp_path,
                                                                           monkeypatch):
    case = load_case_text(BAR.format(z="10.01 mm"))
    real = run_module.build_passes
    monkeypatch.setattr(run_module, "build_passes",
                        lambda c, m: real(c, m) + [_nan_at_step(7, 5)])
    summary = run_module.run_case(case, tmp_path, progress=False)
    assert summary["steps"] == 8  # the step in which the nan appeared (step 7 -> 8)
    assert summary["stop"]["kind"] == "non-finite"
    assert "node 5 (body 'bar') has a non-finite velocity" in summary["stopped"]
    assert "t = " in summary["stopped"]
    assert (tmp_path / "series.pvd").exists()


def test_a_nan_mesh_node_passed_directly_stops_before_the_first_step(tmp_path):
    """(A mesh file with a NaN node is refused by the reader: tests/fuzz/test_fuzz_mesh.py.)"""
    from impactsim.mesh.structured import structured_box

    case = load_case_text(BAR.format(z="10.01 mm"))
    pts, tets = structured_box((4e-3, 4e-3, 20e-3), 2e-3)
    pts = pts + [0, 0, 10.01e-3]
    pts[3, 2] = np.nan
    summary = run_module.run_case(case, tmp_path, progress=False, meshes=[(pts, tets)])
    assert summary["steps"] == 0 and summary["stop"]["kind"] == "non-finite"
    assert "node 3 (body 'bar')" in summary["stopped"]


def test_time_step_floor_error_and_erode(tmp_path):
    base = BAR.format(z="10.01 mm")
    result, summary = _run(tmp_path, base + '[checks]\ntime_step_floor = "1 us"\n')
    assert result.exit_code == 3
    assert "time_step_floor" in summary["stopped"] and "element" in summary["stopped"]
    assert summary["steps"] <= 1
    out2 = tmp_path / "b"
    out2.mkdir()
    result, summary = _run(out2, base + '[checks]\ntime_step_floor = "1 us"\n'
                           'time_step_floor_action = "erode"\n', "--set",
                           "run.max_steps=5")
    rec = summary["checks"]["time_step_floor"]
    assert rec["action"] == "erode" and rec["count"] >= 1
    assert result.output.count("check time_step_floor (erode): time step") == 1  # once
    assert f"check time_step_floor (erode): triggered {rec['count']} time(s)" in result.output


def test_negative_volume_stops_then_erode_goes_on(tmp_path):
    """A bar starting 3 mm (1.5 elements) inside the wall: the wall snaps its nodes out and
    elements invert in the first step."""
    deep = BAR.format(z="7 mm") + '[checks]\ninitial_penetration = "ignore"\n' \
        'energy_balance_action = "ignore"\n'
    result, summary = _run(tmp_path, deep)
    assert result.exit_code == 3 and "inverted" in summary["stopped"]
    assert "first element" in summary["stopped"] and "body 'bar'" in summary["stopped"]
    out2 = tmp_path / "b"
    out2.mkdir()
    result, summary = _run(out2, deep + 'negative_volume = "erode"\n')
    rec = summary["checks"].get("negative_volume")
    assert rec is not None and rec["action"] == "erode" and rec["count"] >= 1, result.output
    assert summary["energy"]["eroded_energy"] >= 0.0
    assert summary["steps"] > 1


def test_hourglass_share_is_generic_over_an_optional_column():
    case = load_case_text(BAR.format(z="10.01 mm"))
    log = CheckLog()
    run_module._hourglass_check({"time": 0.0, "kinetic_energy": 1.0}, case.checks, log)
    assert log.summary() == {}  # no hourglass column: nothing to watch
    run_module._hourglass_check({"time": 1e-6, "kinetic_energy": 1.0, "internal_energy": 1.0,
                                 "hourglass_energy": 0.5}, case.checks, log)
    assert log.summary()["hourglass_share"]["action"] == "warn"
    case.checks.hourglass_share_action = "error"
    with pytest.raises(CheckFailed):
        run_module._hourglass_check({"time": 1e-6, "kinetic_energy": 1.0,
                                     "hourglass_energy": 0.5}, case.checks, CheckLog())


def test_unconverged_contact_rounds_are_told(tmp_path, monkeypatch):
    class Unconverged(Pass):
        name = "fake-contact"
        stage = "velocity"

        def run(self, model, dt):
            pass

        def summary(self, model):
            return {"unconverged_steps": 3, "steps_in_contact": 5}

    case = load_case_text(BAR.format(z="10.01 mm"))
    real = run_module.build_passes
    monkeypatch.setattr(run_module, "build_passes", lambda c, m: real(c, m) + [Unconverged()])
    summary = run_module.run_case(case, tmp_path, progress=False)
    assert summary["checks"]["unconverged_contact"] == {
        "action": "warn", "count": 3, "first": summary["checks"]["unconverged_contact"]["first"],
        "last": summary["checks"]["unconverged_contact"]["last"]}
    assert summary["stopped"] is None
    case.checks.unconverged_contact = "error"
    summary = run_module.run_case(case, tmp_path / "e", progress=False)
    assert "unconverged_contact" in summary["stopped"]


BARS = """
[run]
name = "two-bars"
end_time = "12 us"
[[body]]
name = "striker"
material = "steel-elastic"
shape = "box"
size = ["5 mm", "5 mm", "20 mm"]
position = [0, 0, "10.05 mm"]
mesh_size = "2.5 mm"
mesher = "structured"
velocity = [0, 0, "-20 m/s"]
[[body]]
name = "target"
material = "steel-elastic"
shape = "box"
size = ["5 mm", "5 mm", "20 mm"]
position = [0, 0, "-10 mm"]
mesh_size = "2.5 mm"
mesher = "structured"
[contact]
passes = ["node-face", "edge-edge"]
[checks]
{checks}
"""


def test_unconverged_contact_rounds_of_a_real_contact_are_counted(tmp_path):
    """The projected rounds' unconverged steps sit in the contact pass's table
    (contact.node-face): a real contact run is told when their share of the steps in contact
    exceeds the limit, and not below it."""
    quiet = run_module.run_case(load_case_text(BARS.format(checks="")), tmp_path / "a",
                                progress=False)
    unconverged, in_contact = run_module.unconverged_contact(quiet)
    assert in_contact > 0 and unconverged / in_contact <= 0.25
    assert "unconverged_contact" not in quiet["checks"]
    if unconverged == 0:
        pytest.skip("no unconverged step in this contact")
    told = run_module.run_case(load_case_text(BARS.format(
        checks='unconverged_contact = "error"\nunconverged_contact_share = 0.0')),
        tmp_path / "b", progress=False)
    assert told["stop"]["kind"] == "check" and "unconverged_contact" in told["stopped"]
    assert told["checks"]["unconverged_contact"]["count"] == unconverged


DRAG_HEX = """
[run]
name = "drag-hex"
end_time = "1 us"
[[material]]
name = "al"
library = "al-ideal-plastic"
[[body]]
name = "block"
material = "al"
shape = "box"
size = ["4 mm", "4 mm", "4 mm"]
mesh_size = "1 mm"
mesher = "structured"
element = "hex8"
[[body.constraint]]
nodes = {{ box = {{ lo = ["1.9 mm", "1.9 mm", "1.9 mm"], hi = ["2.1 mm", "2.1 mm", "2.1 mm"] }} }}
velocity = ["2000 m/s", "0 m/s", "0 m/s"]
[checks]
{checks}
"""


def test_hourglass_share_triggered_by_a_hand_made_hex_case(tmp_path):
    """One node of a hex block dragged at 2 km/s: the one-point hexes around it deform in
    hourglass modes, whose energy passes the default 10 % of kinetic + internal."""
    s = run_module.run_case(load_case_text(DRAG_HEX.format(checks="")), tmp_path / "w",
                            progress=False)
    rec = s["checks"]["hourglass_share"]
    assert rec["action"] == "warn" and rec["count"] >= 1 and s["stopped"] is None
    assert s["energy"]["hourglass_energy"] > 0.1 * (s["energy"]["kinetic_energy"]
                                                    + s["energy"]["internal_energy"])
    e = run_module.run_case(load_case_text(DRAG_HEX.format(
        checks='hourglass_share_action = "error"')), tmp_path / "e", progress=False)
    assert e["stop"]["kind"] == "check" and "hourglass_share" in e["stopped"]
    off = run_module.run_case(load_case_text(DRAG_HEX.format(checks="hourglass_share = 10.0")),
                              tmp_path / "o", progress=False)
    assert "hourglass_share" not in off["checks"]


SMALL_BUNDLED = ["elastic-bar-wall", "taylor-bar", "two-cubes", "two-cylinders", "elastic-bars",
                 "hertz-spheres"]


def _bundled_check(name):
    from pathlib import Path

    from impactsim.case import load_case
    from impactsim.case.describe import describe_case

    root = Path(__file__).resolve().parents[2]
    text = describe_case(load_case(root / "cases" / f"{name}.toml"))
    assert "# initial overlap: none" in text
    assert "warning: run.max_steps" not in text


@pytest.mark.parametrize("name", SMALL_BUNDLED)
def test_bundled_cases_trigger_no_check_at_t0(name, monkeypatch):
    monkeypatch.setenv("IMPACTSIM_NO_CALIBRATE", "1")
    _bundled_check(name)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["sphere-plate", "oblique-sphere"])
def test_large_bundled_cases_trigger_no_check_at_t0(name, monkeypatch):
    monkeypatch.setenv("IMPACTSIM_NO_CALIBRATE", "1")
    _bundled_check(name)
