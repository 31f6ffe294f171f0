"""Run a quasistatic case: build the problem, solve the load steps, write the outputs as they
come (a VTU frame per finished step; convergence files and summary.json at the end, also when
the iteration did not converge or the run fails)."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np

from impactsim.case.errors import CaseError
from impactsim.quasistatic.build import problem as build_problem
from impactsim.quasistatic.interfaces import SetupError
from impactsim.quasistatic.solver import solve


def _contact_fields(state, interfaces) -> dict:
    out: dict = {}
    for c, itf in enumerate(interfaces):
        if not state.ua:
            continue
        gap = itf.gap + state.ub[c] - state.ua[c]
        out.setdefault(itf.a, []).append((itf.nodes, state.p[c], gap))
    return out


def resolved_case(case) -> dict:
    d = dataclasses.asdict(case)
    d.pop("raw", None)
    for b in d["bodies"]:
        for bd in b["boundaries"]:
            bd["conditions"] = {k: (list(v) if isinstance(v, tuple) else v)
                                for k, v in bd["conditions"].items()}
    return {"source": str(case.source), "input": case.raw, "resolved": _plain(d)}


def _plain(v):
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items() if x is not None}
    if isinstance(v, (list, tuple)):
        return [_plain(x) if x is not None else "free" for x in v]
    if isinstance(v, Path):
        return str(v)
    return v


def run_quasistatic(case, out_dir: Path | None = None, workers: int | None = None,
                    address: str | None = None, progress: bool = True) -> dict:
    from impactsim.output.quasistatic import QuasistaticWriter

    t0 = time.perf_counter()
    label = str(case.source) if case.source else "<string>"
    directory = out_dir or case.directory or Path("out") / case.name
    try:
        prob = build_problem(case)
    except SetupError as err:
        raise CaseError(f"{label}: {err}") from None
    writer = QuasistaticWriter(directory)
    writer.write_case(resolved_case(case))
    t_build = time.perf_counter() - t0
    nworkers = case.settings["workers"] if workers is None else workers

    def on_step(rec, fields, state, interfaces):
        writer.write_step(rec["time"], prob.bodies, fields, _contact_fields(state, interfaces))
        if progress:
            print(f"step {rec['step']}/{len(prob.settings.times)} t = {rec['time']:g} s: "
                  f"{rec.get('heat_iterations')} heat and {rec.get('iterations')} Schwarz "
                  f"iterations", flush=True)

    try:
        res = solve(prob, nworkers, address, on_step=on_step)
    except SetupError as err:
        raise CaseError(f"{label}: {err}") from None
    finally:
        writer.close()
    res.seconds["build_and_mesh"] = t_build
    writer.write_log(res.log)
    writer.plot_log(res.log)
    summary = {
        "analysis": "quasistatic",
        "case": str(case.source),
        "bodies": len(prob.bodies),
        "interfaces": len(res.interfaces),
        "element": case.settings["element"],
        "dofs": int(sum(3 * f["u"].size // 3 for f in res.fields.values())),
        "workers": res.workers,
        "scheduler": address,
        "load_steps": res.steps,
        "iterations_per_step": [s.get("iterations") for s in res.steps],
        "converged": res.stopped is None,
        "stopped": res.stopped,
        "seconds": res.seconds,
        "max_von_mises": float(max((np.max(_vm(f["stress"])) for f in res.fields.values()),
                                   default=0.0)),
        "max_temperature": float(max((np.max(f["T"]) for f in res.fields.values()),
                                     default=0.0)),
    }
    writer.write_summary(summary)
    if progress:
        print(f"{'converged' if res.stopped is None else 'NOT converged'}: "
              f"{len(res.steps)} load steps, {sum(summary['iterations_per_step'] or [0])} "
              f"Schwarz iterations, {res.seconds['total_wall']:.1f} s; output in {directory}",
              flush=True)
    return {"stopped": res.stopped, "summary": summary, "directory": directory}


def _vm(s):
    from impactsim.output.quasistatic import von_mises
    return von_mises(s)
