"""series: VTU frames round-trip through meshio and the .pvd lists every frame with its time."""

import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest

from impactsim.output import series
from impactsim.output.series import SeriesWriter, read_collection, voigt_to_tensor
from impactsim.output.vtu import write_vtu

POINTS = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], dtype=np.float64)
TETS = np.array([[0, 1, 2, 3], [1, 2, 4, 3], [0, 2, 1, 4]], dtype=np.int32)


def _frame_data(rng):
    point_data = {"velocity": rng.normal(size=(5, 3)), "displacement": rng.normal(size=(5, 3))}
    cell_data = {
        "stress": rng.normal(size=(3, 6)),
        "pressure": rng.normal(size=3),
        "von_mises": rng.random(3),
        "plastic_strain": rng.random(3),
        "temperature": 293.0 + rng.random(3),
        "status": np.array([0, 1, 3], dtype=np.int8),
        "body": np.array([0, 0, 1], dtype=np.int32),
    }
    return point_data, cell_data


@pytest.mark.parametrize("compression", ["zlib", "none"])
def test_vtu_round_trip(tmp_path, compression):
    rng = np.random.default_rng(1)
    point_data, cell_data = _frame_data(rng)
    path = SeriesWriter(tmp_path, compression=compression).write(0.0, POINTS, TETS, point_data,
                                                                 cell_data)
    assert path == tmp_path / "frame_00000.vtu"
    zlib = b'compressor="vtkZLibDataCompressor"' in path.read_bytes()[:400]
    assert zlib == (compression == "zlib")

    mesh = meshio.read(path)
    np.testing.assert_array_equal(mesh.points, POINTS)
    assert [block.type for block in mesh.cells] == ["tetra"]
    np.testing.assert_array_equal(mesh.cells[0].data, TETS)
    for name, value in point_data.items():
        np.testing.assert_array_equal(mesh.point_data[name], value)
    for name, value in cell_data.items():
        expected = voigt_to_tensor(value) if name == "stress" else value
        np.testing.assert_array_equal(mesh.cell_data[name][0], expected)
    assert mesh.cell_data["status"][0].dtype == np.int8


def test_stress_is_written_as_symmetric_3x3_tensor(tmp_path):
    s6 = np.array([[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]])  # xx yy zz xy yz zx
    full = voigt_to_tensor(s6).reshape(3, 3)
    np.testing.assert_array_equal(full, [[1, 4, 6], [4, 2, 5], [6, 5, 3]])
    writer = SeriesWriter(tmp_path)
    tensor = np.broadcast_to(full, (3, 3, 3))
    path = writer.write(0.0, POINTS, TETS, cell_data={"stress": tensor})
    np.testing.assert_array_equal(meshio.read(path).cell_data["stress"][0], tensor.reshape(3, 9))


def test_keep_drops_eroded_cells_and_their_data(tmp_path):
    rng = np.random.default_rng(2)
    point_data, cell_data = _frame_data(rng)
    keep = np.array([True, False, True])
    path = SeriesWriter(tmp_path).write(0.0, POINTS, TETS, point_data, cell_data, keep=keep)
    mesh = meshio.read(path)
    np.testing.assert_array_equal(mesh.cells[0].data, TETS[keep])
    np.testing.assert_array_equal(mesh.cell_data["von_mises"][0], cell_data["von_mises"][keep])
    assert len(mesh.points) == len(POINTS)


def test_pvd_lists_every_frame_with_exact_times(tmp_path):
    writer = SeriesWriter(tmp_path)
    times = [0.0, 0.1 + 0.2, 1e-7 / 3.0]
    for i, time in enumerate(times):
        writer.write(time, POINTS + i, TETS)
        listed = read_collection(tmp_path / "series.pvd")
        assert [t for t, _ in listed] == times[: i + 1]
    root = ET.parse(tmp_path / "series.pvd").getroot()
    assert root.tag == "VTKFile" and root.get("type") == "Collection"
    files = [ds.get("file") for ds in root.find("Collection").iter("DataSet")]
    assert files == ["frame_00000.vtu", "frame_00001.vtu", "frame_00002.vtu"]
    assert all(ds.get("part") == "0" for ds in root.iter("DataSet"))
    assert sorted(p.name for p in tmp_path.iterdir()) == files + ["series.pvd"]


def test_particle_series_with_n_particles(tmp_path):
    rng = np.random.default_rng(3)
    x = rng.random((7, 3))
    data = {"radius": rng.random(7), "velocity": rng.normal(size=(7, 3)), "mass": rng.random(7)}
    writer = SeriesWriter(tmp_path, prefix="particles", pvd_name="particles.pvd")
    path = writer.write(2e-6, x, point_data=data)
    assert path.name == "particles_00000.vtu"
    mesh = meshio.read(path)
    np.testing.assert_array_equal(mesh.points, x)
    assert [block.type for block in mesh.cells] == ["vertex"]
    np.testing.assert_array_equal(mesh.cells[0].data.ravel(), np.arange(7))
    for name, value in data.items():
        np.testing.assert_array_equal(mesh.point_data[name], value)
    assert read_collection(tmp_path / "particles.pvd") == [(2e-6, path)]


