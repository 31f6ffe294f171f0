"""Whole-step time of the working tree against a git revision, measured in one process.

The machine here is shared: the same run can take 1.5x longer from one minute to the next, so
figures from two separate runs do not compare. This runs the bench scene of bench_element.py
(202,752 tets of copper onto a rigid wall, Johnson-Cook + Mie-Grueneisen) with both versions
side by side: the revision's `impactsim` package is exported (`git archive`) into a temporary
folder as `impactsim_rev`, each version builds its own Simulation, and the timed steps
alternate between them in short runs, so both see the same machine. Prints process CPU ns per
element-step for each version (wall ns with --threads > 1), their ratio, and how far apart the
two end states are (the two versions should compute the same physics).

    python benchmarks/compare.py REV [--steps 60] [--warm 20] [--run 5] [--elastic]
        [--cells 32] [--threads 1] [--hex viscous|stiffness]

--hex runs the hex scene of bench_hex.py instead (48^3 hexes, --cells is then the hexes along
an edge) with that hourglass form, and prints ns per hex-step.

The first call for a revision compiles its kernels (about half a minute); they are cached in
the export folder (`.bench_compare/<rev>` under the repository).
"""

from __future__ import annotations

import argparse
import importlib
import re
import subprocess
import sys
import time
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_element import case_text  # noqa: E402
from bench_hex import case_text as hex_case_text  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def export(rev: str) -> str:
    """Export `impactsim` at `rev` as the package `impactsim_rev` under .bench_compare/<sha>;
    returns the folder to put on sys.path."""
    sha = subprocess.run(["git", "rev-parse", "--short", rev], cwd=ROOT, check=True,
                         capture_output=True, text=True).stdout.strip()
    dest = ROOT / ".bench_compare" / sha
    pkg = dest / "impactsim_rev"
    if not pkg.exists():
        dest.mkdir(parents=True, exist_ok=True)
        archive = subprocess.run(["git", "archive", sha, "impactsim"], cwd=ROOT, check=True,
                                 capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)
        (dest / "impactsim").rename(pkg)
        for f in pkg.rglob("*.py"):
            text = f.read_text()
            text = re.sub(r"\bimpactsim\b(?=[. ])", "impactsim_rev", text)
            f.write_text(text)
    return str(dest)


def build(pkg: str, cells: int, elastic: bool, hourglass: str = ""):
    """The bench scene of bench_element.py (of bench_hex.py with an `hourglass` form), built
    with package `pkg`."""
    load_case_text = importlib.import_module(f"{pkg}.case").load_case_text
    mesh_body = importlib.import_module(f"{pkg}.mesh").mesh_body
    build_model = importlib.import_module(f"{pkg}.solver.build").build_model
    build_passes = importlib.import_module(f"{pkg}.solver.pipeline").build_passes
    Simulation = importlib.import_module(f"{pkg}.solver.loop").Simulation
    P = importlib.import_module(f"{pkg}.materials.params")
    case = load_case_text(hex_case_text(cells, hourglass) if hourglass
                          else case_text((cells, cells, cells + 1)))
    model = build_model(case, [mesh_body(case.bodies[0], use_cache=False)])
    if elastic:
        model.mat_params[:, P.STRENGTH] = P.ELASTIC
    return model, Simulation(model, build_passes(case, model), cfl=0.6)


def _count(model) -> int:
    """Elements of the scene: the tets, else the elements of the further blocks (hexes)."""
    return model.n_elem or sum(b.n_elem for b in model.blocks)


def main(argv=None) -> dict:
    from impactsim.kernel_cache import refresh

    refresh()  # the tree's kernels cached from older sources go first, as the CLI does
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rev")
    ap.add_argument("--steps", type=int, default=60, help="timed steps per version")
    ap.add_argument("--warm", type=int, default=20, help="untimed steps first")
    ap.add_argument("--run", type=int, default=5, help="steps per turn of a version")
    ap.add_argument("--elastic", action="store_true", help="the block made elastic")
    ap.add_argument("--cells", type=int, default=32, help="cells along x (6 tets each)")
    ap.add_argument("--threads", type=int, default=1, help="numba threads")
    ap.add_argument("--hex", default="", help="the hex scene with this hourglass form")
    args = ap.parse_args(argv)
    sys.path.insert(0, export(args.rev))
    sys.path.insert(0, str(ROOT))
    numba.set_num_threads(args.threads)
    if args.hex and args.cells == 32:
        args.cells = 48
    sims = {}
    for label, pkg in ((args.rev, "impactsim_rev"), ("working tree", "impactsim")):
        t0 = time.perf_counter()
        model, sim = build(pkg, args.cells, args.elastic, args.hex)
        sim.step()  # compiles (or loads) the kernels
        print(f"{label}: {_count(model)} {'hexes' if args.hex else 'tets'}, ready in "
              f"{time.perf_counter() - t0:.1f} s")
        sims[label] = (model, sim)
    for model, sim in sims.values():
        for _ in range(args.warm - 1):
            sim.step()
    cpu = {label: 0.0 for label in sims}
    wall = {label: 0.0 for label in sims}
    done = 0
    while done < args.steps:
        n = min(args.run, args.steps - done)
        for label, (model, sim) in sims.items():
            c0, w0 = time.process_time(), time.perf_counter()
            for _ in range(n):
                sim.step()
            cpu[label] += time.process_time() - c0
            wall[label] += time.perf_counter() - w0
        done += n
    (ma, _), (mb, _) = sims.values()
    per = 1e9 / (_count(mb) * args.steps)
    # on one thread CPU time, which the neighbours' load disturbs less; on several the wall
    # clock, which also shows how evenly the threads share the work
    ns = {label: per * (cpu[label] if args.threads == 1 else wall[label]) for label in sims}
    a, b = ns.values()
    drift = float(np.abs(ma.x - mb.x).max() / np.abs(mb.x - mb.x0).max())
    plastic = int(np.count_nonzero(mb.blocks[0].eps_p if args.hex else mb.eps_p))
    print(f"{'JC' if not args.elastic else 'elastic'}, {args.threads} thread(s), steps "
          f"{args.warm}..{args.warm + args.steps}, {plastic} plastic elements: "
          f"{'CPU' if args.threads == 1 else 'wall'} ns per element-step")
    for label, v in ns.items():
        print(f"  {label:>14}: {v:7.1f}")
    print(f"  ratio {args.rev} / working tree: {a / b:.2f}")
    print(f"  end states: max |x difference| = {drift:.1e} of the largest displacement")
    return {"ns": ns, "ratio": a / b, "drift": drift}


if __name__ == "__main__":
    main()
