"""Bodies too large to factorise are solved by algebraic multigrid (pyamg) + CG: the same
answer as the direct solve. Bodies held only by their contacts are always factorised
(interfaces._solver)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.sparse.linalg as sla

from impactsim.case.quasistatic import load_quasistatic
from impactsim.quasistatic import interfaces as setup_mod
from impactsim.quasistatic.build import problem
from impactsim.quasistatic.elastic import AMGSolver, rigid_modes
from impactsim.quasistatic.solver import solve

CASES = Path(__file__).parents[2] / "cases"


def test_rigid_modes_are_the_null_space_of_a_free_body():
    prob = problem(load_quasistatic(CASES / "blocks-pressed.toml", []))
    _, _, specs, _, _ = setup_mod.setup(prob)
    from impactsim.quasistatic.body import BodyState
    st = BodyState(specs[1])  # the upper block: no displacement condition
    K = st.elastic.K
    B = rigid_modes(st.space.doflocs)
    assert np.abs(K @ B).max() < 1e-6 * abs(K).max() * np.abs(B).max()


def test_amg_gives_the_direct_answer_on_the_pressed_blocks():
    runs = {}
    for solver in ("direct", "amg"):
        case = load_quasistatic(CASES / "blocks-pressed.toml", [f'quasistatic.solver="{solver}"'])
        prob = problem(case)
        _, _, specs, _, _ = setup = setup_mod.setup(prob)
        # the lower block is held: amg when asked; the upper one floats: always direct
        assert [s.solver for s in specs] == [solver, "direct"]
        out = solve(prob, setup=setup)
        assert out.stopped is None
        runs[solver] = out
    size = max(np.abs(f["u"]).max() for f in runs["direct"].fields.values())
    for i, f in runs["amg"].fields.items():
        assert np.abs(f["u"] - runs["direct"].fields[i]["u"]).max() < 1e-6 * size
        s = f["stress"]
        assert np.abs(s[2] / -10e6 - 1).max() < 5e-3


def test_auto_switches_to_amg_above_the_direct_limit():
    case = load_quasistatic(CASES / "blocks-pressed.toml", ["quasistatic.direct_limit=1000"])
    prob = problem(case)
    _, _, specs, _, _ = setup_mod.setup(prob)
    assert [s.solver for s in specs] == ["amg", "direct"]
    case = load_quasistatic(CASES / "blocks-pressed.toml", [])
    _, _, specs, _, _ = setup_mod.setup(problem(case))
    assert [s.solver for s in specs] == ["direct", "direct"]


def test_amg_solve_matches_splu_on_a_held_body():
    prob = problem(load_quasistatic(CASES / "blocks-pressed.toml", []))
    _, _, specs, _, _ = setup_mod.setup(prob)
    from impactsim.quasistatic.body import BodyState
    e = BodyState(specs[0]).elastic
    A = (e.K[e.F][:, e.F] + e.springs).tocsr()
    b = np.random.default_rng(0).standard_normal(A.shape[0])
    x_direct = sla.splu(A.tocsc()).solve(b)
    x_amg = AMGSolver(A, rigid_modes(e.space.doflocs)[e.F]).solve(b)
    assert np.abs(x_amg - x_direct).max() < 1e-8 * np.abs(x_direct).max()
