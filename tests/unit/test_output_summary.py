"""summary: numpy and path values become plain JSON / TOML; both files read back."""

import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from impactsim.output.summary import write_resolved_case, write_summary


def test_summary_converts_numpy_types(tmp_path):
    path = tmp_path / "summary.json"
    data = {
        "steps": np.int64(1200),
        "end_time": np.float64(2.5e-5),
        "ratio": np.float32(0.5),
        "converged": np.bool_(True),
        "max_velocity": np.array([1.0, 2.5, -3.0]),
        "counts": {np.int32(3): np.arange(2, dtype=np.int16)},
        "timings": {"element": 1.25, "contact": (0.5, 0.25)},
        "output": Path("out/x"),
        "penetration": float("nan"),
    }
    write_summary(path, data)
    text = path.read_text()
    back = json.loads(text, parse_constant=lambda name: pytest.fail(f"non-standard JSON {name}"))
    assert back == {
        "steps": 1200,
        "end_time": 2.5e-5,
        "ratio": 0.5,
        "converged": True,
        "max_velocity": [1.0, 2.5, -3.0],
        "counts": {"3": [0, 1]},
        "timings": {"element": 1.25, "contact": [0.5, 0.25]},
        "output": "out/x",
        "penetration": None,
    }
    assert text.startswith('{\n  "steps": 1200,')
    assert type(back["steps"]) is int


def test_summary_rejects_unknown_objects_naming_the_key(tmp_path):
    with pytest.raises(TypeError, match="timings.bad"):
        write_summary(tmp_path / "summary.json", {"timings": {"bad": object()}})
    assert not list(tmp_path.iterdir())


def test_resolved_case_drops_none_and_converts(tmp_path):
    path = tmp_path / "case.resolved.toml"
    case = {
        "name": "plate",
        "run": {"end_time": np.float64(1e-5), "cfl": 0.6, "checkpoint": None, "out": Path("out/plate")},
        "body": [
            {"name": "projectile", "position": (0.0, 0.0, np.float32(0.25)), "velocity": np.array([0.0, 0.0, -800.0])},
            {"name": "target", "mesh_file": None, "elements": np.int64(12)},
        ],
        "walls": [],
        "contact": {"friction": float("inf")},
    }
    write_resolved_case(path, case)
    back = tomllib.loads(path.read_text())
    assert back["run"] == {"end_time": 1e-5, "cfl": 0.6, "out": "out/plate"}
    assert back["body"][0]["position"] == [0.0, 0.0, 0.25]
    assert back["body"][0]["velocity"] == [0.0, 0.0, -800.0]
    assert back["body"][1] == {"name": "target", "elements": 12}
    assert back["walls"] == [] and math.isinf(back["contact"]["friction"])


def test_resolved_case_refuses_none_inside_an_array(tmp_path):
    with pytest.raises(ValueError, match=r"body\[0\].size\[1\]"):
        write_resolved_case(tmp_path / "c.toml", {"body": [{"size": [1.0, None]}]})
