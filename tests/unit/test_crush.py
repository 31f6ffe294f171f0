"""The parts of the cost estimate's step count and the run's re-estimate (case/crush.py,
case/estimate.py): impacts found from the bodies' boxes and velocities, the crush number and
shrink, the step factor, the load factor, the frames that cost steps and the re-estimate's
arithmetic. Figures, not timings."""

import math

import numpy as np
import pytest

from impactsim.case import load_case_text
from impactsim.case import crush as C
from impactsim.case.estimate import (DEFAULT_SPEED, contention, cpu_share, estimate_cost,
                                     inner_frames, re_estimate)

ROD = """
[run]
name = "rod"
end_time = "{end}"
[[body]]
name = "rod"
material = "{material}"
shape = "cylinder"
diameter = "8 mm"
height = "24 mm"
axis = [0, 0, 1]
position = [0, 0, "{z}"]
mesh_size = "1 mm"
velocity = [0, 0, "{v}"]
[[wall]]
"""

PAIR = """
[run]
name = "pair"
end_time = "{end}"
[[body]]
name = "target"
material = "al-ideal-plastic"
shape = "box"
size = ["20 mm", "20 mm", "10 mm"]
position = [0, 0, "-5 mm"]
mesh_size = "1 mm"
mesher = "structured"
[[body]]
name = "striker"
material = "al-ideal-plastic"
shape = "box"
size = ["6 mm", "6 mm", "6 mm"]
position = [0, 0, "{z}"]
mesh_size = "1 mm"
mesher = "structured"
velocity = ["{vx}", 0, "{vz}"]
[contact]
passes = ["node-face"]
"""


def rod(end="50 us", material="ofhc-copper", z="12.1 mm", v="-190 m/s"):
    return load_case_text(ROD.format(end=end, material=material, z=z, v=v))


def test_a_body_moving_to_a_wall_meets_it_at_gap_over_speed():
    (imp,) = C.impacts(rod())
    assert imp.bodies == ("rod", "wall[0]")
    assert imp.speed == pytest.approx(190.0)
    assert imp.time == pytest.approx(0.1e-3 / 190.0, rel=1e-9)
    assert C.impacts(rod(v="190 m/s")) == []  # moving away
    assert C.impacts(rod(end="0.1 us")) == []  # meets it after end_time


def test_a_pair_meets_along_the_separating_axis_and_the_smaller_one_strikes():
    case = load_case_text(PAIR.format(end="10 us", z="5 mm", vx="300 m/s", vz="-400 m/s"))
    (imp,) = C.impacts(case)
    assert imp.bodies == ("target", "striker")
    # boxes separated along z by 2 mm; the approach speed is the z component only
    assert imp.speed == pytest.approx(400.0)
    assert imp.time == pytest.approx(2e-3 / 400.0)
    assert imp.strikers == (False, True)  # 6 x 6 mm punching into 20 x 20 mm
    apart = load_case_text(PAIR.format(end="10 us", z="5 mm", vx="0 m/s", vz="400 m/s"))
    assert C.impacts(apart) == []


def test_crush_number_is_dynamic_pressure_over_the_initial_flow_stress():
    case = rod()
    copper = case.materials["ofhc-copper"]
    assert C.flow_stress(copper) == copper.strength.A  # Johnson-Cook: A
    assert C.crush_number(copper, 190.0) == pytest.approx(copper.density * 190.0**2
                                                          / copper.strength.A)
    elastic = rod(material="steel-elastic").materials["steel-elastic"]
    assert C.flow_stress(elastic) is None and C.crush_number(elastic, 1e4) == 0.0


def test_shrink_grows_with_the_crush_number_and_is_capped():
    phis = [0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 1e3]
    for element in ("tet", "hex8"):
        s = [C.shrink_of(p, element) for p in phis]
        assert all(v >= 1.0 for v in s)
        assert all(b >= a for a, b in zip(s, s[1:]))  # monotone
        assert s[-1] == C.TET_SHRINK[2] if element == "tet" else C.HEX_SHRINK[2]
    assert C.shrink_of(0.0) == 1.0  # elastic
    assert C.shrink_of(1e300) == C.TET_SHRINK[2]  # no overflow of the power
    extreme = estimate_cost(rod(v="-1e5 m/s"), dict(DEFAULT_SPEED))  # the largest accepted
    assert extreme.crush_factor <= C.TET_SHRINK[2] and extreme.steps >= 1
    assert C.shrink_of(1e3, fails=True) == C.FAILURE_SHRINK  # cells break off first


