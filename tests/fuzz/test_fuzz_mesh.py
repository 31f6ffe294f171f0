"""Property-based fuzzing of mesh files: every file ends in a valid mesh or one clean error.

Hypothesis writes a small tet mesh as .vtu, .msh or .vtk after damaging it (a non-finite or huge
coordinate, a repeated tetrahedron, a cell naming a node that does not exist, no cells at all,
a flattened tet) or damages the written bytes (cut short, bytes overwritten), then runs what
`impactsim check` runs on a case whose body is that file. Accepted files must give a mesh with
finite coordinates, at least one tetrahedron, positive volumes, no tetrahedron twice and no
face shared by more than two tetrahedra;
everything else must be a CaseError naming the case file and `body[0].path`.
"""

from __future__ import annotations

import os
import warnings

import meshio
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from impactsim.case import CaseError, load_case_text
from impactsim.case.describe import describe_case
from impactsim.mesh import mesh_body
from impactsim.mesh.orient import signed_volumes
from impactsim.mesh.structured import structured_box

FAST_EXAMPLES = 200
SLOW_EXAMPLES = 2000
POINTS, TETS = structured_box((0.01, 0.01, 0.01), 0.005)  # 27 nodes, 48 tets

CASE = """
[run]
end_time = "1 us"
[[body]]
name = "part"
material = "steel-elastic"
shape = "file"
path = "{path}"
"""


@st.composite
def damaged_mesh(draw):
    points, tets = POINTS.copy(), TETS.copy().astype(np.int64)
    damage = draw(st.sampled_from(["none", "nan", "inf", "huge", "duplicate", "out-of-range",
                                   "no-cells", "flat", "negative-index", "few"]))
    node = draw(st.integers(0, len(points) - 1))
    if damage == "nan":
        points[node, draw(st.integers(0, 2))] = np.nan
    elif damage == "inf":
        points[node, draw(st.integers(0, 2))] = -np.inf
    elif damage == "huge":
        points[node] *= 1e300
    elif damage == "duplicate":
        tets = np.vstack([tets, tets[draw(st.integers(0, len(tets) - 1))][::-1][None]])
    elif damage == "out-of-range":
        tets[draw(st.integers(0, len(tets) - 1)), 0] = len(points) + draw(st.integers(0, 99))
    elif damage == "negative-index":
        tets[0, 1] = -1
    elif damage == "no-cells":
        tets = tets[:0]
    elif damage == "flat":
        t = tets[draw(st.integers(0, len(tets) - 1))]
        points[t[3]] = points[t[0]]
    elif damage == "few":
        tets = tets[: draw(st.integers(1, 3))]
    fmt = draw(st.sampled_from(["vtu", "msh", "vtk"]))
    byte_damage = draw(st.sampled_from(["none", "none", "cut", "overwrite"]))
    return points, tets, fmt, byte_damage, draw(st.randoms(use_true_random=False))


def _write(tmp, points, tets, fmt, byte_damage, rnd) -> str:
    path = os.path.join(tmp, f"part.{fmt}")
    cells = [("tetra", tets)] if len(tets) else [("triangle", np.array([[0, 1, 2]]))]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            meshio.write(path, meshio.Mesh(points, cells),
                         **({"file_format": "gmsh22", "binary": False} if fmt == "msh" else {}))
    except Exception:  # meshio refuses to write some damage (negative indices): write bytes
        with open(path, "wb") as f:
            f.write(b"not a mesh")
    data = bytearray(open(path, "rb").read())
    if byte_damage == "cut" and data:
        data = data[: rnd.randrange(len(data))]
    elif byte_damage == "overwrite" and data:
        for _ in range(rnd.randrange(1, 8)):
            data[rnd.randrange(len(data))] = rnd.randrange(256)
    with open(path, "wb") as f:
        f.write(bytes(data))
    return path


def check_mesh_file(tmp, sample) -> None:
    path = _write(tmp, *sample)
    source = os.path.join(tmp, "case.toml")
    try:
        case = load_case_text(CASE.format(path=path), source=__import__("pathlib").Path(source))
        describe_case(case, mesh=False)
    except CaseError as err:
        msg = str(err)
        assert msg.startswith(source + ": body[0].path"), msg
        return
    points, tets = mesh_body(case.bodies[0])
    assert len(tets) > 0 and np.isfinite(points).all()
    assert (signed_volumes(points, tets) > 0).all()
    assert len(np.unique(np.sort(tets, axis=1), axis=0)) == len(tets)


# the deadline catches a hang, not slowness (a busy machine must not fail the test)
FUZZ = dict(deadline=30_000, derandomize=True,
            suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


@settings(max_examples=FAST_EXAMPLES, **FUZZ)
@given(damaged_mesh())
def test_fuzzed_mesh_files_end_clean(tmp_path, sample):
    check_mesh_file(str(tmp_path), sample)


@pytest.mark.slow
@settings(max_examples=SLOW_EXAMPLES, **dict(FUZZ, derandomize=False))
@given(damaged_mesh())
def test_fuzzed_mesh_files_end_clean_many(tmp_path, sample):
    check_mesh_file(str(tmp_path), sample)


@pytest.mark.parametrize("damage, fragment", [
    ("corrupt-vtu", "cannot read mesh file"),
    ("empty-msh", "part.msh"),
    ("nan-node", "non-finite coordinates"),
    ("duplicate", "listed more than once"),
    ("non-manifold", "non-manifold mesh: a face is shared by more than two tetrahedra"),
])
def test_mesh_reproducers_of_issue_16(tmp_path, damage, fragment):
    """A corrupt .vtu made meshio exit the process; an empty .msh passed `check` with 0
    elements; a NaN node ran to NaN; a repeated tet was meshed twice."""
    points, tets = POINTS.copy(), TETS.copy()
    if damage == "corrupt-vtu":
        path = tmp_path / "part.vtu"
        path.write_text("<VTKFile garbage")
    elif damage == "empty-msh":
        path = tmp_path / "part.msh"
        path.write_text("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n0\n$EndNodes\n"
                        "$Elements\n0\n$EndElements\n")
    else:
        if damage == "nan-node":
            points[5, 1] = np.nan
        elif damage == "non-manifold":  # a third tet on an inner face (the slow fuzz test's
            # find: face_adjacency's ValueError from the estimate, not a clean error)
            from impactsim.mesh.topology import all_faces, face_adjacency

            e, i = np.argwhere(face_adjacency(tets) >= 0)[0]
            face = all_faces(tets)[4 * e + i]
            a, b, c = points[face]
            points = np.vstack([points, (a + b + c) / 3 + 0.2 * np.cross(b - a, c - a) / 0.005])
            tets = np.vstack([tets, np.append(face, len(points) - 1)[None]])
        else:
            tets = np.vstack([tets, tets[:1]])
        path = tmp_path / "part.vtu"
        meshio.write(path, meshio.Mesh(points, [("tetra", tets)]))
    source = tmp_path / "case.toml"
    case = load_case_text(CASE.format(path=path), source=source)
    with pytest.raises(CaseError) as err:
        describe_case(case, mesh=False)
    msg = str(err.value)
    assert msg.startswith(f"{source}: body[0].path"), msg
    assert fragment in msg and "\n" not in msg
