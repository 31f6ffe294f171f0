"""`impactsim run` end to end: outputs, their contents, and clear stops."""

import json
from pathlib import Path

import meshio
import numpy as np
from click.testing import CliRunner

from impactsim.cli import main
from impactsim.output.series import read_collection
from impactsim.results import history_array

BAR = """
[run]
name = "tiny-bar"
end_time = "20 us"
[[material]]
name = "steel"
library = "steel-elastic"
[[body]]
name = "bar"
material = "steel"
shape = "box"
size = ["4 mm", "4 mm", "20 mm"]
position = [0, 0, "10.01 mm"]
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
    return result, out


def test_run_writes_series_history_summary_and_resolved_case(tmp_path):
    result, out = _run(tmp_path, BAR)
    assert result.exit_code == 0, result.output
    frames = read_collection(out / "series.pvd")
    times = np.array([t for t, _ in frames])
    np.testing.assert_allclose(times, [0.0, 5e-6, 1e-5, 1.5e-5, 2e-5], rtol=1e-15)  # on time
    mesh = meshio.read(frames[-1][1])
    for name in ("stress", "pressure", "von_mises", "plastic_strain", "temperature", "body"):
        assert name in mesh.cell_data
    assert {"velocity", "displacement"} <= set(mesh.point_data)
    hist = history_array(out / "history.csv")
    for col in ("time", "dt", "kinetic_energy", "internal_energy", "total_energy"):
        assert col in hist.dtype.names
    summary = json.loads((out / "summary.json").read_text())
    bar = summary["bodies"]["bar"]
    assert abs(bar["mass"] / (7850 * 4e-3 * 4e-3 * 20e-3) - 1) < 1e-12
    assert {"walls", "element", "nodes"} <= set(summary["seconds_per_pass"])
    assert summary["steps"] == hist["step"][-1]
    assert (out / "case.resolved.toml").exists()
    # the resolved case is itself a valid case
    check = CliRunner().invoke(main, ["check", str(out / "case.resolved.toml")])
    assert check.exit_code == 0, check.output


def test_override_changes_the_run(tmp_path):
    result, out = _run(tmp_path, BAR, "--set", "run.end_time=1e-5", "--set", "output.frames=1")
    assert result.exit_code == 0, result.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["time"] == 1e-5


def test_inverting_element_stops_clearly_with_last_frame(tmp_path):
    """A crushing prescribed velocity far beyond anything physical: the run must stop with a
    message (inverted element or collapsed time step), exit code 3, and keep its frames."""
    crush = BAR.replace('velocity = [0, 0, "-50 m/s"]', 'velocity = [0, 0, 0]') + """
[[body.constraint]]
nodes = { plane = { point = [0, 0, "20.01 mm"], normal = [0, 0, 1] } }
velocity = [0, 0, "-9e4 m/s"]
[checks]
energy_balance_action = "warn"
"""
    result, out = _run(tmp_path, crush.replace('end_time = "20 us"', 'end_time = "2 us"'))
    assert result.exit_code == 3
    assert "Traceback" not in result.output
    assert "inverted" in result.output or "collapsed" in result.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["stopped"]
    frames = read_collection(out / "series.pvd")
    assert frames[-1][0] == summary["time"] > 0.0  # the last frame is the state at the stop


def test_unknown_output_field_is_named(tmp_path):
    result, _ = _run(tmp_path, BAR + 'fields = ["velocity", "von_mise"]\n')
    assert result.exit_code == 2
    assert "output.fields[1]" in result.output and "von_mises" in result.output


def test_selected_fields_only(tmp_path):
    result, out = _run(tmp_path, BAR + 'fields = ["velocity", "pressure"]\n')
    assert result.exit_code == 0, result.output
    mesh = meshio.read(read_collection(out / "series.pvd")[-1][1])
    assert set(mesh.cell_data) == {"pressure"} and set(mesh.point_data) == {"velocity"}
