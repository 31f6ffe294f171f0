"""Pictures of a run, off-screen: images of the expected size that are not blank and show the
bodies (both bodies' categorical colours present), cuts, particles, animations, history plot."""

import numpy as np
import pytest

from impactsim.mesh.structured import structured_box
from impactsim.output.render import RenderError, offscreen_unavailable, parse_cut, render_series
from impactsim.output.series import SeriesWriter

pytest.importorskip("pyvista")
W, H = 320, 240


def _scene(tmp_path, n_frame=3):
    """A 20 x 20 x 2 mm plate and a 4 mm cube coming down on it at 100 m/s, with particles."""
    pp, pt = structured_box((0.02, 0.02, 0.002), 0.002)
    cp, ct = structured_box((0.004, 0.004, 0.004), 0.002)
    cp = cp + [0.0, 0.0, 0.0031]
    pts = np.vstack([pp, cp])
    tets = np.vstack([pt, ct + len(pp)]).astype(np.int32)
    body = np.r_[np.zeros(len(pt), np.int32), np.ones(len(ct), np.int32)]
    vel = np.zeros((len(pts), 3))
    vel[len(pp):, 2] = -100.0
    series = SeriesWriter(tmp_path)
    parts = SeriesWriter(tmp_path, prefix="particles", pvd_name="particles.pvd")
    for k in range(n_frame):
        x = pts + vel * k * 1e-6
        status = np.zeros(len(tets), np.int32)
        status[: k * 10] = 1
        series.write(k * 1e-6, x, tets, point_data={"velocity": vel},
                     cell_data={"body": body, "status": status,
                                "von_mises": np.linspace(0, 1e8, len(tets))})
        parts.write(k * 1e-6, np.array([[0.0, 0.0, -0.002], [0.001, 0.0, -0.003]]), None,
                    point_data={"radius": np.array([3e-4, 3e-4]), "velocity": np.zeros((2, 3))})
    series.close()
    parts.close()
    (tmp_path / "case.resolved.toml").write_text('[[body]]\nname = "plate"\n[[body]]\nname = "cube"\n')
    (tmp_path / "history.csv").write_text(
        "time [s],step,dt [s],kinetic_energy [J],internal_energy [J],total_energy [J],"
        "contact_impulse [N s],particles,bar.velocity_z [m/s]\n"
        + "".join(f"{i * 1e-7},{i},1e-7,{10 - i},{i},10,{0.1 * i},{i},{-100 + 10 * i}\n"
                  for i in range(10)))
    return tmp_path


def _img(path):
    import imageio.v2 as imageio

    return np.asarray(imageio.imread(path))[..., :3].astype(int)


@pytest.fixture(scope="module")
def offscreen():
    reason = offscreen_unavailable()
    if reason:
        pytest.skip(f"no off-screen rendering here: {reason}")


def test_bodies_in_their_categorical_colours(tmp_path, offscreen):
    run = _scene(tmp_path)
    paths = render_series(run, "body", window_size=(W, H), out=tmp_path / "pics")
    assert [p.name for p in paths] == [f"body_frame_0000{i}.png" for i in range(3)]
    img = _img(paths[-1])
    assert img.shape == (H, W, 3)
    background = np.all(img == 255, axis=-1)
    assert background.mean() < 0.9  # not blank
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    orange = (r > b + 60) & (r > 120)  # tab10 #ff7f0e: the cube, shaded
    blue = (b > r + 40)  # tab10 #1f77b4: the plate
    assert orange.mean() > 0.005 and blue.mean() > 0.02


def test_cut_particles_and_animation(tmp_path, offscreen):
    import imageio.v2 as imageio

    run = _scene(tmp_path)
    whole = render_series(run, "von_mises", window_size=(W, H), particles=False)
    cut = render_series(run, "von_mises", window_size=(W, H), cut=parse_cut("y"), out=run / "cut",
                        animate=tmp_path / "a.gif")
    a, c = _img(whole[0]), _img(cut[0])
    assert a.shape == c.shape == (H, W, 3) and np.any(a != c)
    grey = (np.ptp(c, axis=-1) < 8) & (c[..., 0] > 90) & (c[..., 0] < 245)  # the particles
    assert grey.sum() > 20
    assert len(imageio.mimread(tmp_path / "a.gif")) == 3
    render_series(run, "status", window_size=(W, H), every=2, animate=tmp_path / "a.mp4")
    assert (tmp_path / "a.mp4").stat().st_size > 1000
    names = sorted(p.name for p in (run / "render").iterdir())
    assert "status_frame_00002.png" in names and "von_mises_frame_00002.png" in names


def test_bad_options_are_clear(tmp_path):
    run = _scene(tmp_path, 1)
    with pytest.raises(RenderError, match="--slice"):
        parse_cut("q,1")
    with pytest.raises(RenderError, match=".mp4 or .gif"):
        render_series(run, "body", animate=tmp_path / "a.avi")
    n, p = parse_cut("-y,0,0,1e-3")
    np.testing.assert_array_equal(n, [0, -1, 0])
    np.testing.assert_array_equal(p, [0, 0, 1e-3])


def test_history_plot_png(tmp_path):
    from impactsim.output.plot import PlotError, plot_history

    run = _scene(tmp_path, 1)
    png = plot_history(run, size=(6, 4), dpi=50)
    img = _img(png)
    assert img.shape == (200, 300, 3) and (img != 255).any(axis=-1).mean() > 0.05
    with pytest.raises(PlotError, match="not found"):
        plot_history(tmp_path / "nothing")
