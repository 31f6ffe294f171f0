"""The cost estimate of `impactsim check` (impactsim.case.estimate) against real meshes and runs."""

import json
from pathlib import Path

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
    from impactsim.case.estimate import ELEMENT_TE, NODES_TE

    assert est.contention == 1.0  # a speed given: a whole core unless a share is given too
    per_step = speed["seconds_per_step"] + (ELEMENT_TE + NODES_TE) * est.elements * 1e-9 * \
        speed["ns_per_element_step"]
    assert est.seconds["elements"] == pytest.approx(est.steps * per_step)
    assert est.wall_seconds == pytest.approx(sum(est.seconds.values()))
    assert np.isfinite(DEFAULT_SPEED["ns_per_element_step"])


def test_case_that_would_not_fit_in_memory_is_refused_with_the_figure(monkeypatch):
    """Issue 16: a 20M-element case died of MemoryError after meshing; a 480M one was
    estimated at 31.8 minutes."""
    from impactsim.case import CaseError
    from impactsim.case import estimate as E
    from impactsim.case.describe import describe_case

    monkeypatch.setattr(E, "available_memory", lambda: 8e9)
    case = load_case_text(BAR.format(end="20 us").replace('"2.5 mm"', '"0.1 mm"'))
    assert estimate_cost(case).elements == 6 * 100 * 100 * 600
    with pytest.raises(CaseError, match=r"body\[0\]\.mesh_size: the case would need ≈ 72\.4 GB"
                                        r" of memory for ≈ 36,000,000 elements.*8 GB available"):
        describe_case(case)


@pytest.mark.parametrize("shape", ["box", "cylinder"])
def test_huge_hex_body_is_counted_without_meshing_and_refused(shape, monkeypatch):
    """A hex body's count is made by meshing it only while that is cheap: a fuzzed case (a box
    of 81 x 78,896 x 5 cells) allocated memory until the machine killed `make hard`. Now a
    huge hex body is counted from its dimensions (about 5e11 hexes here) and refused for
    memory before anything is allocated."""
    from impactsim.case import CaseError
    from impactsim.case import estimate as E
    from impactsim.case.describe import describe_case

    monkeypatch.setattr(E, "_hex_mesh", lambda body: pytest.fail("meshed a huge hex body"))
    text = BAR.format(end="20 us").replace('"2.5 mm"', '"1 um"').replace(
        'mesher = "structured"', 'mesher = "structured"\nelement = "hex8"')
    if shape == "cylinder":
        text = text.replace('shape = "box"\nsize = ["10 mm", "10 mm", "60 mm"]',
                            'shape = "cylinder"\nradius = "5 mm"\nheight = "60 mm"').replace(
            'mesher = "structured"\n', "")
    case = load_case_text(text)
    assert body_elements(case.bodies[0]) > 1e11
    with pytest.raises(CaseError, match="would need"):
        describe_case(case)


def test_implausible_calibration_is_discarded(tmp_path, monkeypatch):
    from impactsim.case import estimate as E

    monkeypatch.setenv("IMPACTSIM_CACHE", str(tmp_path / "meshes"))
    monkeypatch.setattr(E, "_seconds_per_step", lambda cells, s, c: (
        (384, 1e-4) if cells == 4 else (24_576, 1e-4 + 24_192 * 1e-13)))  # 0.1 ns/element
    speed = calibrate_speed(threads=1, seconds=0.1)
    assert speed["source"].startswith("default (a measurement of 0.1")
    assert speed["ns_per_element_step"] == DEFAULT_SPEED["ns_per_element_step"]
    assert not speed_file().exists()  # not stored


def test_estimate_uses_the_thread_count_of_the_run_and_warns_of_max_steps():
    case = load_case_text(BAR.format(end="1 ms") + "\n[run]\n".replace("[run]\n", ""))
    est = estimate_cost(case)
    assert est.threads == 1  # 2,304 elements: one thread, as the run (solver.run.thread_count)
    capped = load_case_text(BAR.format(end="1 ms").replace("cfl = 0.6", "cfl = 0.6\nmax_steps = 100"))
    est = estimate_cost(capped)
    assert est.steps == 100 and est.steps_needed > 100
    assert any("run.max_steps = 100 stops the run before its end time" in line
               for line in est.detail_lines())


def test_the_output_estimate_counts_at_most_a_frame_a_step():
    """More frames than steps: the run writes at most one a step and stops at max_steps (the
    estimate of frames = 2**63 - 1 was 10^12 days of output)."""
    capped = BAR.format(end="1 ms").replace("cfl = 0.6", "cfl = 0.6\nmax_steps = 100")
    est = {n: estimate_cost(load_case_text(capped.replace("frames = 4", f"frames = {n}")))
           for n in (100, 2**63 - 1)}
    assert est[100].steps == est[2**63 - 1].steps == 100
    assert est[2**63 - 1].seconds["output"] == est[100].seconds["output"] > 0.0


def test_contact_fracture_and_output_are_in_the_wall_time():
    two = load_case_text((Path(__file__).resolve().parents[2] / "cases" /
                          "elastic-bars.toml").read_text())
    est = estimate_cost(two)
    assert est.seconds["contact"] > 0 and est.seconds["output"] > 0
    assert est.wall_seconds == pytest.approx(sum(est.seconds.values()))
