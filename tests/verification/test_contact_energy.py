"""Energy of the kinematic contact passes in the two elastic verification scenes.

ALGORITHMS.md 3: velocity equalisation is an inelastic impact, so a contact impulse may only take
kinetic energy out: in the solver's convention (impactsim.solver.constraints) an impulse J at
t^n does the work J . (U^{n-1/2} + U^{n+1/2}) / 2, booked into ``contact_dissipated``, and the
balance KE + IE + contact_dissipated must stay at its start (both scenes are elastic and slow,
with no wall and no prescribed velocity; the bulk viscosity's heat is part of IE).

Bounds, relative to the initial KE + IE, at the cases' C_cfl = 0.6:
- the balance KE + IE + contact_dissipated stays within 1 %;
- KE + IE never rises above its start by more than 1 %. A kinematic contact cannot be exactly
  energy neutral in central differences: a pair that opened over the previous half step and is
  caught again in this one takes its impulse at t^n while its mean relative velocity still
  opens, a positive work of order J u tau (docs/physics.md, "Contact energy").

Measured (peak / end of KE + IE; largest balance error): hertz-spheres node-face only
+0.38 % / +0.38 %, 0.15 %; hertz-spheres both passes +0.61 % / +0.61 %, 0.16 %; elastic-bars
(matching meshes) 0 / -0.57 %, 0.31 %. Before the projected rounds of the contact passes
(impactsim.contact.passes) the hertz runs gained +3.6 % and +5.3 % by the end (+13.0 % and
+12.5 % at the peak): pairs pushed apart by later corrections of the same step kept their
compressive impulse while separating. The hertz runs take about 20 s each and run in `make test`:
this is the check that the contact creates no energy.
"""

from pathlib import Path

import numpy as np
import pytest

from impactsim.case import load_case
from impactsim.solver.run import run_case
from impactsim.results import history_array

CASES = Path(__file__).parents[2] / "cases"
BALANCE = 0.01  # |KE + IE + contact_dissipated - start| / start, at most
GAIN = 0.01  # (KE + IE - start) / start, at most


@pytest.mark.parametrize("name, passes", [
    ("hertz-spheres", ["node-face"]),
    ("hertz-spheres", ["node-face", "edge-edge"]),
    ("elastic-bars", ["node-face", "edge-edge"]),
])
def test_contact_creates_no_energy(name, passes, tmp_path):
    chosen = ", ".join(f'"{p}"' for p in passes)
    case = load_case(CASES / f"{name}.toml", overrides=[
        "output.history_every=1", "output.frames=1", f"contact.passes=[{chosen}]"])
    summary = run_case(case, tmp_path, progress=False)
    assert summary["stopped"] is None
    h = history_array(tmp_path / "history.csv")
    mech = h["kinetic_energy"] + h["internal_energy"]
    e0 = mech[0]
    assert h["contact_impulse"].sum() > 0  # the bodies did meet
    balance = np.abs(mech + h["contact_dissipated"] - e0).max() / e0
    gain = (mech.max() - e0) / e0
    assert balance < BALANCE, f"KE + IE + contact_dissipated drifts by {balance:.3%}"
    assert gain < GAIN, f"KE + IE rises by {gain:.3%}"
