"""history.csv: one line of scalars per recorded step, safe against a killed run.

Rows are kept in memory as finished text lines and handed to the operating system in one write
call every `flush_rows` rows, every `flush_seconds` of wall time, and at `close`, so the file
holds whole lines: a killed run loses at most the rows of the last interval. One exception, which
no writer can prevent: Linux stops copying a write at a page boundary when the process gets
SIGKILL, so a write straddling a 4096-byte boundary at that moment leaves its first part, a torn
last line without its newline (seen once in a test that kills a writer in a loop).
`impactsim.results.read_history` drops such a line. `close` also fsyncs. Floats are written with `repr`, the shortest text that reads back to the same double
(bit-exact through numpy or float()); integers as integers; a missing value as an empty field.
"""

from __future__ import annotations

import os
import time as _time
from collections import deque
from concurrent.futures import Future
from pathlib import Path

import numpy as np


class HistoryWriter:
    """CSV file at `path` with a header line of `columns`, written at creation.

    `add_columns` extends the header until the first `row`; after that the columns are fixed.
    `header(name)` gives the text of a column in the header line (the run's: "time [s]",
    output/fields.header); rows are given by the bare names.
    """

    def __init__(
        self,
        path: str | os.PathLike,
        columns: list[str],
        flush_rows: int = 100,
        flush_seconds: float = 1.0,
        header=None,
    ):
        self.path = Path(path)
        self.columns: list[str] = []
        self._index: dict[str, int] = {}
        self._flush_rows = max(1, int(flush_rows))
        self._flush_seconds = float(flush_seconds)
        self._pending: list[str] = []
        self._waiting: deque[dict] = deque()  # rows with values not known yet (row)
        self._header = header if header is not None else (lambda name: name)
        self._n_rows = 0
        self._last_flush = _time.monotonic()
        self._check_names(columns)
        self._file = _open_no_follow(self.path)
        self._size = 0  # bytes of whole lines in the file
        self.add_columns(columns)

    def add_columns(self, names: list[str]) -> None:
        """Append `names` to the columns and rewrite the header; only before the first row."""
        if self._n_rows:
            raise RuntimeError(f"{self.path}: columns cannot change after the first row")
        self._check_names(names)
        self.columns += list(names)
        self._index = {name: i for i, name in enumerate(self.columns)}
        self._file.seek(0)
        self._file.truncate()
        self._size = 0
        self._write((",".join(self._header(c) for c in self.columns) + "\n").encode())

    def row(self, values: dict[str, float]) -> None:
        """Append one line; columns absent from `values` (or None) are left empty.

        A value may be a `concurrent.futures.Future` of one (a measure taken in another
        thread): the line then waits for it, and so do the lines after it, so that the lines
        keep their order. `flush` writes the lines before the first one still waiting;
        `position` and `close` wait for them all, and raise the error of a failed one."""
        unknown = values.keys() - self._index.keys()
        if unknown:
            raise KeyError(f"{self.path}: unknown columns {sorted(unknown)}; columns are {self.columns}")
        self._waiting.append(values)
        self._n_rows += 1
        self._take(wait=False)
        if len(self._pending) >= self._flush_rows or _time.monotonic() - self._last_flush >= self._flush_seconds:
            self.flush()

    def _take(self, wait: bool) -> None:
        """The waiting rows as text lines, in order, up to the first whose values are not all
        known yet (all of them with `wait`)."""
        while self._waiting:
            values = self._waiting[0]
            later = [v for v in values.values() if isinstance(v, Future)]
            if later and not wait and not all(f.done() for f in later):
                return
            self._waiting.popleft()  # (a failed value's row goes, and its error is raised)
            fields = [""] * len(self.columns)
            for name, value in values.items():
                fields[self._index[name]] = _format(
                    value.result() if isinstance(value, Future) else value)
            self._pending.append(",".join(fields) + "\n")

    def position(self) -> int:
        """Flush (every row, waiting for their values), then the file's length in bytes: where
        a resumed run goes on writing."""
        self._take(wait=True)
        self.flush()
        return os.fstat(self._file.fileno()).st_size

    @classmethod
    def reopen(cls, path: str | os.PathLike, columns: list[str], offset: int,
               header=None, **kw) -> HistoryWriter:
        """The writer of a resumed run: the file cut back to `offset` (a `position()` of the
        interrupted run, so the rows after its checkpoint go) and appended to."""
        self = cls.__new__(cls)
        self.path = Path(path)
        self.columns = list(columns)
        self._index = {name: i for i, name in enumerate(self.columns)}
        self._flush_rows = max(1, int(kw.get("flush_rows", 100)))
        self._flush_seconds = float(kw.get("flush_seconds", 1.0))
        self._pending = []
        self._waiting = deque()
        self._header = header if header is not None else (lambda name: name)
        self._n_rows = 1  # the columns are fixed
        self._last_flush = _time.monotonic()
        self._file = open(self.path, "r+b", buffering=0)
        self._file.truncate(offset)
        self._file.seek(offset)
        self._size = offset  # bytes of whole lines in the file
        return self

    def flush(self) -> None:
        """Hand the pending whole lines to the operating system in one write (the rows whose
        values are all known: `row`)."""
        self._take(wait=False)
        if self._pending:
            self._write("".join(self._pending).encode())
            self._pending.clear()
        self._last_flush = _time.monotonic()

    def close(self) -> None:
        """Flush, fsync and close; further calls do nothing."""
        if self._file.closed:
            return
        try:
            try:
                self._take(wait=True)
            finally:  # the lines before a failed row stand
                self.flush()
                os.fsync(self._file.fileno())
        finally:
            self._file.close()

    @property
    def closed(self) -> bool:
        return self._file.closed

    def __enter__(self) -> HistoryWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _write(self, data: bytes) -> None:
        """Append whole lines. A write that fails part way (a full disk, a signal) is taken
        back: the file is cut to its last whole line and the error raised."""
        view = memoryview(data)
        try:
            while view:  # a raw write may be partial; finish the lines before returning
                view = view[self._file.write(view):]
        except BaseException:
            try:
                self._file.truncate(self._size)
                self._file.seek(self._size)
            except OSError:
                pass
            raise
        self._size += len(data)

    def _check_names(self, names: list[str]) -> None:
        seen = set(self.columns)
        for name in names:
            if not isinstance(name, str) or not name or any(c in name for c in ',"\r\n'):
                raise ValueError(f"invalid history column name {name!r}")
            if name in seen:
                raise ValueError(f"duplicate history column {name!r}")
            seen.add(name)


def _open_no_follow(path: Path):
    """Open `path` for writing without following a symbolic link: a link planted at the name
    is replaced by a file of its own, never written through (the target stays untouched)."""
    if path.is_symlink():
        path.unlink()
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | getattr(os, "O_NOFOLLOW", 0),
                 0o666)
    return os.fdopen(fd, "wb", buffering=0)


def _format(value) -> str:
    if value is None:
        return ""
    if isinstance(value, (bool, np.bool_)):
        return str(int(value))
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    return repr(float(value))  # shortest round-trip text; 'nan', 'inf', '-inf' when not finite
