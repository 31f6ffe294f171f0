"""`make accuracy`: accuracy against cost, measured and written to docs/accuracy.md.

Runs every study of benchmarks/accuracy_studies.py (mesh size, element formulation, Courant
number, contact passes on the elastic bar, the Taylor bar and two bars in contact), measures each
run (benchmarks/accuracy_measure.py), fits the observed orders (benchmarks/accuracy_fit.py) and
writes the report with its log-log plots of error against wall time
(benchmarks/accuracy_report.py).

    python benchmarks/accuracy.py                 # everything: runs, then docs/accuracy.md
    python benchmarks/accuracy.py --only taylor-cfl,bar-cfl   # rerun these studies, keep the rest
    python benchmarks/accuracy.py --report-only   # rewrite the report from the stored results
    python benchmarks/accuracy.py --jobs 1        # one run at a time (default 2)

Runs go to out/accuracy/<study>/<series>/<level>/ (history.csv, summary.json, two frames) and the
measured figures to out/accuracy/results.json. Runs are spread over --jobs worker processes, each
run on one numba thread, the most expensive first (impactsim.case.estimate); every worker first
runs a tiny case so that loading numba's cache is not charged to a measured run. Wall seconds are
run_case's wall time less meshing (meshes are cached, so a rerun would not pay it again): the
machine's other load shows in them; runs shorter than two seconds are repeated and the fastest
time kept. CPU seconds (the worker's process time, less meshing) are stored beside them: on a busy
machine they show what the run itself cost.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict
from multiprocessing import get_context
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from benchmarks.accuracy_studies import ROOT, Study, studies  # noqa: E402

OUT = ROOT / "out" / "accuracy"
RESULTS = OUT / "results.json"


def _slug(text: str) -> str:
    return "".join(ch if ch.isalnum() or ch in ".-" else "_" for ch in text)


def jobs_of(study: Study) -> list[dict]:
    out = []
    for series, s_ov in study.series.items():
        for i, level in enumerate(study.levels):
            if level.only and series not in level.only:
                continue
            out.append({"study": study.key, "series": series, "level": i, "x": level.x,
                        "label": level.label, "case": str(study.case), "measure": study.measure,
                        "overrides": study.overrides + s_ov + level.overrides,
                        "out": str(OUT / study.key / _slug(series) / f"{i}-{_slug(level.label)}")})
    return out


def estimated_seconds(job: dict) -> float:
    from impactsim.case import load_case
    from impactsim.case.estimate import DEFAULT_SPEED, estimate_cost

    case = load_case(job["case"], overrides=job["overrides"])
    return estimate_cost(case, speed=DEFAULT_SPEED).wall_seconds


REPEAT_BELOW = 2.0  # [s] runs shorter than this are repeated for their time (see run_job)
MAX_REPEATS = 8


def run_job(job: dict) -> dict:
    """Run one job (in a worker process) and measure it. A run shorter than REPEAT_BELOW
    seconds is repeated (up to MAX_REPEATS times, until REPEAT_BELOW seconds are spent) and
    the fastest time kept: the machine's other load would otherwise decide the cost of the
    cheap levels. The runs are deterministic, so the repeats give the same results."""
    from benchmarks.accuracy_measure import MEASURES
    from impactsim.case import load_case
    from impactsim.solver.run import run_case

    case = load_case(job["case"], overrides=job["overrides"])
    walls, cpus, spent = [], [], 0.0
    while not walls or (spent < REPEAT_BELOW and len(walls) < MAX_REPEATS):
        cpu = time.process_time()
        with contextlib.redirect_stderr(io.StringIO()):  # the run's own log lines
            summary = run_case(case, Path(job["out"]), progress=False)
        meshing = summary["seconds_per_pass"].get("meshing", 0.0)
        cpus.append(time.process_time() - cpu - meshing)
        walls.append(summary["wall_seconds"] - meshing)
        spent += summary["wall_seconds"]
    quantities = MEASURES[job["measure"]](case, Path(job["out"]), summary)
    return {**{k: job[k] for k in ("study", "series", "level", "x", "label")},
            "elements": summary["elements"], "steps": summary["steps"],
            "wall_seconds": min(walls), "cpu_seconds": min(cpus), "repeats": len(walls),
            "stopped": summary["stopped"],
            "quantities": {k: asdict(q) for k, q in quantities.items()}}


def _warm_up() -> None:
    """Load the numba kernels of a contact and a wall run once per worker."""
    import tempfile

    from benchmarks.accuracy_studies import BAR, ELASTIC_BARS
    from impactsim.case import load_case
    from impactsim.solver.run import run_case

    with tempfile.TemporaryDirectory() as tmp:
        for path, ov in ((BAR, ["run.end_time=2e-6", "body.0.mesh_size=0.005"]),
                         (ELASTIC_BARS, ["run.end_time=2e-7", "body.striker.mesh_size=0.005",
                                         "body.target.mesh_size=0.005"])):
            with contextlib.redirect_stderr(io.StringIO()):
                run_case(load_case(path, overrides=ov + ["output.frames=1"]),
                         Path(tmp) / path.stem, progress=False)


def run_all(selected: list[Study], n_jobs: int) -> list[dict]:
    jobs = [j for s in selected for j in jobs_of(s)]
    for j in jobs:
        j["estimate"] = estimated_seconds(j)
    jobs.sort(key=lambda j: -j["estimate"])  # longest first: the pool stays balanced
    print(f"{len(jobs)} runs in {len(selected)} studies on {n_jobs} worker(s); estimated "
          f"{sum(j['estimate'] for j in jobs) / 60:.1f} CPU minutes at the default speed",
          flush=True)
    results = []
    start = time.perf_counter()
    with ProcessPoolExecutor(n_jobs, mp_context=get_context("spawn"),
                             initializer=_warm_up) as pool:
        futures = {pool.submit(run_job, j): j for j in jobs}
        for fut in as_completed(futures):
            r = fut.result()
            results.append(r)
            print(f"[{time.perf_counter() - start:7.1f} s] {r['study']:<15} {r['series']:<22} "
                  f"{r['label']:<22} {r['elements']:>7} el {r['steps']:>6} steps "
                  f"{r['wall_seconds']:8.2f} s" + (f"  STOPPED: {r['stopped']}"
                                                    if r["stopped"] else ""), flush=True)
    return results


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", help="comma-separated study keys to run (others keep their stored "
                                   "results)")
    ap.add_argument("--report-only", action="store_true",
                    help="rewrite docs/accuracy.md and its plots from out/accuracy/results.json")
    ap.add_argument("--jobs", type=int, default=int(os.environ.get("ACCURACY_JOBS", "2")))
    args = ap.parse_args(argv)

    from benchmarks.accuracy_report import write_report

    all_studies = studies()
    known = {s.key for s in all_studies}
    stored = json.loads(RESULTS.read_text()) if RESULTS.exists() else {"runs": []}
    t0 = time.perf_counter()
    if not args.report_only:
        wanted = set(args.only.split(",")) if args.only else known
        unknown = wanted - known
        if unknown:
            ap.error(f"unknown studies {sorted(unknown)}; known: {sorted(known)}")
        selected = [s for s in all_studies if s.key in wanted]
        runs = run_all(selected, max(1, args.jobs))
        kept = [r for r in stored["runs"] if r["study"] not in wanted and r["study"] in known]
        elapsed = time.perf_counter() - t0
        seconds = dict(stored.get("seconds", {}))
        seconds.update({s.key: sum(r["wall_seconds"] for r in runs if r["study"] == s.key)
                        for s in selected})
        stored = {"runs": kept + runs, "seconds": seconds, "jobs": args.jobs,
                  "elapsed": elapsed if not args.only else stored.get("elapsed"),
                  "cpus": os.cpu_count()}
        OUT.mkdir(parents=True, exist_ok=True)
        tmp = RESULTS.with_suffix(".tmp")
        tmp.write_text(json.dumps(stored, indent=1))
        tmp.replace(RESULTS)
    path = write_report(all_studies, stored["runs"], stored)
    print(f"wrote {path.relative_to(ROOT)} ({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
