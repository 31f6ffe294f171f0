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


def serialize_cache_files(lock_path: Path) -> None:
    """Make numba's reads and writes of its cache files in this process wait for those of the
    other processes that call this with the same ``lock_path`` (an advisory file lock).

    numba writes each file atomically (a temporary file renamed over it), but a new entry is
    a read-modify-write of the function's index followed by a write of the data file it names:
    two processes adding different signatures of one function can both take the data file
    number 1, and one index can end up naming the other's code. The parallel warm-up
    (impactsim/warmup.py) compiles in several processes at once, so it holds this lock over
    every `save` and `load`; loads take milliseconds, and compiling, the long part, is outside.
    A platform without `fcntl` is not served: the warm-up then compiles in one process.
    """
    import contextlib
    import fcntl

    from numba.core.caching import IndexDataCacheFile

    if getattr(IndexDataCacheFile, "_impactsim_lock", None) is not None:
        IndexDataCacheFile._impactsim_lock = lock_path
        return

    @contextlib.contextmanager
    def held():
        with open(IndexDataCacheFile._impactsim_lock, "a") as f:
            fcntl.flock(f, fcntl.LOCK_EX)
            try:
                yield
            finally:
                fcntl.flock(f, fcntl.LOCK_UN)

    def locked(method):
        def call(self, *args):
            with held():
                return method(self, *args)
        return call

    IndexDataCacheFile.save = locked(IndexDataCacheFile.save)
    IndexDataCacheFile.load = locked(IndexDataCacheFile.load)
    IndexDataCacheFile._impactsim_lock = lock_path


class CompileCounter:
    """Context manager recording the numba kernels compiled inside it (`.kernels`, qualified
    names): loading a kernel from the cache is not a compilation."""

    def __enter__(self):
        from numba.core import event

        kernels = self.kernels = []

        class _Listener(event.Listener):
            def on_start(self, ev):
                pass

            def on_end(self, ev):
                f = ev.data["dispatcher"].py_func
                kernels.append(f"{f.__module__}.{f.__qualname__}")

        self._listener = _Listener()
        event.register("numba:compile", self._listener)
        return self

    def __exit__(self, *exc):
        from numba.core import event

        event.unregister("numba:compile", self._listener)
        return False
