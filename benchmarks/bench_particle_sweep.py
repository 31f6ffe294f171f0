"""The particle-face sweep on oblique-sphere's own pairs: ns per pair, screened and not.

Runs the case (--case, default cases/oblique-sphere.toml, on the threads NUMBA_NUM_THREADS
sets) up to the last of --steps, keeps copies of the sweep's inputs (pairs, particles, the face-node
table, velocities) at each of those steps, then times `particle_face_sweep_packed` on fresh
copies of them, one thread, with the screen (fracture/particle_screen.py) and without it (the
exact test on every pair), alternating, and checks that both give the same impulses, work and
velocities bit for bit. Prints the least of --reps per step. --rev REV times that revision's
sweep too (its package exported as compare.py does), on the same inputs.

    python benchmarks/bench_particle_sweep.py [--case CASE] [--steps 800,1500,2200] [--reps 7]
        [--rev REV]

In `make bench` (BENCH=particle_sweep) with the defaults: about a minute and a half.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # scene_capture, compare


def capture(case_path: Path, steps: set[int]) -> list[tuple[int, list]]:
    """The sweep's arguments at each of ``steps`` (copies), from a run stopped after the last."""
    from impactsim.fracture import passes as FP

    from scene_capture import Captured, run_patched

    sweep, run = FP.particle_face_sweep_packed, FP.ParticlePass.run
    got: list[tuple[int, list]] = []
    model_of: dict = {}

    def run_kept(self, model, dt):
        model_of["m"] = model
        return run(self, model, dt)

    def sweep_kept(*args):
        step = model_of["m"].step
        if step in steps:
            got.append((step, [a.copy() if isinstance(a, np.ndarray) else a for a in args]))
        out = sweep(*args)
        if step >= max(steps):
            raise Captured
        return out

    run_patched(case_path, [(FP, "particle_face_sweep_packed", sweep_kept),
                            (FP.ParticlePass, "run", run_kept)])
    return got


def main(argv=None) -> list[dict]:
    import importlib
    from scene_capture import arguments

    args = arguments(__doc__, "time this revision's sweep too", argv)

    import numba

    from impactsim.fracture.particles import particle_face_sweep_packed as sweep

    sides = {"every pair tested": lambda *a: sweep(*a, False),
             "screened": lambda *a: sweep(*a, True)}
    if args.rev:
        from compare import export

        sys.path.insert(0, export(args.rev))
        old = importlib.import_module("impactsim_rev.fracture.particles")
        sides[args.rev] = old.particle_face_sweep_packed

    got = capture(Path(args.case), {int(s) for s in args.steps.split(",")})
    numba.set_num_threads(1)
    rows = []
    for step, a in got:
        best = {k: np.inf for k in sides}
        out = {}
        for _ in range(args.reps):
            for label, f in sides.items():
                c = [x.copy() if isinstance(x, np.ndarray) else x for x in a]
                t = time.perf_counter()
                applied, work = f(*c)
                best[label] = min(best[label], time.perf_counter() - t)
                out[label] = (applied, np.float64(work).view(np.int64), c[2], c[7])
        ref = out["every pair tested"]
        same = all(o[:2] == ref[:2] and np.array_equal(o[2], ref[2])
                   and np.array_equal(o[3], ref[3]) for o in out.values())
        n = a[0].shape[0]
        row = {"step": step, "pairs": n, "impulses": int(ref[0]), "same": bool(same),
               **{f"ns per pair, {k}": best[k] / n * 1e9 for k in sides}}
        rows.append(row)
        print(f"step {step}: {n} pairs, {row['impulses']} impulses; ns per pair: "
              + ", ".join(f"{k} {best[k] / n * 1e9:.1f}" for k in sides)
              + f"; the same bits: {same}")
    return rows


if __name__ == "__main__":
    main()
