"""Node separation and distortion erosion in an impact (issue 12): a steel sphere at 2 km/s
through a separable Al plate (coarse), with separation alone and together with the library's
spall/loosening: the run ends, mass to round-off, energy within 1 %, no inverted element left,
the plate comes apart (new nodes, several fragments)."""

import numpy as np
import pytest

from impactsim.case import load_case_text
from impactsim.model import ERODED
from impactsim.solver.build import tet_volumes
from impactsim.solver.run import run_case

SCENE = """
[run]
name = "sep-plate"
end_time = "3 us"
threads = 1
[[material]]
name = "al"
library = "{plate}"
failure = {{ fracture_strain = 1.0 }}
[[material]]
name = "steel"
library = "steel-4340"
[[body]]
name = "plate"
material = "al"
shape = "plate"
size = ["24 mm", "24 mm", "2 mm"]
position = ["0 mm", "0 mm", "-1 mm"]
mesh_size = "1 mm"
mesher = "structured"
[[body]]
name = "sphere"
material = "steel"
shape = "sphere"
radius = "5 mm"
position = ["0 mm", "0 mm", "5.05 mm"]
mesh_size = "2 mm"
velocity = ["0 m/s", "0 m/s", "-2000 m/s"]
[fracture]
distortion_interval = "50 ns"
[output]
frames = 1
history_every = 5
"""


@pytest.mark.parametrize("plate", ["al-ideal-plastic", "al-6061-t6"])
def test_sphere_through_a_separable_plate(tmp_path, plate, monkeypatch):
    import impactsim.solver.run as R

    models = []
    real = R.build_model
    monkeypatch.setattr(R, "build_model", lambda *a, **k: models.append(real(*a, **k))
                        or models[-1])
    s = run_case(load_case_text(SCENE.format(plate=plate)), tmp_path, progress=False)
    assert s["stopped"] is None, s["stopped"]
    assert abs(s["mass_error"]) < 1e-12
    assert abs(s["energy_balance_error"]) < 0.01
    sep = s["fracture"]["separation"]
    assert sep["new_nodes"] > 0 and sep["failed_faces"] > 0
    assert s["fragments"]["mesh_pieces"] >= 2
    m = models[0]
    live = m.status != ERODED
    assert np.all(tet_volumes(m.x, m.conn[live]) > 0.0)
    assert np.all(np.isfinite(m.x)) and np.all(np.isfinite(m.v))
