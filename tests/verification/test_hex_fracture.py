"""Fracture of hex bodies at the scale of a scene (fracture/hexes.py; ALGORITHMS.md 4.1-4.2),
the hex versions of tests/verification/test_fracture_spall.py.

Flyer plate: the one-dimensional flyer and target of one material meeting with closing speed u;
the release waves meet at depth F below the target's rear surface: the spall plane. Expanding
block: spall, loosening and particle conversion layer after layer; mass to round-off, momentum
and energy accounted. Erosion by principal strain: the orphan transfer conserves mass and
momentum. One and two threads: the same bits.
"""

import numba
import numpy as np
import pytest

from impactsim.case.schema import Constraint, Failure, Fracture, NodeSelector, Output
from impactsim.fracture import make_fracture_passes
from impactsim.mesh.hexes import box_hexes, fix_hex_orientation
from impactsim.model import DAMAGED, ERODED
from impactsim.results import history_array
from impactsim.solver.build import build_model
from impactsim.solver.loop import Simulation
from impactsim.solver.pipeline import build_passes
from impactsim.solver.run import run_case
from tests.builders import box_case, material


def _hex_mesh(size, h):
    pts, hexes = box_hexes(size, h)
    hexes, _ = fix_hex_orientation(pts, hexes)
    return pts, hexes.astype(np.int32)


def _hex_case(mat, size, h, **kw):
    case = box_case(mat, size=size, h=h, **kw)
    case.bodies[0].element = "hex8"
    return case


@pytest.mark.parametrize("spall_pressure", ["cell", "patch"])
def test_hex_flyer_plate_spalls_at_the_analytic_depth(spall_pressure):
    F, T, h, u = 2e-3, 6e-3, 0.25e-3, 100.0
    mat = material(name="m", failure=Failure(spall_strength=1.2e9))
    case = _hex_case(mat, (h, h, F + T), h)
    case.fracture = Fracture(spall_pressure=spall_pressure)
    case.bodies[0].constraints = [Constraint(NodeSelector("all"), (0.0, 0.0, None))]
    model = build_model(case, [_hex_mesh((h, h, F + T), h)])
    blk = model.blocks[0]
    assert model.n_elem == 0 and blk.n_elem == round((F + T) / h)
    z_if = -(F + T) / 2 + F  # the flyer is below the interface and moves up
    z = model.x[:, 2]
    model.v[:, 2] = np.where(z < z_if - 1e-9, 0.5 * u, np.where(z > z_if + 1e-9, -0.5 * u, 0.0))
    sim = Simulation(model, build_passes(case, model), cfl=0.5)
    c = np.sqrt((mat.bulk_modulus + 4 * mat.shear_modulus / 3) / mat.density)
    first = None
    while model.time < 2.0 * (F + T) / c:
        sim.step()
        dam = blk.status == DAMAGED
        if dam.any():
            first = model.x[blk.conn[dam]].mean(axis=1)[:, 2]
            break
    assert first is not None, "no spall"
    expected = (F + T) / 2 - F
    assert abs(first.mean() - expected) < h, (first, expected)
    assert abs(model.time - (T + F) / c) < 2 * h / c


def _expanding(tmp_path, n_per, rate=3e4, h=1e-3, size=(4e-3, 4e-3, 4e-3)):
    mat = material(name="m", failure=Failure(spall_strength=1.0e9, loosening=0.03))
    case = _hex_case(mat, size, h, end=3e-6)
    case.fracture = Fracture(particles_per_element=n_per, particle_collisions=n_per > 1)
    case.output = Output(frames=2)
    import impactsim.solver.run as R

    orig = R.build_model

    def build(c, meshes):
        m = orig(c, meshes)
        m.v[:] = rate * (m.x - m.x.mean(axis=0))
        return m

    R.build_model = build
    try:
        return run_case(case, tmp_path, progress=False, meshes=[_hex_mesh(size, h)]), rate
    finally:
        R.build_model = orig


