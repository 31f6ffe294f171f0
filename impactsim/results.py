"""A run's output folder as an object (the reading side of impactsim.output).

    r = open_result("out/sphere-plate")
    r.history                 # pandas DataFrame of history.csv, columns without their units
    r.units["kinetic_energy"] # 'J' (from the header "kinetic_energy [J]")
    r.summary                 # summary.json as a dict
    r.case                    # case.resolved.toml as a dict (the case as run, SI units)
    r.times                   # frame times [s]
    r.frame(-1)               # the last frame as a pyvista UnstructuredGrid (with body_name)
    r.particles(-1)           # the particles of that frame as pyvista PolyData (or None)
"""

from __future__ import annotations

import json
import os
import re
import tomllib
from functools import cached_property

import numpy as np
from pathlib import Path

_HEADER = re.compile(r"^(.*?)\s*\[(.*)\]\s*$")


class ResultError(Exception):
    """A folder that is not a run's output folder."""


def split_header(name: str) -> tuple[str, str]:
    """'time [s]' -> ('time', 's'); 'step' -> ('step', '')."""
    m = _HEADER.match(name)
    return (m.group(1), m.group(2)) if m else (name.strip(), "")


def read_history(path: str | os.PathLike):
    """history.csv as a DataFrame with plain column names, and {name: unit}. Reads files with
    and without units in their headers. A last line without its newline (a write torn by the
    run's kill: output/history.py) is not a row and is left out."""
    import io

    import pandas as pd

    data = Path(path).read_bytes()
    if data and not data.endswith(b"\n"):
        data = data[:data.rfind(b"\n") + 1]
    df = pd.read_csv(io.BytesIO(data))
    names, units = [], {}
    for col in df.columns:
        name, unit = split_header(col)
        names.append(name)
        units[name] = unit
    df.columns = names
    return df, units


class Result:
    """The outputs of one run in `directory` (module docstring)."""

    def __init__(self, directory: str | os.PathLike):
        self.directory = Path(directory)
        if not (self.directory / "summary.json").is_file() and \
                not (self.directory / "history.csv").is_file():
            raise ResultError(f"{self.directory}: no summary.json or history.csv: not a run folder")

    def __repr__(self) -> str:
        s = self.summary
        return (f"Result({str(self.directory)!r}: {s.get('case')}, {s.get('steps')} steps to "
                f"t = {s.get('time')} s, {len(self.times)} frames)")

    @cached_property
    def _history(self):
        return read_history(self.directory / "history.csv")

    @property
    def history(self):
        """history.csv as a pandas DataFrame (one row per recorded step)."""
        return self._history[0]

    @property
    def units(self) -> dict[str, str]:
        """Unit of every history column ('' for counts and ratios)."""
        return self._history[1]

    @cached_property
    def summary(self) -> dict:
        path = self.directory / "summary.json"
        return json.loads(path.read_text()) if path.is_file() else {}

    @cached_property
    def case(self) -> dict:
        path = self.directory / "case.resolved.toml"
        return tomllib.loads(path.read_text()) if path.is_file() else {}

    def _series(self, name: str) -> list[tuple[float, Path]]:
        from impactsim.output.series import read_collection

        path = self.directory / name
        return read_collection(path) if path.is_file() else []

    @property
    def times(self) -> list[float]:
        """Times [s] of the frames in series.pvd."""
        return [t for t, _ in self._series("series.pvd")]

    def frame(self, index: int = -1):
        """Frame `index` (negative counts from the end) as a pyvista UnstructuredGrid, with its
        cell and point fields, its time in `mesh.field_data['time']`, and the bodies' names
        (`field_data['body_names']`, and per cell `cell_data['body_name']`)."""
        import pyvista as pv

        frames = self._series("series.pvd")
        if not frames:
            raise ResultError(f"{self.directory}: no frames (series.pvd)")
        t, path = frames[index]
        mesh = pv.read(path)
        mesh.field_data["time"] = [t]
        names = self.body_names
        if names and "body" in mesh.cell_data.keys():
            mesh.field_data["body_names"] = names
            mesh.cell_data["body_name"] = np.asarray(names)[np.asarray(mesh.cell_data["body"])]
        return mesh

    @property
    def body_names(self) -> list[str]:
        """The bodies' names in the order of the `body` field's values."""
        return [b.get("name", str(i)) for i, b in enumerate(self.case.get("body", []))]

    def particles(self, index: int = -1):
        """The particles written with frame `index` as pyvista PolyData (points with velocity,
        mass, radius...), or None for a run without particles."""
        import pyvista as pv

        series = self._series("particles.pvd")
        if not series:
            return None
        t = self.times[index]
        match = [p for tp, p in series if abs(tp - t) <= 1e-9 * max(abs(t), 1e-30)]
        if not match:
            return None
        grid = pv.read(match[0])
        cloud = pv.PolyData(grid.points)
        for k in grid.point_data.keys():
            cloud.point_data[k] = grid.point_data[k]
        return cloud


def open_result(directory: str | os.PathLike) -> Result:
    """The run folder `directory` as a Result."""
    return Result(directory)


def history_array(path: str | os.PathLike):
    """history.csv as a numpy structured array with the plain column names (h["time"]), with
    or without units in the header: the replacement of np.genfromtxt(..., names=True)."""
    import numpy as np

    df, _ = read_history(path)
    return np.rec.fromarrays([df[c].to_numpy(dtype=float) for c in df.columns],
                             names=list(df.columns))
