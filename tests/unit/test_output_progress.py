"""progress: sparse plain lines off a terminal, one redrawn line on a terminal."""

import io
import time

from impactsim.output.progress import Progress, _clock


class FakeTerminal(io.StringIO):
    def isatty(self):
        return True


def _run(progress, n=1000, end=1e-5):
    for i in range(n + 1):
        progress.update(end * i / n, i, end / n)
    progress.close()


def test_plain_mode_prints_about_one_line_per_tenth():
    out = io.StringIO()
    _run(Progress(1e-5, stream=out))
    text = out.getvalue()
    assert "\r" not in text
    lines = text.splitlines()
    assert 2 <= len(lines) <= 12
    assert lines[-1].startswith("100.0 %") and "step 1000" in lines[-1]
    assert "10.000 µs" in lines[-1] and "dt 10 ns" in lines[-1]


def test_plain_mode_close_shows_the_last_state_of_an_unfinished_run():
    out = io.StringIO()
    progress = Progress(1e-5, stream=out)
    progress.update(0.0, 0, 1e-9)
    progress.update(3.5e-7, 350, 1e-9)
    progress.close()
    lines = out.getvalue().splitlines()
    assert len(lines) == 2 and "step 350" in lines[-1] and lines[-1].startswith("  3.5 %")


def test_tty_mode_redraws_one_line_at_most_five_times_a_second():
    out = FakeTerminal()
    start = time.monotonic()
    _run(Progress(1e-5, stream=out))
    elapsed = time.monotonic() - start
    text = out.getvalue()
    assert text.startswith("\r[") and text.endswith("\n") and text.count("\n") == 1
    assert text.count("\r") <= 2 + 5 * elapsed  # the first draw, the rate-limited ones, close
    assert "100.0 %" in text.split("\r")[-1]


def test_tty_log_prints_above_the_bar():
    out = FakeTerminal()
    progress = Progress(1e-5, stream=out)
    progress.update(5e-6, 500, 1e-8)
    progress.log("body 1: 3 elements eroded")
    progress.close()
    segments = out.getvalue().split("\r")
    assert "body 1: 3 elements eroded\n" in segments
    assert segments[-1].startswith("[##########----------]  50.0 %")


def test_disabled_prints_only_log_messages():
    out = FakeTerminal()
    progress = Progress(1e-5, enabled=False, stream=out)
    progress.update(1e-6, 1, 1e-9)
    progress.log("note")
    progress.close()
    assert out.getvalue() == "note\n"


def test_clock_format():
    assert _clock(0.4) == "0:00"
    assert _clock(75) == "1:15"
    assert _clock(3 * 3600 + 62) == "3:01:02"
    assert _clock(float("inf")) == "--:--"
