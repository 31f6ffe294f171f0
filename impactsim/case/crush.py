"""How much crushing will shrink the time step of a run: the crush factor of the cost estimate.

The first time step of a run is C_cfl L_min / c (case/estimate.py). A plastic impact flattens
and shears the elements at the contact (a Taylor bar's foot, the rim of a striker punching into
a target, the rim of a hole) and their smallest altitude, with it the step, falls during the run:
the bundled Taylor bar starts at 40 ns and runs at 11 ns from 45 us on, the tet two-cylinders
falls from 31 to 1.2 ns. The estimate multiplies the steps of an unchanging step by the mean over
the run of dt_first / dt(t), the *step factor* (``step_factor``), from this model of dt(t):

Impacts (``impacts``). Every pair of bodies that approach each other, and every body moving
towards a rigid wall, meet at t_c = gap / v_n: the gap between their bounding boxes along the
axis that separates them (the wall's normal), v_n the approach speed along it. A pair that
separates, or meets after end_time, does not count.

Crush (``Crush``). Each plastic body of an impact is crushed by the dynamic pressure of the
impact against its flow stress: the crush number Phi = rho v^2 / Y0 (Y0 the initial flow stress:
ideal-plastic Y0, Johnson-Cook A), v the relative speed (all of it: an oblique impact gouges as it
presses; a target, the body with the larger cross-section, is indented at half of it and flows
under INDENTATION_CONSTRAINT times its flow stress) and rho the smaller of the two bodies'
densities (a light target cannot press a dense striker harder than its own dynamic pressure). A
striker that the target cannot press past its own Y0 is not crushed at all (``pushes``, Tate's
rigid penetrator). What shrinks the step is how far the crushed cells flatten, so the model
turns the impact into the true strain of the crushed foot (``foot_strain``) with Taylor's
plastic-front balance for a rod on a rigid anvil (G. I. Taylor, Proc. R. Soc. A 194 (1948) 289;
momentum and mass across the front at which the rod's area grows from A0 to A, e = 1 - A0/A):

    rho v^2 / Y = e^2 / (1 - e),    eps = ln(A / A0) = -ln(1 - e),

with a hardening material's flow stress Y taken as its mean over the strain reached,
Y(eps) = (1/eps) integral_0^eps sigma_y de (Johnson-Cook A + B eps^n / (n + 1): the flow stress
whose plastic work to eps is the material's; the rate and thermal terms left out), solved for eps.
Hardening matters: a high-strength steel (Y0 = 806 MPa, B / A = 0.76) at Phi = 0.8 and copper
(Y0 = 90 MPa, B / A = 3.2) at Phi = 3.6 reach eps = 0.69 and 0.98, where Phi alone would put them
4.5 times apart (the bundled Taylor bars' feet reach plastic strains of 1.8 and 2.2 at their rims).
A crushed cell's smallest length then falls as exp(-eps) flattened and further where the rim
shears it: the shrink of its step s = exp(SHRINK_PER_STRAIN[element] eps) once the crushing has
run its course, approached as 1 + (s - 1)(1 - exp(-(t - t_c) / tau)) with the crush time
tau = CRUSH_LENGTHS h / v (h the body's mesh size: the flattening takes the approach of a few
element lengths). Elastic bodies are not crushed. A body whose material erodes or breaks into
particles loses its crushed cells before they flatten further: its shrink is at most
FAILURE_SHRINK; one whose mesh comes apart by node separation frees a crushed cell's faces
once the plastic strain of the cells beside them reaches the fracture strain, so its foot
strain is bounded by it (``separation_strain``). A body's step is its own first step (its
L_min / c, which may be larger than the run's) divided by its shrink; the run's step the
smallest of them (``shrink_profile``).

The constants are fitted to the bundled cases (docs/estimates.md gives real against estimated
steps for each); the model knows nothing of the mesh beyond its size and element type, so a case
unlike them (a sliver in a mesh, a mesh-tangling shear band) can take more steps than it says.
A run re-estimates itself from its own step after its first part (solver/run.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from impactsim.case.schema import Body, Case, Material

# The shrink of a body's step once crushed, s = exp(k eps) for a foot strain eps, at most
# SHRINK_CAP, and the crush time tau = CRUSH_LENGTHS x mesh size / approach speed, by element
# type. k is fitted in-sample to the bundled runs' steps once crushed (docs/estimates.md): tets
# (Taylor bar eps = 0.98: s = 3.8 against 3.8 measured; the tet two-cylinders eps = 2.3: s = 22,
# measured 26 at the end) and hexes (Taylor bars of copper eps = 0.98 and 42CrMo4 eps = 0.69:
# s = 6.1 and 3.6 against 5.6 and 3.8 measured; a hex's first length, V / its largest face, is
# about 1.6 times a tet's altitude at the same mesh size, and both end at about the same crushed
# length, hence the larger k). Hexes flatten more evenly and for longer (the two-cylinders' hex
# striker still shrinking at the end).
SHRINK_PER_STRAIN = {"tet": 1.35, "hex8": 1.85}
SHRINK_CAP = {"tet": 25.0, "hex8": 12.0}
# A target (the body of the larger cross-section) under a striker flows only when pressed at
# about three times its flow stress, the constraint of the material around the indent (Tabor's
# hardness H = 3 Y: D. Tabor, The Hardness of Metals, 1951); Tate's target resistance R_t is of
# that size. Not fitted.
INDENTATION_CONSTRAINT = 3.0
CRUSH_LENGTHS = {"tet": 4.5, "hex8": 8.0}
# a material that fails (spall, loosening, erosion): crushed cells break off or erode first
# (sphere-plate: the step falls about 6.5 times within a microsecond and stays there)
FAILURE_SHRINK = 6.5
STEP_GRID = 400


@dataclass
class Impact:
    """Two bodies (or a body and wall[k]) meeting at `time` with approach speed `speed`."""

    bodies: tuple  # body names; a wall is "wall[k]"
    speed: float  # [m/s] approach speed along the impact axis
    time: float  # [s] when they meet
    # per body: True for a striker (its cross-section across the axis no larger than the
    # other's, or any body meeting a wall), False for the target it punches into
    strikers: tuple = (True, True)
    relative_speed: float = 0.0  # [m/s] |v_a - v_b| (an oblique impact slides as it presses)


@dataclass
class Crush:
    """A body crushed by an impact: its step shrinks by `shrink` from `time` over `duration`."""

    body: int  # index into case.bodies
    shrink: float  # dt_first / dt of the body once crushed
    time: float  # [s] t_c
    duration: float  # [s] tau
    phi: float  # the crush number
    strain: float = 0.0  # the foot strain (foot_strain)

    def shrink_at(self, t):
        """dt_first / dt of the body at time(s) t."""
        t = np.asarray(t, dtype=float)
        x = np.clip((t - self.time) / max(self.duration, 1e-300), 0.0, 700.0)
        return 1.0 + (self.shrink - 1.0) * np.where(t > self.time, 1.0 - np.exp(-x), 0.0)


def flow_stress(mat: Material) -> float | None:
    """Initial flow stress Y0 [Pa] of a plastic material; None when it is elastic."""
    s = mat.strength
    if s.model == "ideal-plastic" and s.yield_stress > 0.0:
        return s.yield_stress
    if s.model == "johnson-cook" and s.A > 0.0:
        return s.A
    if s.model == "johnson-cook" and s.B > 0.0:
        return s.B
    return None


def crush_number(mat: Material, speed: float, density: float | None = None) -> float:
    """Phi = rho v^2 / Y0 of a plastic material met at `speed`, rho the smaller of its own
    density and the other body's (`density`: a light target cannot press a dense striker
    harder than its own dynamic pressure); 0 for an elastic material."""
    y0 = flow_stress(mat)
    if y0 is None or not speed > 0.0:
        return 0.0
    rho = mat.density if density is None else min(mat.density, density)
    return rho * speed * speed / y0


def mean_flow_stress(mat: Material, strain: float) -> float | None:
    """The flow stress whose plastic work to `strain` is the material's [Pa]: the mean of the
    quasi-static, room-temperature flow stress over [0, strain] (Johnson-Cook A + B eps^n /
    (n + 1), ideal-plastic Y0); None when the material is elastic."""
    s = mat.strength
    if s.model == "ideal-plastic" and s.yield_stress > 0.0:
        return s.yield_stress
    if s.model == "johnson-cook" and (s.A > 0.0 or s.B > 0.0):
        return s.A + s.B * max(strain, 0.0) ** s.n / (s.n + 1.0)
    return None


def foot_strain(mat: Material, speed: float, density: float | None = None,
                constraint: float = 1.0) -> float:
    """The true strain eps of the crushed foot of a plastic body met at `speed` (module
    docstring): the root of rho v^2 / Y(eps) = e^2 / (1 - e), e = 1 - exp(-eps), Taylor's
    plastic-front balance with the mean flow stress Y(eps) (``mean_flow_stress``) times
    `constraint` (INDENTATION_CONSTRAINT for a target); rho as in ``crush_number``. 0 for an
    elastic material."""
    phi0 = crush_number(mat, speed, density)
    if not phi0 > 0.0:
        return 0.0
    phi0 = min(phi0, 1e12) / constraint  # 1e12: far beyond any cap (no overflow at 1e300 m/s)
    rho_v2 = phi0 * flow_stress(mat)

    def excess(eps: float) -> float:  # rises with eps: e^2/(1-e) grows, rho v^2 / Y falls
        x = math.exp(-eps)
        return (1.0 - x) ** 2 / x - rho_v2 / max(mean_flow_stress(mat, eps), 1e-300)

    # Y(eps) >= Y0 and e^2/(1-e) >= exp(eps) - 2, so the root lies below ln(phi0 + 2)
    lo, hi = 0.0, math.log(phi0 + 2.0)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if excess(mid) > 0.0:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def shrink_of(strain: float, element: str = "tet", fails: bool = False) -> float:
    """The shrink s of a body's step once its foot is crushed to `strain` (module docstring)."""
    k = SHRINK_PER_STRAIN.get(element, SHRINK_PER_STRAIN["tet"])
    cap = SHRINK_CAP.get(element, SHRINK_CAP["tet"])
    s = math.exp(min(k * strain, 700.0)) if strain > 0.0 else 1.0  # 700: no overflow
    s = min(max(1.0, s), cap)
    return min(s, FAILURE_SHRINK) if fails else s


