"""``Case`` -> plain tables of SI numbers (the resolved case, re-loadable by load_case).

Every default is written out, so the result documents exactly what ran; tomli_w turns it into
``case.resolved.toml``. Keys absent from the result are the ones that are off (None).
"""

from __future__ import annotations

from dataclasses import fields
from pathlib import PurePath

from impactsim.case.schema import (EOS, Body, Case, Constraint, Material, NodeSelector, Strength,
                                   Wall)
from impactsim.case.spec import EOS_KEYS, STRENGTH_KEYS


def case_to_dict(case: Case) -> dict:
    """The resolved case as TOML-serialisable tables (lists, floats, ints, bools, strings)."""
    out: dict = {"run": _plain(_fields(case.run))}
    out["material"] = [_material(m) for m in case.materials.values()]
    out["body"] = [_body(b) for b in case.bodies]
    if case.walls:
        out["wall"] = [_wall(w) for w in case.walls]
    output = _fields(case.output)
    out["output"] = _plain({k: v for k, v in output.items() if v is not None})
    out["contact"] = _plain(_fields(case.contact))
    out["fracture"] = _plain({k: v for k, v in _fields(case.fracture).items() if v is not None})
    out["checks"] = _plain(_fields(case.checks))
    return out


def _fields(obj) -> dict:
    return {f.name: getattr(obj, f.name) for f in fields(obj)}


def _plain(value):
    """Tuples -> lists, paths -> strings, numpy arrays and scalars -> Python, recursively."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, PurePath):
        return str(value)
    if hasattr(value, "tolist"):  # a case built in Python may hold numpy values
        return _plain(value.tolist())
    return value


def _material(m: Material) -> dict:
    return _plain({
        "name": m.name,
        "source": m.source,
        "density": m.density,
        "shear_modulus": m.shear_modulus,
        "bulk_modulus": m.bulk_modulus,
        "specific_heat": m.specific_heat,
        "taylor_quinney": m.taylor_quinney,
        "initial_temperature": m.initial_temperature,
        "strength": _model_table(m.strength, STRENGTH_KEYS[m.strength.model]),
        "eos": _model_table(m.eos, EOS_KEYS[m.eos.model]),
        "failure": {k: v for k, v in _fields(m.failure).items() if v is not None},
    })


def _model_table(obj: Strength | EOS, keys: tuple[str, ...]) -> dict:
    table = {"model": obj.model, **{k: getattr(obj, k) for k in keys}}
    if isinstance(obj, EOS) and obj.model == "linear" and obj.c0 == 0.0:
        del table["c0"]  # not given: the linear EOS uses the bulk modulus
    return table


def _body(b: Body) -> dict:
    out = {"name": b.name, "material": b.material, "shape": b.shape}
    out.update(b.dimensions)
    out.update(position=b.position, rotation=b.rotation)
    if b.mesh_size > 0.0:
        out["mesh_size"] = b.mesh_size
    out.update(mesher=b.mesher, velocity=b.velocity, angular_velocity=b.angular_velocity)
    if b.element != "tet":
        out.update(element=b.element, hourglass=b.hourglass,
                   hourglass_coefficient=b.hourglass_coefficient)
    if b.constraints:
        out["constraint"] = [_constraint(c) for c in b.constraints]
    return _plain(out)


def _constraint(c: Constraint) -> dict:
    return {"nodes": _selector(c.nodes),
            "velocity": ["free" if v is None else v for v in c.velocity]}


def _selector(s: NodeSelector):
    p = s.params
    if s.kind == "all":
        return "all"
    if s.kind == "box":
        return {"box": {"lo": p["lo"], "hi": p["hi"]}}
    if s.kind == "outside-radius":
        return {"outside_radius": p["radius"], "center": p["center"], "axis": p["axis"]}
    if s.kind == "plane":
        return {"plane": {"point": p["point"], "normal": p["normal"]},
                "tolerance": p["tolerance"]}
    raise ValueError(f"unknown node selector kind {s.kind!r}")


def _wall(w: Wall) -> dict:
    return _plain(_fields(w))


__all__ = ["case_to_dict"]
