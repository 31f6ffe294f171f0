"""PNG images and animations of a finished run's frames, rendered off-screen with pyvista.

`render_series` reads `series.pvd` of a run folder and writes `<out>/<field>_<frame>.png` (out:
`render/` in the run folder unless given), one per selected frame, and optionally an animation
(`.mp4` through imageio's ffmpeg plugin, or `.gif`) of those images. Every image has:
- the field's colour bar with its unit (output/fields.py), labels in a short number format; the
  colour range and the camera are the same for every image, so the images play as an animation.
  Multi-component fields (vectors, tensors) are coloured by their magnitude. Categorical fields
  (status, body, cell_id) get one colour per value and a legend of names instead of a scale;
- the simulated time;
- a camera that frames the region of interest: by default the impact, found on the first frame
  as the closest approach of two bodies (the nearest pair of points of different bodies), seen
  from the side, across the direction of the bodies' relative velocity, slightly from above, at a
  distance that shows a few times the smaller body's size around it (a scene of one body: the
  whole body). `view="all"` frames every body;
- optionally a cut (`cut=(normal, point)`): the half of the bodies on the normal's side is
  removed and the camera looks at the cut face, so a perforated plate is seen through;
- the particles (particles.pvd) drawn as spheres of their radius, coloured by the field when
  they carry it, else in grey.

Whether off-screen rendering works is found out first in a child process, because a VTK without
a usable OpenGL context can crash the process rather than raise; `RenderError` then says why.
"""

from __future__ import annotations

import functools
import json
import os
import signal
import subprocess
import sys
import tomllib
import xml.etree.ElementTree as ET
from contextlib import nullcontext
from pathlib import Path

import numpy as np

from impactsim.output.atomic import replacing
from impactsim.output.fields import CATEGORICAL, FIELD_UNITS, STATUS_NAMES
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


def parse_cut(text: str | None):
    """'y' / 'y,0,0,1e-3' / '0,1,0' / '0,1,0,0,0,1e-3' -> (normal, point or None)."""
    if not text:
        return None
    parts = [p.strip() for p in text.split(",") if p.strip()]
    axes = {"x": [1.0, 0, 0], "y": [0, 1.0, 0], "z": [0, 0, 1.0]}
    try:
        if parts and parts[0].lower().lstrip("-") in axes:
            sign = -1.0 if parts[0].startswith("-") else 1.0
            normal = [sign * c for c in axes[parts[0].lower().lstrip("-")]]
            rest = [float(p) for p in parts[1:]]
        else:
            nums = [float(p) for p in parts]
            normal, rest = nums[:3], nums[3:]
    except ValueError:
        rest = None
    if rest is None or len(normal) != 3 or len(rest) not in (0, 3) or not np.any(normal):
        raise RenderError(f"--slice {text}: expected NORMAL[,POINT], NORMAL an axis (x, y, z, -y..)"
                          " or three numbers, POINT three numbers [m], e.g. --slice y,0,0,0")
    n = np.asarray(normal, float)
    return n / np.linalg.norm(n), (np.asarray(rest, float) if rest else None)