def crushes(case: Case, meshes: list | None = None) -> list[Crush]:
    """Every body crushed by an impact before end_time."""
    names = {b.name: i for i, b in enumerate(case.bodies)}
    out = []
    for imp in impacts(case, meshes):
        mats = [case.materials[case.bodies[names[n]].material] if n in names else None
                for n in imp.bodies]  # None: a wall
        for k, (name, striker) in enumerate(zip(imp.bodies, imp.strikers)):
            i = names.get(name)
            if i is None:  # a wall
                continue
            body = case.bodies[i]
            mat, other = mats[k], mats[1 - k]
            if striker and other is not None and not pushes(other, imp.speed, mat):
                continue  # a striker harder than what the target can press on it
            # a target is indented at the striker's speed into it, about half the approach,
            # and flows only under INDENTATION_CONSTRAINT times its flow stress
            speed = imp.relative_speed or imp.speed
            v = speed if striker else 0.5 * speed
            density = other.density if other is not None else None
            phi = crush_number(mat, v, density)
            strain = foot_strain(mat, v, density, 1.0 if striker else INDENTATION_CONSTRAINT)
            if mat.failure.fracture_strain is not None:
                strain = min(strain, separation_strain(case, mat))
            s = shrink_of(strain, body.element, mat.failure.active)
            if s > 1.0:
                h = cell_size(body)
                lengths = CRUSH_LENGTHS.get(body.element, CRUSH_LENGTHS["tet"])
                out.append(Crush(i, s, imp.time, lengths * h / speed, phi, strain))
    return out


