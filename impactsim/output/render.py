"""PNG images of a finished run's frames, rendered off-screen with pyvista.

`render_series` reads `series.pvd` of a run folder and writes `render/<frame>.png`, one per
selected frame, coloured by a cell or point field. The colour range and the camera are the same
for every image (the range of the field and the bounds of the bodies over all selected frames),
so the images play as an animation. Multi-component fields (vectors, tensors) are coloured by
their magnitude (the Euclidean norm of the components).

Whether off-screen rendering works is found out first in a child process, because a VTK without
a usable OpenGL context can crash the process rather than raise; `RenderError` then says why.
"""

from __future__ import annotations

import functools
import os
import signal
import subprocess
import sys
import xml.etree.ElementTree as ET
from contextlib import nullcontext
from pathlib import Path

import numpy as np

from impactsim.output.atomic import replacing
from impactsim.output.series import read_collection


class RenderError(Exception):
    """The frames cannot be rendered; the message says why."""


_PROBE = """
import pyvista as pv
pv.OFF_SCREEN = True
plotter = pv.Plotter(off_screen=True, window_size=(32, 32))
plotter.add_mesh(pv.Cube())
image = plotter.screenshot(return_img=True)
plotter.close()
assert image.shape[:2] == (32, 32), image.shape
"""

_HOW_TO = (
    "Off-screen rendering needs an OpenGL context without a window: a VTK build that can use "
    "EGL or OSMesa (VTK >= 9.4 chooses at run time; install the EGL or OSMesa libraries of "
    "Mesa or of the GPU driver), or an X server (set DISPLAY, or run the command under xvfb-run)."
)


def render_series(
    run_dir: str | os.PathLike,
    field: str = "von_mises",
    every: int = 1,
    *,
    window_size: tuple[int, int] = (1024, 768),
) -> list[Path]:
    """Render every `every`-th frame of `run_dir/series.pvd` coloured by `field`; return the PNGs."""
    run_dir = Path(run_dir)
    frames = _select_frames(run_dir, every)
    try:
        import pyvista as pv
    except ImportError as err:
        raise RenderError(f"pyvista is not available: {err}") from err

    clim, bounds = _scan(pv, frames, field)
    reason = offscreen_unavailable()
    if reason:
        raise RenderError(f"cannot render off-screen: {reason}. {_HOW_TO}")

    out_dir = run_dir / "render"
    out_dir.mkdir(exist_ok=True)
    pv.OFF_SCREEN = True
    quiet = pv.vtk_verbosity("error") if hasattr(pv, "vtk_verbosity") else nullcontext()
    written = []
    with quiet:
        plotter = pv.Plotter(off_screen=True, window_size=list(window_size))
        try:
            for i, (time, path) in enumerate(frames):
                mesh, label = _coloured(pv.read(path), field)
                if mesh.n_cells:
                    plotter.add_mesh(
                        mesh, scalars=label, clim=clim, cmap="viridis", name="bodies",
                        reset_camera=False, scalar_bar_args={"title": label},
                    )
                else:
                    plotter.remove_actor("bodies")
                plotter.add_text(f"t = {time * 1e6:.3f} µs", position="upper_left", font_size=12, name="time")
                if i == 0:
                    plotter.view_isometric()
                    plotter.reset_camera(bounds=bounds)
                target = out_dir / f"{path.stem}.png"
                with replacing(target) as tmp:
                    plotter.screenshot(tmp)
                written.append(target)
        finally:
            plotter.close()
    return written


@functools.cache
def offscreen_unavailable() -> str | None:
    """None when off-screen rendering works here, else the reason (probed once per process).

    When the probe fails, there is no DISPLAY and pyvista still offers `start_xvfb`, a virtual
    X server is started and the probe repeated.
    """
    reason = _probe()
    if reason and sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
        try:
            import pyvista as pv

            start_xvfb = getattr(pv, "start_xvfb", None)
            if start_xvfb is not None:
                start_xvfb()
                reason = _probe()
        except Exception as err:  # start_xvfb raises OSError when Xvfb is missing, among others
            reason = f"{reason}; starting Xvfb failed too ({err})"
    return reason


