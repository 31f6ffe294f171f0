"""Case files -> Case: conversion, defaults, library merge, overrides, round trip, and errors."""

import math
from pathlib import Path

import pytest
import tomli_w

from impactsim.case import CaseError, case_to_dict, load_case, load_case_text
from impactsim.case.reference import render_reference
from impactsim.case.schema import Failure
from impactsim.materials import library

BASE = """\
[run]
end_time = "10 us"

[[material]]
name = "al"
density = "2700 kg/m^3"
youngs_modulus = "70 GPa"
poisson_ratio = 0.25

[[body]]
name = "plate"
material = "al"
shape = "box"
size = ["10 mm", "10 mm", "2 mm"]
mesh_size = "1 mm"
"""

FULL = """\
[run]
name = "everything"
end_time = "25 us"
cfl = 0.5
element = "anp"
max_steps = 1e6

[[material]]
name = "projectile"
library = "d16t"
density = "2.8 g/cm^3"
strength = { A = "300 MPa" }
failure = { erosion = "jc-damage" }

[[material]]
name = "target"
density = 2703
shear_modulus = "26 GPa"
bulk_modulus = "70 GPa"
specific_heat = "885 J/kg/K"
initial_temperature = "20 degC"
strength = { model = "ideal-plastic", yield_stress = "300 MPa" }
eos = { model = "mie-gruneisen", c0 = "5.24 km/s", s = 1.4, gamma0 = 1.97 }
failure = { spall_strength = "1.6 GPa", loosening = 0.03, erosion = "plastic-strain", erosion_value = 2 }

[[body]]
name = "ball"
material = "projectile"
shape = "sphere"
diameter = "7.9 mm"
position = [0, 0, "5 mm"]
rotation = ["10 deg", 0, "0.1 rad"]
mesh_size = "0.5 mm"
speed = "5.5 km/s"
direction = [0, 0, -1]
obliquity = "30 deg"
angular_velocity = ["100 rpm", 0, 0]

[[body]]
name = "plate"
material = "target"
shape = "cylinder"
radius = "50 mm"
length = "2 mm"
axis = [0, 0, 2]
mesh_size = "1 mm"
[[body.constraint]]
nodes = { outside_radius = "45 mm" }
fixed = true
[[body.constraint]]
nodes = { plane = { point = [0, 0, "-1 mm"], normal = [0, 0, -3] } }
velocity = ["free", "free", 0]
[[body.constraint]]
nodes = { box = { lo = [-1, -1, -1], hi = [1, 1, "-0.9 mm"] } }
velocity = [0, "free", "1 m/s"]

[[body]]
name = "witness"
material = "steel-elastic"
shape = "box"
size = ["20 mm", "20 mm", "1 mm"]
position = [0, 0, "-30 mm"]
mesh_size = "1 mm"
mesher = "structured"
[[body.constraint]]
nodes = "all"
fixed = true

[[body]]
name = "cube"
material = "shkh15"
shape = "cube12"
size = "2 cm"
position = [0, 0, "50 mm"]

[[body]]
name = "imported"
material = "al-6061-t6"
shape = "file"
path = "meshes/part.msh"
scale = 0.001
position = [0, "80 mm", 0]

[[wall]]
point = [0, 0, "-40 mm"]
normal = [0, 0, 5]
friction = 0.1

[output]
directory = "out/custom"
times = ["0 us", "5 us", "25 us"]
history_every = 10
fields = ["pressure", "velocity"]

[contact]
passes = ["edge-edge", "node-face"]
friction = 0.2
self_contact = true

[fracture]
particles_per_element = 4
particle_collisions = true
erosion_region = "anywhere"
"""


