"""solver/hugepages.py: the state arrays moved onto huge pages keep their values, types and
sharing, and a run on them gives the same bits as a run on the arrays where numpy put them."""

import hashlib
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from impactsim.solver import hugepages

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))


def test_pack_moves_large_arrays_and_keeps_values_types_and_sharing(monkeypatch):
    monkeypatch.setattr(hugepages, "MIN_TOTAL", 0)
    rng = np.random.default_rng(0)
    shared = rng.random(20000)
    base = rng.random((9000, 3))
    a = SimpleNamespace(x=rng.random((30000, 3)), conn=rng.integers(0, 99, (9000, 8)).astype(np.int32),
                        status=np.ones(70000, np.int8), small=np.ones(10), s=shared,
                        base=base, view=base[::2], fortran=np.asfortranarray(rng.random((9000, 3))))
    b = SimpleNamespace(s=shared, y=np.arange(40000.0))
    before = {k: v.copy() for k, v in vars(a).items()}
    moved = hugepages.pack(a, b)
    assert moved >= a.x.nbytes + a.conn.nbytes + a.status.nbytes + shared.nbytes + b.y.nbytes
    for k, v in before.items():
        new = getattr(a, k)
        assert new.dtype == v.dtype and new.shape == v.shape and np.array_equal(new, v)
    for k in ("x", "conn", "status", "s"):
        assert getattr(a, k).base is not None and getattr(a, k).flags.c_contiguous
        assert getattr(a, k).flags.writeable and getattr(a, k).ctypes.data % hugepages.ALIGN == 0
    assert a.s is b.s  # one array under two names stays one array
    a.s[0] = -1.0
    assert b.s[0] == -1.0
    assert a.small.base is None  # small arrays stay
    assert a.base is base and a.view.base is base  # an array others are views of stays
    assert a.fortran.flags.f_contiguous  # not C-contiguous: left alone
    assert hugepages.pack(a, b) == 0  # nothing left to move


def test_small_models_are_left_alone():
    ns = SimpleNamespace(x=np.zeros((1000, 3)))
    assert hugepages.pack(ns) == 0 and ns.x.base is None


def _run(case_text, steps):
    from impactsim.case import load_case_text
    from impactsim.mesh import mesh_body
    from impactsim.solver.build import build_model
    from impactsim.solver.loop import Simulation
    from impactsim.solver.pipeline import build_passes

    case = load_case_text(case_text)
    model = build_model(case, [mesh_body(case.bodies[0], use_cache=False)])
    sim = Simulation(model, build_passes(case, model), cfl=0.6)
    for _ in range(steps):
        sim.step()
    h = hashlib.sha256()
    for a in (model.x, model.v, model.force, model.sdev, model.pressure, model.energy,
              *(getattr(b, k) for b in model.blocks for k in ("sdev", "pressure", "eps_p"))):
        h.update(np.ascontiguousarray(a).tobytes())
    packed = model.x.base is not None
    return h.hexdigest(), packed, dict(model.energy_terms)


@pytest.mark.parametrize("kind", ["hex", "tet"])
def test_a_run_on_huge_pages_gives_the_same_bits(monkeypatch, kind):
    """Every array the kernels update in place must be the one the model holds: a copy left
    behind (an alias of the old array) would change the result."""
    import bench_element
    import bench_hex

    text = bench_hex.case_text(6) if kind == "hex" else bench_element.case_text((4, 4, 5))
    plain = _run(text, 40)
    monkeypatch.setattr(hugepages, "MIN_TOTAL", 0)
    monkeypatch.setattr(hugepages, "MIN_ARRAY", 0)
    huge = _run(text, 40)
    assert not plain[1] and huge[1]
    assert huge[0] == plain[0] and huge[2] == plain[2]
