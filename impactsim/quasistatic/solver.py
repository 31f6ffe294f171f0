"""A whole quasi-static problem: set up, then per load step the heat and the mechanics
phases of the Schwarz iteration, with a callback per finished step (the output writer).
No files are touched here."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from impactsim.quasistatic import interfaces as setup_mod
from impactsim.quasistatic.blas import single_threaded
from impactsim.quasistatic.model import Problem
from impactsim.quasistatic.pool import make_pool
from impactsim.quasistatic.schwarz import NotConverged, heat_phase, initial_state, \
    mechanics_phase


@dataclass
class Outcome:
    steps: list[dict] = field(default_factory=list)
    log: list[dict] = field(default_factory=list)
    seconds: dict = field(default_factory=dict)
    stopped: str | None = None
    workers: int = 0
    interfaces: list = field(default_factory=list)
    fields: dict = field(default_factory=dict)


class _Log(list):
    """The convergence log, passing each record to `on_log` as it is appended (progress)."""

    def __init__(self, on_log):
        super().__init__()
        self.on_log = on_log

    def append(self, rec) -> None:
        super().append(rec)
        self.on_log(rec)


def solve(problem: Problem, workers: int = 0, address: str | None = None, on_step=None,
          setup=None, on_log=None) -> Outcome:
    """Solve all load steps; `on_step(record, fields, state, interfaces)` after each,
    `on_log(record)` after each heat and Schwarz iteration (progress).
    A step that does not converge stops the run: Outcome.stopped says why, the finished steps
    and the unconverged state of the last one are kept (and passed to on_step).
    This process (the coordinator) runs BLAS on one thread meanwhile (blas.py)."""
    with single_threaded():
        return _solve(problem, workers, address, on_step, setup, on_log)


def _solve(problem, workers, address, on_step, setup, on_log) -> Outcome:
    out = Outcome()
    if on_log is not None:
        out.log = _Log(on_log)
    t0 = time.perf_counter()
    spaces, itfs, specs, route, t_setup = setup or setup_mod.setup(problem)
    out.interfaces = itfs
    out.seconds["contact_setup"] = t_setup
    pool = make_pool(specs, workers, address)
    out.workers = pool.workers
    out.seconds["start"] = time.perf_counter() - t0
    state = initial_state(itfs)
    s = problem.settings
    t_prev = 0.0
    t_heat = t_mech = 0.0
    try:
        for k, t in enumerate(s.times):
            dt = (t - t_prev) if s.heat_transient else None
            ta = time.perf_counter()
            heat_its = heat_phase(pool, route, s, dt, out.log)
            tb = time.perf_counter()
            t_heat += tb - ta
            rec = {"step": k + 1, "time": t, "heat_iterations": heat_its}
            try:
                rec.update(mechanics_phase(pool, itfs, s, state, t / s.times[-1], out.log,
                                           k + 1))
            except NotConverged as err:
                out.stopped = f"load step {k + 1} (t = {t:g} s): {err}"
                rec["converged"] = False
            else:
                rec["converged"] = True
            t_mech += time.perf_counter() - tb
            out.steps.append(rec)
            fields = pool.call("fields")
            out.fields = fields
            if on_step is not None:
                on_step(rec, fields, state, itfs)
            if out.stopped:
                break
            t_prev = t
    except NotConverged as err:
        out.stopped = str(err)
    finally:
        fields = out.fields or {}
        per_body = [f["seconds"] for f in fields.values()]
        out.seconds.update({
            "heat": sum(p["heat"] for p in per_body),
            "factorization": sum(p["factorization"] for p in per_body),
            "solves": sum(p["solves"] for p in per_body),
            "bodies_cpu": sum(p.get("cpu", 0.0) for p in per_body),
            "heat_phase_wall": t_heat,
            "mechanics_phase_wall": t_mech,
            "total_wall": time.perf_counter() - t0,
        })
        out.state = state
        pool.close()
    return out
