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
