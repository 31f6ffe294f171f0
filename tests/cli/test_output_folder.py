"""The output folder: a full disk, an unusable folder, planted symbolic links, a cache entry that
is not what it claims to be. Each is a clean one-line error or is ignored; what was written
stays whole."""

from __future__ import annotations

import errno
import io
import json

import numpy as np
import pytest
from click.testing import CliRunner

from impactsim.case import load_case_text
from impactsim.cli import main
from impactsim.mesh import cache
from impactsim.output import history as history_module
from impactsim.solver.run import SimulationError, run_case

BAR = """
[run]
name = "tiny-bar"
end_time = "20 us"
[[body]]
name = "bar"
material = "steel-elastic"
shape = "box"
size = ["4 mm", "4 mm", "20 mm"]
position = [0, 0, "10.01 mm"]
mesh_size = "2 mm"
mesher = "structured"
velocity = [0, 0, "-50 m/s"]
[[wall]]
[output]
frames = 4
"""


def _full_disk_after(capacity: int):
    """A stand-in for history.csv's file on a disk that fills after `capacity` bytes: the write
    that crosses the limit is partial, the next one fails with ENOSPC (as write(2) does)."""
    real_open = history_module._open_no_follow

    def fake(path):
        f = real_open(path)

        class Full(io.RawIOBase):
            def writable(self):
                return True

            def write(self, b):
                room = capacity - f.tell()
                if room <= 0:
                    raise OSError(errno.ENOSPC, "No space left on device")
                return f.write(bytes(b)[:room])

            def __getattr__(self, name):
                return getattr(f, name)

            def close(self):
                f.close()
                super().close()

            def fileno(self):
                return f.fileno()

            def truncate(self, size=None):
                return f.truncate(size)

            def seek(self, *a):
                return f.seek(*a)

        return Full()

    return fake


def test_full_disk_is_a_clean_error_and_history_keeps_whole_lines(tmp_path, monkeypatch):
    monkeypatch.setattr(history_module, "_open_no_follow", _full_disk_after(5000))
    case = load_case_text(BAR)
    with pytest.raises(SimulationError) as err:
        run_case(case, tmp_path, progress=False)
    msg = str(err.value)
    assert "output.directory" in msg and "No space left on device" in msg and "\n" not in msg
    data = (tmp_path / "history.csv").read_bytes()
    assert 0 < len(data) <= 5000 and data.endswith(b"\n")
    lines = data.decode().splitlines()
    assert len({line.count(",") for line in lines}) == 1  # no torn row
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["stop"]["kind"] == "output"
    assert summary["time"] < summary["end_time"]


def test_unusable_output_folder_is_one_line_naming_the_key(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    case = tmp_path / "case.toml"
    case.write_text(BAR)
    result = CliRunner().invoke(main, ["run", str(case), "-q", "-o", str(blocker / "out")])
    assert result.exit_code == 2
    assert result.output.startswith("error: ") and "output.directory" in result.output
    assert result.output.count("\n") == 1 and "Traceback" not in result.output


def test_output_never_follows_a_symbolic_link_out_of_the_folder(tmp_path):
    outside = tmp_path / "precious"
    outside.mkdir()
    out = tmp_path / "out"
    out.mkdir()
    for name in ("history.csv", "summary.json", "series.pvd", "frame_00000.vtu",
                 "case.resolved.toml"):
        (outside / name).write_text("keep me")
        (out / name).symlink_to(outside / name)
    run_case(load_case_text(BAR), out, progress=False)
    for name in ("history.csv", "summary.json", "series.pvd", "frame_00000.vtu",
                 "case.resolved.toml"):
        assert (outside / name).read_text() == "keep me"
        assert not (out / name).is_symlink() and (out / name).stat().st_size > 0


def test_run_name_cannot_escape_out(tmp_path):
    case = tmp_path / "case.toml"
    case.write_text(BAR.replace('name = "tiny-bar"', 'name = "../../etc"'))
    result = CliRunner().invoke(main, ["check", str(case)])
    assert result.exit_code == 2 and "run.name" in result.output


def test_cache_entry_not_matching_its_digest_is_not_used(tmp_path, monkeypatch):
    monkeypatch.setenv("IMPACTSIM_CACHE", str(tmp_path))
    pts = np.random.default_rng(0).random((5, 3))
    tets = np.array([[0, 1, 2, 3], [1, 2, 3, 4]], dtype=np.int32)
    cache.store("k", pts, tets)
    assert cache.load("k") is not None
    with np.load(tmp_path / "k.npz") as data:
        stored = dict(data)
    stored["points"] = stored["points"] * 2.0  # same key, other content
    np.savez(tmp_path / "k.npz", **stored)
    assert cache.load("k") is None