def separation_strain(case: Case, mat: Material) -> float:
    """The most plastic strain a crushed cell of a body that comes apart by node separation
    reaches (fracture/separation.py): a face is freed when the plastic strain of the cells
    beside it reaches the fracture strain eps_f, by the "max" measure as soon as the crushed
    cell does, by the "mean" measure (the default) when the mean of the two does, which with the
    neighbour behind the crush front still about unstrained is at 2 eps_f; a freed cell is no
    longer pressed flat between its neighbours."""
    eps_f = mat.failure.fracture_strain
    return eps_f if case.fracture.separation_measure == "max" else 1.5 * eps_f


def cell_size(body: Body) -> float:
    """The body's element size [m]: its mesh size, the cube12's edge (one cell), else 0."""
    if body.mesh_size > 0.0:
        return body.mesh_size
    if body.shape == "cube12":
        return float(body.dimensions["size"])
    return 0.0


def pushes(target: Material, speed: float, striker: Material) -> bool:
    """Whether `target`, met at the normal approach `speed`, can press on `striker` harder than
    the striker's flow stress: its resistance to penetration, the stagnation pressure
    rho_t v^2 / 2 plus INDENTATION_CONSTRAINT times its flow stress (Tate's R_t; A. Tate,
    J. Mech. Phys. Solids 15 (1967) 387), against the striker's Y0 (a striker that it cannot
    press harder stays about rigid: Tate's rigid-penetrator regime). An elastic target presses
    as a wall does."""
    y_s, y_t = flow_stress(striker), flow_stress(target)
    if y_s is None or y_t is None:
        return True
    return 0.5 * target.density * speed * speed + INDENTATION_CONSTRAINT * y_t > y_s


