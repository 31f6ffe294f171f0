"""What a case would do, for ``impactsim check``: the resolved case and a "what would run" summary.

``describe_case(case)`` is the resolved case as TOML (every default filled in, SI units) followed
by the summary lines of ``what_would_run(case)``: bodies with their estimated element counts,
walls, the stages of the time loop with the passes active in each, output and end time. The
pieces (``body_volume``, ``estimate_elements``, ``active_passes``) are separate functions so a
cost estimator can build on them.
"""

from __future__ import annotations

import math

import tomli_w

from impactsim.case.dump import case_to_dict
from impactsim.case.schema import Body, Case
from impactsim.case.units import format_quantity



CHECK_MESH_LIMIT = 300_000  # `check` meshes the primitives of cases up to this many elements


def describe_case(case: Case, mesh: bool = True) -> str:
    """The resolved case as TOML, then the summary of what would run.

    Raises CaseError for a case that would not fit in memory and for a mesh file that cannot be
    read or makes no valid mesh. Mesh files are always read; with `mesh`, the primitives of a
    case of at most CHECK_MESH_LIMIT estimated elements are meshed too (through the mesh cache,
    so the run reuses them), for exact counts and the initial-overlap check.
    """
    from impactsim.case.estimate import check_fits, estimate_cost
    from impactsim.mesh import mesh_bodies

    check_fits(case, estimate_cost(case, speed=_NO_SPEED))
    files = [i for i, b in enumerate(case.bodies) if b.shape == "file"]
    which = set(files)
    if mesh and sum(estimate_elements(b) or 0 for b in case.bodies) <= CHECK_MESH_LIMIT:
        which = set(range(len(case.bodies)))
    meshes = mesh_bodies(case, which) if which else None
    notes = initial_state_lines(case, meshes) if meshes is not None and \
        all(m is not None for m in meshes) else ["# initial overlap: not checked (the bodies "
                                                   "are not meshed by check: too large)"]
    resolved = tomli_w.dumps(case_to_dict(case))
    return "# resolved case (defaults filled in, SI units)\n" + resolved + "\n" + \
        "\n".join(what_would_run(case, meshes) + notes) + "\n"


def initial_state_lines(case: Case, meshes: list) -> list[str]:
    """checks.initial_penetration on the meshed bodies: a CaseError when its action is error,
    a warning line when warn."""
    from impactsim.case.errors import CaseError
    from impactsim.checks.overlap import initial_overlaps

    action = case.checks.initial_penetration
    if action == "ignore":
        return ["# initial overlap: not checked (checks.initial_penetration = \"ignore\")"]
    found = initial_overlaps(case, meshes)
    if not found:
        return ["# initial overlap: none (no body inside another or behind a wall)"]
    text = "; ".join(f"{o.what} overlap by {format_quantity(o.depth, 'length')} "
                     f"({o.nodes} node(s) inside)" for o in found)
    if action == "error":
        label = f"{case.source}: " if case.source is not None else ""
        raise CaseError(f"{label}checks.initial_penetration: at t = 0 {text}: move the bodies "
                        "apart (or set checks.initial_penetration = \"warn\")")
    return [f"# warning: initial overlap: {text}"]


_NO_SPEED = {"ns_per_element_step": 0.0, "seconds_per_step": 0.0, "source": "none"}


def body_volume(body: Body) -> float | None:
    """[m^3] of the primitive; None for a mesh file (known only once read)."""
    d = body.dimensions
    if body.shape in ("box", "plate"):
        lx, ly, lz = d["size"]
        return lx * ly * lz
    if body.shape == "cube12":
        return d["size"] ** 3
    if body.shape == "cylinder":
        return math.pi * d["radius"] ** 2 * d["height"]
    if body.shape == "sphere":
        return 4.0 / 3.0 * math.pi * d["radius"] ** 3
    return None


def estimate_elements(body: Body) -> int | None:
    """Approximate tetrahedron count of the body's mesh (impactsim.case.estimate.body_elements:
    exact for structured boxes and cube12, fitted to gmsh's meshes otherwise); None for files."""
    from impactsim.case.estimate import body_elements

    return body_elements(body)


def has_contact(case: Case) -> bool:
    return (len(case.bodies) >= 2 or case.contact.self_contact) and bool(case.contact.passes)


