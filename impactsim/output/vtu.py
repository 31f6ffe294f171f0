"""One VTU file (VTK XML UnstructuredGrid, inline binary, zlib or raw), written without meshio.

The frames of a run are its largest output (a 164k-tet sphere-plate frame: 25 MB of arrays),
and their compression the largest part of writing them: meshio's writer compresses at zlib's
default level 6 (0.49 CPU s for such a frame) where level 1 takes 0.29 s for files 1 % larger,
and it builds an element tree of the whole file first. ``write_vtu`` writes the same file
layout as ``meshio.write(..., file_format="vtu", binary=True, compression=...)`` (meshio 5.3:
the same elements, attributes, array types and block layout, header type UInt32), so meshio,
ParaView and VTK read it as before; only the compressed bytes differ (``ZLIB_LEVEL``).

    write_vtu(path, points, blocks, point_data, cell_data, compression="zlib")

``blocks``: list of (meshio cell type name, (e, k) connectivity), types "tetra", "hexahedron",
"vertex"; ``cell_data`` arrays run over the blocks' concatenated cells. Arrays are written in
native byte order as they are: (k,) or (k, c).
"""

from __future__ import annotations

import base64
import sys
import zlib

import numpy as np

ZLIB_LEVEL = 1  # zlib's fastest level: 0.29 against 0.49 CPU s a frame for files 1 % larger
BLOCK = 32768  # bytes of raw data per compressed block (meshio's and VTK's default)
VTK_TYPE = {"vertex": 1, "tetra": 10, "hexahedron": 12}
_ARRAY_TYPE = {np.dtype(np.float64): "Float64", np.dtype(np.float32): "Float32",
               np.dtype(np.int64): "Int64", np.dtype(np.int32): "Int32",
               np.dtype(np.uint8): "UInt8", np.dtype(np.int8): "Int8",
               np.dtype(np.uint32): "UInt32", np.dtype(np.uint64): "UInt64",
               np.dtype(np.int16): "Int16", np.dtype(np.uint16): "UInt16"}


def write_vtu(path, points: np.ndarray, blocks: list, point_data: dict, cell_data: dict,
              compression: str | None = "zlib") -> None:
    """Write the grid to ``path`` (module docstring); compression "zlib" or None."""
    points = np.ascontiguousarray(points)
    n_cell = sum(conn.shape[0] for _, conn in blocks)
    head = ['<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="0.1" '
            f'byte_order="{"LittleEndian" if sys.byteorder == "little" else "BigEndian"}"'
            + (' compressor="vtkZLibDataCompressor"' if compression else "") + ">\n"
            "<!--This file was created by impactsim (the layout of meshio's VTU writer)-->\n"
            "<UnstructuredGrid>\n"
            f'<Piece NumberOfPoints="{points.shape[0]}" NumberOfCells="{n_cell}">\n']
    with open(path, "w", encoding="ascii") as f:
        f.write("".join(head))
        f.write("<Points>\n")
        _array(f, "Points", points, compression)
        f.write("</Points>\n")
        if blocks:
            conn = np.concatenate([c.reshape(-1) for _, c in blocks])
            offsets = np.concatenate([c.shape[1] * np.arange(1, c.shape[0] + 1, dtype=conn.dtype)
                                      for _, c in blocks])
            start = 0
            for (_, c) in blocks:  # running offsets over the blocks
                offsets[start:start + c.shape[0]] += offsets[start - 1] if start else 0
                start += c.shape[0]
            types = np.concatenate([np.full(c.shape[0], VTK_TYPE[t]) for t, c in blocks])
            f.write("<Cells>\n")
            _array(f, "connectivity", conn, compression)
            _array(f, "offsets", offsets, compression)
            _array(f, "types", types, compression)
            f.write("</Cells>\n")
        for tag, data in (("PointData", point_data), ("CellData", cell_data)):
            if data:
                f.write(f"<{tag}>\n")
                for name, value in data.items():
                    _array(f, name, value, compression)
                f.write(f"</{tag}>\n")
        f.write("</Piece>\n</UnstructuredGrid>\n</VTKFile>")


def _array(f, name: str, data: np.ndarray, compression: str | None) -> None:
    data = np.ascontiguousarray(data)
    data = data.astype(data.dtype.newbyteorder("="), copy=False)
    comps = f' NumberOfComponents="{data.shape[1]}"' if data.ndim == 2 else ""
    f.write(f'<DataArray type="{_ARRAY_TYPE[data.dtype]}" Name="{name}"{comps} '
            'format="binary">\n')
    raw = data.tobytes()
    if compression:
        blocks = [zlib.compress(raw[i:i + BLOCK], ZLIB_LEVEL)
                  for i in range(0, len(raw), BLOCK)]
        n = len(blocks)
        last = len(raw) - (n - 1) * BLOCK
        header = np.array([n, BLOCK, last] + [len(b) for b in blocks], dtype=np.uint32)
        f.write(base64.b64encode(header.tobytes()).decode())
        f.write(base64.b64encode(b"".join(blocks)).decode())
    else:
        header = np.array(len(raw), dtype=np.uint32)
        f.write(base64.b64encode(header.tobytes() + raw).decode())
    f.write("\n</DataArray>\n")
