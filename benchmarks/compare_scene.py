"""A whole scene of the working tree against a git revision's, alternating, one thread each.

The machine is shared: a scene's wall time measures the other processes as much as the code.
This runs `impactsim run CASE` with the revision's package (exported with `git archive` into a
folder of its own, whose numba cache `python -m impactsim.warmup` fills first, as `make setup`
does; minutes with a cold cache, skipped with --no-warmup or when the folder is already there)
and with the working tree's, one after the other, REPS times, each in a fresh process with
NUMBA_NUM_THREADS=1 (--threads), and prints per run the process CPU seconds (user + system, from
getrusage of the child), the wall seconds, the steps and summary.json's seconds per pass; then
whether the two sides' last history.csv are byte-identical (the runs that compiled kernels are
marked). Compare the CPU seconds: on one thread they are the work done, whatever else holds the
cores.

    python benchmarks/compare_scene.py REV cases/sphere-plate.toml [--reps 2] [--base DIR]
        [--no-warmup] [--threads N] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import filecmp
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def export(rev: str, base: Path, warmup: bool) -> Path:
    """The revision's tree in ``base`` (kept between calls), its numba cache warmed up."""
    if not (base / "impactsim").is_dir():
        base.mkdir(parents=True, exist_ok=True)
        archive = subprocess.run(["git", "archive", rev], cwd=ROOT, check=True,
                                 capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(base)], input=archive, check=True)
        if warmup:
            print(f"warming up {rev}'s numba cache in {base} (minutes when cold)", flush=True)
            subprocess.run([sys.executable, "-m", "impactsim.warmup"], cwd=base, check=True,
                           env=_env(base))
    return base


def _env(tree: Path, threads: int = 1) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(tree)
    env["NUMBA_NUM_THREADS"] = str(threads)
    return env


def run_once(tree: Path, case: Path, out: Path, sets: list[str], threads: int = 1) -> dict:
    """One run of ``case`` with the package of ``tree`` in a fresh process."""
    cmd = [sys.executable, "-c", "from impactsim.cli import main; main()", "run", str(case),
           "-o", str(out), "-q"]  # a fresh folder: no --overwrite, which old revisions lack
    for s in sets:
        cmd += ["--set", s]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, cwd=tree, env=_env(tree, threads), check=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    summary = json.loads((out / "summary.json").read_text())
    return {"cpu": cpu, "wall": wall, "steps": summary["steps"],
            "passes": summary["seconds_per_pass"], "out": out,
            "compiled": summary.get("kernels_compiled")}  # revisions before session 23: None


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("rev")
    ap.add_argument("case")
    ap.add_argument("--reps", type=int, default=2)
    ap.add_argument("--base", type=Path, default=None,
                    help="folder for the revision's tree (default: a folder in the temp dir "
                         "named after it, kept for later calls)")
    ap.add_argument("--no-warmup", action="store_true")
    ap.add_argument("--set", action="append", default=[], dest="sets")
    ap.add_argument("--threads", type=int, default=1,
                    help="NUMBA_NUM_THREADS of the runs (then compare the wall seconds)")
    a = ap.parse_args(argv)
    rev = subprocess.run(["git", "rev-parse", "--short", a.rev], cwd=ROOT, check=True,
                         capture_output=True, text=True).stdout.strip()
    base = export(rev, a.base or Path(tempfile.gettempdir()) / f"impactsim-{rev}",
                  not a.no_warmup)
    case = Path(a.case).resolve()
    rel = case.relative_to(ROOT) if case.is_relative_to(ROOT) else case
    outs = Path(tempfile.mkdtemp(prefix="compare_scene_"))
    runs = {"old": [], "new": []}
    for i in range(a.reps):
        for side, tree in (("old", base), ("new", ROOT)):
            r = run_once(tree, tree / rel if not rel.is_absolute() else rel,
                         outs / f"{side}-{i}", a.sets, a.threads)
            runs[side].append(r)
            passes = ", ".join(f"{k} {v:.1f}" for k, v in sorted(
                r["passes"].items(), key=lambda kv: -kv[1]) if v >= 0.5)
            compiled = "" if not r["compiled"] else f", {r['compiled']} kernels compiled"
            print(f"{side} ({rev if side == 'old' else 'tree'}) run {i + 1}: CPU {r['cpu']:.1f} s, "
                  f"wall {r['wall']:.1f} s, {r['steps']} steps{compiled}; wall s per pass: "
                  f"{passes}", flush=True)
    old = min(r["cpu"] for r in runs["old"])
    new = min(r["cpu"] for r in runs["new"])
    # the last runs' histories: a revision before session 24 computed other last bits in a
    # run that compiled kernels than in one from its cache (docs/user-guide.md,
    # "Reproducibility"), and a first run may compile what the warm-up left out
    same = filecmp.cmp(runs["old"][-1]["out"] / "history.csv",
                       runs["new"][-1]["out"] / "history.csv", shallow=False)
    print(f"{rel}: CPU s (least of {a.reps}) {old:.1f} -> {new:.1f} ({old / new:.2f}x); "
          f"history.csv of the last runs byte-identical: {same}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
