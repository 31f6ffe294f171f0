"""The cost estimate of `impactsim check` (impactsim.case.estimate) against real meshes and runs."""

import json

import numpy as np
import pytest

from impactsim.case import load_case_text
from impactsim.case.describe import what_would_run
from impactsim.case.estimate import (DEFAULT_SPEED, body_elements, body_min_length,
                                     calibrate_speed, estimate_cost, machine_speed, speed_file)
from impactsim.mesh import mesh_body
from impactsim.mesh.quality import altitudes
from impactsim.solver.run import run_case

BAR = """
[run]
name = "bar"
end_time = "{end}"
cfl = 0.6
[[body]]
name = "bar"
material = "steel-elastic"
shape = "box"
size = ["10 mm", "10 mm", "60 mm"]
position = [0, 0, "30.001 mm"]
mesh_size = "2.5 mm"
mesher = "structured"
velocity = [0, 0, "-20 m/s"]
[[wall]]
[output]
frames = 4
"""


@pytest.fixture(autouse=True)
def _no_calibration(monkeypatch):
    monkeypatch.setenv("IMPACTSIM_NO_CALIBRATE", "1")


def test_structured_box_elements_exact_and_steps_within_30_percent(tmp_path):
    case = load_case_text(BAR.format(end="20 us"))
    est = estimate_cost(case)
    pts, tets = mesh_body(case.bodies[0])
    assert est.elements == len(tets)
    assert est.l_min == pytest.approx(altitudes(pts, tets).min(), rel=1e-12)
    summary = run_case(case, tmp_path, progress=False)
    assert summary["elements"] == est.elements
    assert est.steps == pytest.approx(summary["steps"], rel=0.3)


@pytest.mark.parametrize("shape, dims", [
    ("cylinder", 'radius = "5 mm"\nheight = "20 mm"'),
    ("sphere", 'radius = "6 mm"'),
    ("box", 'size = ["12 mm", "8 mm", "5 mm"]'),
])
def test_gmsh_element_count_and_smallest_altitude(shape, dims):
    case = load_case_text(f"""
[run]
end_time = 1e-6
[[body]]
material = "steel-elastic"
shape = "{shape}"
{dims}
mesh_size = "0.8 mm"
""")
    body = case.bodies[0]
    pts, tets = mesh_body(body)
    assert body_elements(body) == pytest.approx(len(tets), rel=0.1)
    assert body_min_length(body) == pytest.approx(altitudes(pts, tets).min(), rel=0.35)


def test_check_prints_the_estimate_line():
    lines = what_would_run(load_case_text(BAR.format(end="1 ms")))
    last = lines[-1]
    assert last.startswith("#   ≈ 2,304 elements, ≈ ") and " steps, ≈ " in last
    assert "ns/element-step" in last and all(line.startswith("#") for line in lines)


def test_default_speed_without_calibration_then_stored_measurement(tmp_path, monkeypatch):
    monkeypatch.setenv("IMPACTSIM_CACHE", str(tmp_path / "meshes"))
    assert speed_file() == tmp_path / "speed.json"
    assert machine_speed(threads=1)["source"] == "default"
    speed = calibrate_speed(threads=1, seconds=0.4)
    assert speed["ns_per_element_step"] > 0 and speed["seconds_per_step"] >= 0
    stored = json.loads(speed_file().read_text())
    assert any(k.endswith("threads=1") for k in stored["machines"])
    assert machine_speed(threads=1) == speed  # read back, not measured again
    est = estimate_cost(load_case_text(BAR.format(end="1 ms")), speed)
    per_step = speed["seconds_per_step"] + est.elements * 1e-9 * speed["ns_per_element_step"]
    assert est.seconds["elements"] == pytest.approx(est.steps * per_step)
    assert est.wall_seconds == pytest.approx(sum(est.seconds.values()))
    assert np.isfinite(DEFAULT_SPEED["ns_per_element_step"])