def active_passes(case: Case) -> list[tuple[str, str]]:
    """(stage, pass name) of every pass the case asks for, in the order they would run.

    Stages as in impactsim.solver.passes: "velocity" passes correct the predicted velocities
    (boundary conditions, walls, contact), "fracture" passes follow the element update.
    """
    used = [case.materials[b.material] for b in case.bodies]
    fail = [m.failure for m in used]
    passes: list[tuple[str, str]] = []
    if any(b.constraints for b in case.bodies):
        passes.append(("velocity", "boundary-conditions"))
    if case.walls:
        passes.append(("velocity", "walls"))
    separation = any(f.fracture_strain is not None for f in fail)
    distortion = case.fracture.distortion_interval is not None
    fracture = any(f.active for f in fail) or separation or distortion  # fracture_wanted
    if fracture:  # impactsim.fracture.make_fracture_passes (particles first)
        passes.append(("velocity", "fracture.particles"))
    if has_contact(case):
        passes += [("velocity", f"contact.{name}") for name in case.contact.passes]
    if fracture:
        effects = [name for name, on in (
            ("spall", any(f.spall_strength is not None for f in fail)),
            ("loosening", any(f.loosening is not None for f in fail)),
            ("erosion", any(f.erosion is not None for f in fail)),
            ("distortion erosion", distortion)) if on]
        passes.append(("fracture", "fracture (" + ", ".join(effects) + ")"))
        if separation:
            passes.append(("fracture", "fracture.separation"))
    return passes


def what_would_run(case: Case, meshes: list | None = None) -> list[str]:
    """The summary, one line per item (a cost estimate can append its own lines). `meshes`:
    the bodies already meshed ((points, tets) or None each), for exact counts and the checks
    of the initial state."""
    run = case.run
    lines = ["# ---- what would run " + "-" * 58,
             f"# run '{run.name}'" + (f" from {case.source}" if case.source else ""),
             "#", "# bodies:"]
    total, unknown = 0, False
    for i, body in enumerate(case.bodies):
        mesh = meshes[i] if meshes is not None else None
        n = len(mesh[1]) if mesh is not None else estimate_elements(body)
        total += n or 0
        unknown |= n is None
        lines.append("#   " + _body_line(case, body, n))
    lines.append(f"#   total: ≈ {total:,} tetrahedra" + (" + the mesh files'" if unknown else ""))
    if case.walls:
        lines.append("# walls:")
        for i, w in enumerate(case.walls):
            friction = f"friction {w.friction:g}" if w.friction else "frictionless"
            lines.append(f"#   wall[{i}]: point {_vec(w.point, 'length')}, normal "
                         f"({', '.join(f'{c:g}' for c in w.normal)}), {friction}")
    passes = active_passes(case)
    velocity = [name for stage, name in passes if stage == "velocity"]
    fracture = [name for stage, name in passes if stage == "fracture"]
    lines += [
        "#",
        "# time loop, each step:",
        f"#   1. time step: CFL {run.cfl:g} x smallest element transit time; stop when it falls "
        f"below {run.dt_collapse:g} x the first",
        "#   2. forces from element stresses, predictor U* = U + dt F/m",
        f"#   3. velocity passes: {', '.join(velocity) or 'none'}",
        "#   4. move nodes",
        f"#   5. element update: {_element_line(case)}",
        f"#   6. fracture passes: {', '.join(fracture) or 'none'}",
        "#",
        f"# active passes: {', '.join(name for _, name in passes) or 'none'}",
    ]
    if len(case.bodies) < 2 and not case.contact.self_contact and case.contact.passes:
        lines.append("#   (no contact passes: one body and contact.self_contact = false)")
    out = case.output
    frames = f"frames at {len(out.times)} given times" if out.times else \
        f"{out.frames} frames + the initial one"
    directory = out.directory if out.directory is not None else f"out/{run.name}"
    lines += [f"# output: {frames}, history every {out.history_every} step(s), "
              f"to {directory}",
              f"# end time: {format_quantity(run.end_time, 'time')} "
              f"(at most {run.max_steps:,} steps)"]
    lines += [f"# warning: {w}" for w in warnings(case)]
    from impactsim.solver.formulation import locking_hint

    hint = locking_hint(case)
    if hint:
        lines.append(f"# hint: {hint}")
    from impactsim.case.estimate import estimate_lines

    lines += estimate_lines(case, meshes=meshes)
    return lines


