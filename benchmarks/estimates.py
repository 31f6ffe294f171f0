"""The cost estimate of `impactsim check` / `run` against the real runs of the bundled cases.

    python benchmarks/estimates.py            run every bundled case, store the figures in
                                              benchmarks/estimates.json, write docs/estimates.md
    python benchmarks/estimates.py --table    rewrite docs/estimates.md from the stored runs
                                              with the estimate of the current code

Each case runs in a process of its own (`impactsim run -q`, as a user runs it, the numba cache
warm) after its meshes are in the mesh cache, right after a calibration of the machine's speed
for the run's thread count (stored with the case, with the load average at the end of the run);
a run shorter than SHORT_SECONDS is repeated and the median kept. The estimate is the one `run`
prints at its start (meshes known) with that speed and load. Real figures come from
summary.json: steps, wall seconds and seconds per pass, and the run's own re-estimate. The table
gives estimate / real for steps and wall time (target: within a factor 1.5).
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

CASES = ["elastic-bar-wall", "taylor-bar", "two-cubes", "two-cylinders", "elastic-bars",
         "hertz-spheres", "elastic-bar-wall-hex", "taylor-bar-hex", "taylor-bar-42crmo4",
         "two-cylinders-hex", "sphere-plate", "sphere-plate-hex", "oblique-sphere",
         "three-plate-shield"]
STORE = ROOT / "benchmarks" / "estimates.json"
DOC = ROOT / "docs" / "estimates.md"


def _estimate(name: str, speed: dict | None = None, share: float | None = None,
              threads: int | None = None, until: float | None = None) -> dict:
    """The estimate `run` prints for the case (meshes known), with the run's thread count when
    given; `until` [s]: also the estimated steps to that simulated time (``steps_until``, by
    the crush model's step profile), for a run stopped before its end."""
    import math

    import numpy as np

    from impactsim.case import load_case
    from impactsim.case.crush import shrink_profile
    from impactsim.case.estimate import _mesh_faces, estimate_cost
    from impactsim.mesh import mesh_bodies

    case = load_case(ROOT / "cases" / f"{name}.toml")
    if threads:
        case.run.threads = threads
    meshes = mesh_bodies(case)
    est = estimate_cost(case, speed=speed, meshes=meshes, share=share)
    faces = sum(_mesh_faces(t) for _, t in meshes)
    out = {"elements": est.elements, "steps": est.steps, "wall_seconds": est.wall_seconds,
           "seconds": est.seconds, "threads": est.threads, "faces": faces,
           "memory_bytes": est.memory_bytes, "speed": est.speed}
    if until is not None:
        found, own, first = est.crush
        t = np.linspace(0.0, until, 2001)
        g = shrink_profile(found, own, first, t) if found else np.ones_like(t)
        viscous = math.sqrt(1.0 + case.run.q_linear**2) - case.run.q_linear
        out["steps_until"] = float(np.trapezoid(g, t) / (viscous * est.dt))
    return out


def _speed(name: str) -> dict:
    """The machine's speed measured now, for the thread count the case's run will use (not
    stored: the machine is shared, and its load when the case runs is what the run meets): the
    median of three calibrations, since one can catch a busy or a quiet second (45 to 103 ns
    per element-step within ten minutes at the same load)."""
    from impactsim.case import load_case
    from impactsim.case.estimate import calibrate_speed, estimate_cost, run_threads

    case = load_case(ROOT / "cases" / f"{name}.toml")
    elements = estimate_cost(case, speed={"ns_per_element_step": 1.0,
                                          "seconds_per_step": 0.0}).elements
    speeds = sorted((calibrate_speed(run_threads(case, elements), store=False)
                     for _ in range(3)), key=lambda s: s["ns_per_element_step"])
    return speeds[1]


def _steps_profile(out: Path) -> dict:
    """The time step of the run from its history.csv: first, smallest, and the time at which
    it first fell below half the first one."""
    from impactsim.results import history_array

    h = history_array(out / "history.csv")
    dt = h["dt"][1:]
    t = h["time"][1:]
    if not len(dt):
        return {}
    below = t[dt < 0.5 * dt[0]]
    return {"dt_first": float(dt[0]), "dt_min": float(dt.min()),
            "time_half": float(below[0]) if len(below) else None, "time_last": float(t[-1])}


# a run shorter than this is repeated REPEATS times and the median kept: on a shared machine the
# wall time of a few-second run varies by half of itself from one run to the next
SHORT_SECONDS = 30.0
REPEATS = 3


def _run_once(name: str) -> dict:
    """Calibrate the speed, run the case as a user does, and return its figures."""
    from impactsim.case.estimate import cpu_share

    out = Path("/tmp") / f"impactsim-estimates-{name}"
    speed = _speed(name)
    share = sorted(cpu_share(1.0) for _ in range(3))[1]  # a second each: a burst of
    # another job can halve a 0.3 s probe (two-cylinders: 0.15 before a run that got 0.35)
    t0 = time.perf_counter()
    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.run(
        [sys.executable, "-c", "from impactsim.cli import main; main()", "run",
         str(ROOT / "cases" / f"{name}.toml"), "-q", "--overwrite", "-o", str(out)],
        env=dict(os.environ, PYTHONPATH=str(ROOT)), capture_output=True, text=True)
    wall = time.perf_counter() - t0
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)
    summary = json.loads((out / "summary.json").read_text())
    return {"process_seconds": wall, "process_cpu_seconds": cpu, "exit": proc.returncode,
            "steps": summary["steps"], "elements": summary["elements"],
            "wall_seconds": summary["wall_seconds"], "threads": summary["threads"],
            "seconds_per_pass": summary["seconds_per_pass"],
            "checks": summary.get("checks"), "stopped": summary.get("stopped"),
            "energy_balance_error": summary.get("energy_balance_error"),
            "energy_balance_error_max": summary.get("energy_balance_error_max"),
            "speed": speed, "dt": _steps_profile(out),
            "estimate_in_run": summary.get("estimate"),
            "re_estimate": summary.get("re_estimate"),
            "measured": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
            "load_average": os.getloadavg()[0], "cpu_share": share}


