"""The particle pass's broad phase on oblique-sphere's own boxes: its hash's build and query.

Runs the case (--case, default cases/oblique-sphere.toml, on the threads NUMBA_NUM_THREADS
sets) up to the last of --steps, keeps copies of what the particle pass gives its face hash
(`SpatialHash.build`: the faces' boxes, origin, cell) and its query (the particles' boxes,
rows and bodies) at each of those steps, then times the build and the query on them, on one
thread and on all (the query runs on the threads from QUERY_MIN_CHUNKS chunks of query rows),
and checks that the pairs are the run's. Prints the least of --reps per step. --rev REV times
that revision's hash too (its package exported as compare.py does), alternating, on the same
inputs, and checks that its pairs are the same.

    python benchmarks/bench_particle_query.py [--case CASE] [--steps 800,1500,2200] [--reps 7]
        [--rev REV]

In `make bench` (BENCH=particle_query) with the defaults: about a minute and a half.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # scene_capture, compare


def capture(case_path: Path, steps: set[int]) -> list[dict]:
    """At each of ``steps``: the particle hash's build arguments, its query arguments and the
    pairs it found (copies), from a run stopped after the last."""
    from impactsim.contact.broadphase import SpatialHash
    from impactsim.fracture import passes as FP

    from scene_capture import Captured, run_patched

    build, query, run = SpatialHash.build, SpatialHash.query, FP.ParticlePass.run
    got: list[dict] = []
    seen: dict = {}

    def copy(a):
        return a.copy() if isinstance(a, np.ndarray) else a

    def run_kept(self, model, dt):
        seen["model"], seen["pass"] = model, self
        return run(self, model, dt)

    def mine(h):
        p = seen.get("pass")
        return p is not None and h is p.hash and seen["model"].step in steps

    def build_kept(self, lo, hi, origin, h):
        if mine(self):
            seen["build"] = (lo.copy(), hi.copy(), np.array(origin, float), float(h))
        return build(self, lo, hi, origin, h)

    def query_kept(self, *args):
        pairs = query(self, *args)
        if mine(self):
            step = seen["model"].step
            got.append({"step": step, "build": seen["build"],
                        "query": [copy(a) for a in args], "pairs": pairs.copy()})
            if step >= max(steps):
                raise Captured
        return pairs

    run_patched(case_path, [(SpatialHash, "build", build_kept), (SpatialHash, "query", query_kept),
                            (FP.ParticlePass, "run", run_kept)])
    return got


def main(argv=None) -> list[dict]:
    import importlib
    from scene_capture import arguments

    args = arguments(__doc__, "time this revision's hash too", argv)

    import numba

    from impactsim.contact.broadphase import SpatialHash

    sides = {"tree": SpatialHash}
    if args.rev:
        from compare import export

        sys.path.insert(0, export(args.rev))
        sides[args.rev] = importlib.import_module("impactsim_rev.contact.broadphase").SpatialHash

    got = capture(Path(args.case), {int(s) for s in args.steps.split(",")})
    threads = numba.config.NUMBA_NUM_THREADS
    rows = []
    for g in got:
        lo, hi, origin, h = g["build"]
        n_pairs = g["pairs"].shape[0]
        row = {"step": g["step"], "faces": lo.shape[0], "particles": g["query"][0].shape[0],
               "pairs": n_pairs}
        for t in sorted({1, threads}):
            numba.set_num_threads(t)
            hashes = {k: cls() for k, cls in sides.items()}
            for hs in hashes.values():  # buffers sized, kernels loaded
                hs.build(lo, hi, origin, h)
                hs.query(*g["query"])
            best = {k: [np.inf, np.inf] for k in sides}
            same = True
            for _ in range(args.reps):
                for k, hs in hashes.items():
                    t0 = time.perf_counter()
                    hs.build(lo, hi, origin, h)
                    t1 = time.perf_counter()
                    pairs = hs.query(*g["query"])
                    t2 = time.perf_counter()
                    best[k] = [min(best[k][0], t1 - t0), min(best[k][1], t2 - t1)]
                    same &= bool(np.array_equal(pairs, g["pairs"]))
            for k in sides:
                row[f"{k}, {t} thread(s): build ms"] = 1e3 * best[k][0]
                row[f"{k}, {t} thread(s): query ms"] = 1e3 * best[k][1]
            row[f"the run's pairs, {t} thread(s)"] = same
            print(f"step {g['step']}: {row['faces']} faces, {row['particles']} particles, "
                  f"{n_pairs} pairs; {t} thread(s), ms build / query: "
                  + ", ".join(f"{k} {1e3 * best[k][0]:.3f} / {1e3 * best[k][1]:.3f}"
                              for k in sides) + f"; the run's pairs: {same}")
        numba.set_num_threads(threads)
        rows.append(row)
    return rows


if __name__ == "__main__":
    main()
