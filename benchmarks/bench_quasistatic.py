"""`make bench-quasistatic`: the pellet stack (cases/pellet-stack.toml) with 10, 50 and 350
bodies (pellets + the tube), with 1 and 2 Dask workers, and the monolithic solve of the same
bodies where it fits: Schwarz iterations, heat iterations and wall times.

    QS_SIZES=10,50,350 QS_WORKERS=1,2 python benchmarks/bench_quasistatic.py
    QS_SET="quasistatic.max_iterations=200" ...   # extra --set overrides, ';'-separated
    QS_PROGRESS=50 ...      # a progress line every 50 Schwarz iterations (0: none; default 50)
    QS_CACHE=/tmp/qs ...    # keep each size's meshes and contact set-up (pickled) for reuse
    QS_LOG=/tmp/qs ...      # write each run's convergence log (convergence-<bodies>-<workers>.csv)

(`make bench` runs it with 10 and 50 bodies only.) The wall time of a run is measured without
the cluster start, the meshing and the contact set-up (done once per size and printed):
factorisations and iterations.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

HERE = Path(__file__).parent
CASE = HERE.parent / "cases" / "pellet-stack.toml"
PELLET = 9.83  # mm
GRIDS = [500.0 * k for k in range(1, 7)]  # mm: the spacer grids of the case (tube boundaries 1-6)


def stack_overrides(bodies: int) -> list[str]:
    """--set overrides turning the 350-body case into `bodies` bodies (bodies - 1 pellets)."""
    n = bodies - 1
    tube = n * PELLET + 10.0
    # grids above a shortened tube hold its top end instead (as an upper end plug would)
    grids = []
    for k, z in enumerate(GRIDS):
        z = min(z, tube - 9.0)
        grids.append(f'body.tube.boundary.{k + 1}.box.lo=["-6 mm", "-6 mm", "{z - 3:.3f} mm"]')
        grids.append(f'body.tube.boundary.{k + 1}.box.hi=["6 mm", "6 mm", "{z + 3:.3f} mm"]')
    return grids + [f"body.pellet.copies.count={n - 2}",
            f'body.top-pellet.position=[0, 0, "{(n - 1) * PELLET + 4.915:.3f} mm"]',
            f'body.top-pellet.boundary.0.plane.point=[0, 0, "{n * PELLET:.3f} mm"]',
            f'body.tube.height="{tube:.3f} mm"',
            f'body.tube.position=[0, 0, "{tube / 2 - 5.0:.3f} mm"]']


def prepare(bodies: int):
    """(problem, setup, seconds to mesh, seconds to set up) of the stack with `bodies` bodies.
    With QS_CACHE set, the meshes and the set-up are pickled there, keyed by the overrides,
    and read back by a later run (the 350-body set-up takes minutes)."""
    import hashlib
    import pickle

    from impactsim.case.quasistatic import load_quasistatic
    from impactsim.quasistatic import interfaces as setup_mod
    from impactsim.quasistatic.build import problem

    extra = [x for x in os.environ.get("QS_SET", "").split(";") if x.strip()]
    overrides = stack_overrides(bodies) + extra
    case = load_quasistatic(CASE, overrides)
    cache = os.environ.get("QS_CACHE")
    path = None
    if cache:
        # keyed by the case, the overrides and the code that builds the set-up (a set-up
        # pickled by older code would be read back without the fields it now has)
        code = "".join(p.read_text() for p in sorted(Path(setup_mod.__file__).parent.glob("*.py")))
        key = hashlib.sha1((CASE.read_text() + repr(overrides) + code).encode()).hexdigest()[:16]
        path = Path(cache) / f"pellets-{bodies}-{key}.pkl"
        if path.exists():
            with open(path, "rb") as f:
                prob, setup, t_mesh = pickle.load(f)
            # the settings come from the case as loaded now (the cache key has the overrides)
            return prob, setup, t_mesh, setup[4]
    t0 = time.perf_counter()
    prob = problem(case)
    t_mesh = time.perf_counter() - t0
    setup = setup_mod.setup(prob)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "wb") as f:
            pickle.dump((prob, setup, t_mesh), f, protocol=pickle.HIGHEST_PROTOCOL)
    return prob, setup, t_mesh, setup[4]


def _progress(every: int, label: str):
    """on_log for solve: a line every `every` Schwarz iterations and every 10 heat iterations,
    with the active-set changes since the last line, the wall and CPU seconds (this process)
    since the run started and the load."""
    t0, c0 = time.perf_counter(), time.process_time()
    changes = [0]  # active-set changes since the last line (each restarts Anderson)

    def on_log(rec):
        changes[0] += bool(rec.get("active_changed"))
        if rec.get("phase") == "heat" and rec["iteration"] % 10 == 0:
            print(f"  [{label}] heat iteration {rec['iteration']}: change {rec['change']:.2e}; "
                  f"{time.perf_counter() - t0:.0f} s wall, load {os.getloadavg()[0]:.1f}",
                  flush=True)
        if rec.get("phase") != "mechanics" or rec["iteration"] % every:
            return
        print(f"  [{label}] iteration {rec['iteration']}: gap {rec['gap_residual']:.2e} "
              f"pressure {rec['pressure_residual']:.2e} motion {rec['motion_residual']:.2e} "
              f"active {rec['active']} ({changes[0]} changes); "
              f"{time.perf_counter() - t0:.0f} s wall, "
              f"{time.process_time() - c0:.0f} s CPU here, load {os.getloadavg()[0]:.1f}",
              flush=True)
        changes[0] = 0
    return on_log


def run(prob, setup, workers: int, monolithic: bool = False) -> dict:
    from impactsim.quasistatic.solver import solve

    every = int(os.environ.get("QS_PROGRESS", "50"))
    label = f"{len(prob.bodies)} bodies, {workers} workers"
    c0 = time.process_time()
    out = solve(prob, workers, setup=setup,
                on_log=_progress(every, label) if every > 0 else None)
    row = {"bodies": len(prob.bodies), "workers": out.workers, "setup_s": setup[4],
           "iterations": out.steps[-1].get("iterations"),
           "heat_iterations": out.steps[-1].get("heat_iterations"),
           "wall_s": out.seconds["total_wall"] - out.seconds["start"],
           "heat_s": out.seconds["heat_phase_wall"],
           "mechanics_s": out.seconds["mechanics_phase_wall"],
           "converged": out.stopped is None,
           "max_T": max(float(f["T"].max()) for f in out.fields.values()),
           "max_penetration": out.steps[-1].get("max_penetration"),
           "client_cpu_s": time.process_time() - c0,
           # CPU seconds of the bodies' calls in their workers (heat, factorisations, solves)
           "bodies_cpu_s": out.seconds["bodies_cpu"],
           "load": os.getloadavg()[0]}
    if out.stopped:
        print(f"  stopped: {out.stopped}", flush=True)
    if os.environ.get("QS_LOG"):  # the convergence log of every run, as the CLI writes it
        import csv

        path = Path(os.environ["QS_LOG"]) / f"convergence-{row['bodies']}-{out.workers}.csv"
        path.parent.mkdir(parents=True, exist_ok=True)
        keys = sorted({k for r in out.log for k in r})
        with open(path, "w", newline="") as f:
            w = csv.DictWriter(f, keys)
            w.writeheader()
            w.writerows(out.log)
    if monolithic:
        import numpy as np
        from impactsim.quasistatic.body import BodyState
        from impactsim.quasistatic.monolithic import solve_monolithic

        _, itfs, specs, _, _ = setup
        states = {s.index: BodyState(s) for s in specs}
        # the temperatures of the Schwarz run, then the monolithic mechanical solve
        for i, st in states.items():
            st.heat.T = out.fields[i]["T"]
        t1 = time.perf_counter()
        u, _ = solve_monolithic(states, itfs)
        row["monolithic_s"] = time.perf_counter() - t1
        size = max(np.abs(u[i]).max() for i in u)
        diff = np.array([np.abs(out.fields[i]["u"] - u[i]).reshape(-1, 3).max(axis=0)
                         for i in u]).max(axis=0) / size
        # along the column (z) and across it: the pellets' sideways position is held by the
        # weak centering springs only and is ill-determined (docs/quasistatic.md)
        row["schwarz_vs_monolithic"] = float(diff.max())
        row["axial_diff"] = float(diff[2])
    return row


def main() -> None:
    sys.path.insert(0, str(HERE.parent))
    sizes = [int(s) for s in os.environ.get("QS_SIZES", "10,50").split(",")]
    workers = [int(s) for s in os.environ.get("QS_WORKERS", "1,2").split(",")]
    mono_limit = int(os.environ.get("QS_MONOLITHIC_MAX", "50"))
    cols = ("bodies", "workers", "iterations", "heat_iterations", "setup_s", "wall_s", "heat_s",
            "mechanics_s", "client_cpu_s", "bodies_cpu_s", "load", "monolithic_s",
            "schwarz_vs_monolithic", "axial_diff", "converged", "max_T", "max_penetration")
    print(" ".join(f"{c:>12}" for c in cols), flush=True)
    for n in sizes:
        walls = {}
        prob, setup, t_mesh, t_setup = prepare(n)
        print(f"  {n} bodies: meshed in {t_mesh:.1f} s, contacts set up in {t_setup:.1f} s",
              flush=True)
        for w in workers:
            row = run(prob, setup, w, monolithic=(w == workers[0] and n <= mono_limit))
            walls[w] = row["wall_s"]
            print(" ".join(f"{_fmt(row.get(c, '')):>12}" for c in cols), flush=True)
        if 1 in walls and 2 in walls:
            print(f"  {n} bodies: 1 worker / 2 workers wall time = {walls[1] / walls[2]:.2f}",
                  flush=True)


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


if __name__ == "__main__":
    main()
