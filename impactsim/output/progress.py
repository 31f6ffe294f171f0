"""Progress of a run on the terminal.

On a terminal (the stream's isatty() is true) one line is redrawn in place with '\\r', at most
five times a second: a bar, percent, simulated time [µs], step, time step [ns], wall time elapsed
and the estimated time left. The estimate divides the simulated time still to go by the rate of
simulated time per wall second since the first update. Elsewhere (a log file, a pipe) a plain
line is printed each time another tenth of the simulated time is done, or after 30 s of wall time
without one; no '\\r'. `log` prints a message on its own line, above the bar.
"""

from __future__ import annotations

import math
import shutil
import sys
import time as _time
from typing import TextIO

_BAR = 20  # characters of the bar


class Progress:
    """Reports `update(time, step, dt)` calls of a run that ends at `end_time` [s].

    With enabled=False nothing but `log` messages is printed. The default stream is sys.stderr
    as it is when the Progress is created.
    """

    def __init__(
        self,
        end_time: float,
        enabled: bool = True,
        stream: TextIO | None = None,
        min_interval: float = 0.2,
        plain_interval: float = 30.0,
    ):
        self.end_time = float(end_time)
        self.enabled = enabled
        self.stream = sys.stderr if stream is None else stream
        self.tty = _isatty(self.stream)
        self._min_interval = min_interval
        self._plain_interval = plain_interval
        self._micro = _micro_sign(self.stream)
        self._wall_start = _time.monotonic()
        self._first: tuple[float, float] | None = None  # (simulated time, wall) at the first update
        self._state: tuple[float, int, float, float] | None = None  # time, step, dt, wall
        self._last_shown = -math.inf  # wall time of the last line drawn or printed
        self._shown_state = None  # the state that line showed
        self._tenth = -1  # plain mode: last tenth of the run printed
        self._bar_len = 0  # tty mode: characters of the bar on screen, 0 when none
        self._closed = False

    def update(self, time: float, step: int, dt: float) -> None:
        """Record the state after a step; prints only when it is due (cheap otherwise)."""
        if not self.enabled or self._closed:
            return
        now = _time.monotonic()
        if self._first is None:
            self._first = (time, now)
        self._state = (time, step, dt, now)
        if self.tty:
            if now - self._last_shown >= self._min_interval:
                self._draw()
            return
        tenth = min(10, int(10.0 * self._fraction(time)))
        if tenth > self._tenth or now - self._last_shown >= self._plain_interval:
            self._tenth = max(tenth, self._tenth)
            self._print_plain()

    def log(self, msg: str) -> None:
        """Print `msg` on its own line; the bar, if any, is redrawn below it."""
        if self._bar_len:
            self.stream.write("\r" + " " * self._bar_len + "\r")
            self._bar_len = 0
        self.stream.write(f"{msg}\n")
        if self.enabled and self.tty and self._state is not None and not self._closed:
            self._draw()
        self.stream.flush()

    def close(self) -> None:
        """Show the last state and end the bar's line; further updates are ignored."""
        if self._closed:
            return
        self._closed = True
        if not self.enabled or self._state is None:
            return
        if self.tty:
            self._draw()
            self.stream.write("\n")
            self._bar_len = 0
        elif self._shown_state != self._state:
            self._print_plain()
        self.stream.flush()

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # --- formatting ----------------------------------------------------------------------------

    def _fraction(self, time: float) -> float:
        if self.end_time <= 0.0:
            return 1.0
        return min(1.0, max(0.0, time / self.end_time))

    def _fields(self) -> tuple[float, str]:
        time, step, dt, now = self._state
        frac = self._fraction(time)
        elapsed = now - self._wall_start
        t_first, wall_first = self._first
        rate = (time - t_first) / (now - wall_first) if now > wall_first else 0.0
        eta = _clock((self.end_time - time) / rate) if rate > 0.0 else "--:--"
        text = (
            f"t {time * 1e6:.3f} {self._micro}s  step {step}  dt {dt * 1e9:.4g} ns  "
            f"{_clock(elapsed)} elapsed  ETA {eta}"
        )
        return frac, text

    def _draw(self) -> None:
        frac, text = self._fields()
        filled = int(round(_BAR * frac))
        line = f"[{'#' * filled}{'-' * (_BAR - filled)}] {100 * frac:5.1f} %  {text}"
        width = shutil.get_terminal_size((100, 24)).columns - 1
        line = line[:width]
        pad = " " * max(0, self._bar_len - len(line))
        self.stream.write("\r" + line + pad)
        self.stream.flush()
        self._bar_len = len(line)
        self._mark_shown()

    def _print_plain(self) -> None:
        frac, text = self._fields()
        self.stream.write(f"{100 * frac:5.1f} %  {text}\n")
        self.stream.flush()
        self._mark_shown()

    def _mark_shown(self) -> None:
        self._shown_state = self._state
        self._last_shown = _time.monotonic()


def _clock(seconds: float) -> str:
    """H:MM:SS, or M:SS under an hour."""
    if not math.isfinite(seconds):
        return "--:--"
    s = int(round(max(0.0, seconds)))
    h, rest = divmod(s, 3600)
    m, s = divmod(rest, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def _micro_sign(stream) -> str:
    encoding = getattr(stream, "encoding", None) or "utf-8"
    try:
        "µ".encode(encoding)
    except (UnicodeEncodeError, LookupError):
        return "u"
    return "µ"
