"""The mesh report and VTU of a case (the `impactsim mesh` command)."""

import math

import meshio
import numpy as np
import pytest

from impactsim.case import CaseError
from impactsim.case.schema import Body, Case, Material, Run
from impactsim.mesh import MeshError
from impactsim.mesh.report import mesh_case

AL = Material(name="al", density=2700.0, shear_modulus=26e9, bulk_modulus=70e9)


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("IMPACTSIM_CACHE", str(tmp_path / "cache"))


def two_cubes(*extra):
    bodies = [Body("left", "al", "cube12", {"size": 0.02}),
              Body("right", "al", "box", {"size": (0.02, 0.02, 0.02)}, mesh_size=0.01,
                   mesher="structured", position=(0.03, 0.0, 0.0)), *extra]
    return Case(source=None, run=Run(name="cubes", end_time=1e-5, cfl=0.5),
                materials={"al": AL}, bodies=bodies)


def test_report_counts_mass_dt_and_vtu(tmp_path):
    text = mesh_case(two_cubes(), tmp_path / "out")
    assert "body[0] left: cube12" in text and "nodes 9, elements 12" in text
    assert "nodes 27, elements 48" in text
    assert "mass 21.6 g" in text  # 2700 kg/m^3 * (2 cm)^3
    c = math.sqrt((70e9 + 4 * 26e9 / 3) / 2700.0)
    # cube12: smallest altitude a/2 = 1 cm; Kuhn tets of 1 cm cells: 1 cm / sqrt 2
    assert f"expected stable dt {0.5 * 0.01 / c * 1e9:.4g} ns" in text
    overall = 0.5 * 0.01 / math.sqrt(2.0) / c
    assert f"total: 2 bodies, nodes 36, elements 60, mass 43.2 g, expected stable dt " \
           f"{overall * 1e9:.4g} ns" in text
    assert "warning" not in text

    mesh = meshio.read(tmp_path / "out" / "mesh.vtu")
    assert mesh.points.shape == (36, 3) and mesh.cells[0].data.shape == (60, 4)
    body = mesh.cell_data["body"][0]
    np.testing.assert_array_equal(np.bincount(body), [12, 48])
    assert not list((tmp_path / "out").glob("*.tmp"))


def test_report_warns_about_flat_elements(tmp_path):
    plate = Body("foil", "al", "plate", {"size": (0.02, 0.02, 0.0002)}, mesh_size=0.004,
                 mesher="structured")
    text = mesh_case(two_cubes(plate), tmp_path)
    assert "body[2] foil" in text
    assert "warning: poorly shaped elements" in text


def test_default_out_dir_is_out_run_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    mesh_case(two_cubes())
    assert (tmp_path / "out" / "cubes" / "mesh.vtu").is_file()


def test_mesh_error_names_the_body(tmp_path):
    bad = Body("ball", "al", "sphere", {"radius": 0.01}, mesh_size=0.0)
    with pytest.raises(MeshError, match=r'body\[2\] \(body "ball"\): mesh_size') as info:
        mesh_case(two_cubes(bad), tmp_path)
    assert isinstance(info.value, CaseError)