def test_particle_series_with_no_particles_is_a_valid_file(tmp_path):
    pv = pytest.importorskip("pyvista")  # meshio 5.3 cannot read back an empty VTU; VTK can
    writer = SeriesWriter(tmp_path, prefix="particles", pvd_name="particles.pvd")
    data = {"radius": np.zeros(0), "velocity": np.zeros((0, 3)), "mass": np.zeros(0)}
    path = writer.write(0.0, np.zeros((0, 3)), point_data=data)
    piece = ET.parse(path).getroot().find("UnstructuredGrid/Piece")
    assert piece.get("NumberOfPoints") == "0" and piece.get("NumberOfCells") == "0"
    grid = pv.read(path)
    assert grid.n_points == 0 and grid.n_cells == 0
    assert set(grid.point_data.keys()) == {"radius", "velocity", "mass"}


def test_shape_errors_name_the_field(tmp_path):
    writer = SeriesWriter(tmp_path)
    with pytest.raises(ValueError, match="pressure"):
        writer.write(0.0, POINTS, TETS, cell_data={"pressure": np.zeros(2)})
    with pytest.raises(ValueError, match="cells"):
        writer.write(0.0, POINTS, TETS[:, :3])
    with pytest.raises(ValueError, match="keep"):
        writer.write(0.0, POINTS, TETS, keep=np.ones(3, dtype=int))
    assert writer.frames == [] and not (tmp_path / "series.pvd").exists()


def test_unknown_compression_is_refused(tmp_path):
    with pytest.raises(ValueError, match="compression"):
        SeriesWriter(tmp_path, compression="gzip")


def test_background_frames_hold_the_values_at_write_time(tmp_path):
    """In background mode a frame is a copy: changing the arrays right after write() does not
    change the file, and after close() the collection lists every frame in order."""
    writer = SeriesWriter(tmp_path, background=True)
    points = POINTS.copy()
    velocity = np.zeros((5, 3))
    pressure = np.zeros(3)
    tets = TETS.copy()
    for k in range(5):
        velocity[:] = k
        pressure[:] = -k
        points[:, 0] = POINTS[:, 0] + k
        writer.write(1e-6 * k, points, tets, {"velocity": velocity}, {"pressure": pressure})
        velocity[:] = np.nan  # the caller goes on with its arrays at once
        pressure[:] = np.nan
        points[:, 0] = np.nan
        tets[:] = 0
        tets[:] = TETS
    writer.close()
    listed = read_collection(tmp_path / "series.pvd")
    assert [t for t, _ in listed] == [1e-6 * k for k in range(5)]
    for k, (_, path) in enumerate(listed):
        mesh = meshio.read(path)
        assert np.all(mesh.point_data["velocity"] == k)
        assert np.all(mesh.cell_data["pressure"][0] == -k)
        np.testing.assert_array_equal(mesh.points[:, 0], POINTS[:, 0] + k)
        np.testing.assert_array_equal(mesh.cells[0].data, TETS)


def test_background_errors_surface_at_close(tmp_path, monkeypatch):
    def broken(*args, **kwargs):
        raise OSError("disk full")

    writer = SeriesWriter(tmp_path, background=True)
    writer.write(0.0, POINTS, TETS)
    writer.close()
    monkeypatch.setattr(series, "write_vtu", broken)
    failing = SeriesWriter(tmp_path / "b", background=True)
    failing.write(0.0, POINTS, TETS)
    with pytest.raises(OSError, match="disk full"):
        failing.close()
    assert failing.frames == [] and not (tmp_path / "b" / "series.pvd").exists()
    assert [p.name for _, p in read_collection(tmp_path / "series.pvd")] == ["frame_00000.vtu"]


