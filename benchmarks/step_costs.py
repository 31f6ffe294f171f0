"""Per-step costs of a scene's fracture criteria and contact-surface update, on its own states,
the working tree against a revision, in one process.

Runs CASE with the working tree's package (one thread) and keeps a copy of the arguments of
``fracture_criteria`` at the given calls (steps), then times, alternating, that kernel of the
revision (exported as ``impactsim_rev`` by benchmarks/compare.py) and of the working tree on
copies of each state, and says whether their actions, statuses and counts agree. At the last
kept step it also times removing surface elements (six a time, drawn from the surface) from
the contact surface, with the compact arrays merged from the changes
(``Surface.incremental``, contact/surface.py) and regenerated from every flag (the revision's
way), and checks both give the same arrays.

    NUMBA_NUM_THREADS=1 python benchmarks/step_costs.py REV cases/oblique-sphere.toml
        [--calls 150,450,900,1800] [--reps 8]
"""

from __future__ import annotations

import argparse
import copy
import importlib
import inspect
import sys
import time
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare import export  # noqa: E402

SURFACE = ("faces", "face_elem", "face_local", "face_body", "face_edges", "edges", "edge_mesh",
           "edge_body", "nodes", "node_body")


class _Enough(Exception):
    pass


def states(case: str, calls: list[int]):
    """{call: fracture_criteria's arguments} and the contact surface at the last call."""
    import impactsim.fracture.criteria as C
    from impactsim.cli import main as cli

    kept, surf, count = {}, {}, [0]
    real = C.fracture_criteria
    import impactsim.contact.surface as S

    real_init = S.Surface.__init__

    def init(self, *a, **k):
        real_init(self, *a, **k)
        surf.setdefault("s", self)

    S.Surface.__init__ = init

    def wrapped(*args):
        count[0] += 1
        if count[0] in calls:
            kept[count[0]] = copy.deepcopy(args)
            if len(kept) == len(calls):
                surf["s"] = copy.deepcopy(surf["s"])
                raise _Enough
        return real(*args)

    C.fracture_criteria = wrapped
    try:
        cli(["run", case, "-o", str(Path("/tmp") / "step_costs"), "--overwrite", "-q"])
    except (_Enough, SystemExit):
        pass
    finally:
        C.fracture_criteria = real
        S.Surface.__init__ = real_init
    return kept, surf.get("s")


def best_cpu(fn, make_args, reps):
    best, out = np.inf, None
    for _ in range(reps):
        args = make_args()
        t0 = time.process_time()
        out = fn(*args)
        best = min(best, time.process_time() - t0)
    return best, out, args


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("rev")
    ap.add_argument("case")
    ap.add_argument("--calls", default="150,450,900,1800")
    ap.add_argument("--reps", type=int, default=8)
    a = ap.parse_args(argv)
    sys.path.insert(0, export(a.rev))
    old_fc = importlib.import_module("impactsim_rev.fracture.criteria").fracture_criteria
    import impactsim.fracture.criteria as C

    calls = sorted(int(c) for c in a.calls.split(","))
    kept, surface = states(a.case, calls)
    print(f"{a.case}, {numba.get_num_threads()} thread(s), CPU ms (least of {a.reps})")
    for k, args in sorted(kept.items()):
        times = {"old": [], "new": []}
        res = {}
        for _ in range(2):
            for side, fn in (("old", old_fc), ("new", C.fracture_criteria)):
                # a revision whose kernel takes fewer arguments (before the guard's reach)
                n = len(inspect.signature(fn.py_func).parameters)
                t, out, used = best_cpu(fn, lambda: copy.deepcopy(args[:n]), a.reps)
                times[side].append(t)
                res[side] = (out, used[20].copy(), used[5].copy())
        same = (res["old"][0][:4] == res["new"][0][:4] and np.array_equal(res["old"][1], res["new"][1])
                and np.array_equal(res["old"][2], res["new"][2]))
        print(f"fracture_criteria at call {k} (dt {args[19]:.3g} s): "
              f"{1e3 * min(times['old']):.2f} -> {1e3 * min(times['new']):.2f} ms; "
              f"same counts, actions and statuses: {same}")
    if surface is not None:
        rng = np.random.default_rng(0)
        t = {True: [], False: []}
        for _ in range(40):
            ids = rng.choice(np.unique(surface.face_elem), size=6, replace=False)
            got = {}
            for inc in (True, False):
                s = copy.deepcopy(surface)
                s.incremental = inc
                t0 = time.process_time()
                s.remove_elements(ids)
                t[inc].append(time.process_time() - t0)
                got[inc] = [getattr(s, n) for n in SURFACE]
            assert all(np.array_equal(x, y) and x.dtype == y.dtype
                       for x, y in zip(got[True], got[False]))
            surface.remove_elements(ids)
        print(f"Surface.remove_elements (6 elements, {surface.n_faces} faces): regenerated "
              f"{1e3 * np.median(t[False]):.2f} -> merged {1e3 * np.median(t[True]):.2f} ms "
              "(median of 40; the same arrays)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
