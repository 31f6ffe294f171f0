"""Distortion erosion in a run (ALGORITHMS.md 4.3 [Z]): a corner of a block dragged sideways
far faster than the block can follow distorts the cells around it; they are deleted (tets and
hexes alike), mass stays to round-off, their energy is booked and the balance closes."""

import pytest

from impactsim.case import load_case_text
from impactsim.solver.run import run_case

SCENE = """
[run]
name = "drag"
end_time = "{end}"
[[material]]
name = "al"
library = "al-ideal-plastic"
[[body]]
name = "block"
material = "al"
shape = "box"
size = ["4 mm", "4 mm", "4 mm"]
mesh_size = "1 mm"
mesher = "structured"
element = "{element}"
[[body.constraint]]
nodes = {{ box = {{ lo = ["1.9 mm", "1.9 mm", "1.9 mm"], hi = ["2.1 mm", "2.1 mm", "2.1 mm"] }} }}
velocity = ["2000 m/s", "0 m/s", "0 m/s"]
[fracture]
{fracture}
[output]
frames = 1
history_every = 1
"""


@pytest.mark.parametrize("element", ["tet", "hex8"])
def test_dragged_corner_cells_are_deleted(tmp_path, element):
    text = SCENE.format(end="4 us", element=element,
                        fracture='distortion_interval = "0.1 us"')
    s = run_case(load_case_text(text), tmp_path, progress=False)
    assert s["stopped"] is None, s["stopped"]
    d = s["fracture"]["distortion"]
    assert d["deleted"] >= 1 and d["extent"] >= 1, d
    assert d["checks"] == pytest.approx(40, abs=1)
    assert s["fragments"]["count"] >= 1 and s["fragments"]["mesh_pieces"] >= 1
    assert abs(s["mass_final"] - s["mass_initial"]) <= 1e-13 * s["mass_initial"]
    e = s["energy"]
    assert e["eroded_energy"] > 0.0
    # the balance closes to a few % of the energy moved (the block starts at rest: the initial
    # total is the dragged node's kinetic energy only, too small a yardstick)
    err = s["energy_balance_error"]
    drift = e["total_energy"] * err / (1.0 + err)
    assert abs(drift) < 0.03 * (e["external_work"] + e["eroded_energy"])
    # without distortion erosion the dragged cells stay (and stretch on)
    off = run_case(load_case_text(SCENE.format(end="4 us", element=element, fracture="")),
                   tmp_path / "off", progress=False)
    assert "fracture" not in off or "distortion" not in off["fracture"]
