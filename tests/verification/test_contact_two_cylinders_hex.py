"""Two aluminium cylinders end-on at 1 km/s [D19] with hexahedra (contact/hexes.py): a hex
striker on a tet target, and a tet striker on a hex target. Both contact passes keep the
bodies from overlapping (max_penetration below 1 um at every step, the issue's gate), the
striker's hexes stay untangled (stiffness hourglass control), momentum is conserved. Coarse
meshes (2 mm) keep the test short; the bundled cases/two-cylinders-hex.toml runs at 1 mm.
"""

from pathlib import Path

import meshio
import numba
import numpy as np
import pytest

from impactsim.case import load_case
from impactsim.results import history_array
from impactsim.mesh.hexes import hex_quality
from impactsim.solver.run import run_case

CASE = Path(__file__).parents[2] / "cases" / "two-cylinders-hex.toml"
COARSE = ['body.target.mesh_size="2 mm"', 'body.striker.mesh_size="2 mm"']


def _run(tmp_path_factory, name, case, overrides):
    out = tmp_path_factory.mktemp(name)
    summary = run_case(load_case(case, COARSE + overrides), out, progress=False)
    return summary, history_array(out / "history.csv"), out


@pytest.mark.parametrize("hexes", ["striker", "target"])
def test_no_overlap_with_hexes(tmp_path_factory, hexes):
    case, over = CASE, []
    if hexes == "target":  # the tet scene with its target in hexes
        case = CASE.with_name("two-cylinders.toml")
        over = ['body.target.element="hex8"', 'body.target.hourglass="stiffness"',
                'body.target.hourglass_coefficient=0.1']
    summary, h, out = _run(tmp_path_factory, f"cyl-hex-{hexes}", case, over)
    assert summary["stopped"] is None
    assert h["time"][-1] == pytest.approx(12e-6)
    assert h["max_penetration"].max() < 1e-6
    assert h["contact_pairs"][1:].min() > 0
    # momentum along the axis is conserved (no wall, no constraint), energy finite
    pz = h["momentum_z"]
    assert np.abs(pz - pz[0]).max() < 1e-6 * abs(pz[0])
    assert np.all(np.isfinite(h["total_energy"]))
    mesh = meshio.read(sorted(out.glob("frame_*.vtu"))[-1])
    blocks = {b.type: b.data for b in mesh.cells}
    assert set(blocks) == {"tetra", "hexahedron"}
    assert hex_quality(mesh.points, blocks["hexahedron"])["scaled_jacobian"].min() > 0.0


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two numba threads")
def test_mixed_scene_same_bits_on_one_and_two_threads():
    """Tets and hexes in contact: the same bits on one thread and on two (the tets' force rows,
    then the hexes', each in part order; the contact passes' fixed orders)."""
    from impactsim.solver.build import build_model
    from impactsim.solver.loop import Simulation
    from impactsim.solver.pipeline import build_passes

    def run(threads):
        prev = numba.get_num_threads()
        numba.set_num_threads(threads)
        try:
            case = load_case(CASE, ['body.target.mesh_size="1.5 mm"',
                                    'body.striker.mesh_size="0.7 mm"'])
            model = build_model(case)
            assert model.n_elem > 2 * 2048 and model.blocks[0].n_elem > 1024  # several parts each
            sim = Simulation(model, build_passes(case, model))
            for _ in range(40):
                sim.step()
            return model
        finally:
            numba.set_num_threads(prev)

    a, b = run(1), run(2)
    assert np.array_equal(a.x, b.x) and np.array_equal(a.v, b.v)
    assert np.array_equal(a.sdev, b.sdev) and np.array_equal(a.blocks[0].hg, b.blocks[0].hg)
    assert a.energy_terms == b.energy_terms
