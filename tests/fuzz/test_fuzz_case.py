"""Property-based fuzzing of case files: every input ends in a valid case or one clean error.

Hypothesis mutates the bundled cases (a value replaced by another of any type, extreme numbers,
unit strings with huge exponents, keys deleted or invented, tables nested deeply, the text cut or
spliced) and runs what `impactsim check` runs on each. An example passes when the check either
accepts a case that makes sense (finite positive sizes and times, a Courant number in its range,
an estimate with finite figures) or raises a CaseError whose message is one line naming the file
- never another exception, never a hang (each example has a deadline).

`make test` runs FAST_EXAMPLES examples; `make hard` (the slow marker) SLOW_EXAMPLES.
"""

from __future__ import annotations

import copy
import math
import os
import tomllib
from pathlib import Path

import pytest
import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from impactsim.case import CaseError, load_case_text
from impactsim.case.describe import describe_case

ROOT = Path(__file__).resolve().parents[2]
CASE_FILES = sorted((ROOT / "cases").glob("*.toml"))
BASES = [(p, tomllib.loads(p.read_text())) for p in CASE_FILES]
FAST_EXAMPLES = 200
SLOW_EXAMPLES = 2000
SOURCE = ROOT / "cases" / "fuzzed.toml"  # names the file in messages (never written)

UNITS = ["m", "mm", "us", "s", "ns", "GPa", "m/s", "km/s", "deg", "K", "kg/m^3", "J/kg", "bar",
         "furlong", ""]
numbers = st.one_of(
    st.integers(min_value=-10**6, max_value=10**6),
    st.integers(min_value=-10**400, max_value=10**400),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, -0.0, 1e-300, 1e300, 5e-324, 1.7976931348623157e308, 0.99, 1.0, 1.01]),
)
unit_strings = st.builds(
    lambda m, e, u: f"{m}e{e} {u}".strip(),
    st.integers(min_value=-9, max_value=9),
    st.one_of(st.integers(min_value=-400, max_value=400),
              st.integers(min_value=-10**9, max_value=10**9)),
    st.sampled_from(UNITS))
leaves = st.one_of(numbers, unit_strings, st.booleans(), st.text(max_size=12),
                   st.sampled_from(["all", "none", "free", "file", "gmsh", "structured",
                                    "elastic", "johnson-cook", "node-face", "../../x"]))
values = st.recursive(leaves, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(st.text(min_size=1, max_size=6), inner,
                                                 max_size=3)), max_leaves=8)


factors = st.one_of(st.sampled_from([0.0, -1.0, 1e-300, 1e-30, 1e-6, 1e-3, 0.1, 0.5, 2.0, 10.0,
                                     1e3, 1e6, 1e30, 1e300, math.inf, math.nan]),
                    st.floats(min_value=-1e3, max_value=1e3))


def _scaled(value, factor):
    """`value` times `factor`: numbers, the number of a '<number> <unit>' string, and each item
    of an array; other values unchanged."""
    if isinstance(value, bool):
        return value
    if isinstance(value, int):
        try:
            scaled = value * factor
        except OverflowError:
            return value
        return int(scaled) if math.isfinite(scaled) and abs(scaled) < 1e18 else scaled
    if isinstance(value, float):
        return value * factor
    if isinstance(value, str):
        number, _, unit = value.partition(" ")
        try:
            return f"{float(number) * factor!r} {unit}".strip()
        except ValueError:
            return value
    if isinstance(value, list):
        return [_scaled(v, factor) for v in value]
    return value


def _paths(node, prefix=()):
    """Every (container, key) pair of the raw case tree."""
    items = node.items() if isinstance(node, dict) else enumerate(node)
    for key, val in items:
        yield prefix + (key,)
        if isinstance(val, (dict, list)):
            yield from _paths(val, prefix + (key,))


def _at(root, path):
    node = root
    for k in path[:-1]:
        node = node[k]
    return node


@st.composite
def mutated_case(draw) -> str:
    """The text of a bundled case after 1-4 random mutations."""
    path, raw = draw(st.sampled_from(BASES))
    raw = copy.deepcopy(raw)
    for _ in range(draw(st.integers(1, 4))):
        paths = list(_paths(raw))
        kind = draw(st.sampled_from(["scale", "scale", "scale", "scale", "replace", "replace",
                                     "delete", "insert", "nest"]))
        if not paths:
            break
        where = draw(st.sampled_from(paths))
        parent = _at(raw, where)
        key = where[-1]
        if kind == "scale":  # the same kind of value, another magnitude (units kept)
            parent[key] = _scaled(parent[key], draw(factors))
        elif kind == "replace":
            parent[key] = draw(values)
        elif kind == "delete":
            del parent[key]
        elif kind == "insert" and isinstance(parent, dict):
            parent[draw(st.sampled_from(["mesh_size", "cfl", "size", "radius", "frames",
                                         "times", "name", "directory", "bogus"]))] = draw(values)
        elif kind == "nest":
            inner = parent[key]
            for _ in range(draw(st.integers(1, 60))):
                inner = [inner]
            parent[key] = inner
    try:
        text = tomli_w.dumps(raw)
    except (TypeError, ValueError):  # a value TOML cannot hold
        text = path.read_text()
    edit = draw(st.sampled_from(["none", "none", "none", "cut", "splice", "deep"]))
    if edit == "cut":
        text = text[:draw(st.integers(0, len(text)))]
    elif edit == "splice":
        at = draw(st.integers(0, len(text)))
        text = text[:at] + draw(st.text(max_size=20)) + text[at:]
    elif edit == "deep":
        depth = draw(st.sampled_from([50, 500, 5000, 50000]))
        text += "\nx = " + "[" * depth + "]" * depth + "\n"
    return text


