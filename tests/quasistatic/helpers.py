"""Small quasistatic cases for the tests, from TOML text."""

from __future__ import annotations

import tomllib

import numpy as np

from impactsim.case.quasistatic import quasistatic_from_dict
from impactsim.quasistatic.build import problem
from impactsim.quasistatic.solver import solve


def case(text: str, *overrides: str):
    return quasistatic_from_dict(tomllib.loads(text), None, overrides)


def run(text: str, *overrides: str, workers: int = 0):
    prob = problem(case(text, *overrides))
    out = solve(prob, workers)
    assert out.stopped is None, out.stopped
    return prob, out


def vertex_values(prob, out, i: int, key: str) -> np.ndarray:
    nv = prob.bodies[i].points.shape[1]
    f = out.fields[i][key]
    return f[..., :nv] if key != "u" else f.reshape(-1, 3)[:nv]
