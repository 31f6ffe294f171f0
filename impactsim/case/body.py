"""[[body]], [[body.constraint]] and [[wall]] tables -> schema.Body, Constraint, Wall."""

from __future__ import annotations

import math
from pathlib import Path

from impactsim.case.errors import KeyPath
from impactsim.case.read import Reader, non_negative, positive, type_name, unit_vector
from impactsim.case.schema import HOURGLASS_DEFAULTS, Body, Constraint, NodeSelector, Wall
from impactsim.case.spec import (BODY, CONSTRAINT, SHAPE_KEYS, STRUCTURED_SHAPES,
                                 UNMESHED_SHAPES, WALL)

Vec = tuple[float, float, float]
DEFAULT_PLANE_TOLERANCE = 1e-6  # [m] for bodies without a mesh size
PLANE_TOLERANCE_FRACTION = 0.01  # of the body's mesh size


def read_body(raw: dict, path: KeyPath, index: int, base_dir: Path) -> Body:
    """One [[body]] table; `material` is returned as written (the caller resolves it)."""
    name = raw.get("name", f"body{index}")
    if not isinstance(name, str) or not name:
        raise path.key("name").error(f"expected a non-empty string, got {type_name(name)}")
    r = Reader(raw, BODY, path.labelled(f'body "{name}"'))
    shape = r.get("shape")
    for key in {k for keys in SHAPE_KEYS.values() for k in keys} - set(SHAPE_KEYS[shape]):
        if r.has(key):
            raise r.error(key, f"key '{key}' does not apply to shape '{shape}' "
                               f"(its keys: {', '.join(SHAPE_KEYS[shape])})")
    mesh_size = 0.0
    if shape not in UNMESHED_SHAPES or r.has("mesh_size"):
        mesh_size = _length(r.get("mesh_size"), r.at("mesh_size"))
    mesher = r.get("mesher")
    if mesher == "structured" and shape not in STRUCTURED_SHAPES:
        raise r.error("mesher", f"mesher 'structured' meshes {', '.join(STRUCTURED_SHAPES)} "
                                f"only, not '{shape}'")
    position = r.get("position")
    element = r.get("element")
    hourglass = r.get("hourglass")
    if element != "hex8":
        for key in ("hourglass", "hourglass_coefficient"):
            if r.has(key):
                raise r.error(key, f"'{key}' applies to element = \"hex8\" bodies only")
    if element == "hex8" and shape == "cube12":
        raise r.error("element", "shape 'cube12' is the 12-tet cube; use shape 'box' for hexes")
    hg_coef = (non_negative(r.get("hourglass_coefficient"), r.at("hourglass_coefficient"))
               if r.has("hourglass_coefficient") else HOURGLASS_DEFAULTS[hourglass])
    body = Body(
        name=name,
        material=r.get("material"),
        shape=shape,
        dimensions=_dimensions(r, shape, base_dir),
        position=position,
        rotation=r.get("rotation"),
        mesh_size=mesh_size,
        mesher=mesher,
        velocity=_velocity(r),
        angular_velocity=r.get("angular_velocity"),
        element=element,
        hourglass=hourglass,
        hourglass_coefficient=hg_coef,
    )
    for raw_c, where in r.items("constraint"):
        body.constraints.append(read_constraint(raw_c, where, body))
    return body


MIN_LENGTH = 1e-9  # [m] sizes and mesh sizes below a nanometre are no continuum body


def _length(value: float, path: KeyPath) -> float:
    """A positive size of at least MIN_LENGTH."""
    positive(value, path)
    if value < MIN_LENGTH:
        raise path.error(f"{value:g} m is below {MIN_LENGTH:g} m: no continuum body is that small "
                         "(a wrong unit?)")
    return value


def _either(r: Reader, a: str, b: str, why: str) -> float:
    given = r.given((a, b))
    if len(given) == 2:
        raise r.error(b, f"give {a} or {b}, not both")
    if not given:
        raise r.error(a, f"missing required key '{a}' (or '{b}') for shape '{why}'")
    return _length(r.get(given[0]), r.at(given[0]))


def _dimensions(r: Reader, shape: str, base_dir: Path) -> dict:
    if shape in ("box", "plate"):
        size = r.require("size", f" for shape '{shape}'", kind="vector")
        for i, s in enumerate(size):
            _length(s, r.at(f"size[{i}]"))
        return {"size": size}
    if shape == "cube12":
        return {"size": _length(r.require("size", " for shape 'cube12' (edge length)",
                                          kind="quantity"), r.at("size"))}
    if shape == "sphere":
        d = _either(r, "radius", "diameter", shape)
        return {"radius": d / 2 if r.has("diameter") else d}
    if shape == "cylinder":
        d = _either(r, "radius", "diameter", shape)
        h = _either(r, "height", "length", shape)
        return {"radius": d / 2 if r.has("diameter") else d, "height": h,
                "axis": unit_vector(r.get("axis"), r.at("axis"))}
    # file
    rel = r.require("path", " for shape 'file'")
    path = rel if rel.is_absolute() else (base_dir / rel)
    path = path.resolve()
    if not path.is_file():
        raise r.error("path", f"mesh file not found: {path}")
    return {"path": path, "scale": positive(r.get("scale"), r.at("scale"))}


