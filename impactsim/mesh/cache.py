"""On-disk cache of meshed bodies, so a case is meshed once and re-run instantly.

What is cached is the UNPLACED mesh (centred at the origin, oriented and renumbered): position
and rotation are applied after loading, so moving a body does not re-mesh it.

Key: sha256 of the shape, its dimensions, mesh_size, mesher, MESH_CODE_VERSION (bump it whenever
a change of the meshing code changes its output), the gmsh version for gmsh meshes, and for an
imported file the sha256 of the file's bytes (not its path) and its suffix (which picks the
reader). Location: $IMPACTSIM_CACHE, else ~/.cache/impactsim/meshes; IMPACTSIM_CACHE=off
disables the cache. Files are written to a temporary name and renamed (a killed run or two runs
at once leave no half file); an unreadable or inconsistent cache file is ignored and rewritten.
Each entry holds its key and the sha256 of its arrays' bytes: an entry whose key is not its file
name, whose arrays do not match their digest (a flipped bit, a file copied over another) or
whose values make no mesh (non-finite points, node indices out of range) is not used.
A cache directory that cannot be written only costs the re-meshing next time.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from importlib import metadata
from pathlib import Path

import numpy as np

from impactsim.case.schema import Body

MESH_CODE_VERSION = "impactsim-mesh-2"


def cache_dir() -> Path | None:
    """The cache folder (not created here), or None when IMPACTSIM_CACHE=off."""
    value = os.environ.get("IMPACTSIM_CACHE", "")
    if value.strip().lower() == "off":
        return None
    if value:
        return Path(value)
    return Path.home() / ".cache" / "impactsim" / "meshes"


def _file_digest(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for chunk in iter(lambda: stream.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def _plain(value):
    """A JSON-able, canonical form of a dimension value (tuples -> lists, numpy -> float)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in sorted(value.items())}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, (bool, str)) or value is None:
        return value
    return repr(float(value))


def cache_key(body: Body) -> str:
    """Hex sha256 identifying the unplaced mesh of `body` (see the module docstring)."""
    dims = dict(body.dimensions)
    if body.shape == "file":
        path = Path(dims.pop("path"))
        dims["file_sha256"] = _file_digest(path)
        dims["file_suffix"] = path.suffix.lower()
    record = {
        "code": MESH_CODE_VERSION,
        "shape": body.shape,
        "dimensions": _plain(dims),
        "mesh_size": repr(float(body.mesh_size)),
        "mesher": body.mesher,
    }
    if body.shape in ("box", "plate", "cylinder", "sphere") and body.mesher == "gmsh":
        record["gmsh"] = metadata.version("gmsh")
    text = json.dumps(record, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def load(key: str) -> tuple[np.ndarray, np.ndarray] | None:
    """The cached (points (n,3) float64, tets (e,4) int32) for `key`, or None if absent or bad."""
    folder = cache_dir()
    if folder is None:
        return None
    path = folder / f"{key}.npz"
    try:
        with np.load(path, allow_pickle=False) as data:
            points, tets, stored = data["points"], data["tets"], str(data["key"])
            digest = str(data["digest"]) if "digest" in data else ""
    except Exception:  # missing, truncated or foreign file: treat as absent
        return None
    ok = (stored == key and points.dtype == np.float64 and points.ndim == 2
          and points.shape[1] == 3 and tets.dtype == np.int32 and tets.ndim == 2
          and tets.shape[1] == 4 and len(tets) > 0
          and tets.min() >= 0 and tets.max() < len(points)
          and digest == array_digest(points, tets) and bool(np.isfinite(points).all()))
    return (points, tets) if ok else None


def array_digest(points: np.ndarray, tets: np.ndarray) -> str:
    """sha256 of the arrays' shapes and bytes (C order)."""
    h = hashlib.sha256()
    for a in (points, tets):
        h.update(repr(a.shape).encode())
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def store(key: str, points: np.ndarray, tets: np.ndarray) -> None:
    """Write the mesh under `key` atomically; a failure to write is silently skipped."""
    folder = cache_dir()
    if folder is None:
        return
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{key}.", suffix=".tmp", dir=folder)
    except OSError:
        return
    try:
        with os.fdopen(fd, "wb") as stream:
            np.savez(stream, points=points, tets=tets, key=np.array(key),
                     digest=np.array(array_digest(points, tets)))
        os.replace(tmp, folder / f"{key}.npz")
    except OSError:
        try:
            os.unlink(tmp)
        except OSError:
            pass
