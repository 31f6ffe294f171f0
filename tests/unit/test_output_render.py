"""render: clear errors always; PNGs only where off-screen rendering works here."""

import numpy as np
import pytest

from impactsim.output.render import RenderError, offscreen_unavailable, render_series
from impactsim.output.series import SeriesWriter

pytest.importorskip("pyvista")

POINTS = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], dtype=np.float64)
TETS = np.array([[0, 1, 2, 3], [1, 2, 4, 3]], dtype=np.int32)


def _run_dir(tmp_path, n_frame=3):
    writer = SeriesWriter(tmp_path)
    for k in range(n_frame):
        writer.write(
            k * 1e-6,
            POINTS + [0.0, 0.0, 0.1 * k],
            TETS,
            point_data={"velocity": np.full((5, 3), float(k))},
            cell_data={"von_mises": np.array([1.0, 2.0]) * (k + 1), "stress": np.ones((2, 6))},
            keep=np.array([True, k < 2]),
        )
    return tmp_path


def test_missing_field_lists_the_available_ones(tmp_path):
    with pytest.raises(RenderError, match="no field 'damage'.*stress, velocity, von_mises"):
        render_series(_run_dir(tmp_path, 1), field="damage")
    assert not (tmp_path / "render").exists()


def test_not_a_run_folder_or_bad_every(tmp_path):
    with pytest.raises(RenderError, match="series.pvd not found"):
        render_series(tmp_path)
    with pytest.raises(RenderError, match="every"):
        render_series(_run_dir(tmp_path, 1), every=0)


def test_renders_selected_frames_to_png(tmp_path):
    reason = offscreen_unavailable()
    if reason:
        pytest.skip(f"no off-screen rendering here: {reason}")
    run_dir = _run_dir(tmp_path)
    paths = render_series(run_dir, field="velocity", every=2, window_size=(160, 120))
    assert paths == [run_dir / "render" / "velocity_frame_00000.png",
                     run_dir / "render" / "velocity_frame_00002.png"]
    for path in paths:
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in (run_dir / "render").iterdir()) == ["velocity_frame_00000.png",
                                                                       "velocity_frame_00002.png"]


@pytest.mark.parametrize(
    "probe, expected",
    [("import os; os.abort()", "crashed (SIGABRT)"), ("raise SystemExit('no EGL device')", "failed (no EGL device)")],
)
def test_probe_failure_is_explained(monkeypatch, probe, expected):
    import impactsim.output.render as render

    monkeypatch.setattr(render, "_PROBE", probe)
    assert expected in render._probe()
