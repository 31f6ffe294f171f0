"""The pass pipeline built from the case: a pass exists only when the scene asks for its effect."""

from __future__ import annotations

import numpy as np

from impactsim.case.schema import Case
from impactsim.materials.params import bulk_sound_speed
from impactsim.model import Model
from impactsim.solver.constraints import PrescribedVelocityPass, WallPass
from impactsim.solver.passes import Pass


def build_passes(case: Case, model: Model) -> list[Pass]:
    """Velocity-stage passes in their order (boundary conditions, walls, the particles' contacts,
    contact in the order the case lists them), then fracture-stage passes.

    The particle pass (fracture.particles) runs before the contact passes: its impulses change
    the velocities of face nodes (a light plate node hit by debris gained several hundred m/s),
    and run after them they pushed nodes through the other body's faces after the contact
    passes had converged (sphere-plate, 1 mm plate: nodes 0.17 mm (tets) and 0.97 mm (hexes)
    inside the sphere; with the particles first, 0.25 and 0.6 um)."""
    passes: list[Pass] = []
    if len(model.bc_nodes):
        passes.append(PrescribedVelocityPass())
    if len(model.walls):
        passes.append(WallPass())
    from impactsim.fracture.passes import fracture_wanted

    fracture = []
    if fracture_wanted(case):
        from impactsim.fracture import make_fracture_passes

        fracture = make_fracture_passes(case, model)
    passes.extend(p for p in fracture if p.stage == "velocity")
    if (len(case.bodies) > 1 or case.contact.self_contact) and case.contact.passes:
        from impactsim.contact import make_contact_passes

        passes.extend(make_contact_passes(case, model))
    passes.extend(p for p in fracture if p.stage != "velocity")
    return passes


def mach_warnings(case: Case) -> list[str]:
    """ALGORITHMS.md 1 [D19 after Fomin et al.]: with M0 = U0/C0, M0 <= 0.75 suits
    elastic-plastic flow with a simple EOS, 0.75 < M0 < 1.5 needs a hydrodynamic EOS, and beyond
    1.5 phase transitions (out of scope) matter. U0 is the largest closing speed of a body with
    another body or a wall; C0 the body's bulk sound speed."""
    out = []
    vel = [np.asarray(b.velocity, float) for b in case.bodies]
    for i, body in enumerate(case.bodies):
        speeds = [np.linalg.norm(vel[i] - vel[j]) for j in range(len(vel)) if j != i]
        if case.walls:
            speeds.append(np.linalg.norm(vel[i]))
        if not speeds:
            continue
        mat = case.materials[body.material]
        m0 = max(speeds) / bulk_sound_speed(mat)
        if m0 > 1.5:
            out.append(f"body {body.name!r}: impact Mach number M0 = {m0:.2f} > 1.5: phase "
                       "transitions may matter and are outside the model (ALGORITHMS.md 1)")
        elif m0 > 0.75 and mat.eos.model != "mie-gruneisen":
            out.append(f"body {body.name!r}: impact Mach number M0 = {m0:.2f} > 0.75 with a "
                       f"{mat.eos.model} EOS: a hydrodynamic (Mie-Grueneisen) EOS is needed here")
    return out
