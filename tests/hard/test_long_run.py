"""Long runs and determinism (issue 16).

- 10^5 steps of a small spinning elastic cube (no contact, no wall): the total energy drift,
  reported per 10^4 steps, stays bounded (slow: `make hard`).
- The same case twice gives identical history.csv and summary (timings aside), on 1 and on 2
  threads, for a wall case and a contact case (fast).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from impactsim.case import load_case, load_case_text
from impactsim.results import history_array
from impactsim.solver.run import run_case

ROOT = Path(__file__).resolve().parents[2]

SPIN = """
[run]
name = "spin"
end_time = 1.0
max_steps = {steps}
[[body]]
name = "cube"
material = "steel-elastic"
shape = "box"
size = ["10 mm", "10 mm", "10 mm"]
mesh_size = "5 mm"
mesher = "structured"
velocity = ["1 m/s", 0, 0]
angular_velocity = [0, 0, "2000 rad/s"]
[output]
frames = 1
history_every = 10000
"""


@pytest.mark.slow
def test_1e5_steps_of_a_spinning_elastic_cube_keep_the_energy(tmp_path):
    summary = run_case(load_case_text(SPIN.format(steps=100_000)), tmp_path, progress=False)
    assert summary["steps"] == 100_000
    hist = history_array(tmp_path / "history.csv")
    e = hist["total_energy"]
    drift = (e - e[0]) / e[0]
    report = ", ".join(f"{int(s)}: {d:+.2e}" for s, d in zip(hist["step"], drift))
    print("energy drift per 10^4 steps:", report)
    assert len(e) >= 11  # every 10^4 steps (and the row of the max_steps stop)
    # measured: within 1e-6 up to 9e4 steps, 2.9e-6 at 1e5
    assert np.abs(drift).max() < 1e-5, report


TIMING_KEYS = {"wall_seconds", "seconds_to_first_step", "seconds_per_pass",
               "ns_per_element_step", "threads", "estimate", "re_estimate"}


def _outputs(out: Path) -> tuple[bytes, dict]:
    summary = json.loads((out / "summary.json").read_text())
    return (out / "history.csv").read_bytes(), {k: v for k, v in summary.items()
                                                if k not in TIMING_KEYS}


@pytest.mark.parametrize("name, overrides", [
    ("elastic-bar-wall", ["run.end_time=\"20 us\""]),
    ("two-cubes", []),
])
def test_same_case_twice_on_one_and_two_threads_gives_the_same_files(tmp_path, name, overrides):
    results = []
    for threads in (1, 2, 1, 2):
        case = load_case(ROOT / "cases" / f"{name}.toml", overrides + [f"run.threads={threads}"])
        out = tmp_path / f"t{len(results)}"
        run_case(case, out, progress=False)
        results.append(_outputs(out))
    hist0, sum0 = results[0]
    for hist, summ in results[1:]:
        assert hist == hist0
        assert summ == sum0