def write(tmp_path: Path, text: str, name: str = "case.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def load(tmp_path, text, overrides=()):
    return load_case(write(tmp_path, text), overrides)


def error(tmp_path, text, overrides=()) -> str:
    with pytest.raises(CaseError) as err:
        load(tmp_path, text, overrides)
    return str(err.value)


def full_case(tmp_path):
    (tmp_path / "meshes").mkdir(exist_ok=True)
    (tmp_path / "meshes" / "part.msh").write_text("not a real mesh: only its existence is checked")
    return load(tmp_path, FULL)


# --- values and defaults ------------------------------------------------------------------------

def test_minimal_case_fills_defaults(tmp_path):
    case = load(tmp_path, BASE)
    assert case.run.name == "case"  # the file stem
    assert case.run.end_time == 1e-5
    assert case.run.cfl == 0.6 and case.run.element == "auto"
    body = case.bodies[0]
    assert body.dimensions == {"size": (0.01, 0.01, 0.002)}
    assert body.mesh_size == 0.001 and body.mesher == "gmsh"
    assert body.velocity == (0.0, 0.0, 0.0) and body.constraints == []
    mat = case.materials["al"]
    assert mat.shear_modulus == pytest.approx(70e9 / 2.5)
    assert mat.bulk_modulus == pytest.approx(70e9 / 1.5)
    assert mat.strength.model == "elastic" and mat.eos.model == "linear"
    assert mat.failure == Failure()
    assert case.walls == [] and case.output.directory is None
    assert case.contact.passes == ["node-face", "edge-edge"]


def test_full_case_values(tmp_path):
    case = full_case(tmp_path)
    assert case.run.max_steps == 1_000_000 and isinstance(case.run.max_steps, int)
    ball, plate, witness, cube, imported = case.bodies
    assert ball.dimensions == {"radius": pytest.approx(0.00395)}
    assert ball.rotation == pytest.approx((math.radians(10), 0.0, 0.1))
    assert ball.angular_velocity == pytest.approx((100 * 2 * math.pi / 60, 0, 0))
    assert plate.dimensions["height"] == 0.002 and plate.dimensions["axis"] == (0, 0, 1)
    rim, plane, box = plate.constraints
    assert rim.nodes.kind == "outside-radius"
    assert rim.nodes.params == {"center": (0.0, 0.0, 0.0), "axis": (0, 0, 1), "radius": 0.045}
    assert rim.velocity == (0.0, 0.0, 0.0)
    assert plane.nodes.kind == "plane" and plane.nodes.params["normal"] == (0, 0, -1)
    assert plane.nodes.params["tolerance"] == pytest.approx(0.01 * 0.001)
    assert plane.velocity == (None, None, 0.0)
    assert box.nodes.params["hi"] == (1.0, 1.0, -0.0009) and box.velocity == (0.0, None, 1.0)
    assert witness.constraints[0].nodes.kind == "all"
    assert cube.dimensions == {"size": 0.02} and cube.mesh_size == 0.0
    assert cube.material == "steel-52100"  # alias resolved to the entry name
    assert imported.dimensions["path"] == (tmp_path / "meshes" / "part.msh").resolve()
    assert case.walls[0].normal == (0.0, 0.0, 1.0) and case.walls[0].friction == 0.1
    assert case.output.times == [0.0, 5e-6, 25e-6] and case.output.directory == Path("out/custom")
    assert case.contact.passes == ["edge-edge", "node-face"]
    target = case.materials["target"]
    assert target.initial_temperature == pytest.approx(293.15)
    assert target.failure.erosion_value == 2.0
    assert set(case.materials) == {"projectile", "target", "steel-elastic", "steel-52100",
                                   "al-6061-t6"}


def test_round_trip_through_resolved_toml(tmp_path):
    case = full_case(tmp_path)
    text = tomli_w.dumps(case_to_dict(case))
    again = load_case(write(tmp_path, text, "resolved.toml"))
    again.source = case.source
    assert again == case


def test_round_trip_of_minimal_case(tmp_path):
    case = load(tmp_path, BASE)
    again = load_case_text(tomli_w.dumps(case_to_dict(case)), source=case.source)
    assert again == case


def test_speed_direction_obliquity(tmp_path):
    text = BASE + 'speed = "2 km/s"\ndirection = [0, 0, -2]\nobliquity = "60 deg"\n'
    v = load(tmp_path, text).bodies[0].velocity
    # rotated about +y: -z tilts toward -x
    assert v == pytest.approx((-2000 * math.sin(math.pi / 3), 0.0, -2000 * math.cos(math.pi / 3)))
    # an axis with a part along the direction: only the perpendicular part counts
    text2 = text + "obliquity_axis = [0, 1, 5]\n"
    v2 = load(tmp_path, text2).bodies[0].velocity
    assert v2 == pytest.approx(v)
    cos = -v2[2] / math.hypot(*v2)
    assert math.degrees(math.acos(cos)) == pytest.approx(60.0)


def test_speed_without_obliquity_and_plain_velocity(tmp_path):
    v = load(tmp_path, BASE + 'speed = "1 mm/us"\ndirection = [3, 4, 0]\n').bodies[0].velocity
    assert v == pytest.approx((600.0, 800.0, 0.0))
    v = load(tmp_path, BASE + 'velocity = [0, "-0.19 km/s", 0]\n').bodies[0].velocity
    assert v == (0.0, -190.0, 0.0)


@pytest.mark.parametrize("constants, G, K", [
    ('youngs_modulus = "200 GPa"\npoisson_ratio = 0.25', 80e9, 200e9 / 1.5),
    ('shear_modulus = "80 GPa"\nbulk_modulus = "160 GPa"', 80e9, 160e9),
    ('youngs_modulus = "200 GPa"\nshear_modulus = "80 GPa"', 80e9, 200e9 / 1.5),
    ('youngs_modulus = "200 GPa"\nbulk_modulus = "133.33333333333334 GPa"', 80e9, 200e9 / 1.5),
    ('shear_modulus = "80 GPa"\npoisson_ratio = 0.25', 80e9, 200e9 / 1.5),
    ('bulk_modulus = "133.33333333333334 GPa"\npoisson_ratio = 0.25', 80e9, 200e9 / 1.5),
    ('shear_modulus = "80 GPa"\neos = { c0 = "5 km/s" }', 80e9, 7800 * 5000.0**2),
])
def test_elastic_constants(tmp_path, constants, G, K):
    text = f"""[run]
end_time = 1e-5
[[material]]
name = "m"
density = 7800
{constants}
[[body]]
material = "m"
shape = "sphere"
radius = 0.01
mesh_size = 0.002
"""
    mat = load(tmp_path, text).materials["m"]
    assert mat.shear_modulus == pytest.approx(G, rel=1e-12)
    assert mat.bulk_modulus == pytest.approx(K, rel=1e-12)


# --- the library ----------------------------------------------------------------------------------

@pytest.mark.parametrize("name", library.names())
def test_every_library_entry_loads_and_has_a_source(tmp_path, name):
    text = BASE.replace('material = "al"', f'material = "{name}"')
    case = load(tmp_path, text)
    mat = case.materials[name]
    assert mat.source and mat.density > 0 and mat.shear_modulus > 0 and mat.bulk_modulus > 0


def test_library_values_follow_materials_md():
    cu = library.get("ofhc-copper")
    assert cu["strength"]["A"] == "90 MPa" and cu["eos"]["c0"] == "3940 m/s"
    assert library.get("d16t") == library.get("al-2024-t3")
    assert library.get("shkh15")["strength"] == {"model": "ideal-plastic", "yield_stress": "2 GPa"}
    for name, spall in [("al-2024-t3", "1.6 GPa"), ("al-6061-t6", "1.6 GPa"),
                        ("steel-4340", "7 GPa"), ("steel-52100", "7 GPa")]:
        entry = library.get(name)
        assert entry["failure"]["spall_strength"] == spall
        assert entry["failure"]["loosening"] == 0.03
        assert "[D19]" in entry["source"]
    assert library.get("steel-4340")["failure"]["jc_damage"] == [0.05, 3.44, -2.12, 0.002, 0.61]
    assert "check" in library.get("steel-4340")["source"]
    with pytest.raises(KeyError):
        library.get("unobtainium")


def test_library_merge_with_override(tmp_path):
    text = BASE + """
[[material]]
name = "cu"
library = "ofhc-copper"
density = "9000 kg/m^3"
strength = { B = "300 MPa" }
"""
    case = load(tmp_path, text.replace('material = "al"', 'material = "cu"'))
    cu = case.materials["cu"]
    assert cu.density == 9000.0
    assert cu.strength.model == "johnson-cook"
    assert cu.strength.A == 90e6 and cu.strength.B == 300e6 and cu.strength.n == 0.31
    assert cu.shear_modulus == 47.7e9
    assert cu.bulk_modulus == pytest.approx(9000.0 * 3940.0**2)  # rho c0^2 with the new rho
    assert cu.eos.model == "mie-gruneisen" and cu.eos.c0 == 3940.0
    assert "Steinberg" in cu.source and "density" in cu.source and "strength.B" in cu.source


def test_failure_key_none_switches_off_one_library_mechanism(tmp_path):
    text = BASE + """
[[material]]
name = "plate"
library = "al-6061-t6"
failure = { fracture_strain = 1.0, spall_strength = "none", loosening = "none" }
"""
    case = load(tmp_path, text.replace('material = "al"', 'material = "plate"'))
    f = case.materials["plate"].failure
    assert f.spall_strength is None and f.loosening is None and f.fracture_strain == 1.0
    assert f.jc_damage is not None  # what was not switched off stays
    full = load(tmp_path, text.replace('material = "al"', 'material = "plate"').replace(
        ', spall_strength = "none", loosening = "none"', ""))
    assert full.materials["plate"].failure.spall_strength == 1.6e9

    assert full.materials["plate"].failure.spall_time == pytest.approx(0.03e-6)  # calibrated, docs/fracture.md


def test_spall_time_and_criterion_keys(tmp_path):
    """failure.spall_time (the Tuler-Butcher time, fracture/spall.py) comes from the library
    and can be replaced or switched off; [fracture] spall_criterion and spall_pressure default
    to the time integral on the lesser tension; bad values name key and file in one line."""
    text = BASE + """
[[material]]
name = "plate"
library = "al-6061-t6"
failure = { spall_time = "50 ns" }
"""
    case = load(tmp_path, text.replace('material = "al"', 'material = "plate"'))
    assert case.materials["plate"].failure.spall_time == pytest.approx(50e-9)
    assert case.fracture.spall_criterion == "tuler-butcher"
    assert case.fracture.spall_pressure == "lesser"
    off = load(tmp_path, text.replace('material = "al"', 'material = "plate"').replace(
        '"50 ns"', '"none"'))
    assert off.materials["plate"].failure.spall_time is None
    msg = error(tmp_path, text.replace('material = "al"', 'material = "plate"').replace(
        '"50 ns"', '"-1 ns"'))
    assert "spall_time" in msg and "\n" not in msg.strip()
    msg = error(tmp_path, text + '[fracture]\nspall_criterion = "slow"\n')
    assert "spall_criterion" in msg and "\n" not in msg.strip()

def test_library_merge_model_change_and_elastic_set(tmp_path):
    text = BASE + """
[[material]]
library = "al-2024-t3"
youngs_modulus = "72 GPa"
poisson_ratio = 0.33
strength = { model = "ideal-plastic", yield_stress = "345 MPa" }
eos = { model = "linear" }
failure = "none"
"""
    case = load(tmp_path, text.replace('material = "al"', 'material = "al-2024-t3"'))
    mat = case.materials["al-2024-t3"]
    assert mat.strength.model == "ideal-plastic" and mat.strength.yield_stress == 345e6
    assert mat.strength.A == 0.0  # the library's JC keys are gone with the model change
    assert mat.shear_modulus == pytest.approx(72e9 / 2.66)
    assert mat.eos.model == "linear" and mat.eos.c0 == 0.0
    assert mat.failure == Failure()


# --- overrides ------------------------------------------------------------------------------------

@pytest.mark.parametrize("key", ["body.0.mesh_size", "body[0].mesh_size", "body.plate.mesh_size"])
def test_override_addresses_bodies(tmp_path, key):
    case = load(tmp_path, BASE, [f"{key}=0.5 mm"])
    assert case.bodies[0].mesh_size == 0.0005


def test_overrides_take_toml_values_and_create_tables(tmp_path):
    case = load(tmp_path, BASE, [
        "run.cfl=0.3",
        'run.end_time="20 us"',
        "body.0.velocity=[0, 0, -100]",
        "contact.friction=0.25",
        'contact.passes=["node-face"]',
        "material.al.density=2800",
        "run.name=renamed",
    ])
    assert case.run.cfl == 0.3 and case.run.end_time == 2e-5
    assert case.bodies[0].velocity == (0.0, 0.0, -100.0)
    assert case.contact.friction == 0.25 and case.contact.passes == ["node-face"]
    assert case.materials["al"].density == 2800.0
    assert case.run.name == "renamed"


@pytest.mark.parametrize("override, fragment", [
    ("body.0.mesh_sise=1", "body[0].mesh_sise: unknown key 'mesh_sise' in [[body]]; did you mean 'mesh_size'?"),
    ("rn.cfl=0.5", "rn: unknown key 'rn' in the top level; did you mean 'run'?"),
    ("body.3.mesh_size=1", "no element 3: the case has 1 [[body]] tables"),
    ("body.plat.mesh_size=1", "no [[body]] named 'plat'; did you mean 'plate'?"),
    ("run.cfl", "expected KEY=VALUE"),
    ("run.cfl.x=1", "'cfl' is a value, not a table"),
])
def test_override_errors(tmp_path, override, fragment):
    msg = error(tmp_path, BASE, [override])
    assert msg.startswith(f"{tmp_path / 'case.toml'}: ")
    assert fragment in msg
    if "=" in override:
        assert f"(from --set {override})" in msg


def test_invalid_value_from_override_names_the_key(tmp_path):
    msg = error(tmp_path, BASE, ["run.cfl=1.5"])
    assert msg == f"{tmp_path / 'case.toml'}: run.cfl: must be in (0, 0.9], got 1.5"


# --- errors: each names the file and the key ------------------------------------------------------

ERRORS = [
    # (replace this, with this (or append when old is ""), key path, fragment)
    ("mesh_size =", "mesh_sise =", 'body[0].mesh_sise (body "plate")',
     "unknown key 'mesh_sise' in [[body]]; did you mean 'mesh_size'?"),
    ("end_time", "end_tme", "run.end_tme", "did you mean 'end_time'?"),
    ("[[body]]", "[[bodys]]", "bodys", "did you mean 'body'?"),
    ('poisson_ratio = 0.25', 'poisson_ratio = 0.25\nstrength = { model = "johnson-cook", A = 1e8, B = 1e8, nn = 1 }',
     'material[0].strength.nn (material "al")', "did you mean 'n'?"),
    ('end_time = "10 us"\n', "", "run.end_time", "missing required key 'end_time'"),
    ('density = "2700 kg/m^3"\n', "", 'material[0].density (material "al")',
     "missing required key 'density'"),
    ('shape = "box"\n', "", 'body[0].shape (body "plate")', "missing required key 'shape'"),
    ('mesh_size = "1 mm"\n', "", 'body[0].mesh_size (body "plate")',
     "missing required key 'mesh_size'"),
    ('size = ["10 mm", "10 mm", "2 mm"]', 'size = ["10 mm", "10 mm"]', 'body[0].size (body "plate")',
     "expected 3 values, got 2"),
    ("", '[output]\nframes = "many"\n', "output.frames", "expected an integer"),
    # beyond TOML's 64-bit integers (the fuzzer's: an OverflowError in the estimate before)
    ("", "[output]\nframes = " + "9" * 80 + "\n", "output.frames",
     "expected an integer of at most 19 digits (TOML's 64 bits), got one of 80 digits"),
    ("", "[output]\nhistory_every = 1e300\n", "output.history_every", "got one of 301 digits"),
    ("", "[contact]\nself_contact = \"yes\"\n", "contact.self_contact", "expected true or false"),
    ("", "[output]\nfields = \"pressure\"\n", "output.fields", "expected an array"),
    ('end_time = "10 us"', 'end_time = "10 GPa"', "run.end_time", "is a stress, but this key expects a time"),
    ('mesh_size = "1 mm"', 'mesh_size = "1 mmm"', 'body[0].mesh_size (body "plate")', "unknown unit 'mmm'"),
    ('material = "al"', 'material = "alu"', 'body[0].material (body "plate")',
     "unknown material 'alu'"),
    ('material = "al"', 'material = "ofhc-coper"', 'body[0].material (body "plate")',
     "did you mean 'ofhc-copper'?"),
    ('shape = "box"', 'shape = "bx"', 'body[0].shape (body "plate")', "unknown shape 'bx'; did you mean 'box'?"),
    ("", '[contact]\npasses = ["node-face", "edge-egde"]\n', "contact.passes[1]",
     "unknown value 'edge-egde' in passes; did you mean 'edge-edge'?"),
    ('poisson_ratio = 0.25', 'poisson_ratio = 0.25\nstrength = { model = "johnson-cok" }',
     'material[0].strength.model (material "al")', "did you mean 'johnson-cook'?"),
    ('poisson_ratio = 0.25', 'poisson_ratio = 0.25\neos = { model = "gruneisen" }',
     'material[0].eos.model (material "al")', "did you mean 'mie-gruneisen'?"),
    ("", '[[material]]\nname = "x"\nlibrary = "al-2042-t3"\n', 'material[1].library (material "x")',
     "unknown library material 'al-2042-t3'; did you mean 'al-2024-t3'?"),
    ('density = "2700 kg/m^3"', "density = 0", 'material[0].density (material "al")', "> 0, got 0"),
    # a wave speed beyond the floats (the fuzzer's: a ZeroDivisionError in the estimate before)
    ('density = "2700 kg/m^3"', 'density = "1.4e-303 kg/m^3"',
     'material[0].density (material "al")', "gives a wave speed of inf m/s"),
    ('youngs_modulus = "70 GPa"', 'youngs_modulus = "-70 GPa"', 'material[0].youngs_modulus (material "al")', "> 0"),
    ('poisson_ratio = 0.25', "poisson_ratio = 0.5", 'material[0].poisson_ratio (material "al")',
     "must be in (-1, 0.5), got 0.5"),
    ('poisson_ratio = 0.25', "poisson_ratio = -1", 'material[0].poisson_ratio (material "al")',
     "must be in (-1, 0.5), got -1"),
    ('poisson_ratio = 0.25', 'shear_modulus = "20 GPa"', 'material[0].shear_modulus (material "al")',
     "give a Poisson ratio of 0.75"),
    ('poisson_ratio = 0.25', 'poisson_ratio = 0.25\nbulk_modulus = "1 GPa"',
     'material[0].bulk_modulus (material "al")', "too many elastic constants"),
    ('poisson_ratio = 0.25\n', "", 'material[0].youngs_modulus (material "al")',
     "missing elastic constants"),
    ('end_time = "10 us"', 'end_time = "10 us"\ncfl = 0', "run.cfl", "must be in (0, 0.9], got 0"),
    ('end_time = "10 us"', "end_time = 1e-5\ncfl = 1.2", "run.cfl", "must be in (0, 0.9], got 1.2"),
    ('end_time = "10 us"', 'end_time = "-10 us"', "run.end_time", "must be > 0, got -1e-05 s"),
    ('mesh_size = "1 mm"', "mesh_size = 0", 'body[0].mesh_size (body "plate")', "must be > 0, got 0"),
    ('size = ["10 mm", "10 mm", "2 mm"]', 'size = ["10 mm", "-10 mm", "2 mm"]',
     'body[0].size[1] (body "plate")', "must be > 0"),
    ('poisson_ratio = 0.25', 'poisson_ratio = 0.25\nfailure = { spall_strength = "-1 GPa" }',
     'material[0].failure.spall_strength (material "al")', "must be > 0"),
    ('poisson_ratio = 0.25', 'poisson_ratio = 0.25\nfailure = { spall_strength = "1 GPa", loosening = 1.0 }',
     'material[0].failure.loosening (material "al")', "must be in (0, 1), got 1"),
    ("", "[contact]\nfriction = -0.1\n", "contact.friction", "must be >= 0, got -0.1"),
    ("", "[[wall]]\nnormal = [0, 0, 1]\nfriction = -1\n", "wall[0].friction", "must be >= 0"),
    ("", "[[wall]]\nnormal = [0, 0, 0]\n", "wall[0].normal", "must be a nonzero vector"),
    ("", '[[body]]\nname = "plate"\nmaterial = "al"\nshape = "sphere"\nradius = 0.01\nmesh_size = 0.001\n',
     "body[1].name", "duplicate body name 'plate' (also body[0])"),
    ("", '[[material]]\nname = "al"\ndensity = 1\nshear_modulus = 1\nbulk_modulus = 1\n',
     "material[1].name", "duplicate material name 'al' (also material[0])"),
    ('shape = "box"\nsize = ["10 mm", "10 mm", "2 mm"]', 'shape = "sphere"\nradius = 0.01\nheight = 0.01',
     'body[0].height (body "plate")', "does not apply to shape 'sphere'"),
    ('mesh_size = "1 mm"', 'mesh_size = "1 mm"\nspeed = 10', 'body[0].direction (body "plate")',
     "missing required key 'direction' with speed"),
    ('mesh_size = "1 mm"', 'mesh_size = "1 mm"\nvelocity = [1, 0, 0]\nspeed = 10\ndirection = [1, 0, 0]',
     'body[0].speed (body "plate")', "not both"),
    ('shape = "box"\nsize = ["10 mm", "10 mm", "2 mm"]', 'shape = "sphere"\nradius = 0.01\nmesher = "structured"',
     'body[0].mesher (body "plate")', "mesher 'structured' meshes box, plate, cube12 only"),
    ("", '[[body.constraint]]\nnodes = { box = { lo = [0, 0, 0], hi = [1, 1, 1] } }\n',
     'body[0].constraint[0].velocity (body "plate")', "(or fixed = true)"),
    ("", '[[body.constraint]]\nnodes = "some"\nfixed = true\n',
     'body[0].constraint[0].nodes (body "plate")', 'expected a table or "all"'),
    ("", '[[body.constraint]]\nnodes = { box = { lo = [0, 0, 0], hi = [1, 1, 1] }, outside_radius = 1 }\nfixed = true\n',
     'body[0].constraint[0].nodes (body "plate")', "give exactly one of box, outside_radius, plane"),
    ("", '[[body.constraint]]\nnodes = { box = { lo = [0, 0, 2], hi = [1, 1, 1] } }\nfixed = true\n',
     'body[0].constraint[0].nodes.box.hi (body "plate")', "is below lo"),
    ("", '[output]\ntimes = ["1 us", "20 us"]\n', "output.times[1]", "after run.end_time"),
    ('shape = "box"\nsize = ["10 mm", "10 mm", "2 mm"]', 'shape = "file"\npath = "missing.msh"',
     'body[0].path (body "plate")', "mesh file not found"),
    ('[[body]]\nname = "plate"\nmaterial = "al"\nshape = "box"\nsize = ["10 mm", "10 mm", "2 mm"]\nmesh_size = "1 mm"\n',
     "", "body", "the case has no bodies"),
    ('[run]\nend_time = "10 us"\n', "run = 3\n", "run", "expected a table, got an integer"),
    ("[[body]]", "[body]", "body", "expected an array of tables ([[body]]), got a single table"),
    ('poisson_ratio = 0.25', 'poisson_ratio = 0.25\nstrength = { model = "ideal-plastic", A = 1 }',
     'material[0].strength.A (material "al")', "does not apply to strength model 'ideal-plastic'"),
    ('poisson_ratio = 0.25', 'poisson_ratio = 0.25\nfailure = { erosion = "plastic-strain" }',
     'material[0].failure.erosion_value (material "al")', "missing required key 'erosion_value'"),
]


@pytest.mark.parametrize("old, new, key, fragment", ERRORS,
                         ids=[f"{i}-{e[2].split(' ')[0]}" for i, e in enumerate(ERRORS)])
def test_error_names_file_key_and_problem(tmp_path, old, new, key, fragment):
    if old:
        assert old in BASE
        text = BASE.replace(old, new, 1)
    else:
        text = BASE + new
    msg = error(tmp_path, text)
    assert msg.startswith(f"{tmp_path / 'case.toml'}: {key}: "), msg
    assert fragment in msg, msg


def test_toml_syntax_error_gives_line_and_column(tmp_path):
    msg = error(tmp_path, BASE.replace('name = "plate"', 'name = "plate'))
    assert msg.startswith(f"{tmp_path / 'case.toml'}: line 11, column 14: ")
    assert "invalid TOML" in msg


def test_missing_file(tmp_path):
    with pytest.raises(CaseError) as err:
        load_case(tmp_path / "nope.toml")
    assert str(err.value) == f"{tmp_path / 'nope.toml'}: file not found"


def test_text_without_file_is_named_string():
    with pytest.raises(CaseError, match=r"^<string>: run.end_time: missing"):
        load_case_text(BASE.replace('end_time = "10 us"\n', ""))


# --- the generated reference ----------------------------------------------------------------------

def test_committed_reference_matches_the_key_table():
    committed = Path(__file__).parents[2] / "docs" / "case-reference.md"
    assert committed.read_text() == render_reference(), \
        "regenerate: python -m impactsim.case.reference > docs/case-reference.md"


def test_reference_documents_every_key():
    text = render_reference()
    for key in ["end_time", "mesh_size", "obliquity_axis", "spall_strength", "outside_radius",
                "self_contact", "erosion_region", "jc_damage", "history_every"]:
        assert f"`{key}`" in text
    assert "`ofhc-copper`" in text and "`d16t`" in text


def test_case_built_in_python_dumps_and_reloads():
    """A Case made in Python (numpy values allowed) gives a resolved TOML that loads back."""
    import numpy as np

    from impactsim.case.schema import EOS, Body, Case, Material, Run, Strength

    steel = Material(name="s", density=7850.0, shear_modulus=80e9, bulk_modulus=160e9,
                     strength=Strength(model="ideal-plastic", yield_stress=1e9),
                     eos=EOS(model="linear"))
    body = Body(name="b", material="s", shape="box", dimensions={"size": (0.01, 0.01, 0.01)},
                mesh_size=0.002, velocity=tuple(np.array([0.0, 0.0, -50.0])))
    case = Case(source=None, run=Run(name="py", end_time=1e-5), materials={"s": steel},
                bodies=[body])
    again = load_case_text(tomli_w.dumps(case_to_dict(case)))
    assert again == case


def test_node_separation_key_is_validated(tmp_path):
    """failure.fracture_strain switches node separation on; it must be positive."""
    text = BASE.replace('poisson_ratio = 0.25\n',
                        'poisson_ratio = 0.25\nfailure = { fracture_strain = -0.8 }\n')
    msg = error(tmp_path, text)
    assert "material[0].failure.fracture_strain" in msg and "> 0" in msg
