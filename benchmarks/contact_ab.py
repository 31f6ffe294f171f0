"""Contact passes of the working tree against another tree, whole packages, alternating processes.

compare_contact.py swaps only the sweep kernels inside one process; a change elsewhere (the
rows' projection, the broad phase, the surface, the cubic) reaches both of its sides. This runs
bench_contact.py's block pressed into a plate (``--h``) in fresh processes, one with the package
of ``BASE`` (a folder holding another revision's ``impactsim``, e.g. from ``git archive REV``
or a copy of a checkout, its numba cache warm), one with the working tree's, alternating
``--reps`` times, and prints the process CPU ns per boundary node per step of each contact pass
over the timed steps (broad phase, sweeps, projection: the pass's whole run; the projection and
the detection sweeps of both passes run in the last pass, edge-edge), the least of the reps,
and whether the two sides end in bit-identical states.

    python benchmarks/contact_ab.py BASE [--h 0.001] [--reps 3] [--warm 30] [--steps 40]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def child(h: float, warm: int, steps: int) -> dict:
    """Run in the child: the block, CPU seconds of each contact pass over the timed steps."""
    import numba

    sys.path.insert(0, str(ROOT / "benchmarks"))
    from bench_contact import pressed_blocks

    from impactsim.case import load_case_text
    from impactsim.mesh import mesh_body
    from impactsim.solver.build import build_model
    from impactsim.solver.loop import Simulation
    from impactsim.solver.pipeline import build_passes

    numba.set_num_threads(1)
    case = load_case_text(pressed_blocks(h))
    model = build_model(case, [mesh_body(b, use_cache=False) for b in case.bodies])
    passes = build_passes(case, model)
    sim = Simulation(model, passes, cfl=0.6)
    contact = [p for p in passes if p.name.startswith("contact.")]
    cpu = {p.name: 0.0 for p in contact}

    def timed(p):
        run = p.run

        def t(model, dt):
            t0 = time.process_time()
            run(model, dt)
            cpu[p.name] += time.process_time() - t0
        return t

    for p in contact:
        p.run = timed(p)
    for _ in range(warm):
        sim.step()
    for k in cpu:
        cpu[k] = 0.0
    for _ in range(steps):
        sim.step()
    n = contact[0].ctx.surface.n_nodes * steps
    digest = hashlib.sha256(model.x.tobytes() + model.v.tobytes()).hexdigest()[:16]
    return {"ns": {k: 1e9 * v / n for k, v in cpu.items()}, "nodes": contact[0].ctx.surface.n_nodes,
            "state": digest}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser()
    ap.add_argument("base", type=Path)
    ap.add_argument("--h", type=float, default=0.001)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--warm", type=int, default=30)
    ap.add_argument("--steps", type=int, default=40)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        print(json.dumps(child(a.h, a.warm, a.steps)))
        return {}
    runs = {"base": [], "tree": []}
    for _ in range(a.reps):
        for side, tree in (("base", a.base.resolve()), ("tree", ROOT)):
            env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_NUM_THREADS="1")
            out = subprocess.run([sys.executable, str(Path(__file__).resolve()), str(a.base),
                                  "--child", "--h", str(a.h), "--warm", str(a.warm),
                                  "--steps", str(a.steps)], cwd=tree, env=env, check=True,
                                 capture_output=True, text=True).stdout
            r = json.loads(out.strip().splitlines()[-1])
            runs[side].append(r)
            print(f"  {side}: " + ", ".join(f"{k} {v:.0f}" for k, v in r["ns"].items())
                  + f" (sum {sum(r['ns'].values()):.0f})", flush=True)
    best = {s: min(runs[s], key=lambda r: sum(r["ns"].values())) for s in runs}
    print(f"block pressed into a plate, h = {1e3 * a.h:g} mm, {best['tree']['nodes']} boundary "
          f"nodes, {a.steps} steps after {a.warm}, one thread; CPU ns per boundary node per step, "
          f"least of {a.reps} (base: {a.base})")
    for k in best["tree"]["ns"]:
        o = best["base"]["ns"][k]
        n = best["tree"]["ns"][k]
        print(f"  {k:<20}{o:8.0f} -> {n:6.0f}  ({o / n:.2f}x)")
    o = sum(best["base"]["ns"].values())
    n = sum(best["tree"]["ns"].values())
    same = best["base"]["state"] == best["tree"]["state"]
    print(f"  {'both':<20}{o:8.0f} -> {n:6.0f}  ({o / n:.2f}x)\n  end states bit-identical: {same}")
    return {"base": o, "tree": n, "identical": same}


if __name__ == "__main__":
    main()
