"""What the particle cells (fracture/particle_cells.py) cost and spare, on a scene's own inputs.

Runs the case (--case, default cases/oblique-sphere.toml) up to the last of --steps and keeps,
at each of those steps, what the particle pass gave `ParticleCells.mark_boxes`,
`faces_near_threads` and its hash's query. Then, on one thread, least of --reps, it times two
ways of picking the faces and hashing them:
  without: the faces whose boxes meet the particles' bounding box (every cell marked);
  with:    those that also touch a cell of a particle's box (the run's way), after the marking.
For each way it times the selection, the hash's build and its query, and it checks that both give
the same pairs.

    python benchmarks/bench_particle_cells.py [--case CASE] [--steps 800,1500,2200,2900]
        [--reps 11]

(docs/performance.md, "Whole scenes, session 26".)
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # scene_capture

def capture(case_path: Path, steps: set[int]) -> dict[int, dict]:
    """Per step of ``steps``: the marking's arguments, faces_near_threads' and the query's."""
    from impactsim.contact.broadphase import SpatialHash
    from impactsim.fracture import passes as FP

    from scene_capture import Captured, run_patched

    run, mark, near, query = (FP.ParticlePass.run, FP.ParticleCells.mark_boxes,
                              FP.faces_near_threads, SpatialHash.query)
    kept: dict[int, dict] = {}
    seen: dict = {}

    def copies(args):
        return [a.copy() if isinstance(a, np.ndarray) else a for a in args]

    def now():
        return seen.get("step") in steps

    def run_kept(self, model, dt):
        seen["step"], seen["pass"] = model.step, self
        return run(self, model, dt)

    def mark_kept(self, lo, hi, n, cloud, cell):
        if now():
            kept.setdefault(seen["step"], {})["mark"] = (lo[:n].copy(), hi[:n].copy(), n,
                                                         cloud.copy(), cell)
        return mark(self, lo, hi, n, cloud, cell)

    def near_kept(*args):
        if now():
            kept[seen["step"]]["near"] = copies(args)
        return near(*args)

    def query_kept(self, *args):
        pairs = query(self, *args)
        if now() and self is seen["pass"].hash:
            kept[seen["step"]]["query"] = copies(args[:4])
            kept[seen["step"]]["pairs"] = pairs.copy()
            if seen["step"] >= max(steps):
                raise Captured
        return pairs

    run_patched(case_path, [(FP.ParticlePass, "run", run_kept),
                            (FP.ParticleCells, "mark_boxes", mark_kept),
                            (FP, "faces_near_threads", near_kept),
                            (SpatialHash, "query", query_kept)])
    return kept


def main(argv=None) -> list[dict]:
    from scene_capture import arguments

    args = arguments(__doc__, None, argv, steps="800,1500,2200,2900", reps=11)

    import numba

    kept = capture(Path(args.case), {int(s) for s in args.steps.split(",")})
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        return _timed(kept, args.reps)
    finally:
        numba.set_num_threads(threads)


def _timed(kept: dict[int, dict], reps: int) -> list[dict]:
    """The two ways timed on each step's inputs (the module docstring), one row per step."""
    from impactsim.contact.broadphase import SpatialHash, grid_from_bounds
    from impactsim.fracture.particle_cells import EVERY_CELL, ParticleCells
    from impactsim.fracture.particle_faces import faces_near_threads

    rows = []
    for step, d in sorted(kept.items()):
        if "near" not in d or "query" not in d:  # faces_near on one thread (few faces or one
            print(f"step {step}: the faces were not found on the threads; left out")  # thread)
            continue
        lo, hi, n, cloud, cell = d["mark"]
        cells = ParticleCells()

        def select(occ, near=d["near"]):
            a = list(near)
            a[8:12] = occ  # origin, inv_c, dims, bits (faces_near_threads' signature)
            k = faces_near_threads(*a)
            return k, a[12], a[13], a[14], a[15], a[16]  # lo, hi, sel, sel_body, bounds

        ways = {}
        for way in ("without", "with"):
            if way == "with":
                cells.mark_boxes(lo, hi, n, cloud, cell)
            occ = cells.args() if way == "with" else EVERY_CELL
            k, flo, fhi, sel, sel_body, bounds = select(occ)
            flo, fhi = flo[:k].copy(), fhi[:k].copy()
            sel, sel_body = sel[:k].copy(), sel_body[:k].copy()
            origin, h = grid_from_bounds(bounds[0], bounds[1], cell)
            hs = SpatialHash()
            ways[way] = dict(k=k, occ=occ, flo=flo, fhi=fhi, sel=sel, sel_body=sel_body,
                             origin=origin, h=h, hash=hs)
        times = {key: np.inf for key in ("mark", "without select", "with select",
                                         "without build", "with build", "without query",
                                         "with query")}
        same = True

        def timed(key, f):
            t0 = time.perf_counter()
            r = f()
            times[key] = min(times[key], time.perf_counter() - t0)
            return r

        for _ in range(reps):
            timed("mark", lambda: cells.mark_boxes(lo, hi, n, cloud, cell))
            for way, w in ways.items():
                timed(f"{way} select", lambda: select(w["occ"]))
                timed(f"{way} build", lambda: w["hash"].build(w["flo"], w["fhi"], w["origin"],
                                                              w["h"]))
                pairs = timed(f"{way} query", lambda: w["hash"].query(
                    *d["query"], w["sel"], w["sel_body"], False, False))
                # the same particle and face for every pair
                same &= bool(np.array_equal(pairs[:, 0], d["pairs"][:, 0])
                             and np.array_equal(w["sel"][pairs[:, 1]],
                                                ways["with"]["sel"][d["pairs"][:, 1]]))
        ms = {key: 1e3 * t for key, t in times.items()}
        total = {way: sum(ms[f"{way} {p}"] for p in ("select", "build", "query"))
                 + (ms["mark"] if way == "with" else 0.0) for way in ways}
        row = {"step": step, "faces near the box": ways["without"]["k"],
               "faces kept": ways["with"]["k"], "pairs": int(d["pairs"].shape[0]),
               "same pairs": same, **{f"{key}, ms": v for key, v in ms.items()},
               "without, all, ms": total["without"], "with, all, ms": total["with"]}
        rows.append(row)
        print(f"step {step}: faces {row['faces near the box']} -> {row['faces kept']}, "
              f"{row['pairs']} pairs (the same: {same}); ms without -> with: mark "
              f"{ms['mark']:.3f}, select {ms['without select']:.3f} -> {ms['with select']:.3f}, "
              f"build {ms['without build']:.3f} -> {ms['with build']:.3f}, query "
              f"{ms['without query']:.3f} -> {ms['with query']:.3f}; all "
              f"{total['without']:.3f} -> {total['with']:.3f}")
    return rows


if __name__ == "__main__":
    main()