def body_box(body: Body, mesh=None) -> tuple[np.ndarray, np.ndarray] | None:
    """(lo, hi) [m] of the placed body: from its mesh when given, else from the primitive
    (a rotated primitive by its bounding sphere); None for a mesh file not read yet."""
    if mesh is not None and len(mesh[0]):
        return mesh[0].min(axis=0), mesh[0].max(axis=0)
    c = np.asarray(body.position, dtype=float)
    d = body.dimensions
    if body.shape in ("box", "plate"):
        half = 0.5 * np.asarray(d["size"], dtype=float)
    elif body.shape == "cube12":
        half = np.full(3, 0.5 * d["size"])
    elif body.shape == "sphere":
        half = np.full(3, d["radius"])
    elif body.shape == "cylinder":
        axis = np.asarray(d.get("axis", (0.0, 0.0, 1.0)), dtype=float)
        axis = axis / (np.linalg.norm(axis) or 1.0)
        r, h = d["radius"], d["height"]
        # the box of a disc of radius r along `axis` extended by h/2 either way
        half = 0.5 * h * np.abs(axis) + r * np.sqrt(np.clip(1.0 - axis * axis, 0.0, 1.0))
    else:
        return None
    if any(abs(a) > 0.0 for a in body.rotation) and body.shape != "sphere":
        half = np.full(3, float(np.linalg.norm(half)))
    return c - half, c + half


def impacts(case: Case, meshes: list | None = None) -> list[Impact]:
    """The impacts of the case before end_time (module docstring)."""
    boxes = []
    for i, body in enumerate(case.bodies):
        mesh = meshes[i] if meshes is not None and i < len(meshes) else None
        boxes.append(body_box(body, mesh))
    end = case.run.end_time
    out = []
    for a, body in enumerate(case.bodies):
        if boxes[a] is None:
            continue
        for b in range(a + 1, len(case.bodies)):
            if boxes[b] is None:
                continue
            v_rel = np.subtract(body.velocity, case.bodies[b].velocity)
            hit = _pair(boxes[a], boxes[b], v_rel)
            if hit is not None and hit[1] < end:
                out.append(Impact((body.name, case.bodies[b].name), *hit,
                                  relative_speed=float(np.linalg.norm(v_rel))))
        for k, wall in enumerate(case.walls):
            hit = _wall(boxes[a], np.asarray(body.velocity, dtype=float), wall)
            if hit is not None and hit[1] < end:
                out.append(Impact((body.name, f"wall[{k}]"), *hit, (True, True),
                                  float(np.linalg.norm(body.velocity))))
    return out


def _pair(box_a, box_b, v_rel) -> tuple[float, float, tuple] | None:
    """(approach speed, meeting time, strikers) of two boxes along the axis that separates
    them most, with a's velocity relative to b; None when they do not approach."""
    (lo_a, hi_a), (lo_b, hi_b) = box_a, box_b
    # gap along each axis: positive when separated, with the side of b seen from a
    gaps = np.maximum(lo_b - hi_a, lo_a - hi_b)
    axis = int(np.argmax(gaps))
    sign = 1.0 if lo_b[axis] - hi_a[axis] >= lo_a[axis] - hi_b[axis] else -1.0
    speed = float(v_rel[axis]) * sign  # a moves towards b along +sign
    if not speed > 0.0:
        return None
    others = [k for k in range(3) if k != axis]
    area_a = float(np.prod([hi_a[k] - lo_a[k] for k in others]))
    area_b = float(np.prod([hi_b[k] - lo_b[k] for k in others]))
    return speed, max(float(gaps[axis]), 0.0) / speed, (area_a <= area_b, area_b <= area_a)


def _wall(box, velocity, wall) -> tuple[float, float] | None:
    """(approach speed, meeting time) of a box moving towards a wall."""
    n = np.asarray(wall.normal, dtype=float)
    n = n / (np.linalg.norm(n) or 1.0)
    lo, hi = box
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    dist = (corners - np.asarray(wall.point, dtype=float)) @ n
    speed = -float(velocity @ n)
    if not speed > 0.0:
        return None
    return speed, max(float(dist.min()), 0.0) / speed


def shrink_profile(found: list[Crush], first_steps, dt_first: float, t) -> np.ndarray:
    """dt_first / dt(t) of the run: each crushed body's step is its own first step
    first_steps[body] divided by its shrink; the run's step the smallest of them and dt_first."""
    t = np.asarray(t, dtype=float)
    out = np.ones_like(t)
    for c in found:
        own = first_steps[c.body]
        if own > 0.0 and math.isfinite(own):
            out = np.maximum(out, dt_first / own * c.shrink_at(t))
    return out


def step_factor(found: list[Crush], first_steps, dt_first: float, end_time: float,
                start: float = 0.0) -> float:
    """The mean of dt_first / dt(t) over [start, end_time]: the steps of the run are this many
    times those of an unchanging first step."""
    if not found or not end_time > start:
        return 1.0
    t = np.linspace(start, end_time, STEP_GRID + 1)
    g = shrink_profile(found, first_steps, dt_first, t)
    return float(0.5 * np.sum((g[1:] + g[:-1]) * np.diff(t)) / (end_time - start))
