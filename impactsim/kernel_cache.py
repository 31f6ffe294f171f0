"""Keep numba's on-disk kernel cache true to the sources of the whole package.

numba keys a cached kernel on the file that defines it (its modification time and size) and
on nothing else. A kernel that calls njit functions of other files carries their machine code
inlined, so after an edit of, say, the Johnson-Cook return in solver/element.py the hex kernel
of solver/hex8.py still loads its old code from the cache: the run silently uses the previous
physics (found when a benchmark of a changed kernel timed the old one).

`refresh()` closes that gap for the package as a whole: it hashes the sources a kernel can
depend on (every file that uses numba, and the package modules those import at their top: the
constants numba freezes into a kernel, e.g. model.py's status codes) and, when the hash differs
from the one stored beside the cache, removes the cached kernels (`__pycache__/*.nbi, *.nbc`)
so that they are compiled afresh from the current sources. An edit elsewhere (the CLI, the case
validation, the quasi-static solver) keeps the cache.
The CLI calls it once per command and the warm-up before compiling, in the parent process,
never in workers. Hashing the sources costs a few milliseconds. A read-only installation
(nothing can be cached there either) is left alone.
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent
STAMP = PACKAGE / "__pycache__" / "kernel-sources.sha256"


_IMPORT = re.compile(r"^from impactsim((?:\.\w+)*) import \(?([^)\n]*)", re.M)


def kernel_sources(package: Path = PACKAGE) -> list[Path]:
    """The files a cached kernel can depend on: those that use numba, and the package modules
    they import at their top level (one level: what those modules import is found when they
    use numba themselves)."""
    files = {f for f in package.rglob("*.py") if "numba" in f.read_text()}
    for f in list(files):
        for dotted, names in _IMPORT.findall(f.read_text()):
            base = package.joinpath(*dotted.split(".")[1:])
            found = [base.with_suffix(".py"), base / "__init__.py"]
            found += [base / f"{n.split(' as ')[0].strip()}.py" for n in names.split(",")]
            files.update(c for c in found if c.is_file())
    return sorted(files)


def source_digest(package: Path = PACKAGE) -> str:
    """The SHA-256 of `kernel_sources`, by relative path and content."""
    h = hashlib.sha256()
    for f in kernel_sources(package):
        h.update(str(f.relative_to(package)).encode())
        h.update(b"\0")
        h.update(f.read_bytes())
        h.update(b"\0")
    return h.hexdigest()


def cached_kernels(package: Path = PACKAGE) -> list[Path]:
    """numba's cache files in the package (index .nbi and data .nbc)."""
    return [f for pattern in ("*.nbi", "*.nbc") for f in package.rglob(f"__pycache__/{pattern}")]


def refresh(package: Path = PACKAGE) -> int:
    """Remove the cached kernels if the sources changed since they were cached.

    Returns how many cache files were removed (0 when the cache is current, or cannot be
    written). The first call on a cache of unknown age treats it as stale.
    """
    stamp = package / "__pycache__" / STAMP.name
    digest = source_digest(package)
    try:
        if stamp.read_text().strip() == digest:
            return 0
    except OSError:
        pass
    removed = 0
    try:
        for f in cached_kernels(package):
            try:
                f.unlink()
                removed += 1
            except FileNotFoundError:  # another process removed it first
                pass
        stamp.parent.mkdir(exist_ok=True)
        tmp = stamp.with_suffix(f".{digest[:8]}.tmp")
        tmp.write_text(digest + "\n")
        tmp.replace(stamp)
    except OSError:  # a read-only installation: nothing is cached there either
        return removed
    return removed