def _velocity(r: Reader) -> Vec:
    if not r.has("speed"):
        for key in ("direction", "obliquity", "obliquity_axis"):
            if r.has(key):
                raise r.error(key, f"'{key}' goes with speed (speed = ..., direction = [...])")
        return r.get("velocity")
    if r.has("velocity"):
        raise r.error("speed", "give velocity or speed with direction, not both")
    speed = non_negative(r.get("speed"), r.at("speed"))
    direction = unit_vector(r.require("direction", " with speed"), r.at("direction"))
    angle = r.get("obliquity")
    if angle != 0.0:
        axis = r.get("obliquity_axis")
        along = sum(a * d for a, d in zip(axis, direction))
        perp = tuple(a - along * d for a, d in zip(axis, direction))
        if math.sqrt(sum(c * c for c in perp)) < 1e-12:
            raise r.error("obliquity_axis", "is parallel to direction: give an axis "
                                            "perpendicular to it")
        direction = rotate(direction, unit_vector(perp, r.at("obliquity_axis")), angle)
    return tuple(speed * d for d in direction)


def rotate(v: Vec, axis: Vec, angle: float) -> Vec:
    """v rotated by angle [rad] about the unit vector axis (Rodrigues)."""
    c, s = math.cos(angle), math.sin(angle)
    kx, ky, kz = axis
    cross = (ky * v[2] - kz * v[1], kz * v[0] - kx * v[2], kx * v[1] - ky * v[0])
    dot = kx * v[0] + ky * v[1] + kz * v[2]
    return tuple(v[i] * c + cross[i] * s + axis[i] * dot * (1 - c) for i in range(3))


def read_constraint(raw: dict, path: KeyPath, body: Body) -> Constraint:
    r = Reader(raw, CONSTRAINT, path)
    if not r.has("nodes"):
        raise r.error("nodes", "missing required key 'nodes' (\"all\", or a table with box, "
                               "outside_radius or plane)")
    nodes = _selector(r.sub("nodes"), body)
    if r.has("velocity") and r.has("fixed"):
        raise r.error("fixed", "give velocity or fixed = true, not both")
    if r.has("velocity"):
        return Constraint(nodes=nodes, velocity=r.get("velocity"))
    if not r.get("fixed"):
        raise r.error("velocity", "missing required key 'velocity' (or fixed = true)")
    return Constraint(nodes=nodes, velocity=(0.0, 0.0, 0.0))


def _selector(r: Reader | str, body: Body) -> NodeSelector:
    if r == "all":
        return NodeSelector(kind="all")
    kinds = r.given(("box", "outside_radius", "plane"))
    if len(kinds) != 1:
        got = f"got {', '.join(kinds)}" if kinds else "got none"
        raise r.path.error(f"give exactly one of box, outside_radius, plane ({got})")
    kind = kinds[0]
    for key, owner in (("center", "outside_radius"), ("axis", "outside_radius"),
                       ("tolerance", "plane")):
        if r.has(key) and kind != owner:
            raise r.error(key, f"'{key}' goes with {owner}, not {kind}")
    if kind == "box":
        box = r.sub("box")
        lo, hi = box.get("lo"), box.get("hi")
        for i in range(3):
            if lo[i] > hi[i]:
                raise box.error("hi", f"component {i} ({hi[i]:g} m) is below lo ({lo[i]:g} m)")
        return NodeSelector(kind="box", params={"lo": lo, "hi": hi})
    if kind == "outside_radius":
        return NodeSelector(kind="outside-radius", params={
            "center": r.get("center") if r.has("center") else body.position,
            "axis": unit_vector(r.get("axis"), r.at("axis")),
            "radius": positive(r.get("outside_radius"), r.at("outside_radius")),
        })
    plane = r.sub("plane")
    if r.has("tolerance"):
        tol = positive(r.get("tolerance"), r.at("tolerance"))
    elif body.mesh_size > 0.0:
        tol = PLANE_TOLERANCE_FRACTION * body.mesh_size
    else:
        tol = DEFAULT_PLANE_TOLERANCE
    return NodeSelector(kind="plane", params={
        "point": plane.get("point"),
        "normal": unit_vector(plane.get("normal"), plane.at("normal")),
        "tolerance": tol,
    })


def read_wall(raw: dict, path: KeyPath) -> Wall:
    r = Reader(raw, WALL, path)
    return Wall(point=r.get("point"), normal=unit_vector(r.get("normal"), r.at("normal")),
                friction=non_negative(r.get("friction"), r.at("friction")))
