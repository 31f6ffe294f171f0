"""history: header at creation, whole lines only, floats read back bit-exactly."""

import csv
import os
import subprocess
import sys
import time

import numpy as np
import pytest

import impactsim
from impactsim.output.history import HistoryWriter
from tests.killed import whole_history

ROOT = os.path.dirname(os.path.dirname(impactsim.__file__))

COLUMNS = ["time", "step", "dt", "kinetic_energy"]


def test_header_rows_and_missing_values(tmp_path):
    path = tmp_path / "history.csv"
    writer = HistoryWriter(path, COLUMNS)
    assert path.read_text() == "time,step,dt,kinetic_energy\n"
    writer.row({"time": 0.5, "step": 3, "dt": 1e-9, "kinetic_energy": 2.0})
    writer.row({"time": 1.0, "step": np.int64(4)})
    writer.close()
    assert path.read_text().splitlines() == [
        "time,step,dt,kinetic_energy",
        "0.5,3,1e-09,2.0",
        "1.0,4,,",
    ]


def test_values_read_back_bit_exactly(tmp_path):
    rng = np.random.default_rng(7)
    values = np.concatenate([rng.normal(size=50) * 10.0 ** rng.integers(-300, 300, 50), [0.1 + 0.2, 5e-324, -0.0]])
    path = tmp_path / "history.csv"
    with HistoryWriter(path, ["a", "b"]) as writer:
        for v in values:
            writer.row({"a": v, "b": np.float32(v) if abs(v) < 1e30 else None})
    back = np.genfromtxt(path, delimiter=",", names=True)
    assert back["a"].tobytes() == values.tobytes()
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    assert [float(r["a"]) for r in rows] == list(values)
    for r, v in zip(rows, values):
        assert (r["b"] == "") if abs(v) >= 1e30 else float(r["b"]) == float(np.float32(v))


def test_columns_extend_only_before_first_row(tmp_path):
    path = tmp_path / "history.csv"
    writer = HistoryWriter(path, ["time"])
    writer.add_columns(["contact_pairs"])
    assert path.read_text() == "time,contact_pairs\n"
    with pytest.raises(ValueError):
        writer.add_columns(["time"])
    writer.row({"time": 0.0, "contact_pairs": 2})
    with pytest.raises(RuntimeError):
        writer.add_columns(["late"])
    with pytest.raises(KeyError, match="typo"):
        writer.row({"typo": 1.0})
    writer.close()
    writer.close()
    assert path.read_text() == "time,contact_pairs\n0.0,2\n"


def test_flushes_every_n_rows_and_every_interval(tmp_path):
    path = tmp_path / "history.csv"
    writer = HistoryWriter(path, ["time"], flush_rows=3, flush_seconds=3600.0)
    for i in range(4):
        writer.row({"time": float(i)})
    assert path.read_text().splitlines() == ["time", "0.0", "1.0", "2.0"]
    writer.close()
    assert path.read_text().splitlines()[-1] == "3.0"

    writer = HistoryWriter(path, ["time"], flush_rows=1000, flush_seconds=0.05)
    writer.row({"time": 1.0})
    time.sleep(0.06)
    writer.row({"time": 2.0})
    assert path.read_text().splitlines() == ["time", "1.0", "2.0"]
    writer.close()


CHILD = """
import sys
from impactsim.output.history import HistoryWriter
writer = HistoryWriter(sys.argv[1], ["time", "step", "energy"], flush_rows=7, flush_seconds=0.001)
i = 0
while True:
    writer.row({"time": i * 1.1e-9, "step": i, "energy": 1.0 / (i + 3)})
    i += 1
"""


def test_killed_run_leaves_only_whole_lines(tmp_path):
    path = tmp_path / "history.csv"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([ROOT, os.environ.get("PYTHONPATH", "")]))
    child = subprocess.Popen([sys.executable, "-c", CHILD, str(path)], env=env)
    try:
        deadline = time.monotonic() + 120.0  # generous: CI machines can be busy
        while time.monotonic() < deadline and (not path.exists() or path.stat().st_size < 200_000):
            assert child.poll() is None, "the writing process died on its own"
            time.sleep(0.02)
    finally:
        child.kill()
        child.wait()
    text = path.read_text()
    assert len(text) >= 200_000
    lines = whole_history(text).splitlines()
    assert lines[0] == "time,step,energy"
    for i, line in enumerate(lines[1:]):
        assert line == f"{i * 1.1e-9!r},{i},{1.0 / (i + 3)!r}"


def test_read_history_leaves_out_a_torn_last_line(tmp_path):
    from impactsim.results import read_history

    path = tmp_path / "history.csv"
    path.write_text("time [s],step\n0.0,0\n1e-09,1\n2e-0")
    df, units = read_history(path)
    assert list(df["step"]) == [0, 1] and units == {"time": "s", "step": ""}
    path.write_text("time [s],step\n0.0,0\n")
    assert list(read_history(path)[0]["step"]) == [0]


def test_rows_with_values_to_come_keep_their_order(tmp_path):
    # a value may be a Future (the penetration measure taken in its meter's thread): the row
    # and those after it wait for it; flush writes what is known, position and close wait
    from concurrent.futures import Future

    path = tmp_path / "history.csv"
    writer = HistoryWriter(path, ["time", "p"], flush_rows=1)
    later = [Future() for _ in range(3)]
    writer.row({"time": 0.0, "p": 1.5})
    writer.row({"time": 1.0, "p": later[0]})
    writer.row({"time": 2.0, "p": 2.5})
    writer.row({"time": 3.0, "p": later[1]})
    assert path.read_text().splitlines()[1:] == ["0.0,1.5"]
    later[1].set_result(4.0)  # the later one first: still held behind the first
    writer.flush()
    assert path.read_text().splitlines()[1:] == ["0.0,1.5"]
    later[0].set_result(np.float64(3.0))
    writer.row({"time": 4.0, "p": 5.0})
    assert path.read_text().splitlines()[1:] == ["0.0,1.5", "1.0,3.0", "2.0,2.5", "3.0,4.0",
                                                 "4.0,5.0"]
    writer.row({"time": 5.0, "p": later[2]})
    import threading
    threading.Timer(0.05, later[2].set_result, (6.0,)).start()
    size = writer.position()  # waits for the value
    assert path.read_text().splitlines()[-1] == "5.0,6.0"
    assert size == path.stat().st_size
    writer.close()


def test_a_failed_value_drops_its_row_and_is_raised_at_close(tmp_path):
    # the rows before it and after it stand
    from concurrent.futures import Future

    path = tmp_path / "history.csv"
    writer = HistoryWriter(path, ["time", "p"])
    bad = Future()
    writer.row({"time": 0.0, "p": 1.0})
    writer.row({"time": 1.0, "p": bad})
    writer.row({"time": 2.0, "p": 2.0})
    bad.set_exception(FloatingPointError("non-finite position in the penetration measure"))
    with pytest.raises(FloatingPointError):
        writer.close()
    assert writer.closed
    assert path.read_text().splitlines()[1:] == ["0.0,1.0", "2.0,2.0"]
