"""A time series of VTU files indexed by a ParaView collection file (.pvd).

`SeriesWriter.write` writes one frame, `<prefix>_00000.vtu` (output/vtu.py: meshio's file
layout, binary, zlib-compressed at level 1 unless `compression="none"`: about 3x faster to
write, 1.7x larger),
then rewrites the collection `<pvd_name>` listing every frame written so far; both through
`atomic.replacing`, so a killed run leaves a readable series of the finished frames. Two writers
can share a directory: the solver writes the mesh as ``frame_*.vtu`` / ``series.pvd`` and the
particles as ``particles_*.vtu`` / ``particles.pvd``.

With `background=True` a frame is copied when `write` is called and written by a thread of the
writer's own, frame after frame in order, while the caller goes on (the run's kernels release
the GIL, and zlib does while it compresses): the compression of a frame then costs the run
little on a second core. `write_later` hands the thread a function that makes the frame's
arrays (the run passes copies of its state, solver/run.py `frame_snapshot`, and the fields are
derived in the writer's thread). `close()` waits for the frames still being written and raises the
first error of any; the collection lists a frame only once its file is complete.

Array conventions of a frame (k = number of points or of cells):
- ``(k,)`` and ``(k, c)`` arrays are written as they are (bool as uint8);
- ``(k, 6)`` arrays are symmetric tensors in the model's Voigt order xx, yy, zz, xy, yz, zx and
  are expanded to ``(k, 9)`` row-major full tensors, as are ``(k, 3, 3)`` arrays: ParaView shows
  a 9-component array as a tensor (components, eigenvalues, von Mises of its own).
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from impactsim.background import background_thread
from impactsim.output.atomic import replacing, write_text
from impactsim.output.vtu import write_vtu

# full row-major 3x3 tensor from Voigt xx, yy, zz, xy, yz, zx
_VOIGT_TO_FULL = np.array([0, 3, 5, 3, 1, 4, 5, 4, 2])


def voigt_to_tensor(s: np.ndarray) -> np.ndarray:
    """(k, 6) symmetric tensors xx, yy, zz, xy, yz, zx -> (k, 9) row-major 3x3 tensors.
    (np.take along the columns: a third of the time of the fancy index on 163k rows.)"""
    return np.take(np.asarray(s), _VOIGT_TO_FULL, axis=1)


class SeriesWriter:
    """Writes numbered VTU frames into `directory` and keeps `<pvd_name>` listing them.

    `frames` holds (time [s], file name) of every frame written, in order (in background mode,
    of every frame whose file is complete).
    """

    MAX_PENDING = 2  # frames copied but not yet written, in background mode

    def __init__(self, directory: str | os.PathLike, prefix: str = "frame", pvd_name: str = "series.pvd",
                 compression: str = "zlib", background: bool = False):
        if compression not in ("zlib", "none"):
            raise ValueError(f"compression must be 'zlib' or 'none', got {compression!r}")
        self.compression = None if compression == "none" else compression
        self.directory = Path(directory)
        self.directory.mkdir(parents=True, exist_ok=True)
        self.prefix = prefix
        self.pvd_path = self.directory / pvd_name
        self.frames: list[tuple[float, str]] = []
        self._count = 0  # frames handed to write() and write_later()
        self._pool = (ThreadPoolExecutor(1, thread_name_prefix=f"impactsim-{prefix}",
                                         initializer=background_thread) if background else None)
        self._pending: deque[Future] = deque()

    def write(
        self,
        time: float,
        points: np.ndarray,
        cells: np.ndarray | None = None,
        point_data: dict[str, np.ndarray] | None = None,
        cell_data: dict[str, np.ndarray] | None = None,
        keep: np.ndarray | None = None,
    ) -> Path:
        """Write the frame at `time` [s] and return its path.

        points: (n, 3) float [m]. cells: (e, 4) int tetrahedra, (e, 8) hexahedra (VTK_HEXAHEDRON),
        a list of such blocks (cell data and keep then run over their concatenation), or None
        (or (e, 1)) for one vertex cell per point (particles). point_data: name -> (n, ...) array. cell_data: name ->
        (e, ...) array. keep: (e,) bool, False for cells left out of the file (eroded elements);
        their cell data is dropped with them, the points stay.
        """
        mesh = self._mesh(time, points, cells, point_data, cell_data, keep,
                          copy=self._pool is not None)
        return self._submit(float(time), lambda: mesh)

    def write_later(self, time: float, make) -> Path:
        """``write(time, *make())``, with ``make()`` (returning points, cells, point data, cell
        data, keep) called in the writer's thread when in background mode: the caller hands
        over arrays of its own (copies) and the frame's fields are derived there while it goes
        on. An error of ``make`` or of the arrays surfaces as a failed frame does (at the next
        write beyond MAX_PENDING, position or close)."""
        time = float(time)
        return self._submit(time, lambda: self._mesh(time, *make(), copy=False))

    def _submit(self, time: float, mesh) -> Path:
        """Write the frame ``mesh()`` (a callable) now, or queue it in background mode."""
        if not np.isfinite(time):
            raise ValueError(f"frame time must be finite, got {time}")
        name = f"{self.prefix}_{self._count:05d}.vtu"
        self._count += 1
        if self._pool is None:
            self._write(time, name, mesh)
        else:
            while len(self._pending) >= self.MAX_PENDING:
                self._pending.popleft().result()  # raises the error of a failed frame
            self._pending.append(self._pool.submit(self._write, time, name, mesh))
        return self.directory / name

    @staticmethod
    def _mesh(time, points, cells, point_data, cell_data, keep, copy: bool) -> tuple:
        """The checked arrays of a frame for ``write_vtu`` (copies of the caller's with copy)."""
        time = float(time)
        if not np.isfinite(time):
            raise ValueError(f"frame time must be finite, got {time}")
        pts = np.asarray(points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise ValueError(f"points must have shape (n, 3), got {pts.shape}")
        n = pts.shape[0]
        # a list of cell arrays is a list of blocks (tets, hexes), the cell data and `keep`
        # running over their concatenation
        typed = [_cell_block(c, n) for c in (cells if isinstance(cells, list) else [cells])]
        sizes = [conn.shape[0] for _, conn in typed]
        e = sum(sizes)
        pdata = {name: _field(name, value, n, "point") for name, value in (point_data or {}).items()}
        cdata = {name: _field(name, value, e, "cell") for name, value in (cell_data or {}).items()}
        if keep is not None:
            keep = np.asarray(keep)
            if keep.dtype != np.bool_ or keep.shape != (e,):
                raise ValueError(f"keep must be a ({e},) bool array, got {keep.dtype} {keep.shape}")
            cdata = {name: value[keep] for name, value in cdata.items()}
            bounds = np.cumsum([0] + sizes)
            typed = [(t, conn[keep[bounds[i]:bounds[i + 1]]]) for i, (t, conn) in enumerate(typed)]
            sizes = [conn.shape[0] for _, conn in typed]
        typed = [(t, np.ascontiguousarray(conn)) for t, conn in typed]
        if copy:  # the caller goes on changing its arrays: a frame of copies
            pts = pts.copy()
            typed = [(t, conn.copy()) for t, conn in typed]
            pdata = {name: value.copy() for name, value in pdata.items()}
            cdata = {name: value.copy() for name, value in cdata.items()}
        live = [i for i, size in enumerate(sizes) if size] or [len(sizes) - 1]  # one, if empty
        # the cell data of the blocks left out is empty: its rows are those of the live blocks
        return pts, [typed[i] for i in live], pdata, cdata

    def position(self) -> dict:
        """Wait for the frames being written; then what a resumed writer needs to go on:
        the frames listed so far and the number of the next file."""
        while self._pending:
            self._pending.popleft().result()
        return {"frames": [tuple(f) for f in self.frames], "count": self._count}

    def resume(self, position: dict) -> None:
        """Go on from a `position()` of an interrupted run's writer."""
        self.frames = [(float(t), str(name)) for t, name in position["frames"]]
        self._count = int(position["count"])
        write_text(self.pvd_path, collection_xml(self.frames))

    def close(self) -> None:
        """Wait for the frames still being written (background mode); raises the first error.
        Frames written after this are written at once, as without background."""
        if self._pool is None:
            return
        try:
            while self._pending:
                self._pending.popleft().result()
        finally:
            self._pending.clear()
            self._pool.shutdown(wait=True)
            self._pool = None

    def _write(self, time: float, name: str, mesh) -> None:
        """Write the frame ``mesh()`` to its file, then the collection with it (in order: one
        thread at most)."""
        arrays = mesh()
        with replacing(self.directory / name) as tmp:
            write_vtu(tmp, *arrays, compression=self.compression)
        self.frames.append((time, name))
        write_text(self.pvd_path, collection_xml(self.frames))


def collection_xml(frames: list[tuple[float, str]]) -> str:
    """The ParaView collection (.pvd) text listing `frames` as (time [s], relative file name)."""
    lines = [
        '<?xml version="1.0"?>',
        '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
        "  <Collection>",
    ]
    for time, name in frames:
        lines.append(f'    <DataSet timestep="{time!r}" part="0" file={quoteattr(name)}/>')
    lines += ["  </Collection>", "</VTKFile>", ""]
    return "\n".join(lines)


def read_collection(pvd_path: str | os.PathLike) -> list[tuple[float, Path]]:
    """(time [s], absolute file path) of every data set listed in a .pvd file, in file order."""
    pvd_path = Path(pvd_path)
    root = ET.parse(pvd_path).getroot()
    if root.tag != "VTKFile" or root.get("type") != "Collection":
        raise ValueError(f"{pvd_path}: not a VTK collection file")
    return [
        (float(ds.get("timestep", "0")), pvd_path.parent / ds.get("file", ""))
        for ds in root.iter("DataSet")
    ]


def _cell_block(cells: np.ndarray | None, n_point: int) -> tuple[str, np.ndarray]:
    if cells is None:
        return "vertex", np.arange(n_point, dtype=np.int64).reshape(-1, 1)
    conn = np.asarray(cells)
    if conn.ndim != 2 or conn.shape[1] not in (1, 4, 8) or not np.issubdtype(conn.dtype, np.integer):
        raise ValueError(f"cells must be an integer (e, 4), (e, 8) or (e, 1) array, got {conn.dtype} {conn.shape}")
    if conn.size and (conn.min() < 0 or conn.max() >= n_point):
        raise ValueError(f"cells refer to points outside 0..{n_point - 1}")
    return {4: "tetra", 8: "hexahedron", 1: "vertex"}[conn.shape[1]], conn


def _field(name: str, value: np.ndarray, k: int, kind: str) -> np.ndarray:
    a = np.asarray(value)
    if a.dtype == np.bool_:
        a = a.astype(np.uint8)
    if a.ndim == 3 and a.shape[1:] == (3, 3):
        a = a.reshape(a.shape[0], 9)
    elif a.ndim == 2 and a.shape[1] == 6:
        a = voigt_to_tensor(a)
    if a.ndim not in (1, 2) or a.shape[0] != k:
        raise ValueError(f"{kind} data {name!r}: expected shape ({k},) or ({k}, c), got {a.shape}")
    return np.ascontiguousarray(a)