def render_series(
    run_dir: str | os.PathLike,
    field: str = "von_mises",
    every: int = 1,
    *,
    out: str | os.PathLike | None = None,
    cut: tuple | None = None,
    view: str = "impact",
    particles: bool = True,
    animate: str | os.PathLike | None = None,
    fps: float = 4.0,
    window_size: tuple[int, int] = (1024, 768),
) -> list[Path]:
    """Render every `every`-th frame of `run_dir/series.pvd` coloured by `field` (module
    docstring); return the PNGs (and write `animate` when given)."""
    run_dir = Path(run_dir)
    frames = _select_frames(run_dir, every)
    if view not in ("impact", "all"):
        raise RenderError(f"view must be 'impact' or 'all', got {view!r}")
    if animate is not None and Path(animate).suffix.lower() not in (".mp4", ".gif"):
        raise RenderError(f"--animate {animate}: the file must end in .mp4 or .gif")
    try:
        import pyvista as pv
    except ImportError as err:
        raise RenderError(f"pyvista is not available: {err}") from err

    clim, bounds, values = _scan(pv, frames, field)
    categorical = field in CATEGORICAL
    reason = offscreen_unavailable()
    if reason:
        raise RenderError(f"cannot render off-screen: {reason}. {_HOW_TO}")

    out_dir = Path(out) if out is not None else run_dir / "render"
    out_dir.mkdir(parents=True, exist_ok=True)
    camera = _camera(pv, frames[0][1], bounds, view, cut)
    parts = _particle_frames(run_dir) if particles else {}
    unit = FIELD_UNITS.get(field, "")
    pv.OFF_SCREEN = True
    quiet = pv.vtk_verbosity("error") if hasattr(pv, "vtk_verbosity") else nullcontext()
    written = []
    bar = _bar_args(field, unit, categorical, window_size[0])
    with quiet:
        plotter = pv.Plotter(off_screen=True, window_size=list(window_size))
        plotter.set_background("white")
        try:
            for time, path in frames:
                mesh, label = _coloured(pv.read(path), field)
                if cut is not None and mesh.n_cells:
                    mesh = mesh.clip(normal=cut[0], origin=camera["cut_point"], invert=True)
                plotter.remove_actor("bodies")
                plotter.remove_actor("particles")
                for title in list(plotter.scalar_bars.keys()):
                    plotter.remove_scalar_bar(title)
                if mesh.n_cells:
                    kw = _colour_args(field, values, clim, categorical, run_dir)
                    plotter.add_mesh(mesh, scalars=label, name="bodies", reset_camera=False,
                                     scalar_bar_args=bar, show_edges=False, **kw)
                cloud = parts.get(_key(time))
                if cloud is not None:
                    _add_particles(pv, plotter, cloud, field, clim, categorical, cut, camera,
                                   values, run_dir, mesh.n_cells == 0, bar)
                plotter.add_text(f"t = {time * 1e6:.3f} µs", position="upper_left",
                                 font_size=max(7, int(12 * min(1.0, window_size[0] / 1024))),
                                 name="time", color="black")
                plotter.camera_position = camera["position"]
                target = out_dir / f"{field}_{path.stem}.png"
                with replacing(target) as tmp:
                    plotter.screenshot(tmp)
                written.append(target)
        finally:
            plotter.close()
    if animate is not None:
        write_animation(written, Path(animate), fps)
    return written


def write_animation(images: list[Path], target: Path, fps: float = 4.0) -> Path:
    """The images as an .mp4 (imageio's ffmpeg plugin, H.264) or .gif, written atomically."""
    import imageio.v2 as imageio

    target.parent.mkdir(parents=True, exist_ok=True)
    with replacing(target) as tmp:
        if target.suffix.lower() == ".gif":
            imageio.mimsave(tmp, [imageio.imread(p) for p in images], duration=1.0 / fps, loop=0)
        else:
            with imageio.get_writer(tmp, fps=fps, codec="libx264", quality=8,
                                    macro_block_size=8) as w:
                for p in images:
                    w.append_data(imageio.imread(p))
    return target


def _key(t: float) -> float:
    return float(f"{t:.9g}")


def _bar_args(field: str, unit: str, categorical: bool, width: int = 1024) -> dict:
    title = f"{field} [{unit}]" if unit else field
    scale = min(1.0, width / 1024)
    args = {"title": title, "color": "black", "vertical": True, "position_x": 0.84,
            "position_y": 0.2, "width": 0.05, "height": 0.6,
            "title_font_size": max(8, int(16 * scale)), "label_font_size": max(7, int(14 * scale)),
            "fmt": "%.3g", "n_labels": 5}
    if categorical:
        args.update(n_labels=0)
    return args


STATUS_COLOURS = ["#b0c4de", "#ff8c00", "#d62728", "#222222"]  # intact, damaged, fractured, eroded