def sensible(case) -> None:
    """What an accepted case must satisfy (a nonsensical case is never accepted silently)."""
    run = case.run
    assert math.isfinite(run.end_time) and run.end_time > 0
    assert 0 < run.cfl <= 0.9 and run.max_steps >= 1
    assert case.bodies
    name = run.name
    assert name and "/" not in name and "\\" not in name and name not in (".", "..")
    for body in case.bodies:
        assert body.mesh_size >= 0 and math.isfinite(body.mesh_size)
        for v in (*body.position, *body.velocity, *body.rotation):
            assert math.isfinite(v)
    for mat in case.materials.values():
        assert mat.density > 0 and math.isfinite(mat.density)
        assert mat.shear_modulus >= 0 and mat.bulk_modulus > 0


def check_text(text: str) -> None:
    """What `impactsim check` does with the text, minus meshing of primitives."""
    try:
        case = load_case_text(text, source=SOURCE)
        out = describe_case(case, mesh=False)
    except CaseError as err:
        msg = str(err)
        assert msg.startswith(str(SOURCE) + ": "), msg
        return
    sensible(case)
    assert "nan" not in out.split("# cost estimate:")[-1].lower(), out


@pytest.fixture(autouse=True, scope="module")
def _no_calibration():
    old = os.environ.get("IMPACTSIM_NO_CALIBRATE")
    os.environ["IMPACTSIM_NO_CALIBRATE"] = "1"
    yield
    if old is None:
        del os.environ["IMPACTSIM_NO_CALIBRATE"]
    else:
        os.environ["IMPACTSIM_NO_CALIBRATE"] = old


# the deadline catches a hang, not slowness: an example takes 0.1-3 s, and 4.3 s on a machine
# at load 3 (a 2.9 m long hex rod checked) failed the 3 s deadline once
FUZZ = dict(deadline=30_000, suppress_health_check=[HealthCheck.too_slow,
                                                   HealthCheck.data_too_large], derandomize=True)


@settings(max_examples=FAST_EXAMPLES, **FUZZ)
@given(mutated_case())
def test_fuzzed_case_files_end_clean(text):
    check_text(text)


@pytest.mark.slow
@settings(max_examples=SLOW_EXAMPLES, **dict(FUZZ, derandomize=False))
@given(mutated_case())
def test_fuzzed_case_files_end_clean_many(text):
    check_text(text)


@pytest.mark.parametrize("text_edit, fragment", [
    (lambda t: t.replace('end_time = "60 us"', 'end_time = "1e99999999 us"'), "run.end_time"),
    (lambda t: t.replace('end_time = "60 us"', 'end_time = "1e-99999999 us"'), "run.end_time"),
    (lambda t: t + "\nx = " + "[" * 5000 + "]" * 5000, "nested too deeply"),
    (lambda t: t.replace('cfl = 0.6', 'cfl = 1' + '0' * 5000), "4300"),
    (lambda t: t.replace('mesh_size = "2.5 mm"', 'mesh_size = 1e-300'), "mesh_size"),
    (lambda t: t.replace('name = "elastic-bar-wall"', 'name = "../../escape"'), "run.name"),
])
def test_reproducers_of_issue_16(text_edit, fragment):
    """Each was a traceback, a hang or an accepted nonsense on `impactsim check`."""
    text = text_edit((ROOT / "cases" / "elastic-bar-wall.toml").read_text())
    with pytest.raises(CaseError) as err:
        load_case = load_case_text(text, source=SOURCE)
        describe_case(load_case, mesh=False)
    assert fragment in str(err.value) and "\n" not in str(err.value)


override_keys = st.one_of(
    st.sampled_from(["run.cfl", "run.end_time", "body.0.mesh_size", "body[0].velocity",
                     "body.bar.position", "output.frames", "contact.passes", "run.name",
                     "material.0.density", "body.9.size", "wall.0.normal", "checks.energy_balance",
                     "body." + "9" * 5000 + ".x", "run", "body", ""]),
    st.text(max_size=20))
override_values = st.one_of(
    st.sampled_from(["0.5", "1e99999999", '"1e99999999 us"', "[[[[[]]]]]", "nan", "inf", '"x"',
                     "{a = 1}", "true", '"../../x"', "[" * 3000 + "]" * 3000, "1" * 5000, ""]),
    st.text(max_size=20))


def check_overrides(pairs):
    text = (ROOT / "cases" / "elastic-bar-wall.toml").read_text()
    try:
        case = load_case_text(text, source=SOURCE, overrides=[f"{k}={v}" for k, v in pairs])
        describe_case(case, mesh=False)
    except CaseError as err:
        assert str(err).startswith(str(SOURCE) + ": "), str(err)
        return
    sensible(case)


overrides = st.lists(st.tuples(override_keys, override_values), min_size=1, max_size=3)


@settings(max_examples=FAST_EXAMPLES, **FUZZ)
@given(overrides)
def test_fuzzed_overrides_end_clean(pairs):
    check_overrides(pairs)


@pytest.mark.slow
@settings(max_examples=SLOW_EXAMPLES, **dict(FUZZ, derandomize=False))
@given(overrides)
def test_fuzzed_overrides_end_clean_many(pairs):
    check_overrides(pairs)
