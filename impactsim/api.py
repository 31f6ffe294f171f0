"""The Python API for notebooks and scripts (docs/api.md): load a case, change it, run it, and
open a result folder as an object.

    from impactsim import api
    case = api.load_case("cases/elastic-bar-wall.toml")
    case = api.change(case, {"body.bar.mesh_size": "5 mm", "run.end_time": "20 us"})
    result = api.run(case, "out/bar", quiet=True)
    result.history            # pandas DataFrame, one row per recorded step
    result.summary["energy_balance_error"]
    mesh = result.frame(-1)   # pyvista UnstructuredGrid of the last frame

A case is the validated dataclasses of impactsim.case.schema (SI floats); `change` applies
overrides with the same key paths and value syntax as `--set`, and validates again, so a typo
raises CaseError as on the command line. The result object is impactsim.results.Result.
"""

from __future__ import annotations

import copy
import os
from pathlib import Path

from impactsim.case import CaseError, case_to_dict
from impactsim.case import load_case as _load_case
from impactsim.case.schema import Case
from impactsim.results import Result, open_result

__all__ = ["Case", "CaseError", "Result", "change", "load_case", "open_result", "run", "sweep"]


def load_case(path: str | os.PathLike, overrides: dict | list | tuple = ()) -> Case:
    """The case file at `path`, validated, with optional overrides (see `change`)."""
    return _load_case(Path(path), _as_sets(overrides))


def change(case: Case, overrides: dict | list | tuple) -> Case:
    """A new case: `case` with `overrides` applied and validated again. Overrides are a dict
    {"key.path": value} (a value is a Python number, string with unit, list...) or a list of
    "key.path=value" texts as for --set. `case` itself is not modified."""
    from impactsim.case.load import case_from_dict

    raw = copy.deepcopy(case_to_dict(case))
    return case_from_dict(raw, case.source, _as_sets(overrides))


def run(case: Case | str | os.PathLike, out: str | os.PathLike | None = None, quiet: bool = True,
        overwrite: bool = False) -> Result:
    """Run `case` (a Case or a case file) into `out` (default out/<run name>) and return the
    result. A run into a folder holding an earlier run's frames needs overwrite=True."""
    from impactsim.solver.run import run_case

    if not isinstance(case, Case):
        case = load_case(case)
    out = Path(out) if out is not None else (case.output.directory or Path("out") / case.run.name)
    run_case(case, out, progress=not quiet, overwrite=overwrite)
    return open_result(out)


def sweep(sweep_file: str | os.PathLike, out: str | os.PathLike | None = None,
          scheduler: str | None = None, workers: int | None = None):
    """Run a sweep file (docs/user-guide.md, Sweeps); returns its results DataFrame."""
    from impactsim.studies.sweep import run_sweep

    df, _ = run_sweep(Path(sweep_file), Path(out) if out else None, scheduler, workers,
                      say=lambda s: None)
    return df


def _as_sets(overrides) -> list[str]:
    if isinstance(overrides, dict):
        from impactsim.studies.sweep import toml_value

        return [f"{k}={toml_value(v)}" for k, v in overrides.items()]
    return [str(o) for o in overrides]