@pytest.mark.parametrize("compression", ["zlib", None])
def test_own_vtu_writer_reads_back_as_meshios_own_file(tmp_path, compression):
    """output/vtu.py writes meshio's file layout: meshio reads every array of a file with tets,
    hexes and vertices (in blocks, cell data over their concatenation) back with the values,
    dtypes and cell blocks of the same mesh written by meshio itself; more than one compressed
    block per array (64k rows); zlib at level 1 (the stream header 78 01)."""
    rng = np.random.default_rng(4)
    pts = rng.normal(size=(20_000, 3))
    blocks = [("tetra", rng.integers(0, 20_000, size=(16_000, 4))),
              ("hexahedron", rng.integers(0, 20_000, size=(5, 8))),
              ("vertex", np.arange(7).reshape(-1, 1))]
    e = sum(c.shape[0] for _, c in blocks)
    pdata = {"velocity": rng.normal(size=(20_000, 3)), "mass": rng.random(20_000)}
    cdata = {"stress": rng.normal(size=(e, 9)), "status": rng.integers(0, 3, e).astype(np.int8),
             "body": np.zeros(e, dtype=np.int32)}
    write_vtu(tmp_path / "own.vtu", pts, blocks, pdata, cdata, compression=compression)
    bounds = np.cumsum([0] + [c.shape[0] for _, c in blocks])
    meshio.write(tmp_path / "ref.vtu", meshio.Mesh(
        pts, blocks, point_data=pdata,
        cell_data={k: [v[bounds[i]:bounds[i + 1]] for i in range(3)] for k, v in cdata.items()}),
        file_format="vtu", binary=True, compression=compression)
    own, ref = meshio.read(tmp_path / "own.vtu"), meshio.read(tmp_path / "ref.vtu")
    np.testing.assert_array_equal(own.points, ref.points)
    assert [(b.type, b.data.dtype) for b in own.cells] == [(b.type, b.data.dtype)
                                                            for b in ref.cells]
    for a, b in zip(own.cells, ref.cells):
        np.testing.assert_array_equal(a.data, b.data)
    for k, v in ref.point_data.items():
        assert own.point_data[k].dtype == v.dtype
        np.testing.assert_array_equal(own.point_data[k], v)
    for k, v in ref.cell_data.items():
        for a, b in zip(own.cell_data[k], v, strict=True):
            assert a.dtype == b.dtype
            np.testing.assert_array_equal(a, b)
    text = (tmp_path / "own.vtu").read_text()
    assert ('compressor="vtkZLibDataCompressor"' in text) == (compression is not None)
    if compression:
        import base64
        start = text.index('Name="stress"')
        data = text[text.index(">", start) + 1:].lstrip()
        n_blocks = 9 * e * 8 // 32768 + 1
        header_chars = 4 * -(-4 * (3 + n_blocks) // 3)
        assert base64.b64decode(data[header_chars:header_chars + 4])[:2] == b"\x78\x01"


def test_frames_from_a_snapshot_hold_the_state_at_write_time(tmp_path):
    """solver/run.py writes frames with ``write_later`` from copies of the state
    (``frame_snapshot``), their fields derived in the writer's thread: the file holds the
    fields of ``frame_fields`` at the time of the call, bit for bit, though the run changes its
    arrays right after; a live-cell mask drops the eroded cell."""
    from types import SimpleNamespace

    from impactsim.model import ERODED
    from impactsim.solver.run import frame_args, frame_snapshot

    rng = np.random.default_rng(7)
    model = SimpleNamespace(
        x=POINTS + 0.01 * rng.random(POINTS.shape), x0=POINTS.copy(), v=rng.normal(size=(5, 3)),
        conn=TETS.copy(), sdev=rng.normal(size=(3, 6)), pressure=rng.normal(size=3),
        eps_p=rng.random(3), temperature=293.0 + rng.random(3),
        status=np.array([0, ERODED, 1], dtype=np.int8), elem_body=np.array([0, 0, 1], np.int32),
        elem_mass=rng.random(3), vol=rng.random(3), energy=rng.random(3),
        damage=rng.random(3), blocks=[])
    pressure0 = model.pressure.copy()
    expected = frame_args(frame_snapshot(model), None)
    expected = tuple(a.copy() if isinstance(a, np.ndarray) else a for a in expected)
    writer = SeriesWriter(tmp_path, background=True)
    snap = frame_snapshot(model)
    writer.write_later(1e-6, lambda: frame_args(snap, None))
    for a in (model.x, model.v, model.sdev, model.pressure, model.eps_p, model.temperature,
              model.energy, model.damage, model.vol):
        a += 1.0
    model.status[:] = ERODED
    writer.close()
    ref = SeriesWriter(tmp_path / "ref").write(1e-6, *expected[:4], keep=expected[4])
    got, want = meshio.read(tmp_path / "frame_00000.vtu"), meshio.read(ref)
    np.testing.assert_array_equal(got.points, want.points)
    np.testing.assert_array_equal(got.cells[0].data, TETS[[0, 2]])
    np.testing.assert_array_equal(got.cells[0].data, want.cells[0].data)
    for k, v in want.point_data.items():
        np.testing.assert_array_equal(got.point_data[k], v)
    assert sorted(want.cell_data) == sorted(got.cell_data)
    for k, v in want.cell_data.items():
        np.testing.assert_array_equal(got.cell_data[k][0], v[0])
    np.testing.assert_array_equal(got.cell_data["pressure"][0], pressure0[[0, 2]])
