"""Subcycling (solver/subcycle.py): the parts of a graded mesh updated at their own intervals.

A cube whose cells are eight times thinner near one face strikes a rigid wall with that face:
the parts away from the fine cells take levels 1 and 2 (an update every 2 or 4 steps). The run
must stay what the run without subcycling is, within the error of the longer intervals, and
keep its energy balance; a mesh whose parts all have level 0 must give the same bits.
"""

from pathlib import Path

import numba
import numpy as np
import pytest

from impactsim.case.errors import CaseError
from impactsim.case.load import load_case
from impactsim.case.schema import Wall
from impactsim.mesh.renumber import renumber
from impactsim.mesh.structured import structured_box
from impactsim.model import ERODED
from impactsim.solver import element as E
from impactsim.solver.build import build_model
from impactsim.solver.loop import Simulation
from impactsim.solver.pipeline import build_passes
from impactsim.solver.run import SimulationError, run_case
from tests.builders import box_case, material

SPEED = 50.0  # [m/s] onto the wall


def graded_box(edge=0.04, h=0.002, fine=8.0, graded=0.2):
    """A structured cube whose cell thickness in z grows from h/fine at z = -edge/2 to h over
    the `graded` share of the cells, then stays (Z-curve order, as the meshers give)."""
    pts, tets = structured_box((edge, edge, edge), h)
    z = np.round(pts[:, 2], 12)
    levels = np.unique(z)
    n = len(levels) - 1
    thick = np.minimum(1.0, fine ** (np.arange(n) / (graded * n) - 1.0))
    zn = np.concatenate([[0.0], np.cumsum(thick)])
    pts = pts.copy()
    pts[:, 2] = (zn / zn[-1] - 0.5)[np.searchsorted(levels, z)] * edge
    return renumber(pts, tets)


def wall_sim(subcycle, mesh=None):
    """The cube (graded unless `mesh` is given) at SPEED onto a wall under its fine face."""
    case = box_case(material(), size=(0.04, 0.04, 0.04), h=0.002, velocity=(0.0, 0.0, -SPEED))
    case.walls = [Wall(point=(0.0, 0.0, -0.02 - 1e-6), normal=(0.0, 0.0, 1.0))]
    model = build_model(case, [graded_box() if mesh is None else mesh])
    return model, Simulation(model, build_passes(case, model), cfl=0.6, subcycle=subcycle)


def wall_run(subcycle, end=1.2e-5, mesh=None, threads=None):
    before = numba.get_num_threads()
    if threads:
        numba.set_num_threads(threads)
    try:
        model, sim = wall_sim(subcycle, mesh)
        e0 = sim.energies()["total_energy"]
        while model.time < end:
            sim.step(end - model.time)  # the last step ends on `end`: every part updated
    finally:
        numba.set_num_threads(before)
    return model, sim, e0


@pytest.fixture(scope="module")
def graded_runs():
    return wall_run(0), wall_run(3)


def test_the_graded_mesh_takes_levels_and_spares_updates(graded_runs):
    _, (model, sim, _) = graded_runs
    levels = np.bincount(sim.sub.part_level, minlength=4)
    assert levels[0] > 0 and levels[1:].sum() > 0
    report = sim.sub.report(model.step)
    assert report["part_updates_share"] < 0.99
    # a kick's interval and an update's stay within the part's stable step: U <= L <= M
    assert (sim.sub.part_level <= sim.sub.part_top).all()


def test_subcycled_run_follows_the_plain_run(graded_runs):
    (m0, s0, _), (m3, s3, _) = graded_runs
    assert m3.step == pytest.approx(m0.step, rel=0.02)
    # the coarse parts run at about the fine parts' Courant number instead of a quarter of it:
    # the wave fronts' ringing differs (at most 2.8 m/s at a node, 0.27 rms, when written)
    dv = m3.v - m0.v
    assert np.sqrt((dv ** 2).mean()) < 0.01 * SPEED
    assert np.abs(dv).max() < 0.1 * SPEED
    # the wave has come back from the wall: the mean velocity has turned
    assert m3.v[:, 2].mean() == pytest.approx(m0.v[:, 2].mean(), abs=0.005 * SPEED)
    assert np.abs(m3.sdev - m0.sdev).max() < 0.05 * np.abs(m0.sdev).max()


