"""The cost estimate of `impactsim check` / `run` against the real runs of the bundled cases.

    python benchmarks/estimates.py            run every bundled case, store the figures in
                                              benchmarks/estimates.json, write docs/estimates.md
    python benchmarks/estimates.py --table    rewrite docs/estimates.md from the stored runs
                                              with the estimate of the current code

Each case runs in a process of its own (`impactsim run -q`, as a user runs it, the numba cache
warm) after its meshes are in the mesh cache; the estimate is the one `run` prints at its start
(meshes known). Real figures come from summary.json: steps, wall seconds and seconds per pass.
The table gives estimate / real for steps and wall time (target: within a factor 1.5).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

CASES = ["elastic-bar-wall", "taylor-bar", "two-cubes", "two-cylinders", "elastic-bars",
         "hertz-spheres", "elastic-bar-wall-hex", "taylor-bar-hex", "two-cylinders-hex",
         "sphere-plate", "oblique-sphere"]
STORE = ROOT / "benchmarks" / "estimates.json"
DOC = ROOT / "docs" / "estimates.md"


def _estimate(name: str, speed: dict | None = None) -> dict:
    from impactsim.case import load_case
    from impactsim.case.estimate import estimate_cost
    from impactsim.mesh import mesh_bodies

    case = load_case(ROOT / "cases" / f"{name}.toml")
    meshes = mesh_bodies(case)
    est = estimate_cost(case, speed=speed, meshes=meshes)
    from impactsim.mesh.topology import boundary_faces

    faces = sum(len(boundary_faces(t)[0]) for _, t in meshes)
    return {"elements": est.elements, "steps": est.steps, "wall_seconds": est.wall_seconds,
            "seconds": est.seconds, "threads": est.threads, "faces": faces,
            "memory_bytes": est.memory_bytes, "speed": est.speed}


def _speed(name: str) -> dict:
    """The machine's speed measured now, for the thread count the case's run will use (not
    stored: the machine is shared, and its load when the case runs is what the run meets)."""
    from impactsim.case import load_case
    from impactsim.case.estimate import calibrate_speed, estimate_cost, run_threads

    case = load_case(ROOT / "cases" / f"{name}.toml")
    elements = estimate_cost(case, speed={"ns_per_element_step": 1.0,
                                          "seconds_per_step": 0.0}).elements
    return calibrate_speed(run_threads(case, elements), store=False)


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
            "time_half": float(below[0]) if len(below) else None}


def run_all(cases: list[str]) -> dict:
    data = json.loads(STORE.read_text()) if STORE.exists() else {}
    for name in cases:
        out = Path("/tmp") / f"impactsim-estimates-{name}"
        speed = _speed(name)
        t0 = time.perf_counter()
        proc = subprocess.run(
            [sys.executable, "-c", "from impactsim.cli import main; main()", "run",
             str(ROOT / "cases" / f"{name}.toml"), "-q", "--overwrite", "-o", str(out)],
            env=dict(os.environ, PYTHONPATH=str(ROOT)), capture_output=True, text=True)
        wall = time.perf_counter() - t0
        summary = json.loads((out / "summary.json").read_text())
        rss = None
        data[name] = {"process_seconds": wall, "exit": proc.returncode,
                      "steps": summary["steps"], "elements": summary["elements"],
                      "wall_seconds": summary["wall_seconds"], "threads": summary["threads"],
                      "seconds_per_pass": summary["seconds_per_pass"],
                      "checks": summary.get("checks"), "stopped": summary.get("stopped"),
                      "energy_balance_error": summary.get("energy_balance_error"),
                      "energy_balance_error_max": summary.get("energy_balance_error_max"),
                      "max_rss": rss, "speed": speed, "dt": _steps_profile(out),
                      "estimate_in_run": summary.get("estimate"),
                      "re_estimate": summary.get("re_estimate"),
                      "measured": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                      "load_average": os.getloadavg()[0]}
        STORE.write_text(json.dumps(data, indent=1))
        print(f"{name}: {summary['steps']} steps, {summary['wall_seconds']:.1f} s",
              flush=True)
    return data


def table(data: dict) -> str:
    rows = ["| case | elements | steps est. / real | wall est. / real [s] | ratio | "
            "per step est. / real [ms] | ratio | checks triggered |",
            "|---|---:|---:|---:|---:|---:|---:|---|"]
    for name in CASES:
        if name not in data:
            continue
        real = data[name]
        est = _estimate(name, real.get("speed"))
        ratio = est["wall_seconds"] / real["wall_seconds"]
        per_est = 1e3 * est["wall_seconds"] / max(est["steps"], 1)
        per_real = 1e3 * real["wall_seconds"] / max(real["steps"], 1)
        rows.append(f"| {name} | {real['elements']:,} | {est['steps']:,} / {real['steps']:,} | "
                    f"{est['wall_seconds']:.1f} / {real['wall_seconds']:.1f} | {ratio:.2f} | "
                    f"{per_est:.2f} / {per_real:.2f} | {per_est / per_real:.2f} | "
                    f"{', '.join(real['checks'] or {}) or 'none'} |")
    return "\n".join(rows)


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