def _colour_args(field, values, clim, categorical, run_dir) -> dict:
    if not categorical:
        return {"clim": clim, "cmap": "viridis"}
    import matplotlib

    cats = np.unique(np.asarray(values).astype(int))
    lo, hi = int(cats.min()), int(cats.max())
    if field == "status":
        colours = [STATUS_COLOURS[k % 4] for k in range(lo, hi + 1)]
    else:
        table = matplotlib.colormaps["tab20" if hi - lo >= 10 else "tab10"].colors
        colours = [matplotlib.colors.to_hex(table[k % len(table)]) for k in range(lo, hi + 1)]
    if len(colours) == 1:
        colours = colours * 2
    names = _category_names(field, run_dir)
    out = {"clim": (lo - 0.5, hi + 0.5), "cmap": colours, "n_colors": hi - lo + 1,
           "categories": True}
    if len(cats) <= 20:
        out["annotations"] = {float(c): names.get(int(c), str(int(c))) for c in cats}
    return out


def _category_names(field: str, run_dir: Path) -> dict[int, str]:
    if field == "status":
        return dict(STATUS_NAMES)
    if field == "body":
        try:
            case = tomllib.loads((run_dir / "case.resolved.toml").read_text())
            return {i: b.get("name", str(i)) for i, b in enumerate(case.get("body", []))}
        except (OSError, tomllib.TOMLDecodeError):
            return {}
    return {}


def _particle_frames(run_dir: Path) -> dict:
    pvd = run_dir / "particles.pvd"
    if not pvd.is_file():
        return {}
    try:
        return {_key(t): p for t, p in read_collection(pvd) if p.is_file()}
    except (ET.ParseError, ValueError):
        return {}


