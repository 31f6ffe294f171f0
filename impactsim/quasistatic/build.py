"""A validated quasistatic case -> a ``Problem``: meshes (one per [[body]] entry, shared by its
copies), facet sets of the boundary parts, materials and settings."""

from __future__ import annotations

import numpy as np

from impactsim.quasistatic import geometry as geo
from impactsim.quasistatic.interfaces import SetupError
from impactsim.quasistatic.model import (BodyModel, Condition, ContactRule, Problem, Settings,
                                         ThermoMaterial)


def materials(case) -> dict[str, ThermoMaterial]:
    out = {}
    for name, m in case.materials.items():
        out[name] = ThermoMaterial(
            name=name, youngs_modulus=m.youngs_modulus, poisson_ratio=m.poisson_ratio,
            expansion=m.expansion, conductivity=m.conductivity or 1.0,
            conductivity_table=m.conductivity_table, density=m.density,
            heat_capacity=m.specific_heat, reference_temperature=m.initial_temperature)
    return out


def _mesh(b) -> tuple[np.ndarray, np.ndarray, dict]:
    if b.shape == "file":
        p, t, groups = geo.read_mesh(b.dims["path"], b.dims["scale"])
        p = p - 0.5 * (p.min(axis=0) + p.max(axis=0))
    else:
        refine = geo.Refine(**b.refine) if b.refine else None
        p, t = geo.primitive(b.shape, b.dims, b.mesh_size, refine, b.clip,
                             structured=b.mesher == "structured")
        groups = {}
    return p, t, groups


def _conditions(bd, mesh, groups: dict, shift: np.ndarray, mesh_size: float) -> list[Condition]:
    if bd.region == "plane":
        facets = geo.select_plane(mesh, np.asarray(bd.params["point"]) + shift,
                                  bd.params["normal"], bd.tolerance)
    elif bd.region == "box":
        facets = geo.select_box(mesh, np.asarray(bd.params["lo"]) + shift,
                                np.asarray(bd.params["hi"]) + shift, bd.tolerance)
    elif bd.region == "cylinder":
        facets = geo.select_cylinder(mesh, np.asarray(bd.params["point"]) + shift,
                                     bd.params["axis"], bd.params["radius"], bd.tolerance)
    else:
        if bd.params["group"] not in groups:
            raise SetupError(f"{bd.where}.group: no physical group '{bd.params['group']}' of "
                             f"triangles in the mesh (it has: {', '.join(groups) or 'none'})")
        facets = geo.select_triangles(mesh, groups[bd.params["group"]])
    if not len(facets):
        raise SetupError(f"{bd.where}: the {bd.region} selects no boundary facet of the body")
    out = []
    c = bd.conditions
    for kind in ("temperature", "flux", "pressure"):
        if kind in c:
            out.append(Condition(kind, facets, value=c[kind], ramp=bd.ramp, name=bd.name))
    if "exchange" in c:
        out.append(Condition("exchange", facets, value=c["exchange"], ambient=c["ambient"],
                             name=bd.name))
    if "displacement" in c:
        out.append(Condition("displacement", facets, vector=c["displacement"], ramp=bd.ramp,
                             name=bd.name))
    if "traction" in c:
        out.append(Condition("traction", facets, vector=c["traction"], ramp=bd.ramp,
                             name=bd.name))
    return out


def problem(case) -> Problem:
    mats = materials(case)
    order = 2 if case.settings["element"] == "tet10" else 1
    bodies = []
    for b in case.bodies:
        p0, t0, groups = _mesh(b)
        p0 = geo.place(p0, b.rotation, b.position)
        t0 = geo.fix_orientation(p0, t0)
        count, offset = b.copies if b.copies else (1, (0.0, 0.0, 0.0))
        for k in range(count):
            shift = k * np.asarray(offset, float)
            name = f"{b.name}{k + 1}" if b.copies else b.name
            model = BodyModel(name, (p0 + shift).T.copy(), t0.T.copy(), order,
                              mats[b.material], initial_temperature=b.initial_temperature,
                              centering_axis=b.centering_axis)
            mesh = model.mesh()
            for bd in b.boundaries:
                model.conditions += _conditions(bd, mesh, groups, shift, b.mesh_size)
            if b.heat_source:
                model.conditions.append(Condition("source", value=b.heat_source))
            bodies.append(model)
    s = case.settings
    settings = Settings(times=case.times, heat_transient=s["heat"] == "transient",
                        relaxation=s["relaxation"], aitken=s["aitken"], coarse=s["coarse"],
                        anderson=s["anderson"],
                        solver=s["solver"], direct_limit=s["direct_limit"],
                        max_iterations=s["max_iterations"], gap_tolerance=s["gap_tolerance"],
                        pressure_tolerance=s["pressure_tolerance"],
                        heat_tolerance=s["heat_tolerance"],
                        max_heat_iterations=s["max_heat_iterations"],
                        regularization=s["regularization"], detect_tolerance=case.gap_tolerance,
                        detect=case.detect)
    rules = [ContactRule(p.bodies[0], p.bodies[1], p.friction, p.conductance, p.gap_tolerance,
                         p.tied, p.robin) for p in case.pairs]
    pairs = None
    if not case.detect:
        import fnmatch
        names = [m.name for m in bodies]
        pairs = [(x, y) for p in case.pairs
                 for i, x in enumerate(names) for y in names[i + 1:]
                 if (fnmatch.fnmatchcase(x, p.bodies[0]) and fnmatch.fnmatchcase(y, p.bodies[1]))
                 or (fnmatch.fnmatchcase(y, p.bodies[0]) and fnmatch.fnmatchcase(x, p.bodies[1]))]
    return Problem(bodies, rules, settings, pairs)
