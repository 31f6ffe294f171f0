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
  opens, a positive work of order J u tau (docs/physics.md, "Contact energy"); measured at
  +0.44 % (node-face alone) and +0.76 % (both passes) in hertz-spheres once over-pushed pairs
  give their impulse back, so 1 % leaves room for that and nothing else.

elastic-bars (matching meshes): measured gain 0, balance 0.31 %: passes. hertz-spheres does not
meet the bounds yet and is a strict expected failure with the measured figures: pairs pushed
apart by later corrections of the same step (the symmetric node-face pass, edge-edge after
node-face) keep their compressive impulse while separating, and it does positive work
(docs/physics.md, "Contact energy"). These runs take a minute each: marked slow.
"""

from pathlib import Path

import numpy as np
import pytest

from impactsim.case import load_case
from impactsim.solver.run import run_case

CASES = Path(__file__).parents[2] / "cases"
BALANCE = 0.01  # |KE + IE + contact_dissipated - start| / start, at most
GAIN = 0.01  # (KE + IE - start) / start, at most


def _over_push(figures):
    return [pytest.mark.slow, pytest.mark.xfail(strict=True, reason=(
        "over-pushed contact pairs keep a compressive impulse while separating: " + figures))]


@pytest.mark.parametrize("name, passes", [
    pytest.param("hertz-spheres", ["node-face"], marks=_over_push(
        "KE + IE +3.6 % at the end, +13.0 % peak; balance 4.8 % peak (measured)")),
    pytest.param("hertz-spheres", ["node-face", "edge-edge"], marks=_over_push(
        "KE + IE +5.3 % at the end, +12.5 % peak; balance 4.3 % peak (measured)")),
    ("elastic-bars", ["node-face", "edge-edge"]),
])
def test_contact_creates_no_energy(name, passes, tmp_path):
    chosen = ", ".join(f'"{p}"' for p in passes)
    case = load_case(CASES / f"{name}.toml", overrides=[
        "output.history_every=1", "output.frames=1", f"contact.passes=[{chosen}]"])
    summary = run_case(case, tmp_path, progress=False)
    assert summary["stopped"] is None
    h = np.genfromtxt(tmp_path / "history.csv", delimiter=",", names=True)
    mech = h["kinetic_energy"] + h["internal_energy"]
    e0 = mech[0]
    assert h["contact_impulse"].sum() > 0  # the bodies did meet
    balance = np.abs(mech + h["contact_dissipated"] - e0).max() / e0
    gain = (mech.max() - e0) / e0
    assert balance < BALANCE, f"KE + IE + contact_dissipated drifts by {balance:.3%}"
    assert gain < GAIN, f"KE + IE rises by {gain:.3%}"
