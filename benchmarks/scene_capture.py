"""A bundled scene run until patched functions have kept what a benchmark wants.

bench_particle_sweep.py and bench_particle_query.py time kernels on oblique-sphere's own inputs
at a few steps: they replace the functions that receive those inputs by ones that copy them,
and the last copy raises `Captured` to end the run there.
"""

from __future__ import annotations

import tempfile
from pathlib import Path


class Captured(Exception):
    """Raised by a patched function once the benchmark has all it wants: ends the run."""


def run_patched(case_path: Path, patches) -> None:
    """Run the case with ``patches`` (object, attribute name, replacement) in place, until it
    ends or a replacement raises `Captured`; the attributes are restored afterwards."""
    from impactsim.case import load_case
    from impactsim.solver.run import run_case

    saved = [(obj, name, getattr(obj, name)) for obj, name, _ in patches]
    for obj, name, new in patches:
        setattr(obj, name, new)
    try:
        run_case(load_case(case_path), Path(tempfile.mkdtemp()), progress=False)
    except Captured:
        pass
    finally:
        for obj, name, old in saved:
            setattr(obj, name, old)


def arguments(doc: str, rev_help: str | None, argv=None, steps: str = "800,1500,2200",
              reps: int = 7):
    """The particle benchmarks' options (--case, --steps, --reps, and --rev unless rev_help is
    None), parsed; first the kernel cache refreshed, as the CLI does (kernels cached from older
    sources go first)."""
    import argparse

    from impactsim.kernel_cache import refresh

    refresh()
    root = Path(__file__).resolve().parents[1]
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--case", default=str(root / "cases" / "oblique-sphere.toml"))
    ap.add_argument("--steps", default=steps)
    ap.add_argument("--reps", type=int, default=reps)
    if rev_help is not None:
        ap.add_argument("--rev", default="", help=rev_help)
    return ap.parse_args(argv)
