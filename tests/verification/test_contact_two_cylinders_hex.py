"""Two aluminium cylinders end-on at 1 km/s [D19] with hexahedra (contact/hexes.py): a hex
striker on a tet target, and a tet striker on a hex target. Both contact passes keep the
bodies from overlapping (max_penetration below 1 um at every step, the issue's gate), the
striker's hexes stay untangled (stiffness hourglass control), momentum is conserved. Coarse
meshes (2 mm) keep the test short; the bundled cases/two-cylinders-hex.toml runs at 1 mm.
"""

from pathlib import Path

import meshio
import numpy as np
import pytest

from impactsim.case import load_case
from impactsim.mesh.hexes import hex_quality
from impactsim.solver.run import run_case

CASE = Path(__file__).parents[2] / "cases" / "two-cylinders-hex.toml"
COARSE = ['body.target.mesh_size="2 mm"', 'body.striker.mesh_size="2 mm"']


def _run(tmp_path_factory, name, case, overrides):
    out = tmp_path_factory.mktemp(name)
    summary = run_case(load_case(case, COARSE + overrides), out, progress=False)
    return summary, np.genfromtxt(out / "history.csv", delimiter=",", names=True), out


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
