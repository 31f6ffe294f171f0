"""The time step near output times (impactsim.solver.loop.Simulation.next_dt).

A frame time cuts a step short; that must not throttle the steps after it (the growth limit
of 1.1 per step counts from the last full step), and a limit between one and two steps away is
reached in two equal steps rather than a full step and a sliver. Found in elastic-bars: a step
ended 1.15e-10 s before the 45 us frame, the sliver step then capped the next one at 1.1 times
itself, and the collapse check stopped the run.
"""

import pytest

from impactsim.solver.loop import DT_GROWTH, Simulation
from tests.builders import box_model, material


def _sim():
    model, _ = box_model(material(), h=0.5)
    model.v[:, 0] = 1.0
    sim = Simulation(model, [])
    for _ in range(3):
        sim.step()
    return sim


def test_a_sliver_before_a_frame_does_not_throttle_the_next_steps():
    sim = _sim()
    full = sim.next_dt()
    sliver = 1e-6 * full
    assert sim.step(sliver) == sliver
    after = sim.step()
    assert after == pytest.approx(min(sim.cfl * sim.dt_stable, DT_GROWTH * full), rel=1e-3)
    assert after > 0.5 * full
    for _ in range(5):  # no collapse stop, steady steps
        assert sim.step() > 0.5 * full


def test_a_limit_between_one_and_two_steps_is_reached_in_two_equal_steps():
    sim = _sim()
    full = sim.next_dt()
    t_frame = sim.model.time + 1.5 * full
    first = sim.step(t_frame - sim.model.time)
    second = sim.step(t_frame - sim.model.time)
    assert first == pytest.approx(0.75 * full, rel=1e-12)
    assert second == pytest.approx(0.75 * full, rel=1e-9)
    assert sim.model.time == pytest.approx(t_frame, rel=1e-14)
