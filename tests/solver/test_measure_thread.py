"""The history's penetration measure in its meter's thread (contact/diagnostics.py
``measure_later``) gives the history of the measure taken in the run's thread, bit for bit."""

import json

from impactsim.case import load_case
from impactsim.solver import run as run_module
from impactsim.solver.run import run_case
from tests.solver.test_checkpoint import PLATE


def test_the_measure_in_its_thread_gives_the_same_history(tmp_path, monkeypatch):
    # a sphere through a plate: erosion changes the surface between the rows, particles fly
    case_file = tmp_path / "case.toml"
    case_file.write_text(PLATE.replace('checkpoint_every = "0.7 us"', "history_every = 3"))
    case = load_case(case_file)
    threaded = run_case(case, tmp_path / "threaded", progress=False)
    monkeypatch.setattr(run_module, "_measures_later", lambda passes: [])
    at_once = run_case(load_case(case_file), tmp_path / "at_once", progress=False)
    a = (tmp_path / "threaded" / "history.csv").read_bytes()
    assert a == (tmp_path / "at_once" / "history.csv").read_bytes()
    seen = [json.loads((tmp_path / d / "summary.json").read_text())["contact.node-face"]
            ["max_penetration_seen"] for d in ("threaded", "at_once")]
    assert seen[0] == seen[1] > 0.0
    assert threaded["eroded_elements"] > 0 and at_once["steps"] == threaded["steps"]
