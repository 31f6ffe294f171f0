"""Sweeps: variants expanded from a sweep file, run on a 2-worker LocalCluster and in this
process with the same rows, finished variants skipped, a failed variant recorded."""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from impactsim.studies import sweep as S

BAR = """
[run]
name = "tiny-bar"
end_time = "20 us"
[[material]]
name = "steel"
library = "steel-elastic"
[[body]]
name = "bar"
material = "steel"
shape = "box"
size = ["4 mm", "4 mm", "20 mm"]
position = [0, 0, "10.01 mm"]
mesh_size = "2 mm"
mesher = "structured"
velocity = [0, 0, "-50 m/s"]
[[wall]]
point = [0, 0, 0]
normal = [0, 0, 1]
[output]
frames = 2
"""

SWEEP = """
base = "bar.toml"
[vary]
"body.bar.speed" = { start = 20, stop = 40, num = 2, unit = "m/s" }
[zip]
"run.cfl" = [0.5, 0.6]
"output.history_every" = [1, 2]
"""

VOLATILE = ["wall [s]", "run wall [s]", "skipped"]


def _files(tmp_path):
    (tmp_path / "bar.toml").write_text(BAR)
    (tmp_path / "sweep.toml").write_text(SWEEP)
    return tmp_path / "sweep.toml"


def test_expansion_product_zip_range_and_speed(tmp_path):
    sw = S.read_sweep(_files(tmp_path))
    assert sw.keys == ["body.bar.speed", "run.cfl", "output.history_every"]
    vals = [(v.values["body.bar.speed"], v.values["run.cfl"], v.values["output.history_every"])
            for v in sw.variants]
    assert vals == [("20 m/s", 0.5, 1), ("20 m/s", 0.6, 2), ("40 m/s", 0.5, 1),
                    ("40 m/s", 0.6, 2)]
    raw = S.variant_case(sw.base, sw.variants[2])
    np.testing.assert_allclose(raw["body"][0]["velocity"], [0.0, 0.0, -40.0])  # direction kept
    assert raw["run"]["cfl"] == 0.5 and raw["run"]["name"] == sw.variants[2].name
    assert S.expand_range({"start": 1, "stop": 2, "step": 0.25}, "x") == [1, 1.25, 1.5, 1.75, 2]


def test_bad_sweep_files_name_the_key(tmp_path):
    _files(tmp_path)
    bad = tmp_path / "bad.toml"
    bad.write_text('base = "bar.toml"\n[zip]\na = [1, 2]\nb = [1]\n')
    with pytest.raises(S.SweepError, match="zip: the lists have different lengths"):
        S.read_sweep(bad)
    bad.write_text('base = "bar.toml"\n[vary]\n"body.bar.radiuss" = [1]\n')
    sw = S.read_sweep(bad)
    from impactsim.case import CaseError

    with pytest.raises(CaseError, match="radiuss"):
        S.prepare(sw, tmp_path / "o")


def test_local_cluster_gives_the_rows_of_runs_one_by_one(tmp_path):
    path = _files(tmp_path)
    said = []
    dask_df, folder = S.run_sweep(path, tmp_path / "dask", workers=2, say=said.append)
    serial_df, _ = S.run_sweep(path, tmp_path / "serial", workers=0, say=said.append)
    assert len(dask_df) == 4 and (dask_df["status"] == "ok").all()
    pd.testing.assert_frame_equal(dask_df.drop(columns=VOLATILE), serial_df.drop(columns=VOLATILE))
    # physics in the table: the bar leaves the wall with nearly its impact speed, faster for 40
    vz = dask_df["bar.mean_velocity_z [m/s]"].to_numpy()
    assert np.all(vz > 0) and np.all(np.abs(vz / dask_df["body.bar.speed"].str.split().str[0]
                                            .astype(float) - 0.9) < 0.1)
    assert (np.abs(dask_df["energy_balance_error"]) < 0.02).all()
    back = pd.read_parquet(folder / "results.parquet")
    assert list(back["variant"]) == list(dask_df["variant"])
    assert (folder / "results.csv").read_text().splitlines()[0].startswith("variant,body.bar.speed")
    # a re-run skips every finished variant and gives the same table
    again, _ = S.run_sweep(path, tmp_path / "dask", workers=2, say=said.append)
    assert again["skipped"].all()
    pd.testing.assert_frame_equal(again.drop(columns=VOLATILE), dask_df.drop(columns=VOLATILE))


