"""The per-element memory accounting (impactsim/solver/footprint.py) against the bytes numpy
holds for a built run after a few steps, and the warning before a run that would not fit."""

import gc
import re
import tracemalloc

import numpy as np
import pytest

from impactsim.case import load_case_text
from impactsim.mesh import mesh_body
from impactsim.solver import hugepages
from impactsim.solver.build import build_model
from impactsim.solver.footprint import (case_memory_warning, memory_warning, peak_bytes,
                                        run_bytes)
from impactsim.solver.loop import Simulation
from impactsim.solver.pipeline import build_passes
from impactsim.warmup import scenes


def _numpy_bytes() -> int:
    snap = tracemalloc.take_snapshot().filter_traces(
        [tracemalloc.DomainFilter(True, np.lib.tracemalloc_domain)])
    return sum(t.size for t in snap.traces)


@pytest.mark.parametrize("scene,scale,tol", [("jc-wall", 0.25, 0.05), ("fracture", 0.3, 0.08)])
def test_run_bytes_match_what_a_built_run_holds(scene, scale, tol):
    text = dict((n, t) for n, t, _ in scenes())[scene]
    text = re.sub(r"mesh_size = ([0-9.e-]+)",
                  lambda m: f"mesh_size = {float(m.group(1)) * scale}", text)
    case = load_case_text(text)
    meshes = [mesh_body(b, use_cache=False) for b in case.bodies]
    gc.collect()
    arenas = hugepages.arena_bytes()  # the arrays build_model moves onto huge pages
    tracemalloc.start()
    try:
        model = build_model(case, meshes)
        del meshes
        passes = build_passes(case, model)
        sim = Simulation(model, passes, cfl=0.6)
        sim.step()
        sim.step()
        held = _numpy_bytes() + hugepages.arena_bytes() - arenas
    finally:
        tracemalloc.stop()
    names = [p.name for p in passes]
    est = run_bytes(model.n_elem, model.n_node, contact="contact.node-face" in names,
                    fracture="fracture" in names)
    assert model.n_elem > 8000
    assert est == pytest.approx(held, rel=tol)
    # the warning's own flags from the case give the same estimate
    peak = peak_bytes(model.n_elem, model.n_node, contact="contact.node-face" in names,
                      fracture="fracture" in names)
    assert case_memory_warning(case, model.n_elem, model.n_node, available=int(1.01 * peak)) \
        is None
    assert "GiB" in case_memory_warning(case, model.n_elem, model.n_node,
                                        available=int(0.99 * peak))


def test_memory_warning_names_the_need_and_the_memory():
    msg = memory_warning(2_000_000, 400_000, available=2**29)
    assert msg is not None and "2,000,000 elements" in msg and "0.5 GiB available" in msg
    assert memory_warning(10_000, 2_000, available=2**40) is None


def test_run_warns_before_a_run_that_would_not_fit(tmp_path, monkeypatch, capsys):
    from impactsim.solver import footprint
    from impactsim.solver.run import run_case

    monkeypatch.setattr(footprint, "available_bytes", lambda: 1 << 10)  # 1 kiB: less than 144 tets need
    text = dict((n, t) for n, t, _ in scenes())["elastic-wall"]
    run_case(load_case_text(text, overrides=["run.max_steps=1"]), tmp_path, progress=False)
    err = capsys.readouterr().err
    assert "warning: this run needs about" in err