def test_crushed_body_and_step_factor():
    """An elastic rod is never crushed; a copper rod at 190 m/s is, from its impact on, and its
    step shrinks towards the shrink over the crush time."""
    assert C.crushes(rod(material="steel-elastic")) == []
    (cr,) = C.crushes(rod())
    assert cr.body == 0 and cr.shrink == pytest.approx(C.shrink_of(cr.phi))
    assert cr.duration == pytest.approx(C.CRUSH_LENGTHS["tet"] * 1e-3 / 190.0)
    assert cr.shrink_at(0.0) == 1.0  # before the impact
    assert cr.shrink_at(cr.time + 50 * cr.duration) == pytest.approx(cr.shrink, rel=1e-9)
    own = [1e-7]
    factor = C.step_factor([cr], own, 1e-7, 50e-6)
    assert 1.0 < factor < cr.shrink
    assert C.step_factor([cr], own, 1e-7, 1e-3) == pytest.approx(cr.shrink, rel=0.05)
    assert C.step_factor([], own, 1e-7, 50e-6) == 1.0


def test_a_body_with_a_larger_first_step_shrinks_the_run_only_below_the_run_step():
    cr = C.Crush(body=1, shrink=4.0, time=0.0, duration=1e-300, phi=10.0)
    # body 1's own first step is twice the run's: shrunk 4 times it is half the run's
    g = C.shrink_profile([cr], [1e-8, 2e-8], 1e-8, [1e-6])
    assert g[0] == pytest.approx(2.0)
    cr.shrink = 1.5  # 2e-8 / 1.5 is still above the run's 1e-8: no change
    assert C.shrink_profile([cr], [1e-8, 2e-8], 1e-8, [1e-6])[0] == 1.0


def test_estimated_steps_carry_the_crush_factor():
    speed = dict(DEFAULT_SPEED)
    elastic = estimate_cost(rod(material="steel-elastic"), speed)
    plastic = estimate_cost(rod(), speed)
    assert elastic.crush_factor == 1.0 and plastic.crush_factor > 2.0
    base = plastic.steps_needed - 1 - inner_frames(rod())
    lean = estimate_cost(rod(material="steel-elastic"), speed)
    assert base == pytest.approx(plastic.crush_factor * (lean.steps_needed - 1 - inner_frames(
        rod())) * elastic.dt / plastic.dt, rel=0.01)


def test_contention_and_frames_inside_the_run(monkeypatch):
    assert 0.0 < cpu_share(0.05) <= 1.0
    assert contention(1.0) == 1.0 and contention(0.25) == pytest.approx(4.0)
    monkeypatch.setenv("IMPACTSIM_NO_CALIBRATE", "1")
    assert contention() == 1.0  # not measured under tests and CI
    case = rod()
    assert inner_frames(case) == case.output.frames - 1
    shared = estimate_cost(case, dict(DEFAULT_SPEED), share=0.25)
    alone = estimate_cost(case, dict(DEFAULT_SPEED))
    assert alone.contention == 1.0 and shared.contention == pytest.approx(4.0)
    for part, seconds in alone.seconds.items():
        assert shared.seconds[part] == pytest.approx(4.0 * seconds, rel=1e-9), part


def test_re_estimate_is_the_measured_rate_over_the_steps_left():
    case = rod(material="steel-elastic")
    est = estimate_cost(case, dict(DEFAULT_SPEED))
    r = re_estimate(est, time=5e-6, end_time=50e-6, steps=100, dt=1e-8, loop_seconds=2.0,
                    elapsed=3.0, frames_left=0)
    assert r["shrink_ahead"] == 1.0  # nothing crushed
    assert r["steps"] == 100 + 4500
    assert r["wall_seconds"] == pytest.approx(3.0 + 4500 * 0.02)
    plastic = estimate_cost(rod(), dict(DEFAULT_SPEED))
    r2 = re_estimate(plastic, time=5e-6, end_time=50e-6, steps=100, dt=1e-8, loop_seconds=2.0,
                     elapsed=3.0)
    assert r2["shrink_ahead"] > 1.0 and r2["steps"] > r["steps"]  # the step shrinks further
    assert math.isfinite(r2["wall_seconds"])


def test_a_run_reestimates_itself_and_keeps_it_in_the_summary(tmp_path, monkeypatch):
    from impactsim.solver.run import run_case

    monkeypatch.setenv("IMPACTSIM_NO_CALIBRATE", "1")
    case = rod(end="4 us", material="steel-elastic")
    s = run_case(case, tmp_path, progress=False)
    r = s["re_estimate"]
    assert r["time"] >= 0.05 * case.run.end_time and r["time"] < case.run.end_time
    assert r["steps_so_far"] >= 1 and r["steps"] == pytest.approx(s["steps"], rel=0.2)
    assert s["estimate"]["crush_factor"] == 1.0
