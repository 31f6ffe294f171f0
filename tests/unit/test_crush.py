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


def test_foot_strain_solves_taylors_plastic_front_balance():
    """Ideal plasticity: rho v^2 / Y0 = e^2 / (1 - e) with e = 1 - exp(-eps), Taylor (1948);
    at large crush numbers eps -> ln(Phi)."""
    al = rod(material="al-ideal-plastic").materials["al-ideal-plastic"]
    y0 = al.strength.yield_stress
    for v in (50.0, 190.0, 400.0, 2000.0):
        phi = al.density * v * v / y0
        eps = C.foot_strain(al, v)
        e = 1.0 - math.exp(-eps)
        assert e * e / (1.0 - e) == pytest.approx(phi, rel=1e-9)
    assert C.foot_strain(al, 1e4) == pytest.approx(math.log(al.density * 1e8 / y0), rel=0.01)
    # a target flows under three times its flow stress: as if met at 1/sqrt(3) of the speed
    assert C.foot_strain(al, 400.0, constraint=3.0) == pytest.approx(
        C.foot_strain(al, 400.0 / math.sqrt(3.0)), rel=1e-9)
    elastic = rod(material="steel-elastic").materials["steel-elastic"]
    assert C.foot_strain(elastic, 1e3) == 0.0 and C.mean_flow_stress(elastic, 1.0) is None


def test_hardening_lowers_the_foot_strain_through_the_mean_flow_stress():
    copper = rod().materials["ofhc-copper"]
    a, b, n = copper.strength.A, copper.strength.B, copper.strength.n
    # the mean of A + B e^n over [0, eps]: its plastic work over eps
    grid = np.linspace(0.0, 1.5, 200001)
    work = np.trapezoid(a + b * grid**n, grid)
    assert C.mean_flow_stress(copper, 1.5) == pytest.approx(work / 1.5, rel=1e-4)
    eps = C.foot_strain(copper, 190.0)
    e = 1.0 - math.exp(-eps)
    assert copper.density * 190.0**2 / C.mean_flow_stress(copper, eps) == pytest.approx(
        e * e / (1.0 - e), rel=1e-9)
    # without its hardening (Y = A throughout) the same copper would flow much further
    from dataclasses import replace
    soft = replace(copper, strength=replace(copper.strength, B=0.0))
    assert C.foot_strain(soft, 190.0) > 1.5 * eps
    # the bundled Taylor bars: copper at 190 m/s (Phi 3.6) and a quenched steel at 287 m/s
    # (Phi 0.8) reach feet of 0.98 and 0.69 (their runs: rim plastic strains 2.2 and 1.8), not
    # strains 4.5 times apart as their crush numbers are
    steel = load_case_text(ROD.format(end="50 us", material="steel-42crmo4", z="12.1 mm",
                                      v="-287 m/s")).materials["steel-42crmo4"]
    assert C.crush_number(copper, 190.0) / C.crush_number(steel, 287.0) > 4.0
    assert eps == pytest.approx(0.98, abs=0.02)
    assert C.foot_strain(steel, 287.0) == pytest.approx(0.69, abs=0.02)


def test_shrink_grows_with_the_foot_strain_and_is_capped():
    strains = [0.0, 0.2, 0.5, 1.0, 2.0, 4.0, 1e3]
    for element in ("tet", "hex8"):
        s = [C.shrink_of(x, element) for x in strains]
        assert s[0] == 1.0 and all(v >= 1.0 for v in s)
        assert all(b >= a for a, b in zip(s, s[1:]))  # monotone
        assert s[-1] == C.SHRINK_CAP[element]
        assert s[3] == pytest.approx(math.exp(C.SHRINK_PER_STRAIN[element]))
    assert C.shrink_of(1e300) == C.SHRINK_CAP["tet"]  # no overflow of the exponential
    extreme = estimate_cost(rod(v="-1e5 m/s"), dict(DEFAULT_SPEED))  # the largest accepted
    assert extreme.crush_factor <= C.SHRINK_CAP["tet"] and extreme.steps >= 1
    assert C.shrink_of(1e3, fails=True) == C.FAILURE_SHRINK  # cells break off first


def test_a_hard_striker_the_target_cannot_press_is_not_crushed():
    """Tate: a target presses on a striker at most with rho_t v^2 / 2 + 3 Y_t; a bearing-steel
    sphere (Y0 2 GPa) on an aluminium plate at 500 m/s stays rigid, at 2 km/s it is crushed;
    the plate (the target) is crushed, at half the speed and three times its flow stress."""
    text = PAIR.replace('material = "al-ideal-plastic"\nshape = "box"\nsize = ["6 mm"',
                        'material = "steel-52100"\nshape = "box"\nsize = ["6 mm"')
    for vz, crushed in (("-500 m/s", {"target"}), ("-2000 m/s", {"target", "striker"})):
        case = load_case_text(text.format(end="10 us", z="5 mm", vx="0 m/s", vz=vz))
        found = C.crushes(case)
        assert {case.bodies[c.body].name for c in found} == crushed, vz
        target = next(c for c in found if case.bodies[c.body].name == "target")
        al = case.materials["al-ideal-plastic"]
        v = abs(float(vz.split()[0]))
        assert target.strain == pytest.approx(C.foot_strain(al, 0.5 * v, constraint=3.0))
    steel = case.materials["steel-52100"]
    assert not C.pushes(al, 500.0, steel) and C.pushes(al, 2000.0, steel)
    assert C.pushes(steel, 10.0, al)  # a soft striker on a hard target is crushed


def test_crushed_body_and_step_factor():
    """An elastic rod is never crushed; a copper rod at 190 m/s is, from its impact on, and its
    step shrinks towards the shrink over the crush time."""
    assert C.crushes(rod(material="steel-elastic")) == []
    (cr,) = C.crushes(rod())
    assert cr.body == 0 and cr.shrink == pytest.approx(C.shrink_of(cr.strain))
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


def test_cpu_share_from_the_schedulers_times(monkeypatch):
    """The share is the thread's time on a core over its time wanting one (on a core or in the
    run queue), since the last reading, or since the thread started when too little time has
    passed since then; without the scheduler's figures it is a busy loop's."""
    from impactsim.case import estimate

    readings = iter([(3e8, 1e8), (5e8, 5e8), (5.5e8, 5.5e8), None])
    monkeypatch.setattr(estimate, "_schedstat", lambda: next(readings))
    monkeypatch.setattr(estimate, "_last_schedstat", None)
    assert cpu_share(0.3) == pytest.approx(0.75)        # since the thread started
    assert cpu_share(0.3) == pytest.approx(2 / 6)       # since the last reading
    assert cpu_share(0.3) == pytest.approx(0.5)         # 0.1 s since: since the start
    assert 0.0 < cpu_share(0.05) <= 1.0                 # no figures: the busy loop


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
