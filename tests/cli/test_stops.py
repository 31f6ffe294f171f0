"""SIGTERM and SIGINT at any moment of `impactsim run` stop it cleanly: exit 3, a summary.json
naming the signal, only whole files (history.csv whole lines, every frame in series.pvd
readable), and the last frame when the loop had started. SIGKILL leaves whole files too."""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import pytest

from tests.killed import whole_history

ROOT = Path(__file__).resolve().parents[2]
CASE = ROOT / "cases" / "elastic-bar-wall.toml"
# long enough to be mid-run when signalled: a finer mesh and a longer end time
LONG = ["--set", "run.end_time=\"2 ms\"", "--set", "body.0.mesh_size=\"1.25 mm\"",
        "--set", "output.frames=400"]


def _start(out: Path, extra=()) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    code = "from impactsim.cli import main; main()"
    return subprocess.Popen([sys.executable, "-c", code, "run", str(CASE), "-q", "-o", str(out),
                             *LONG, *extra], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=ROOT)


def _history_lines(out: Path) -> int:
    try:
        return (out / "history.csv").read_bytes().count(b"\n")
    except OSError:
        return 0


def assert_whole_files(out: Path) -> None:
    """history.csv: whole lines with a full set of fields; every listed frame readable."""
    hist = out / "history.csv"
    if hist.exists():
        data = hist.read_text()
        assert data == "" or data.endswith("\n"), "torn last line"
        lines = data.splitlines()
        width = lines[0].count(",") if lines else 0
        assert all(line.count(",") == width for line in lines)
    pvd = out / "series.pvd"
    if pvd.exists():
        for ds in ET.parse(pvd).getroot().iter("DataSet"):
            meshio.read(out / ds.get("file"))
    assert not [p for p in out.glob(".*") if p.name != ".impactsim-write-test"]


def _wait_for(pred, timeout: float) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if pred():
            return True
        time.sleep(0.05)
    return False


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_signal_mid_run_stops_with_last_frame_summary_and_exit_3(tmp_path, sig):
    out = tmp_path / "run"
    proc = _start(out)
    try:
        assert _wait_for(lambda: _history_lines(out) > 20, 240), proc.stderr.read()
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode == 3, err
    assert "Traceback" not in err and f"{signal.Signals(sig).name} received" in err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["stop"]["kind"] == "signal" and summary["stop"]["signal"] == sig.name
    assert 0 < summary["time"] < summary["end_time"]
    assert_whole_files(out)
    # the last frame is the state the run stopped at
    frames = list(ET.parse(out / "series.pvd").getroot().iter("DataSet"))
    assert float(frames[-1].get("timestep")) == pytest.approx(summary["time"], rel=1e-12)


@pytest.mark.parametrize("sig, seed", [(signal.SIGTERM, 0), (signal.SIGTERM, 1),
                                       (signal.SIGTERM, 2), (signal.SIGINT, 3),
                                       (signal.SIGINT, 4)])
def test_signal_at_a_random_moment_of_start_up(tmp_path, sig, seed):
    """During imports, meshing, numba compilation or the first steps: SIGTERM (a batch
    scheduler's time limit) and SIGINT (Ctrl-C, which gave click's "Aborted!" and exit 1 with
    nothing written) alike."""
    out = tmp_path / "run"
    proc = _start(out, ["--set", "run.name=\"random\""])
    delay = random.Random(seed).uniform(0.6, 6.0)
    time.sleep(delay)
    proc.send_signal(sig)
    try:
        _, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    name = signal.Signals(sig).name
    assert proc.returncode == 3, err
    assert "Traceback" not in err and "Aborted" not in err and f"{name} received" in err, err
    summary = json.loads((out / "summary.json").read_text())
    assert f"{name} received" in summary["stopped"]
    assert summary["stop"]["signal"] == name
    assert_whole_files(out)


def test_sigkill_leaves_whole_files(tmp_path):
    out = tmp_path / "run"
    proc = _start(out)
    try:
        assert _wait_for(lambda: _history_lines(out) > 5, 240)
        time.sleep(random.Random(1).uniform(0.0, 1.0))
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        proc.kill()
    hist = whole_history((out / "history.csv").read_text())
    assert hist.count("\n") > 5
    pvd = out / "series.pvd"
    if pvd.exists():
        for ds in ET.parse(pvd).getroot().iter("DataSet"):
            meshio.read(out / ds.get("file"))