@pytest.mark.parametrize("n_per", [1, 4])
def test_expanding_hex_block_conserves_mass_momentum_energy(tmp_path, n_per):
    s, rate = _expanding(tmp_path, n_per)
    assert s["stopped"] is None
    assert s["fracture"]["converted_to_particles"] > 0
    assert s["particles"] == n_per * s["fracture"]["converted_to_particles"]
    assert abs(s["mass_final"] - s["mass_initial"]) <= 1e-13 * s["mass_initial"]
    assert abs(s["energy_balance_error"]) < 0.02
    hist = history_array(tmp_path / "history.csv")
    assert hist["damaged"].max() + hist["fractured"].max() > 0
    scale = s["mass_initial"] * rate * 4e-3
    for ax in "xyz":
        total = hist[f"momentum_{ax}"] + hist[f"particle_momentum_{ax}"]
        assert np.all(np.abs(total) < 1e-9 * scale)
    assert (tmp_path / "particles.pvd").exists()
    assert "residual_velocity" in s["bodies"]["box"] or s["bodies"]["box"]["fragments"] == 0


def test_hex_erosion_by_principal_strain_conserves_mass_and_momentum():
    """Erosion anywhere by principal strain: eroded hexes pass their orphans' mass and
    momentum to their remaining corners (or become particles when all are orphaned): mass to
    round-off, momentum to round-off, orphans hold nothing; the contact-free block keeps its
    free quads in step (every free quad of a live hex, none of an eroded one)."""
    mat = material(name="m", failure=Failure(erosion="principal-strain", erosion_value=0.01))
    case = _hex_case(mat, (4e-3, 4e-3, 4e-3), 1e-3)
    model = build_model(case, [_hex_mesh((4e-3, 4e-3, 4e-3), 1e-3)])
    rng = np.random.default_rng(0)
    model.v[:] = 3e4 * (model.x - model.x.mean(axis=0)) * (1 + 0.3 * rng.random((model.n_node, 1)))
    model.v[:, 0] += 10.0
    case.fracture = Fracture(erosion_region="anywhere")
    passes = make_fracture_passes(case, model)
    sim = Simulation(model, passes)
    m0, p0 = model.mass.sum(), model.mass @ model.v
    for _ in range(60):
        sim.step()
    st = passes[-1].s
    pa = st.particles
    blk = model.blocks[0]
    assert st.counts["eroded"] > 0
    assert (model.mass.sum() + pa.mass()) == pytest.approx(m0, rel=1e-14)
    assert np.allclose(model.mass @ model.v + pa.momentum(), p0, rtol=1e-12, atol=1e-15)
    assert np.all(model.mass[st.node_live == 0] == 0.0)
    hb = st.hexes[0].boundary
    live = blk.status != ERODED
    assert np.array_equal(hb.alive, live)
    assert not hb.face_flag.reshape(-1, 6)[~live].any()


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two numba threads")
def test_hex_fracture_same_bits_on_one_and_two_threads():
    """Spall, loosening, particles and their contacts on a hex block of two parts (1152
    hexes): the same state on one thread and on two."""
    size, h = (6e-3, 6e-3, 4e-3), 0.5e-3

    def run(threads):
        prev = numba.get_num_threads()
        numba.set_num_threads(threads)
        try:
            mat = material(name="m", failure=Failure(spall_strength=1.0e9, loosening=0.03))
            case = _hex_case(mat, size, h)
            case.fracture = Fracture(particles_per_element=2, particle_collisions=True,
                                     spall_pressure="patch")
            model = build_model(case, [_hex_mesh(size, h)])
            assert model.blocks[0].n_elem > 1024
            model.v[:] = 4e4 * (model.x - model.x.mean(axis=0))
            passes = make_fracture_passes(case, model)
            sim = Simulation(model, passes)
            for _ in range(40):
                sim.step()
            return model, passes[-1].s
        finally:
            numba.set_num_threads(prev)

    (a, sa), (b, sb) = run(1), run(2)
    assert sa.particles.n > 0 and sa.particles.n == sb.particles.n
    assert np.array_equal(a.x, b.x) and np.array_equal(a.v, b.v)
    assert np.array_equal(a.blocks[0].status, b.blocks[0].status)
    n = sa.particles.n
    assert np.array_equal(sa.particles.x[:n], sb.particles.x[:n])
    assert a.energy_terms == b.energy_terms