def test_failed_variant_recorded_others_go_on_and_rerun(tmp_path, monkeypatch):
    import impactsim.solver.run as R

    path = _files(tmp_path)
    real = R.run_case

    def flaky(case, out, **kw):
        if case.run.name.startswith("speed-40ms_cfl-0.5"):
            raise RuntimeError("disk full")
        return real(case, out, **kw)

    monkeypatch.setattr(R, "run_case", flaky)
    df, folder = S.run_sweep(path, tmp_path / "o", workers=0, say=lambda s: None)
    bad = df[df["status"] == "failed"]
    assert list(bad["variant"]) == ["speed-40ms_cfl-0.5_history_every-1"]
    assert "RuntimeError: disk full" in bad["error"].iloc[0]
    assert (df["status"] != "failed").sum() == 3
    assert json.loads((folder / bad["variant"].iloc[0] / "row.json").read_text())["status"] == "failed"
    monkeypatch.setattr(R, "run_case", real)
    df2, _ = S.run_sweep(path, tmp_path / "o", workers=0, say=lambda s: None)
    assert (df2["status"] == "ok").all()
    assert list(df2["skipped"]) == [v != bad["variant"].iloc[0] for v in df2["variant"]]


def test_named_variants_and_mesh_size_sweep_file(tmp_path):
    import tomllib

    cases = Path(__file__).parents[2] / "cases"
    sw = S.read_sweep(cases / "sweeps" / "mesh-size.toml")
    names = [v.name for v in sw.variants]
    assert len(names) == 7 and "mesh_size-2.5mm_element-anp" in names and "cfl-0.3" in names
    v = sw.variants[names.index("mesh_size-2.5mm_element-anp")]
    assert v.overrides == ["output.frames=4", 'body.0.mesh_size="2.5 mm"', 'run.element="anp"']
    items = S.prepare(sw, tmp_path / "out")
    raw = tomllib.loads(items[names.index("cfl-0.3")][1].read_text())
    assert raw["run"]["cfl"] == 0.3 and raw["run"]["name"] == "cfl-0.3"
    bad = tmp_path / "bad.toml"
    bad.write_text(f'base = "{cases / "elastic-bar-wall.toml"}"\nvari = 1\n')
    with pytest.raises(S.SweepError, match="unknown keys"):
        S.read_sweep(bad)
    bad.write_text(f'base = "{cases / "elastic-bar-wall.toml"}"\nset = []\n')
    with pytest.raises(S.SweepError, match="nothing to run"):
        S.read_sweep(bad)


def test_existing_cluster_by_scheduler_address(tmp_path):
    from distributed import LocalCluster

    path = _files(tmp_path)
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster:
        df, _ = S.run_sweep(path, tmp_path / "remote", scheduler=cluster.scheduler_address,
                            say=lambda s: None)
    serial, _ = S.run_sweep(path, tmp_path / "serial", workers=0, say=lambda s: None)
    pd.testing.assert_frame_equal(df.drop(columns=VOLATILE), serial.drop(columns=VOLATILE))


def test_workers_run_one_numba_thread(tmp_path):
    from impactsim.studies.cluster import executor

    with executor(None, 2) as ex:
        got = dict(ex.map(_numba_threads, [(), ()]))
    assert got == {0: 1, 1: 1}


def _numba_threads():
    import numba

    return numba.config.NUMBA_NUM_THREADS


def test_local_cluster_leaves_this_process_environment_alone():
    import os

    from impactsim.studies.cluster import WORKER_ENV, executor

    before = {k: os.environ.get(k) for k in WORKER_ENV}
    with executor(None, 1):
        pass
    assert {k: os.environ.get(k) for k in WORKER_ENV} == before