def warnings(case: Case) -> list[str]:
    """Things that validate but look unintended."""
    out = []
    used = {b.material for b in case.bodies}
    for name in case.materials:
        if name not in used:
            out.append(f"material '{name}' is not used by any body")
    for body in case.bodies:
        if body.mesh_size > 0 and body.shape != "file":
            smallest = _smallest_dimension(body)
            if smallest is not None and body.mesh_size > smallest:
                out.append(f"body '{body.name}': mesh_size "
                           f"{format_quantity(body.mesh_size, 'length')} exceeds its smallest "
                           f"dimension {format_quantity(smallest, 'length')}")
        mat = case.materials[body.material]
        c0 = mat.eos.c0 or math.sqrt(mat.bulk_modulus / mat.density)
        speed = math.sqrt(sum(v * v for v in body.velocity))
        if speed / c0 > 0.75 and mat.eos.model == "linear":
            out.append(f"body '{body.name}': speed/c0 = {speed / c0:.2f} > 0.75 with a linear "
                       "EOS: a Mie-Grueneisen EOS describes such impacts better (ALGORITHMS.md 1)")
    return out


def _smallest_dimension(body: Body) -> float | None:
    d = body.dimensions
    if body.shape in ("box", "plate"):
        return min(d["size"])
    if body.shape == "cube12":
        return None
    if body.shape == "cylinder":
        return min(2 * d["radius"], d["height"])
    return 2 * d["radius"]


def _body_line(case: Case, body: Body, n: int | None) -> str:
    mat = case.materials[body.material]
    d = body.dimensions
    L = lambda v: format_quantity(v, "length")  # noqa: E731
    if body.shape in ("box", "plate"):
        geometry = f"{body.shape} {' x '.join(L(s) for s in d['size'])}"
    elif body.shape == "cube12":
        geometry = f"cube12 edge {L(d['size'])}"
    elif body.shape == "cylinder":
        geometry = f"cylinder r {L(d['radius'])}, h {L(d['height'])}"
    elif body.shape == "sphere":
        geometry = f"sphere r {L(d['radius'])}"
    else:
        geometry = f"file {d['path']} (scale {d['scale']:g})"
    if body.shape == "cube12":
        mesh = "12 tetrahedra"
    elif n is None:
        mesh = "element count known after meshing"
    else:
        size = f"mesh {L(body.mesh_size)} {body.mesher}, " if body.mesh_size else ""
        mesh = f"{size}≈ {n:,} tetrahedra"
    speed = math.sqrt(sum(v * v for v in body.velocity))
    motion = f", v {_vec(body.velocity, 'velocity')}" if speed else ", at rest"
    fixed = f", {len(body.constraints)} constraint(s)" if body.constraints else ""
    return (f"{body.name}: {geometry} at {_vec(body.position, 'length')}, {mat.name} "
            f"({mat.strength.model}, {mat.eos.model}), {mesh}{motion}{fixed}")


def _element_line(case: Case) -> str:
    used = [case.materials[n] for n in dict.fromkeys(b.material for b in case.bodies)]
    strength = sorted({m.strength.model for m in used})
    eos = sorted({m.eos.model for m in used})
    thermal = any(m.strength.model == "johnson-cook" and m.strength.melt_temperature < 1e8
                  for m in used)
    from impactsim.solver.formulation import element_reason, resolve_element

    tets = f"{resolve_element(case)} ({element_reason(case)})"
    kinds = [tets] if any(b.element != "hex8" for b in case.bodies) else []
    kinds += [f"hex8 ({b.name}: {b.hourglass} hourglass control {b.hourglass_coefficient:g})"
              for b in case.bodies if b.element == "hex8"]
    return (f"{' + '.join(kinds)}, strength {'/'.join(strength)}, eos {'/'.join(eos)}, "
            f"artificial viscosity C_q {case.run.q_quadratic:g} C_l {case.run.q_linear:g}"
            + (", adiabatic temperature" if thermal else ""))


def _vec(v, dim: str) -> str:
    return "(" + ", ".join(format_quantity(c, dim) if c else "0" for c in v) + ")"
