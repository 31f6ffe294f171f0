"""The Courant number's accepted range is what the element's stable-step estimate supports.

The stable step is C_cfl x smallest altitude / wave speed (ALGORITHMS.md 1), an estimate: on the
bundled elastic-bar-wall, cfl 0.99 and 1.0 gained 55 % and 222 % energy (issue 16). The range
is (0, 0.9]: at its edge the bar's energy balance stays within 1 % at every step, and a value
past the edge is refused with the key named.
"""

from pathlib import Path

import pytest

from impactsim.case import CaseError, load_case
from impactsim.case.load import MAX_CFL
from impactsim.solver.run import run_case

CASE = Path(__file__).resolve().parents[2] / "cases" / "elastic-bar-wall.toml"


def test_largest_accepted_courant_number_keeps_the_energy(tmp_path):
    summary = run_case(load_case(CASE, [f"run.cfl={MAX_CFL}"]), tmp_path, progress=False)
    assert summary["stopped"] is None and summary["checks"] == {}
    assert abs(summary["energy_balance_error_max"]) < 0.01
    assert abs(summary["energy_balance_error"]) < 0.005


@pytest.mark.parametrize("cfl", [MAX_CFL + 0.01, 0.99, 1.0])
def test_courant_number_past_the_edge_is_refused(cfl):
    with pytest.raises(CaseError, match=r"run\.cfl: must be in \(0, 0\.9\]"):
        load_case(CASE, [f"run.cfl={cfl}"])