def _probe() -> str | None:
    try:
        done = subprocess.run(
            [sys.executable, "-c", _PROBE], capture_output=True, text=True, timeout=120
        )
    except subprocess.TimeoutExpired:
        return "a test render did not finish within 120 s"
    if done.returncode == 0:
        return None
    if done.returncode < 0:
        return f"a test render crashed ({signal.Signals(-done.returncode).name})"
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    return f"a test render failed ({lines[-1] if lines else f'exit status {done.returncode}'})"


def _select_frames(run_dir: Path, every: int) -> list[tuple[float, Path]]:
    pvd = run_dir / "series.pvd"
    if not pvd.is_file():
        raise RenderError(f"{pvd} not found: {run_dir} is not the output folder of a run")
    if every < 1:
        raise RenderError(f"every must be at least 1, got {every}")
    try:
        frames = read_collection(pvd)
    except (ET.ParseError, ValueError) as err:
        raise RenderError(f"{pvd}: {err}") from err
    if not frames:
        raise RenderError(f"{pvd} lists no frames")
    frames = frames[::every]
    missing = [str(path) for _, path in frames if not path.is_file()]
    if missing:
        raise RenderError(f"{pvd} lists missing files: {', '.join(missing)}")
    return frames


def _field_values(mesh, field: str) -> tuple[np.ndarray, str, bool]:
    """The field's values (magnitudes if multi-component), where they live, and if they are scalar.

    Cell data is looked up first. A missing field raises RenderError listing the available ones.
    """
    for where, data in (("cell", mesh.cell_data), ("point", mesh.point_data)):
        if field in data.keys():
            values = np.asarray(data[field], dtype=np.float64)
            if values.ndim == 1:
                return values, where, True
            return np.linalg.norm(values.reshape(len(values), -1), axis=1), where, False
    available = sorted({*mesh.cell_data.keys(), *mesh.point_data.keys()})
    raise RenderError(f"no field {field!r} in the frames; available fields: {', '.join(available) or 'none'}")


def _coloured(mesh, field: str):
    """`mesh` with the scalars to colour by attached, and their name for the scalar bar."""
    values, where, scalar = _field_values(mesh, field)
    if scalar:
        return mesh, field
    label = f"{field} magnitude"
    (mesh.cell_data if where == "cell" else mesh.point_data)[label] = values
    return mesh, label


def _scan(pv, frames: list[tuple[float, Path]], field: str):
    """Check the field is in every frame; return its colour range and the bodies' bounds."""
    lo, hi = np.inf, -np.inf
    box_lo, box_hi = np.full(3, np.inf), np.full(3, -np.inf)
    for _, path in frames:
        try:
            mesh = pv.read(path)
        except Exception as err:  # VTK readers raise several types for broken files
            raise RenderError(f"{path}: cannot read: {err}") from err
        values = _field_values(mesh, field)[0]
        finite = values[np.isfinite(values)]
        if finite.size:
            lo, hi = min(lo, finite.min()), max(hi, finite.max())
        if mesh.n_points:
            box_lo = np.minimum(box_lo, mesh.points.min(axis=0))
            box_hi = np.maximum(box_hi, mesh.points.max(axis=0))
    clim = None
    if lo <= hi:
        clim = (lo, hi) if hi > lo else (lo - 0.5 * max(abs(lo), 1.0), hi + 0.5 * max(abs(hi), 1.0))
    if not np.all(box_lo <= box_hi):
        box_lo, box_hi = -np.ones(3), np.ones(3)
    bounds = (box_lo[0], box_hi[0], box_lo[1], box_hi[1], box_lo[2], box_hi[2])
    return clim, bounds
