"""Contact passes of the working tree against a git revision's, measured in one process.

The block pressed into a plate of bench_contact.py, built twice with the working tree's package:
"new" as it is, "old" with the revision's sweep kernels (contact/edgeedge.py and nodeface.py
of REV, each loaded as a module of its own) and the broad phase run afresh every step (no kept
candidate list, contact/skin.py; --old-skin keeps it on the old side too). The timed steps
alternate between the two in short runs, so both see the same (shared, noisy) machine. Prints
process CPU ns per boundary node per step of each contact pass (broad phase, sweeps,
projection: the pass's whole run) for both, their ratio, and whether the two end states are
bit-identical (the changes do not change the arithmetic).

    python benchmarks/compare_contact.py [REV] [--h 0.001] [--warm 30] [--steps 40] [--run 5]
        [--old-skin]
"""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_contact import pressed_blocks  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def old_module(rev: str, name: str):
    """contact/<name>.py of ``rev`` as a module of its own (it imports the tree's helpers)."""
    src = subprocess.run(["git", "show", f"{rev}:impactsim/contact/{name}.py"], cwd=ROOT,
                         check=True, capture_output=True, text=True).stdout
    folder = Path(tempfile.mkdtemp(prefix="compare_contact_"))
    path = folder / f"{name}_rev.py"
    path.write_text(src)
    spec = importlib.util.spec_from_file_location(f"{name}_rev", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def build(h: float, old=None, old_skin=False):
    from impactsim.case import load_case_text
    from impactsim.mesh import mesh_body
    from impactsim.solver.build import build_model
    from impactsim.solver.loop import Simulation
    from impactsim.solver.pipeline import build_passes

    case = load_case_text(pressed_blocks(h))
    model = build_model(case, [mesh_body(b, use_cache=False) for b in case.bodies])
    passes = build_passes(case, model)
    sim = Simulation(model, passes, cfl=0.6)
    contact = [p for p in passes if p.name.startswith("contact.")]
    cpu = {p.name: 0.0 for p in contact}
    for p in contact:
        if old is not None:
            if not old_skin:
                p.skin.skin_rel = 0.0
            p._sweep = (_old_sweep(p, old[0]) if p.name == "contact.edge-edge"
                        else _old_nf_sweep(p, old[1]))
            if not hasattr(old[0], "far_apart"):  # sweeps that know no pairs skipped from the
                p._far_apart = lambda *args: None  # start (edgeedge.far_apart): none
        p.run = _timed(p.run, cpu, p.name)
    return sim, model, contact, cpu


def _old_sweep(p, old):
    def sweep(model, dt, h, pairs, active, stamp, sweep_id, since, geo, slack):
        ctx = p.ctx
        s = ctx.surface
        return old.edge_edge_sweep(pairs, s.edges, p.normals, model.x, model.v, model.mass, dt,
                                   ctx.friction, ctx.band_rel * h, ctx.restore, active, stamp,
                                   sweep_id, since, geo, slack, ctx.lock(model))
    return sweep


def _old_nf_sweep(p, old):
    def sweep(model, dt, h, pairs, active, stamp, sweep_id, since, geo, slack):
        ctx = p.ctx
        s = ctx.surface
        return old.node_face_sweep(pairs, s.nodes, s.faces, model.x, model.v, model.mass, dt,
                                   ctx.friction, ctx.band_rel * h, ctx.eps_bary, ctx.restore,
                                   active, stamp, sweep_id, since, geo, slack, ctx.lock(model))
    return sweep


def _timed(run, cpu, name):
    def timed(model, dt):
        t0 = time.process_time()
        run(model, dt)
        cpu[name] += time.process_time() - t0
    return timed


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser()
    ap.add_argument("rev", nargs="?", default="f08bcc3")
    ap.add_argument("--h", type=float, default=0.001)
    ap.add_argument("--warm", type=int, default=30)
    ap.add_argument("--steps", type=int, default=40)
    ap.add_argument("--run", type=int, default=5)
    ap.add_argument("--old-skin", action="store_true",
                    help="the old side keeps its candidate lists too (only the sweeps differ)")
    a = ap.parse_args(argv)
    numba.set_num_threads(1)
    runs = {"new": build(a.h), "old": build(a.h, (old_module(a.rev, "edgeedge"),
                                                old_module(a.rev, "nodeface")), a.old_skin)}
    for sim, _, _, cpu in runs.values():
        for _ in range(a.warm):
            sim.step()
        for k in cpu:
            cpu[k] = 0.0
    done = 0
    while done < a.steps:
        for sim, *_ in runs.values():
            for _ in range(a.run):
                sim.step()
        done += a.run
    out = {}
    n = runs["new"][2][0].ctx.surface.n_nodes * done
    print(f"contact passes, block pressed into a plate, h = {1e3 * a.h:g} mm, "
          f"{runs['new'][2][0].ctx.surface.n_nodes} boundary nodes, {done} steps, one thread "
          f"(CPU ns per boundary node per step; old: {a.rev}'s sweeps"
          + (")" if a.old_skin else ", fresh broad phase)"))
    for name in runs["new"][3]:
        new = 1e9 * runs["new"][3][name] / n
        old = 1e9 * runs["old"][3][name] / n
        out[name] = (old, new)
        print(f"  {name:<20}{old:8.0f} -> {new:6.0f}  ({old / new:.2f}x)")
    tot_old = sum(o for o, _ in out.values())
    tot_new = sum(nw for _, nw in out.values())
    print(f"  {'both':<20}{tot_old:8.0f} -> {tot_new:6.0f}  ({tot_old / tot_new:.2f}x)")
    same = (np.array_equal(runs["new"][1].v, runs["old"][1].v)
            and np.array_equal(runs["new"][1].x, runs["old"][1].x))
    print(f"  end states bit-identical: {same}")
    out["identical"] = same
    return out


if __name__ == "__main__":
    sys.exit(0 if main()["identical"] else 1)