def run_all(cases: list[str]) -> dict:
    data = json.loads(STORE.read_text()) if STORE.exists() else {}
    for name in cases:
        runs = [_run_once(name)]
        if runs[0]["wall_seconds"] < SHORT_SECONDS:
            runs += [_run_once(name) for _ in range(REPEATS - 1)]
        runs.sort(key=lambda r: r["wall_seconds"])
        record = runs[len(runs) // 2]
        record["repeats_wall_seconds"] = [r["wall_seconds"] for r in runs]
        data[name] = record
        STORE.write_text(json.dumps(data, indent=1))
        print(f"{name}: {record['steps']} steps, {record['wall_seconds']:.1f} s "
              f"(runs: {', '.join(f'{r:.1f}' for r in record['repeats_wall_seconds'])})",
              flush=True)
    return data


def table(data: dict) -> str:
    rows = ["| case | elements | threads | steps est. / real | ratio | share of a core: probe "
            "/ run | wall est. / real [s] | ratio | at the run's share | CPU est. / real [s] "
            "| ratio | re-estimate in the run [s] | ratio | checks triggered |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    notes = []
    for name in CASES:
        if name not in data:
            continue
        real = data[name]
        partial = bool(real.get("stopped"))
        until = (real.get("dt") or {}).get("time_last") if partial else None
        est = _estimate(name, real.get("speed"), real.get("cpu_share"), real["threads"], until)
        cpu = real.get("process_cpu_seconds")
        # the share of a core the run got: its CPU over its wall time (on two threads the
        # passes that run on one thread mix in; the figure is then the cores' mean share)
        got = cpu / real["process_seconds"] if cpu else real.get("cpu_share")
        # the run's CPU seconds: the process's without the interpreter's start before the run
        # (imports, about a second, outside summary.json's wall_seconds)
        cpu = got * real["wall_seconds"] if cpu else None
        probe = real.get("cpu_share")
        own = _estimate(name, real.get("speed"), got, real["threads"]) if got else est
        alone = _estimate(name, real.get("speed"), 1.0, real["threads"])  # a free core
        shares = f"{probe:.2f} / {got:.2f}" if probe and got else "-"
        again = real.get("re_estimate") or {}
        if partial:  # stopped before its end: its steps and CPU to the time it reached
            part = est["steps_until"] / est["steps"] if est["steps"] else 0.0
            steps = (f"{est['steps_until']:,.0f} / {real['steps']:,} to "
                     f"{1e6 * until:.1f} us | {est['steps_until'] / real['steps']:.2f}")
            wall = "- | - | -"
            cpu_s = (f"{part * alone['wall_seconds']:.0f} / {cpu:.0f} | "
                     f"{part * alone['wall_seconds'] / cpu:.2f}" if cpu else "- | -")
            notes.append(f"- {name}: stopped at t = {1e6 * until:.2f} us of "
                         f"{_end_time(name) * 1e6:.0f} us ({real['stopped']}); the estimate "
                         f"for the whole run is {est['steps']:,} steps and "
                         f"{alone['wall_seconds'] / 60:.1f} min of CPU on a free core"
                         + (f"; the run's own re-estimate after its first "
                            f"{again['steps_so_far']:,} steps: {again['steps']:,} steps"
                            if again.get("steps") else "") + ".")
        else:
            steps = (f"{est['steps']:,} / {real['steps']:,} | "
                     f"{est['steps'] / real['steps']:.2f}")
            wall = (f"{est['wall_seconds']:.1f} / {real['wall_seconds']:.1f} | "
                    f"{est['wall_seconds'] / real['wall_seconds']:.2f} | "
                    f"{own['wall_seconds'] / real['wall_seconds']:.2f}")
            cpu_s = (f"{alone['wall_seconds']:.1f} / {cpu:.1f} | "
                     f"{alone['wall_seconds'] / cpu:.2f}" if cpu and real["threads"] == 1
                     else "- | -")
        again_s = (f"{again['wall_seconds']:.1f} | "
                   f"{again['wall_seconds'] / real['wall_seconds']:.2f}"
                   if again.get("wall_seconds") and not partial else "- | -")
        rows.append(f"| {name} | {real['elements']:,} | {real['threads']} | {steps} | "
                    f"{shares} | {wall} | {cpu_s} | {again_s} | "
                    f"{', '.join(real['checks'] or {}) or 'none'} |")
    return "\n".join(rows + ([""] + notes if notes else []))


def _end_time(name: str) -> float:
    from impactsim.case import load_case

    return load_case(ROOT / "cases" / f"{name}.toml").run.end_time


def main() -> None:
    cases = [a for a in sys.argv[1:] if not a.startswith("-")] or CASES
    data = json.loads(STORE.read_text()) if "--table" in sys.argv else run_all(cases)
    text = DOC.read_text() if DOC.exists() else ""
    marker = "<!-- table -->"
    head = text.split(marker)[0] if marker in text else "# Estimates against real runs\n\n"
    DOC.write_text(head + marker + "\n" + table(data) + "\n")
    print(table(data))


if __name__ == "__main__":
    main()