def test_levels_never_shorten_the_step():
    """After every step the global step is the least stable step of all (the fine parts'). Here
    the fine cells are removed mid-cycle: the coarse parts' steps over their intervals then
    come below the least one, and the cycle ends at once (`Subcycle._binding`) instead of the
    step shrinking until its end."""
    model, sim = wall_sim(3)
    least = sim.chunk_out[:, E.OUT_DT].min
    for _ in range(21):  # into a cycle
        sim.step()
        assert sim.dt_stable == least()
    assert sim.sub.part_level.max() > 0 and sim.sub.step_in_cycle != 0
    centroid_z = model.x[model.conn].mean(axis=1)[:, 2]
    model.status[centroid_z < -0.017] = ERODED  # the thin cells, as erosion would
    sim.refresh_stable_step()
    for _ in range(3):
        sim.step()
        assert sim.dt_stable == least()
    assert sim.sub.resyncs >= 1


def test_erosion_mid_cycle_keeps_the_forces_of_nodes_not_due():
    """Cells between the levels removed in a step that updates only the finest: the nodes due
    take their forces from the live cells at once (Simulation.refresh_forces), and a node not
    due keeps the force of its last kick, which a kick cut short is settled with and the
    half-step term reads (its parts are updated without the removed cells before its next
    kick)."""
    model, sim = wall_sim(3)
    for _ in range(40):
        sim.step()
        sub = sim.sub
        if sub.part_level.max() > 0 and not sub.synced and sub.top < sub.node_level.max():
            break
    else:
        pytest.fail("no step inside a cycle")
    corner_levels = sub.node_level[model.conn]  # cells with nodes due and nodes not due
    ids = np.flatnonzero((corner_levels.min(axis=1) <= sub.top)
                         & (corner_levels.max(axis=1) > sub.top) & (model.status != ERODED))
    ids = ids[::max(1, len(ids) // 40)]
    nodes = np.unique(model.conn[ids])
    due = sub.node_level[nodes] <= sub.top
    assert due.any() and (~due).any()
    before = model.force.copy()
    model.status[ids] = ERODED
    sim.refresh_forces(ids)
    np.testing.assert_array_equal(model.force[nodes[~due]], before[nodes[~due]])
    assert np.any(model.force[nodes[due]] != before[nodes[due]])


def test_subcycled_run_keeps_its_energy(graded_runs):
    """At a cycle's end (here the run's end, a time limit) the balance holds as without
    subcycling; within a cycle the coarse parts' internal energy lags (a few tenths of a per
    cent of this run's energy, docs/physics.md)."""
    _, (model, sim, e0) = graded_runs
    assert sim.sub.synced and sim.sub.step_in_cycle == 0 and not sim.sub.stale.any()
    energies = sim.energies()
    assert abs(energies["total_energy"] - e0) < 1e-3 * e0
    assert energies["internal_energy"] > 0.2 * e0  # the impact did happen


def test_levels_all_zero_give_the_plain_runs_bits():
    """A uniform mesh: every part at level 0, and the same bits as without subcycling."""
    pts, tets = renumber(*structured_box((0.04, 0.04, 0.02), 0.002))
    runs = [wall_run(k, end=4e-6, mesh=(pts, tets)) for k in (0, 2)]
    (m0, _, _), (m2, s2, _) = runs
    assert s2.sub.part_level.max() == 0
    assert m2.step == m0.step
    for name in ("x", "v", "force", "sdev", "pressure", "energy"):
        assert np.array_equal(getattr(m2, name), getattr(m0, name)), name


def test_one_and_two_threads_give_the_same_bits():
    one, two = wall_run(3, end=4e-6, threads=1), wall_run(3, end=4e-6, threads=2)
    assert one[0].step == two[0].step
    assert np.array_equal(one[0].x, two[0].x) and np.array_equal(one[0].v, two[0].v)


@pytest.mark.parametrize("n_cells", [(12, 12, 8), (20, 20, 20)])  # serial path, parallel path
def test_element_update_leaves_skipped_parts_alone(n_cells):
    """The tet kernel's `skip`: a part flagged keeps its state and adds no force."""
    h = 0.002
    size = tuple(h * n for n in n_cells)
    pts, tets = renumber(*structured_box(size, h))
    mat = material()
    case = box_case(mat, size=size, h=h, velocity=(0.0, 0.0, -SPEED))
    model = build_model(case, [(pts, tets)])
    assert (model.n_elem >= E.PARALLEL_ELEMENTS) == (n_cells[2] == 20)
    sim = Simulation(model, build_passes(case, model), cfl=0.6)
    rng = np.random.default_rng(1)
    model.v += rng.normal(0.0, 5.0, model.v.shape)  # a strain rate everywhere
    model.x += 1e-7 * model.v
    n_parts = len(E.part_flags(model.n_elem, sim.force_rows.part_size // E.CHUNK))
    assert n_parts >= 2
    skip = np.zeros(n_parts, np.int64)
    skip[1] = 1
    sdev = model.sdev.copy()
    sim.fext[:] = 0.0
    sim.tet_kernel(model.v, 1e-7, skip=skip)
    part = np.arange(model.n_elem) // sim.force_rows.part_size
    assert np.array_equal(model.sdev[part == 1], sdev[part == 1])
    assert (np.abs(model.sdev[part == 0] - sdev[part == 0]).max(axis=1) > 0).all()
    rows = np.unique(sim.force_rows.rows[part == 1])
    own = np.setdiff1d(rows, sim.force_rows.rows[part != 1])
    assert np.abs(sim.fext[own]).max() == 0.0
    sim.fext[:] = 0.0


@pytest.mark.parametrize("value", ["5", "-1", "true", "1.5"])
def test_subcycle_key_is_checked(tmp_path, value):
    path = tmp_path / "c.toml"
    path.write_text(f"""
[run]
end_time = "1 us"
subcycle = {value}

[[material]]
name = "cu"
library = "ofhc-copper"

[[body]]
name = "b"
material = "cu"
shape = "box"
size = [0.01, 0.01, 0.01]
mesh_size = 0.005
""")
    with pytest.raises(CaseError, match="run.subcycle"):
        load_case(path)
    path.write_text(path.read_text().replace(f"subcycle = {value}", "subcycle = 2"))
    assert load_case(path).run.subcycle == 2


def test_node_separation_is_refused_with_subcycling(tmp_path):
    case = sphere_block("material.block-al.failure={ fracture_strain = 0.05 }")
    with pytest.raises(SimulationError, match="run.subcycle: node separation"):
        run_case(case, tmp_path / "sep", progress=False)


ROOT = Path(__file__).resolve().parents[2]


def sphere_block(*more):
    """benchmarks/cases/sphere-block.toml made small: a 0.5 mm sphere of 3 mm radius into a
    block of 2.5 mm cells, 60 x 60 x 15 mm (its own parts: level 2 or 3), 6 us."""
    return load_case(ROOT / "benchmarks" / "cases" / "sphere-block.toml", overrides=[
        "run.end_time=6 us", "run.subcycle=3", "output.frames=2",
        'body.block.size=["60 mm", "60 mm", "15 mm"]',
        'body.block.position=["0 mm", "0 mm", "-7.5 mm"]',
        'body.sphere.radius=3 mm', 'body.sphere.position=["0 mm", "0 mm", "3.02 mm"]',
        *more])


def test_contact_on_a_coarse_body_books_its_work(tmp_path):
    """A fine sphere strikes a block of coarse cells (their own parts: level 2 or 3). The
    contact passes book an impulse's work with the node's velocity before its kick, which a
    coarse node not kicked in the step did not get (`Subcycle.kick`'s force for them)."""
    s = run_case(sphere_block(), tmp_path / "sb", progress=False)
    assert s["subcycle"]["part_updates_share"] < 0.8
    assert s["energy"]["contact_dissipated"] > 0.0 and s["energy"]["internal_energy"] > 0.0
    assert abs(s["energy_balance_error"]) < 2e-3
