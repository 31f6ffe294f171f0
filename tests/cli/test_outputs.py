"""Outputs that say what they are: units in history.csv and summary.json, per-body velocity
columns, new frame fields, derived wall measures, a refused run into an earlier run's folder,
the material listing, -q."""

import json

import meshio
import numpy as np
from click.testing import CliRunner

from impactsim.cli import main
from impactsim.output.series import read_collection
from impactsim.results import history_array, read_history
from tests.cli.test_run import BAR, _run


def test_units_velocity_columns_fields_and_wall_measures(tmp_path):
    result, out = _run(tmp_path, BAR)
    assert result.exit_code == 0, result.output
    first = (out / "history.csv").read_text().splitlines()[0].split(",")
    assert first[:3] == ["time [s]", "step", "dt [s]"]
    assert "bar.velocity_z [m/s]" in first and "wall_force [N]" in first
    h = history_array(out / "history.csv")
    df, units = read_history(out / "history.csv")
    assert units["kinetic_energy"] == "J" and units["step"] == ""
    # the per-body velocity is the momentum over the mass: one body here
    mass = 7850 * 4e-3 * 4e-3 * 20e-3
    np.testing.assert_allclose(h["bar.velocity_z"] * mass, h["momentum_z"], rtol=1e-9, atol=1e-15)
    assert abs(h["bar.velocity_z"][0] + 50.0) < 1e-12 and h["bar.velocity_z"][-1] > 40.0  # rebound
    mesh = meshio.read(read_collection(out / "series.pvd")[-1][1])
    cd = {k: v[0] for k, v in mesh.cell_data.items()}
    assert {"specific_internal_energy", "cell_id", "jc_damage"} <= set(cd)
    assert "internal_energy" not in cd
    np.testing.assert_array_equal(np.sort(cd["cell_id"]), np.arange(len(cd["cell_id"])))
    s = json.loads((out / "summary.json").read_text())
    assert s["units"]["mass"] == "kg" and s["units"]["final_length"] == "m"
    bar = s["bodies"]["bar"]
    # the elastic bar is as long as it was, and its foot is the 4 x 4 mm square (diagonal)
    assert abs(bar["final_length"] / 0.020 - 1) < 0.01 and bar["initial_length"] == 0.020
    assert abs(bar["foot_diameter"] / (4e-3 * np.sqrt(2)) - 1) < 0.05


def test_run_into_an_earlier_runs_folder_needs_overwrite(tmp_path):
    result, out = _run(tmp_path, BAR)
    assert result.exit_code == 0
    (out / "frame_00099.vtu").write_text("stale")
    again, _ = _run(tmp_path, BAR)
    assert again.exit_code == 2 and "--overwrite" in again.output
    assert "Traceback" not in again.output
    ok, _ = _run(tmp_path, BAR, "--overwrite")
    assert ok.exit_code == 0 and not (out / "frame_00099.vtu").exists()


def test_quiet_and_where_outputs_went(tmp_path):
    case = tmp_path / "case.toml"
    case.write_text(BAR)
    loud = CliRunner().invoke(main, ["run", str(case), "-o", str(tmp_path / "a")])
    assert f"outputs in {tmp_path / 'a'}" in loud.output
    quiet = CliRunner().invoke(main, ["run", str(case), "-o", str(tmp_path / "b"), "-q"])
    assert quiet.exit_code == 0 and quiet.output == ""


def test_materials_listing_has_sources():
    r = CliRunner().invoke(main, ["materials"])
    assert r.exit_code == 0
    assert "al-2024-t3 (also: d16t" in r.output and "source: EOS: Steinberg" in r.output
    one = CliRunner().invoke(main, ["materials", "d16t"])
    assert one.exit_code == 0 and 'density = "2785 kg/m^3"' in one.output
    bad = CliRunner().invoke(main, ["materials", "unobtainium"])
    assert bad.exit_code == 2 and "no material 'unobtainium'" in bad.output
