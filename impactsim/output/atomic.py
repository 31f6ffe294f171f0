"""Atomic file replacement: a file is either its old self or complete, never half written.

Every writer in `impactsim.output` goes through `replacing`: the content is written to a hidden
temporary file in the destination's directory (same file system, so the rename is atomic), flushed
to disk with fsync, then renamed over the destination with `os.replace`. A run killed at any moment
leaves the previous version of the file or the new one, and no temporary file once the writer has
returned or raised. (A SIGKILL between creating and renaming the temporary file can leave a hidden
`.<name>.<random><suffix>` behind; it never shadows the real file.)
"""

from __future__ import annotations

import os
import re
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

# permissions a plain open() would give a new file; mkstemp creates 0600 files
_UMASK = os.umask(0)
os.umask(_UMASK)
_FILE_MODE = 0o666 & ~_UMASK


@contextmanager
def replacing(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path to write; on success it replaces `path`, on error it is removed.

    The temporary name keeps the suffix of `path` (``.frame_00000.k2j4x1.vtu``) so writers that
    pick a format from the extension (meshio, numpy.savez, image writers) behave as for `path`.
    The directory of `path` must exist.
    """
    path = Path(path)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        os.chmod(tmp, _FILE_MODE)
        _fsync_file(tmp)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    _fsync_dir(path.parent)


def write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Replace `path` atomically with `data`."""
    with replacing(path) as tmp, open(tmp, "wb") as f:
        f.write(data)


def write_text(path: str | os.PathLike, text: str, encoding: str = "utf-8") -> None:
    """Replace `path` atomically with `text` (encoded, newlines written as given)."""
    write_bytes(path, text.encode(encoding))


def _fsync_file(path: Path) -> None:
    fd = os.open(path, os.O_RDWR)  # Windows refuses fsync on a read-only descriptor
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_dir(directory: Path) -> None:
    """Make the rename itself durable; not supported on every platform, so best effort."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


_TEMPORARY = re.compile(r"^\.[^/]+\.[A-Za-z0-9_]{8}(\.[A-Za-z0-9]+)?$")


def remove_stale_temporaries(directory: str | os.PathLike) -> list[Path]:
    """Remove the temporary files of `replacing` that a killed process left in `directory`
    (`.<name>.<8 random characters><suffix>`); call it only when no writer is running there."""
    removed = []
    directory = Path(directory)
    if not directory.is_dir():
        return removed
    for p in directory.iterdir():
        if p.is_file() and _TEMPORARY.match(p.name):
            p.unlink(missing_ok=True)
            removed.append(p)
    return removed