def _add_particles(pv, plotter, path, field, clim, categorical, cut, camera, values, run_dir,
                   alone, bar):
    cloud = pv.read(path)
    if cloud.n_points == 0:
        return
    pts = pv.PolyData(np.asarray(cloud.points))
    for k in cloud.point_data.keys():
        pts.point_data[k] = np.asarray(cloud.point_data[k])
    if cut is not None:
        keep = (pts.points - camera["cut_point"]) @ cut[0] <= 0.0
        pts = pts.extract_points(keep, adjacent_cells=False) if keep.any() else None
        if pts is None or pts.n_points == 0:
            return
        pts = pv.PolyData(np.asarray(pts.points), ) if not hasattr(pts, "point_data") else pts
    radius = np.asarray(pts.point_data["radius"]) if "radius" in pts.point_data.keys() else None
    if radius is None:
        return
    pts.point_data["_r"] = radius
    glyphs = pts.glyph(geom=pv.Sphere(radius=1.0, theta_resolution=10, phi_resolution=10),
                       scale="_r", orient=False)
    if field in pts.point_data.keys():
        vals = np.asarray(pts.point_data[field])
        if vals.ndim > 1:
            glyphs.point_data["_c"] = np.repeat(np.linalg.norm(vals, axis=1),
                                                glyphs.n_points // pts.n_points)
            scal = "_c"
        else:
            scal = field
        kw = _colour_args(field, values, clim, categorical, run_dir)
        plotter.add_mesh(glyphs, scalars=scal, name="particles", reset_camera=False,
                         show_scalar_bar=alone, scalar_bar_args=bar, **kw)
    else:
        plotter.add_mesh(glyphs, color="lightgrey", name="particles", reset_camera=False)


def _camera(pv, first_frame: Path, bounds, view: str, cut):
    """Camera position (and the cut's point) for every image (module docstring)."""
    mesh = pv.read(first_frame)
    pts = np.asarray(mesh.points)
    lo, hi = np.array(bounds[0::2]), np.array(bounds[1::2])
    centre, size = 0.5 * (lo + hi), float(np.linalg.norm(hi - lo)) or 1.0
    look = np.array([0.0, 1.0, 0.0])  # the direction the camera looks along
    up = np.array([0.0, 0.0, 1.0])
    if view == "impact" and pts.size:
        roi = _impact_region(mesh)
        if roi is not None:
            centre, size, approach = roi
            look = _side_direction(approach)
            up = approach / np.linalg.norm(approach) if np.any(approach) else up
            up = -up  # the projectile comes from the top of the picture
    cut_point = centre.copy()
    if cut is not None:
        if cut[1] is not None:
            cut_point = cut[1]
        look = -cut[0]  # look at the cut face (the kept half lies on the -normal side)
        if abs(look @ up) > 0.9:
            up = np.array([1.0, 0.0, 0.0]) if abs(look[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    else:  # a little from above, so surfaces facing up show
        look = look - 0.35 * up
        look = look / np.linalg.norm(look)
    up = up - (up @ look) * look
    up = up / np.linalg.norm(up)
    distance = 2.2 * size
    eye = centre - distance * look
    return {"position": [tuple(eye), tuple(centre), tuple(up)], "cut_point": cut_point}


def _impact_region(mesh):
    """(centre, size, approach direction) of the closest approach of two bodies on the first
    frame, or of the single body; None when the frame has no bodies."""
    from scipy.spatial import cKDTree

    if "body" not in mesh.cell_data.keys():
        return None
    body = np.asarray(mesh.cell_data["body"]).astype(int)
    cells = mesh.cells_dict if hasattr(mesh, "cells_dict") else {}
    conn = next(iter(cells.values())) if cells else None
    if conn is None:
        return None
    pts = np.asarray(mesh.points)
    node_body = np.full(len(pts), -1)
    node_body[conn.ravel()] = np.repeat(body, conn.shape[1])
    vel = np.asarray(mesh.point_data["velocity"]) if "velocity" in mesh.point_data.keys() \
        else np.zeros_like(pts)
    ids = [b for b in np.unique(node_body) if b >= 0]
    extents = {b: np.ptp(pts[node_body == b], axis=0) for b in ids}
    if len(ids) < 2:
        b = ids[0]
        sel = node_body == b
        v = vel[sel].mean(axis=0)
        return pts[sel].mean(axis=0), float(np.linalg.norm(extents[b])), v
    best = None
    for i, a in enumerate(ids):
        tree = cKDTree(pts[node_body == a])
        for b in ids[i + 1:]:
            d, j = tree.query(pts[node_body == b])
            k = int(np.argmin(d))
            if best is None or d[k] < best[0]:
                # the centre of the patch of b's points within reach of a, and their partners
                reach = d[k] + 0.1 * min(np.max(extents[a]), np.max(extents[b]))
                near = d <= reach
                pa = pts[node_body == a][j[near]].mean(axis=0)
                pb = pts[node_body == b][near].mean(axis=0)
                best = (d[k], a, b, 0.5 * (pa + pb))
    _, a, b, centre = best
    va = vel[node_body == a].mean(axis=0)
    vb = vel[node_body == b].mean(axis=0)
    small = min(float(np.max(extents[a])), float(np.max(extents[b])))
    return centre, 3.0 * small, vb - va if np.any(vb - va) else np.array([0.0, 0.0, -1.0])


def _side_direction(approach: np.ndarray) -> np.ndarray:
    """A viewing direction across `approach`: the axis most perpendicular to it."""
    a = approach / (np.linalg.norm(approach) or 1.0)
    axes = [np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])]
    ax = min(axes, key=lambda e: abs(e @ a))
    d = ax - (ax @ a) * a
    return d / np.linalg.norm(d)


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
    seen = set()
    for _, path in frames:
        try:
            mesh = pv.read(path)
        except Exception as err:  # VTK readers raise several types for broken files
            raise RenderError(f"{path}: cannot read: {err}") from err
        values = _field_values(mesh, field)[0]
        finite = values[np.isfinite(values)]
        if finite.size:
            lo, hi = min(lo, finite.min()), max(hi, finite.max())
            if field in CATEGORICAL and len(seen) <= 1000:
                seen.update(np.unique(finite).tolist())
        if mesh.n_points:
            box_lo = np.minimum(box_lo, mesh.points.min(axis=0))
            box_hi = np.maximum(box_hi, mesh.points.max(axis=0))
    clim = None
    if lo <= hi:
        clim = (lo, hi) if hi > lo else (lo - 0.5 * max(abs(lo), 1.0), hi + 0.5 * max(abs(hi), 1.0))
    if not np.all(box_lo <= box_hi):
        box_lo, box_hi = -np.ones(3), np.ones(3)
    bounds = (box_lo[0], box_hi[0], box_lo[1], box_hi[1], box_lo[2], box_hi[2])
    return clim, bounds, np.array(sorted(seen) or [0.0])
