"""The validation ladder (issue 17, item 2): `make validate` runs every rung with each tet
formulation and writes docs/validation.md (tables), docs/validation/*.png (plots) and
benchmarks/validation_reference.json (the stored results the cheap rung of `make test` checks,
tests/verification/test_validation_rung.py).

    python benchmarks/validate.py              # run the ladder, write the report
    python benchmarks/validate.py --rungs perforation-400 plate  # rerun some rungs only
    python benchmarks/validate.py --report-only  # rewrite the report from the stored results

The results the report is written from are kept in git (benchmarks/validation_results.json,
one record per rung, element and mesh size): a run of some rungs replaces their records and
keeps every other one, so the report keeps every section on any machine, also on a fresh clone
without the last full run's out/validation/. Records carried over from the report of an
earlier run say so in their `source`.

Rungs (each with tet4 and anp; modest resolutions, for a shared two-core machine):
- Taylor bars: OFHC copper at 190 m/s (the bundled case), 6061-T6 at 373 m/s and 4340 at
  343 m/s (7.62 x 25.4 mm rods): final length, foot diameter, cells fractured, wall time; the
  measured values where a reference is on record here (REFERENCES, with their status);
- a symmetric plate impact (6061-T6 onto 6061-T6 at 500 m/s, uniaxial strain): the rear free
  surface's velocity history, its plateau against the impact speed (the free-surface
  approximation u_fs = 2 u_p, u_p = V/2 exactly by symmetry) and the pull-back signal of the
  spall, its acoustic spall-strength estimate rho0 c0 du / 2 against the 1.6 GPa the material
  was given;
- a perforation: the bundled oblique-sphere case [R20] at the coarse test mesh, the sphere's
  residual velocity and the hole;
- the code-to-code 42CrMo4 Taylor bar (cases/taylor-bar-42crmo4.toml, 287 m/s) against DynELA
  and Abaqus/Explicit, as a refinement series with tet4, anp and hex8: final length, foot
  diameter, peak plastic strain and temperature, CPU seconds.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

OUT = ROOT / "out" / "validation"
DOC = ROOT / "docs" / "validation.md"
FIG = ROOT / "docs" / "validation"
STORED = ROOT / "benchmarks" / "validation_reference.json"
RESULTS = ROOT / "benchmarks" / "validation_results.json"  # every rung's last result, in git
ELEMENTS = ("tet4", "anp")

# measured values on record here, with how sure we are of them
BANERJEE = ("as transcribed in B. Banerjee's collection of high-rate data "
            "(github.com/bbanerjee/HighRateExptData, TaylorData/MATLAB/{f}, function {fn}); "
            "not confirmed against the original paper")
REFERENCES = {
    "taylor-cu-190": {"length_mm": 0.638 * 25.4, "foot_mm": 1.78 * 7.62,
                      "source": "Johnson & Cook (1983), 7th Int. Symp. Ballistics, OFHC copper, "
                      "L0 = 25.4 mm, D0 = 7.62 mm at 190 m/s: L_f / L0 = 0.638, D_f / D0 = 1.78 "
                      "(also in Zerilli & Armstrong 1987, J. Appl. Phys. 61:1816), "
                      + BANERJEE.format(f="plotOFHCCu.m", fn="zerilliData")},
    "taylor-6061-373": {"length_mm": 0.703 * 23.47, "foot_mm": 16.6,
                        "source": "Wilkins & Guinan (1973), J. Appl. Phys. 44:1200, aluminium "
                        "rod L0 = 23.47 mm, D0 = 7.62 mm at 373 m/s: L_f / L0 = 0.703, D_f = "
                        "16.6 mm, " + BANERJEE.format(f="plot6061T6Al.m", fn="wilkinsData")
                        + "; the alloy taken as 6061-T6 as there"},
    "taylor-4340-208": {"length_mm": 0.885 * 25.4, "foot_mm": 11.1,
                        "source": "Johnson & Cook (1983) and Johnson & Holmquist (1988), J. Appl. "
                        "Phys. 64:3901, 4340 steel (Rc 30), L0 = 25.4 mm, D0 = 7.62 mm at 208 "
                        "m/s: L_f / L0 = 0.885, D_f = 11.1 mm, "
                        + BANERJEE.format(f="plot4340St.m", fn="johnsonData")},
    "taylor-4340-282": {"length_mm": 0.843 * 12.7, "foot_mm": 10.4,
                        "source": "the same series, L0 = 12.7 mm at 282 m/s: L_f / L0 = 0.843, "
                        "D_f = 10.4 mm, " + BANERJEE.format(f="plot4340St.m", fn="johnsonData")},
    "taylor-4340-343": {"length_mm": 0.808 * 8.1, "foot_mm": 12.0,
                        "source": "the same series, L0 = 8.1 mm at 343 m/s: L_f / L0 = 0.808, "
                        "D_f = 12.0 mm, " + BANERJEE.format(f="plot4340St.m", fn="johnsonData")},
}

# results of other codes for the same problem (code-to-code), with their source
CODE_REFERENCES = {
    "taylor-42crmo4-287": {
        "codes": {
            "DynELA": {"length_mm": 26.52, "foot_diameter_mm": 11.18,
                       "peak_plastic_strain": 1.84, "peak_temperature_c": 597.10},
            "Abaqus/Explicit": {"length_mm": 26.55, "foot_diameter_mm": 11.22,
                                "peak_plastic_strain": 1.84, "peak_temperature_c": 597.01},
        },
        "source": "O. Pantale, DynELA v4 documentation (github.com/pantale/DynELA-v.-4.0, "
                  "Documentation/Samples-Impacts.tex, Table 'Comparison of numerical results "
                  "for the 3D Taylor impact test'; input Samples/Taylor/Taylor-3D/Taylor.py): "
                  "42CrMo4, 6.4 x 32.4 mm, 287 m/s onto a rigid frictionless wall, 80 us, "
                  "DynELA's mesh 4,455 elements",
    },
}
CRMO_SIZES = (1.0, 0.8, 0.6, 0.45)  # mm
CRMO_FORMULATIONS = ("tet4", "anp", "hex8")
CRMO_MEASURES = ("length_mm", "foot_diameter_mm", "peak_plastic_strain", "peak_temperature_c")

TAYLOR = """
[run]
name = "{name}"
end_time = "{end} us"
element = "{element}"

[[body]]
name = "rod"
material = "{material}"
shape = "cylinder"
diameter = "7.62 mm"
height = "{length} mm"
axis = [0, 0, 1]
position = ["0 mm", "0 mm", "{centre} mm"]
mesh_size = "{h} mm"
velocity = ["0 m/s", "0 m/s", "-{speed} m/s"]

[[wall]]
point = [0, 0, 0]
normal = [0, 0, 1]

[output]
frames = 1
"""

TAYLORS = [  # name, material, speed [m/s], mesh size [mm], end [us], length [mm]
    ("taylor-cu-190", "ofhc-copper", 190.0, 0.8, 80.0, 25.4),
    ("taylor-6061-373", "al-6061-t6", 373.0, 1.0, 60.0, 23.47),
    ("taylor-6061-373", "al-6061-t6", 373.0, 0.7, 60.0, 23.47),
    # the three 4340 tests of Johnson & Cook (1983), each with its own rod length
    ("taylor-4340-208", "steel-4340", 208.0, 1.0, 60.0, 25.4),
    ("taylor-4340-208", "steel-4340", 208.0, 0.7, 60.0, 25.4),
    ("taylor-4340-282", "steel-4340", 282.0, 1.0, 40.0, 12.7),
    ("taylor-4340-282", "steel-4340", 282.0, 0.7, 40.0, 12.7),
    ("taylor-4340-343", "steel-4340", 343.0, 1.0, 30.0, 8.1),
    ("taylor-4340-343", "steel-4340", 343.0, 0.7, 30.0, 8.1),
]


def taylor_measures(out: Path) -> dict:
    import meshio

    frame = sorted(out.glob("frame_*.vtu"))[-1]
    x = np.asarray(meshio.read(frame).points)
    return {"length_mm": 1e3 * float(np.ptp(x[:, 2])),
            "foot_diameter_mm": 2e3 * float(np.hypot(x[:, 0], x[:, 1]).max())}
TAYLOR_RUNGS = {t[0] for t in TAYLORS}


def run_taylor(name, material, speed, h, end, length, element) -> dict:
    from impactsim.case import load_case_text
    from impactsim.solver.run import run_case

    case = load_case_text(TAYLOR.format(name=name, end=end, element=element,
                                        material=material, h=h, speed=speed, length=length,
                                        centre=0.5 * length + 1e-4))
    out = OUT / f"{name}-{element}-{h}"
    t0 = time.perf_counter()
    s = run_case(case, out, progress=False)
    wall = time.perf_counter() - t0
    res = {"rung": name, "element": element, "h_mm": h, "length0_mm": length,
           "elements": s["elements"],
           "steps": s["steps"], "wall_s": wall, "energy_balance_error": s["energy_balance_error"],
           "stopped": s["stopped"]}
    res.update(taylor_measures(out))
    f = s.get("fracture")
    res["fractured_cells"] = (f["fractured_total"] + f["damaged_total"]) if f else 0
    res["damaged_cells"] = f["damaged_total"] if f else 0  # cells damaged (spall or ductile)
    res["ductile_cells"] = f.get("damaged_ductile", 0) if f else 0  # of which ductile
    return res


def run_crmo(h: float, formulation: str) -> dict:
    """The code-to-code 42CrMo4 bar at mesh size h [mm] with a tet formulation or hex8."""
    import meshio

    from impactsim.case import load_case
    from impactsim.solver.run import run_case

    over = [f'body.0.mesh_size="{h} mm"', "output.frames=1", "run.threads=1"]
    if formulation == "hex8":
        over.append('body.0.element="hex8"')
    else:
        over += ['body.0.element="tet"', f'run.element="{formulation}"']
    case = load_case(ROOT / "cases" / "taylor-bar-42crmo4.toml", over)
    out = OUT / f"taylor-42crmo4-{formulation}-{h}"
    cpu = time.process_time()
    s = run_case(case, out, progress=False)
    cpu = time.process_time() - cpu
    res = {"rung": "taylor-42crmo4-287", "element": formulation, "h_mm": h,
           "elements": s["elements"], "steps": s["steps"], "cpu_s": cpu,
           "wall_s": s["wall_seconds"], "energy_balance_error": s["energy_balance_error"],
           "stopped": s["stopped"]}
    res.update(taylor_measures(out))
    cells = meshio.read(sorted(out.glob("frame_*.vtu"))[-1]).cell_data
    res["peak_plastic_strain"] = float(max(np.max(a) for a in cells["plastic_strain"]))
    res["peak_temperature_c"] = float(max(np.max(a) for a in cells["temperature"])) - 273.15
    return res


def run_plate(element: str, d19: bool = False) -> dict:
    """Symmetric 6061-T6 plate impact in uniaxial strain: flyer F = 2 mm, target T = 4 mm,
    500 m/s closing speed, h = 0.1 mm, one column of cells held in x and y; the target's rear
    free-surface velocity every step. d19: with the instantaneous cell criterion of [D19]
    instead of the default spall (rung plate-6061-500-d19)."""
    from impactsim.case.material import library_material
    from impactsim.case.schema import Constraint, NodeSelector
    from impactsim.mesh.structured import structured_box
    from impactsim.solver.build import build_model
    from impactsim.solver.loop import Simulation
    from impactsim.solver.pipeline import build_passes
    from tests.builders import box_case

    F, T, h, u = 2e-3, 4e-3, 0.1e-3, 500.0
    mat = library_material("al-6061-t6")
    case = box_case(mat, size=(h, h, F + T), h=h)
    case.bodies[0].constraints = [Constraint(NodeSelector("all"), (0.0, 0.0, None))]
    rung = "plate-6061-500"
    if d19:
        case.fracture.spall_criterion, case.fracture.spall_pressure = "instant", "cell"
        rung += "-d19"
    pts, tets = structured_box((h, h, F + T), h)
    model = build_model(case, [(pts, tets)])
    z = model.x[:, 2]
    z_if = -(F + T) / 2 + F
    model.v[:, 2] = np.where(z < z_if - 1e-9, 0.5 * u, np.where(z > z_if + 1e-9, -0.5 * u, 0.0))
    rear = np.isclose(z, (F + T) / 2)
    sim = Simulation(model, build_passes(case, model), cfl=0.5, element=element)
    t0 = time.perf_counter()
    ts, us = [], []
    c0 = mat.eos.c0
    peak, fail_tension = 0.0, None  # the largest axial tension before the first cell spalls
    while model.time < 3.2e-6:
        sim.step()
        ts.append(model.time)
        us.append(float(model.v[rear, 2].mean()))  # +z: away from the target
        if fail_tension is None:
            if np.any(model.status > 0):
                fail_tension = peak
            else:
                peak = max(peak, float(np.max(model.sdev[:, 2] - model.pressure)))
    wall = time.perf_counter() - t0
    ts, us = np.array(ts), np.array(us)
    # the target moves at -u/2 before the shock arrives; the free surface's velocity change
    # jumps to 2 u_p = u in a symmetric impact
    rel = us + 0.5 * u
    peak_i = int(np.argmax(rel))
    peak = float(np.median(rel[max(peak_i - 5, 0):peak_i + 6]))
    after = rel[peak_i:]
    pull = float(peak - after.min()) if after.size else 0.0
    np.savez(OUT / f"{rung}-{element}.npz".replace("plate-6061-500", "plate"), t=ts, u=rel)
    return {"rung": rung, "element": element, "h_mm": 0.1,
            "elements": model.n_elem, "steps": model.step, "wall_s": wall,
            "free_surface_plateau": peak, "impact_speed": u, "pullback": pull,
            "spall_estimate_gpa": 0.5 * mat.density * c0 * pull / 1e9,
            "spall_given_gpa": mat.failure.spall_strength / 1e9,
            "spall_time_us": 1e6 * (mat.failure.spall_time or 0.0),
            "failure_tension_gpa": (fail_tension or 0.0) / 1e9,
            "damaged": int(np.count_nonzero(model.status > 0))}


def run_perforation(element: str, default_spall: bool = False) -> dict:
    """The bundled oblique-sphere case at the coarse test mesh; default_spall: with the default
    spall criterion instead of the case's [D19] one (rung oblique-sphere-1001-default-spall)."""
    from impactsim.case import load_case
    from impactsim.solver.run import run_case

    over = ['body.0.mesh_size="1.8 mm"', 'body.1.mesh_size="1.4 mm"', 'run.end_time="30 us"',
            'output.frames=1', f'run.element="{element}"']
    rung = "oblique-sphere-1001"
    if default_spall:
        over += ['fracture.spall_criterion="tuler-butcher"', 'fracture.spall_pressure="lesser"']
        rung += "-default-spall"
    case = load_case(ROOT / "cases" / "oblique-sphere.toml", over)
    out = OUT / f"{rung}-{element}"
    t0 = time.perf_counter()
    s = run_case(case, out, progress=False)
    wall = time.perf_counter() - t0
    b = s["bodies"]
    v = b["sphere"]["residual_velocity"]
    hole = b["plate"].get("hole", {})
    return {"rung": rung, "element": element, "h_mm": 1.4,
            "elements": s["elements"], "steps": s["steps"], "wall_s": wall,
            "residual_speed": float(np.linalg.norm(v)),
            "angle_deg": math.degrees(math.atan2(math.hypot(v[0], v[1]), -v[2])),
            "hole_diameter_mm": 1e3 * hole.get("diameter_equivalent", 0.0),
            "energy_balance_error": s["energy_balance_error"], "stopped": s["stopped"]}


def run_sphere_plate(ductile: bool) -> dict:
    """The [D19] sphere-plate scene (4340 sphere r = 10 mm at 2 km/s onto a 2 mm 2024-T3
    plate) at the test suite's coarse mesh (plate 1 mm, sphere 2.4 mm), 4 us, under the default
    spall criterion (the case itself keeps [D19]'s instantaneous one); ductile: with the ductile
    criterion (`ductile_criterion = "johnson-cook"`), else without it (the default).
    [D19]'s experiment perforates."""
    from impactsim.case import load_case
    from impactsim.solver.run import run_case

    over = ['body.plate.mesh_size="1 mm"', 'body.sphere.mesh_size="2.4 mm"', "output.frames=1",
            'fracture.spall_criterion="tuler-butcher"', 'fracture.spall_pressure="lesser"']
    rung = "sphere-plate-2000"
    over.append(f'fracture.ductile_criterion="{"johnson-cook" if ductile else "none"}"')
    if not ductile:
        rung += "-no-ductile"
    case = load_case(ROOT / "cases" / "sphere-plate.toml", over)
    out = OUT / rung
    t0 = time.perf_counter()
    s = run_case(case, out, progress=False)
    wall = time.perf_counter() - t0
    b, f = s["bodies"], s["fracture"]
    return {"rung": rung, "element": "tet4", "h_mm": 1.0, "elements": s["elements"],
            "steps": s["steps"], "wall_s": wall,
            "hole_diameter_mm": 1e3 * b["plate"].get("hole", {}).get("diameter_equivalent", 0.0),
            "residual_speed": float(np.linalg.norm(b["sphere"]["residual_velocity"])),
            "damaged": f["damaged_total"], "ductile": f.get("damaged_ductile", 0),
            "particles": s["particles"], "energy_balance_error": s["energy_balance_error"],
            "stopped": s["stopped"]}



# A normal-incidence perforation swept over the striking speed (residual velocity against
# striking velocity, the curve a ballistic test reports): the [R20] sphere and plate of
# cases/oblique-sphere.toml (52100 sphere 12.7 mm, 2024-T3 plate 4.9 mm) hit square on, with the
# ductile criterion on (a perforation scene asks for it: docs/fracture.md) and the default
# spall. No measured residual velocities for this pairing are on record here (the ladder's "Not
# on the ladder" list names what was searched for), so the rung reports the simulated curve, a
# Recht-Ipson fit of it (V_r = a (V_s^p - V_bl^p)^(1/p), p = 2) and its mesh dependence: the
# place where a measured series, once found, goes into PERFORATION_REFERENCE.
PERFORATION_SPEEDS = (300.0, 400.0, 600.0, 1000.0)  # m/s
PERFORATION_MESHES = ((1.8, 1.4), (1.2, 1.0))  # (sphere, plate) mesh sizes [mm]
PERFORATION_REFERENCE: dict = {}  # striking speed [m/s] -> measured residual speed [m/s]

PERFORATION = """
[run]
name = "perforation-{speed:.0f}"
end_time = "{end} us"
cfl = 0.6
element = "tet4"

[[body]]
name = "plate"
material = "al-2024-t3"
shape = "plate"
size = ["40 mm", "40 mm", "4.9 mm"]
position = ["0 mm", "0 mm", "-2.45 mm"]
mesh_size = "{hp} mm"
mesher = "structured"

# clamped outside a 38 mm circle (the 40 mm square's edges and corners), as a test fixture
# holds a target: below the ballistic limit the sphere stops instead of pushing a free plate
[[body.constraint]]
nodes = {{ outside_radius = "19 mm" }}
fixed = true

[[body]]
name = "sphere"
material = "steel-52100"
shape = "sphere"
diameter = "12.7 mm"
position = ["0 mm", "0 mm", "6.55 mm"]
mesh_size = "{hs} mm"
speed = "{speed} m/s"
direction = [0, 0, -1]

[contact]
passes = ["node-face", "edge-edge"]

[fracture]
ductile_criterion = "johnson-cook"
particles_per_element = 1

[output]
frames = 1
"""


def run_perforation_sweep(speed: float, hs: float, hp: float) -> dict:
    """One striking speed of the normal-incidence perforation (PERFORATION): the sphere's
    residual velocity along the normal after it has cleared the plate (negative: it rebounds;
    near zero: it is stuck in the plate)."""
    from impactsim.case import load_case_text
    from impactsim.solver.run import run_case

    # long enough for the sphere's trailing side to clear the plate's rear face with margin
    end = round(1e6 * 3 * (12.7e-3 + 4.9e-3) / speed + 10.0)
    case = load_case_text(PERFORATION.format(speed=speed, end=end, hs=hs, hp=hp))
    out = OUT / f"perforation-{speed:.0f}-{hp}"
    t0 = time.perf_counter()
    s = run_case(case, out, progress=False)
    wall = time.perf_counter() - t0
    b, f = s["bodies"], s["fracture"] or {}
    v = b["sphere"]["residual_velocity"]
    return {"rung": f"perforation-{speed:.0f}", "element": "tet4", "h_mm": hp, "h_sphere_mm": hs,
            "striking_speed": speed, "end_us": end, "elements": s["elements"],
            "steps": s["steps"], "wall_s": wall, "residual_speed": float(-v[2]),
            "hole_diameter_mm": 1e3 * b["plate"].get("hole", {}).get("diameter_equivalent", 0.0),
            "damaged": f.get("damaged_total", 0), "ductile": f.get("damaged_ductile", 0),
            "particles": s["particles"], "energy_balance_error": s["energy_balance_error"],
            "stopped": s["stopped"]}


def recht_ipson(vs: np.ndarray, vr: np.ndarray) -> tuple[float, float]:
    """Least-squares fit of V_r = a sqrt(V_s^2 - V_bl^2) (Recht & Ipson 1963, p = 2) to the
    perforating points (V_r > 0), in V_r itself: for each trial V_bl below the slowest of them
    the best a is linear, so V_bl is found on a fine grid. Returns (a, V_bl) [m/s]."""
    ok = vr > 0
    vs, vr = vs[ok], vr[ok]
    best = (np.inf, 0.0, 0.0)
    for vbl in np.linspace(0.0, vs.min(), 4001)[:-1]:
        f = np.sqrt(vs ** 2 - vbl ** 2)
        a = float(f @ vr / (f @ f))
        sse = float(np.sum((a * f - vr) ** 2))
        if sse < best[0]:
            best = (sse, a, float(vbl))
    return best[1], best[2]


def perforation_sweep_report(results: list[dict]) -> list[str]:
    rows = [r for r in results if r["rung"].startswith("perforation-")
            and "striking_speed" in r]
    if not rows:
        return []
    lines = ["## Perforation: residual velocity against striking velocity", "",
             "The [R20] sphere and plate (52100 sphere 12.7 mm, 8.4 g; 2024-T3 plate 4.9 mm, "
             "40 x 40 mm, clamped outside a 38 mm circle) hit square on at "
             + ", ".join(f"{v:.0f}" for v in PERFORATION_SPEEDS)
             + " m/s, tet4 (contact scene), the default spall criterion and the ductile "
             "criterion on (`ductile_criterion = \"johnson-cook\"`, the library's 2024 "
             "D1..D5), at two meshes. `residual` is the sphere's velocity along the normal at "
             "the end (it has cleared the plate's rear face, or stopped in it); the Recht-Ipson "
             "fit V_r = a "
             "sqrt(V_s^2 - V_bl^2) through each mesh's perforating points gives the simulated "
             "ballistic limit V_bl. No measured series for this pairing is on record here "
             "(below), so there is no error column: the rung gives the curve a measurement "
             "would be laid against, and its mesh dependence.", "",
             "| V_s [m/s] | sphere / plate h [mm] | elements | steps | wall s | residual "
             "[m/s] | V_r / V_s | hole [mm] | damaged (ductile) | particles | energy balance |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in sorted(rows, key=lambda r: (-r["h_mm"], r["striking_speed"])):
        lines.append(f"| {r['striking_speed']:.0f} | {r['h_sphere_mm']} / {r['h_mm']} | "
                     f"{r['elements']:,} | {r['steps']:,} | {r['wall_s']:.0f} | "
                     f"{r['residual_speed']:.0f} | {r['residual_speed'] / r['striking_speed']:.3f}"
                     f" | {r['hole_diameter_mm']:.1f} | {r['damaged']:,} ({r['ductile']:,}) | "
                     f"{r['particles']:,} | {r['energy_balance_error']:+.1e} |")
    lines.append("")
    fits = []
    for hp in sorted({r["h_mm"] for r in rows}, reverse=True):
        rs = sorted((r for r in rows if r["h_mm"] == hp), key=lambda r: r["striking_speed"])
        vs = np.array([r["striking_speed"] for r in rs])
        vr = np.array([r["residual_speed"] for r in rs])
        if np.count_nonzero(vr > 0) >= 2:
            a, vbl = recht_ipson(vs, vr)
            fits.append((a, vbl))
            lines.append(f"- plate h = {hp} mm: Recht-Ipson fit a = {a:.3f}, "
                         f"V_bl = {vbl:.0f} m/s ({np.count_nonzero(vr > 0)} perforating points).")
    from impactsim.case.material import library_material

    r_s, t = 6.35e-3, 4.9e-3
    m_s = library_material("steel-52100").density * 4.0 / 3.0 * math.pi * r_s ** 3
    m_plug = library_material("al-2024-t3").density * math.pi * r_s ** 2 * t
    a_plug = m_s / (m_s + m_plug)
    by_speed: dict = {}
    for r in rows:
        by_speed.setdefault(r["striking_speed"], []).append(r["residual_speed"])
    spread = [(sp, v) for sp, v in sorted(by_speed.items()) if len(v) == 2]
    if len(fits) < 2 or not spread:
        return lines
    dvbl = 100 * abs(fits[1][1] - fits[0][1]) / fits[0][1]
    da = [100 * (a / a_plug - 1) for a, _v in fits]
    lines += ["", "**Reading.** The refinement (2.4 times the elements) moves the residual "
              "speed by " + ", ".join(
                  f"{100 * abs(v[1] - v[0]) / v[0]:.1f} % at {sp:.0f}" if v[0] > 0.2 * sp
                  else f"{v[0]:.0f} -> {v[1]:.0f} m/s at {sp:.0f}" for sp, v in spread)
              + f" m/s and the fitted ballistic limit by {dvbl:.1f} %, while the number of "
              "cells the "
              "ductile criterion damages doubles: the local damage law localises (docs/"
              "fracture.md), but where the sphere clearly perforates its exit speed is carried by "
              "the momentum and work of the plug and the plate and moves by a few per cent; "
              "near the ballistic limit (the lowest speed) V_r is steep in V_s and differs by "
              "tens of m/s. One check needs "
              f"no measurement: Recht and Ipson's plugging model gives a = m_s / (m_s + m_plug) "
              f"= {a_plug:.3f} (sphere {1e3 * m_s:.2f} g, a plug of the sphere's diameter "
              f"through the plate {1e3 * m_plug:.2f} g); the fitted a is "
              f"{min(da):.0f}-{max(da):.0f} % above it, close to the plugging picture (above "
              "it, a little less than a full plug of the sphere's cross-section rides with "
              "the sphere). The "
              "support matters as much as the mesh: with the plate's edges free (session 9's "
              "first sweep, coarse mesh) the residual speeds at 400 / 600 / 1000 m/s read 210 "
              "/ 431 / 824 m/s, 6 / 5 / 0.6 % above the clamped plate's, and below the "
              "ballistic limit a free plate carries the stuck sphere away. Against "
              "an experiment, this rung has nothing yet: that is the missing piece of issue "
              "17's perforation item (the searches and the two ballistic limits found for "
              "other pairings: 'Sources not available here', below).", ""]
    lines += tether_report()
    return lines


def tether_report() -> list[str]:
    """The fine 400 m/s point's step count and hole, explained: measured with
    benchmarks/perforation_tether.py (a study apart from the ladder's table; session 10, one
    thread, AMD EPYC Zen 4, shared two-core machine)."""
    return [
        "**The fine 400 m/s point: a damaged cell tethers the plug.** Its 35,572 steps "
        "(13,535 on the coarse mesh) and its hole of 8.8 mm (12.6-13.7 mm at every other "
        "point) have one cause, found by recording the element that sets the step every 100 "
        "steps (`python benchmarks/perforation_tether.py 400 1.2 1.0`; rerun in session 10: "
        "35,435 steps, 320 CPU s, residual 198.5 m/s, hole 8.5 mm; the step counts of the two "
        "runs differ by 0.4 %, the residual speeds by 0.3 m/s). The sphere is through by "
        "45 us (its speed is constant from there), yet from 58 us to the end (142 us) one "
        "plate cell sets the step: a cell the ductile criterion has damaged (D = 1.00, "
        "plastic strain 0.80), which then carries bulk compression only, links the plug that "
        "follows the sphere to the plate and is dragged into a needle: its longest edge grows "
        "from 13 to 42 mm at constant volume (V/V0 = 1.01), so its height and the stable "
        "step fall with it, from 6.4 to 1.8 ns. That is 30,500 of the run's steps (86 %). "
        "Loosening (fracture/criteria.py, step 2) judges only the volumetric opening "
        "1 - V0/V > chi* = 0.03, which a cell stretched at constant volume never reaches, so "
        "the cell stays in the mesh. The same two cells join the plug (about 1,750 cells, "
        "52 mm below the plate at the end) to the plate through shared nodes; the hole is "
        "measured on the plate's largest piece (summary.json's definition), which then "
        "includes the plug, whose projection covers part of the opening. Without the two "
        "stretched cells, or joining pieces through intact cells only, the plug is a piece of "
        "its own and the hole reads 12.9 mm, in line with the other points. The residual "
        "speed is not affected: the cell carries no tension.", "",
        "The coarse 400 m/s run (13,535 steps, 59 CPU s) has no such tether; its step "
        "(8-9 ns after the perforation, against 52 ns at the start) is set by intact rim "
        "cells sheared to plastic strains of 4-5 and 20 mm long, a flap of the petals still "
        "attached to the plate (its hole, 13.2 mm, is not affected).", "",
        "What would fix it, in files this rung does not own: (a) loosen a damaged cell also "
        "on its stretch. Tried in a scratch copy of the package (fracture/criteria.py: a "
        "DAMAGED cell whose largest principal stretch since t = 0 exceeds 3 becomes "
        "FRACTURED, hence particles on the surface): 11,930 steps, 145 CPU s, residual "
        "198.5 m/s, hole 12.7 mm; the step then stays at 11.5 ns, set by intact rim cells "
        "(plastic strain 4). Built in session 10 (for tets and hexes, and also only for "
        "cells on the surface) and reverted: it rescued this point but throttled "
        "sphere-plate's step (cases/sphere-plate.toml: 603 -> 1,718 steps), where an intact "
        "rim cell of the plate was then drawn "
        "from 2.8 to 9.2 mm (plastic strain 2.6 -> 4.6) and set the step from 5 to 0.8 ns. "
        "(b) Join the "
        "hole's largest piece through intact cells only (fracture/measures.py): the hole "
        "reads 12.9 mm, the step stays throttled. Distortion erosion (`[fracture] "
        "distortion_interval = \"0.5 us\"`, r1 = 3) is not a fix for this rung: it removes "
        "the tether (5,874 steps, hole 12.6 mm) but deletes 424 sheared cells around the "
        "plug during the perforation, and the residual speed reads 241.0 m/s (+21 %). The "
        "table above keeps the stock runs.", ""]



# The library's 6061-T6 Johnson-Cook strength against measured flow curves (no FE run): true
# stress at given plastic strains, as processed from the papers' figures in B. Banerjee's
# collection (github.com/bbanerjee/HighRateExptData, 6061T6AlData/SigEpsEp*.dat.raw: columns P,
# T, strain rate, strain, plastic strain, stress [MPa]; the plastic strain is the strain less
# stress / E). A few points of each curve, read from those files.
FLOW_BANERJEE = ("as digitised and processed in B. Banerjee's collection "
                 "(github.com/bbanerjee/HighRateExptData, 6061T6AlData/{f})")
FLOW_REFERENCES = {
    # name: (strain rate [1/s], test temperature [K], [(plastic strain, stress MPa)], source)
    "Fish 0.001/s": (1e-3, 295.0, [(0.020, 316.0), (0.170, 366.1)],
                     "Fish, Oskay, Fan & Barsoum (2005), Al 6061-T6-Elastomer Impact "
                     "Simulations, RPI SCOREC report 2005-11 (quasi-static), " + FLOW_BANERJEE.format(
                         f="SigEpsEp0001s295KFis.dat.raw")),
    "Fish 2500/s": (2500.0, 295.0, [(0.020, 365.1), (0.169, 437.4)],
                    "Fish et al. (2005) (Hopkinson bar), " + FLOW_BANERJEE.format(
                        f="SigEpsEp2500s295KFis.dat.raw")),
    "Lee 1000/s": (1000.0, 298.0, [(0.052, 376.9), (0.150, 398.9), (0.244, 408.5)],
                   "Lee, Shyu & Chiou (2000), Scripta Mater. 42:51, " + FLOW_BANERJEE.format(
                       f="SigEpsEp1000s298KLee.dat.raw")),
    "Lee 4000/s": (4000.0, 298.0, [(0.058, 406.2), (0.145, 423.8), (0.229, 432.8)],
                   "Lee, Shyu & Chiou (2000), " + FLOW_BANERJEE.format(
                       f="SigEpsEp4000s298KLee.dat.raw")),
    "Lesuer 4000/s": (4000.0, 298.0, [(0.049, 364.0), (0.112, 403.0), (0.262, 419.0),
                                      (0.412, 432.1)],
                      "Lesuer, Kay & LeBlanc (1999/2001), UCRL-JC-134118, "
                      + FLOW_BANERJEE.format(f="SigEpsEp4000s298KLes.dat.raw")),
}


def jc_flow_curve(material, rate: float, t0: float, eps: np.ndarray) -> np.ndarray:
    """The Johnson-Cook flow stress of a library Material at a constant plastic strain rate,
    from the test temperature t0, along the plastic strains eps (increasing): adiabatic (the
    Taylor-Quinney share of the plastic work heats the specimen) above 10 1/s, isothermal
    below, as a Hopkinson-bar and a quasi-static test are. Stress in Pa."""
    st = material.strength
    n = 2000
    grid = np.linspace(0.0, float(eps.max()), n)
    t = t0
    out = np.empty(n)
    rf = 1.0 + st.C * math.log(max(rate / st.strain_rate_ref, 1e-30))
    for i, e in enumerate(grid):
        ts = min(max((t - st.room_temperature) / (st.melt_temperature - st.room_temperature),
                     0.0), 1.0)
        out[i] = (st.A + st.B * e ** st.n) * rf * (1.0 - ts ** st.m)
        if rate > 10.0 and i + 1 < n:
            t += material.taylor_quinney * out[i] * (grid[i + 1] - e) / (
                material.density * material.specific_heat)
    return np.interp(eps, grid, out)


def run_flow_curves(name: str = "al-6061-t6") -> list[dict]:
    from impactsim.case.material import library_material

    mat = library_material(name)
    rows = []
    for ref, (rate, t0, pts, _src) in FLOW_REFERENCES.items():
        eps = np.array([p[0] for p in pts])
        sim = jc_flow_curve(mat, rate, t0, eps) / 1e6
        for (e, meas), s in zip(pts, sim):
            rows.append({"rung": "flow-6061", "element": ref, "h_mm": e, "material": name,
                         "strain_rate": rate, "plastic_strain": e, "measured_mpa": meas,
                         "jc_mpa": float(s), "error": float((s - meas) / meas)})
    return rows



TAYLOR_RATE_C = (0.002, 0.012)  # the library's C, and the C the measured rate rise asks for


def run_taylor_rate_study(C: float) -> dict:
    """The 6061-T6 Taylor bar (373 m/s, anp, h = 1 mm) with the library's Johnson-Cook set but
    the strain-rate constant C: how far the constants move the length and the foot."""
    from impactsim.case import load_case_text
    from impactsim.solver.run import run_case

    text = TAYLOR.format(name="taylor-6061-rate", end=60.0, element="anp",
                         material="al6061-rate", h=1.0, speed=373.0, length=23.47,
                         centre=0.5 * 23.47 + 1e-4)
    text += f"""
[[material]]
name = "al6061-rate"
library = "al-6061-t6"
strength = {{ model = "johnson-cook", A = "324 MPa", B = "114 MPa", n = 0.42, C = {C}, m = 1.34, melt_temperature = "925 K", room_temperature = "293 K", strain_rate_ref = "1 /s" }}
"""
    out = OUT / f"taylor-6061-rate-C{C}"
    t0 = time.perf_counter()
    s = run_case(load_case_text(text), out, progress=False)
    res = {"rung": "taylor-6061-373-rate", "element": "anp", "h_mm": C, "C": C,
           "wall_s": time.perf_counter() - t0, "steps": s["steps"],
           "energy_balance_error": s["energy_balance_error"], "stopped": s["stopped"]}
    res.update(taylor_measures(out))
    f = s.get("fracture")
    res["damaged"] = f["damaged_total"] if f else 0
    return res


def fit_rate_constant() -> float:
    """The Johnson-Cook C that gives Fish et al.'s measured rise of the flow stress from 0.001
    to 2500 1/s at a plastic strain of 0.17 (FLOW_REFERENCES), the strain-hardening and thermal
    factors being equal at the two rates to first order."""
    lo = FLOW_REFERENCES["Fish 0.001/s"][2][1][1]
    hi = FLOW_REFERENCES["Fish 2500/s"][2][1][1]
    r, l1, l2 = hi / lo, math.log(2500.0), math.log(1e-3)
    return (r - 1.0) / (l1 - r * l2)


def flow_report(results: list[dict]) -> list[str]:
    rows = [r for r in results if r["rung"] == "flow-6061"]
    if not rows:
        return []
    lines = ["## The 6061-T6 strength law against measured flow curves", "",
             "The library's Johnson-Cook set for `al-6061-t6` (A = 324 MPa, B = 114 MPa, "
             "n = 0.42, C = 0.002, m = 1.34; the 'Lesuer/Corbett' set) evaluated at the tests' "
             "strain rates and temperatures (adiabatic heating above 10 1/s, the Taylor-Quinney "
             "0.9), against the true stress the tests measured at the same plastic strain. "
             "No FE run: this checks the constants, not the solver.", "",
             "| test | strain rate [1/s] | plastic strain | measured [MPa] | Johnson-Cook "
             "[MPa] | error |", "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['element']} | {r['strain_rate']:g} | {r['plastic_strain']:.3f} | "
                     f"{r['measured_mpa']:.0f} | {r['jc_mpa']:.0f} | {100 * r['error']:+.1f} % |")
    quasi = [r["error"] for r in rows if r["strain_rate"] < 1]
    fast = [r["error"] for r in rows if r["strain_rate"] >= 1000]
    lines += ["", f"**Reading.** The set is {100 * np.mean(quasi):+.0f} % off at 0.001 1/s and "
              f"{100 * min(fast):+.0f} to {100 * max(fast):+.0f} % off at 1,000-4,000 1/s: the "
              "measured flow stress rises by about 15-20 % from quasi-static to Hopkinson-bar "
              "rates, the set's C = 0.002 gives 3 %. The Taylor bar (above) flows at "
              "10^3-10^4 1/s, where the set is too soft; a softer rod ends shorter, which is "
              "the sign of the 6061-T6 bar's length error (-1.7 to -2.9 %). This is the "
              "material-constants part of that error (the element and the mesh move the "
              "length by about half a per cent). The entry is left as it is: a set fitted to "
              "these rates would be the fix, to be checked against the Taylor bar and the "
              "plate again.", ""]
    study = sorted((r for r in results if r["rung"] == "taylor-6061-373-rate"),
                   key=lambda r: r["C"])
    ref = REFERENCES["taylor-6061-373"]
    if study:
        lines += [f"**How far the rate constant moves the Taylor bar.** Fish et al.'s rise of "
                  f"the flow stress from 0.001 to 2500 1/s at a plastic strain of 0.17 asks for "
                  f"C = {fit_rate_constant():.4f}. The 6061-T6 bar at 373 m/s (anp, h = 1 mm, "
                  "the library's set with only C changed):", "",
                  "| C | steps | wall s | length [mm] | error | foot [mm] | error | damaged | "
                  "energy balance |", "|---|---|---|---|---|---|---|---|---|"]
        for r in study:
            el = 100 * (r["length_mm"] - ref["length_mm"]) / ref["length_mm"]
            ef = 100 * (r["foot_diameter_mm"] - ref["foot_mm"]) / ref["foot_mm"]
            lines.append(f"| {r['C']:g} | {r['steps']:,} | {r['wall_s']:.0f} | "
                         f"{r['length_mm']:.2f} | {el:+.1f} % | {r['foot_diameter_mm']:.2f} | "
                         f"{ef:+.1f} % | {r['damaged']} | {r['energy_balance_error']:+.1e} |")
        if len(study) == 2:
            a, b = study
            dl = 100 * (b["length_mm"] - a["length_mm"]) / ref["length_mm"]
            df = 100 * (b["foot_diameter_mm"] - a["foot_diameter_mm"]) / ref["foot_mm"]
            lines += ["", f"The measured rate sensitivity moves the length by {dl:+.1f} % and "
                      f"the foot by {df:+.1f} % of the measured values: the constants alone "
                      "span the length's error on either side, so within this set's "
                      "uncertainty the length is not a measure of the solver. The foot "
                      "narrows as the length grows; a set fitted to all the curves (it would "
                      "also lower A, 2-8 % high quasi-statically) is needed before either "
                      "number can say more.", ""]
    lines += ["Sources:", ""]
    for ref, (_r, _t, _p, src) in FLOW_REFERENCES.items():
        lines.append(f"- {ref}: {src}.")
    lines.append("")
    return lines


def run_all(rungs=None) -> list[dict]:
    """Run the ladder, or with rungs (name prefixes) only those rungs, their results replacing
    the same rung, element and mesh size in benchmarks/validation_results.json (RESULTS)."""
    OUT.mkdir(parents=True, exist_ok=True)
    results = []

    def wanted(name):
        return rungs is None or any(name.startswith(r) for r in rungs)

    def add(res):
        results.append(res)
        print(json.dumps(res), flush=True)

    for element in ELEMENTS:
        for args in TAYLORS:
            if wanted(args[0]):
                add(run_taylor(*args, element))
        if wanted("plate-6061-500"):
            add(run_plate(element))
            add(run_plate(element, d19=True))
        if wanted("oblique-sphere-1001"):
            add(run_perforation(element))
            if element == "tet4":
                add(run_perforation(element, default_spall=True))
    if wanted("sphere-plate-2000"):
        add(run_sphere_plate(True))
        add(run_sphere_plate(False))
    if wanted("flow-6061"):
        for r in run_flow_curves():
            add(r)
    if wanted("taylor-6061-373-rate"):
        for C in TAYLOR_RATE_C:
            add(run_taylor_rate_study(C))
    for hs, hp in PERFORATION_MESHES:
        for speed in PERFORATION_SPEEDS:
            if wanted(f"perforation-{speed:.0f}"):
                add(run_perforation_sweep(speed, hs, hp))
    for formulation in CRMO_FORMULATIONS:
        for h in CRMO_SIZES:
            if wanted("taylor-42crmo4-287"):
                add(run_crmo(h, formulation))
    if rungs is not None:
        results = merge_results(load_results(), results)
    RESULTS.write_text(json.dumps(results, indent=1) + "\n")
    (OUT / "results.json").write_text(json.dumps(results, indent=1))
    return results


def _key(r: dict) -> tuple:
    return r["rung"], r["element"], r["h_mm"]


def load_results() -> list[dict]:
    """The stored results of the last runs of every rung (RESULTS, in git), else those of this
    machine's last run (out/validation/results.json), else none."""
    for f in (RESULTS, OUT / "results.json"):
        if f.exists():
            return json.loads(f.read_text())
    return []


def merge_results(old: list[dict], new: list[dict]) -> list[dict]:
    """The old records with those the new run replaces (same rung, element and mesh size)
    taken out, in their order, then the new ones: a partial run never drops another rung."""
    keys = {_key(r) for r in new}
    return [r for r in old if _key(r) not in keys] + list(new)


def _fmt(v, nd=3):
    if v is None:
        return "–"
    if isinstance(v, float):
        return f"{v:.{nd}g}" if abs(v) < 1e4 else f"{v:,.0f}"
    return f"{v:,}" if isinstance(v, int) else str(v)


def plots(results: list[dict]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    FIG.mkdir(parents=True, exist_ok=True)
    histories = [(element, tag, label, OUT / f"plate{tag}-{element}.npz") for element in ELEMENTS
                 for tag, label in (("", ""), ("-d19", ", [D19] spall"))]
    # all four curves or none: a machine holding only some histories (an older run's) would
    # redraw the figure with curves missing; then the figure of the last full run is kept
    if all(f.exists() for *_x, f in histories):
        plate_plot(histories)
    crmo_plot(results)
    tay = [r for r in results if r["rung"] in TAYLOR_RUNGS]
    if tay:
        fig, ax = plt.subplots(figsize=(6, 3.5))
        names = sorted({r["rung"] for r in tay})
        xs = np.arange(len(names))
        for k, element in enumerate(ELEMENTS):
            vals = [next((r["foot_diameter_mm"] for r in tay if r["rung"] == n
                          and r["element"] == element), np.nan) for n in names]
            ax.bar(xs + 0.35 * k, vals, 0.35, label=element)
        ax.set_xticks(xs + 0.175, names, fontsize=8)
        ax.set_ylabel("foot diameter [mm]")
        ax.legend()
        fig.tight_layout()
        fig.savefig(FIG / "taylor-foot.png", dpi=110)
        plt.close(fig)


def plate_plot(histories) -> None:
    """The rear free-surface velocity histories of the plate rung (out/validation/*.npz)."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.5))
    for element, tag, label, f in histories:
        if f.exists():
            d = np.load(f)
            ax.plot(1e6 * d["t"], d["u"], label=element + label, ls="--" if tag else "-")
    ax.axhline(500.0, color="grey", lw=0.8, ls="--", label="impact speed = 2 u_p")
    ax.set_xlabel("t [us]")
    ax.set_ylabel("free-surface velocity [m/s]")
    ax.set_title("6061-T6 symmetric plate impact, 500 m/s")
    ax.legend()
    fig.tight_layout()
    fig.savefig(FIG / "plate-free-surface.png", dpi=110)
    plt.close(fig)


def crmo_plot(results: list[dict]) -> None:
    """Foot diameter and length of the 42CrMo4 bar against the mesh size, per formulation,
    with the two codes' values."""
    import matplotlib.pyplot as plt

    rows = [r for r in results if r["rung"] == "taylor-42crmo4-287"]
    if not rows:
        return
    codes = CODE_REFERENCES["taylor-42crmo4-287"]["codes"]
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.5))
    for ax, key, label in ((axes[0], "foot_diameter_mm", "foot diameter [mm]"),
                           (axes[1], "length_mm", "final length [mm]")):
        for formulation in CRMO_FORMULATIONS:
            rs = sorted((r for r in rows if r["element"] == formulation), key=lambda r: r["h_mm"])
            ax.plot([r["h_mm"] for r in rs], [r[key] for r in rs], "o-", label=formulation)
        for (name, ref), ls in zip(codes.items(), ("--", ":")):
            ax.axhline(ref[key], color="grey", ls=ls, lw=1, label=name)
        ax.set_xlabel("mesh size h [mm]")
        ax.set_ylabel(label)
        ax.invert_xaxis()
    axes[0].legend(fontsize=8)
    fig.suptitle("42CrMo4 Taylor bar, 287 m/s: impactsim against DynELA and Abaqus/Explicit")
    fig.tight_layout()
    fig.savefig(FIG / "taylor-42crmo4.png", dpi=110)
    plt.close(fig)


def crmo_report(results: list[dict]) -> list[str]:
    rows = [r for r in results if r["rung"] == "taylor-42crmo4-287"]
    if not rows:
        return []
    ref = CODE_REFERENCES["taylor-42crmo4-287"]
    codes = ref["codes"]
    mean = {k: sum(c[k] for c in codes.values()) / len(codes) for k in CRMO_MEASURES}
    lines = ["## Code to code: the 42CrMo4 Taylor bar", "",
             "`cases/taylor-bar-42crmo4.toml`: a 6.4 mm x 32.4 mm 42CrMo4 rod (Johnson-Cook "
             "with adiabatic heating, elastic volume response; library entry `steel-42crmo4`) "
             "onto a rigid frictionless wall at 287 m/s, 80 us, refined with each "
             "formulation. The references are two codes' 3-D results for the same problem "
             "(DynELA's mesh: 4,455 elements); they agree with each other within 0.4 %. "
             "The error columns are against the mean of the two. CPU seconds, one thread.", "",
             "| element | h [mm] | elements | steps | CPU s | length [mm] | error | foot [mm] "
             "| error | peak plastic strain | error | peak T [C] | energy balance |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, c in codes.items():
        n = "4,455" if name == "DynELA" else ""
        lines.append(f"| {name} | | {n} | | | {c['length_mm']:.2f} | | "
                     f"{c['foot_diameter_mm']:.2f} | | {c['peak_plastic_strain']:.2f} | | "
                     f"{c['peak_temperature_c']:.1f} | |")

    def err(r, k):
        return f"{100 * (r[k] - mean[k]) / mean[k]:+.1f} %"

    for formulation in CRMO_FORMULATIONS:
        for r in sorted((r for r in rows if r["element"] == formulation),
                        key=lambda r: -r["h_mm"]):
            lines.append(f"| {formulation} | {r['h_mm']} | {r['elements']:,} | {r['steps']:,} | "
                         f"{r['cpu_s']:.1f} | {r['length_mm']:.2f} | {err(r, 'length_mm')} | "
                         f"{r['foot_diameter_mm']:.2f} | {err(r, 'foot_diameter_mm')} | "
                         f"{r['peak_plastic_strain']:.2f} | {err(r, 'peak_plastic_strain')} | "
                         f"{r['peak_temperature_c']:.0f} | {r['energy_balance_error']:+.1e} |")
    lines += ["", "**Convergence.** Change between the two finest levels of each series:", ""]
    for formulation in CRMO_FORMULATIONS:
        rs = sorted((r for r in rows if r["element"] == formulation), key=lambda r: r["h_mm"])
        if len(rs) < 2:
            continue
        a, b = rs[0], rs[1]
        d = {k: 100 * abs(a[k] - b[k]) / abs(a[k]) for k in CRMO_MEASURES[:3]}
        lines.append(f"- {formulation}, {b['h_mm']} -> {a['h_mm']} mm: length {d['length_mm']:.2f} %, "
                     f"foot {d['foot_diameter_mm']:.2f} %, peak plastic strain "
                     f"{d['peak_plastic_strain']:.1f} %.")
    lines += ["", "**Reading.** The length hardly depends on the element (all three series within "
              "0.5 % of the codes): it is set by the momentum and the flow stress. The foot and "
              "the peak strain are where the element matters. tet4 locks in the nearly "
              "incompressible plastic flow of the foot: its foot is 14 % narrow at the case's "
              "0.8 mm and still 9 % narrow with 46,000 elements, its peak strain and heating far "
              "too low; refining cures it only slowly. anp (the averaged nodal pressure removes "
              "the locking) and hex8 (one point, no locking) converge in the foot (0.1 % between "
              "their two finest levels) to within 0.7 % (anp) and 1.4 % (hex8) of the codes; "
              "their values at the codes' own resolution (DynELA's 4,455 elements are about "
              "0.4 mm along the axis and 0.8 mm across) are within 1.1 % (anp) and 0.8 % (hex8 "
              "at 0.8 mm, which also matches the peak strain and temperature within 0.2 %). "
              "The peak plastic strain is one cell's value at the centre of the impact face: "
              "it grows with refinement in every series and is not a converged quantity, so "
              "compare it at equal cell size. hex8 reaches the codes' answer with the fewest "
              "elements and the least CPU time, which is why the bundled case uses it. This is "
              "the evidence behind the defaults (docs/physics.md): plastic tet bodies without "
              "contact get anp, and `impactsim check` hints at locking when tet4 meets "
              "plasticity.", "",
              f"Source: {ref['source']}.", "",
              "![42CrMo4 Taylor bar](validation/taylor-42crmo4.png)", ""]
    return lines


def report(results: list[dict]) -> str:
    import numba
    import numpy

    lines = ["# Validation ladder", "",
             "<!-- Generated by `make validate` (python benchmarks/validate.py); "
             "`python benchmarks/validate.py --report-only` rewrites it from "
             "benchmarks/validation_results.json. Do not edit by hand. -->", "",
             f"Generated on {time.strftime('%Y-%m-%d')} (Python {platform.python_version()}, "
             f"numpy {numpy.__version__}, numba {numba.__version__}); the two-core machine was "
             "shared with other work, so wall times carry its load. Each rung runs with both tet "
             "formulations (`run.element`: `tet4`, the constant-strain tet; `anp`, the "
             "averaged-nodal-pressure tet, the default for plastic bodies without contact between "
             "bodies: docs/physics.md).", "",
             "**Resolution.** The copper bar runs at 0.8 mm, where the accuracy study "
             "(docs/accuracy.md, taylor-mesh) has its length within 0.1 % and the anp foot "
             "within 0.4 % of the 0.635 mm run; the 6061-T6 and 4340 bars run at 1.0 and "
             "0.7 mm (their convergence is stated below the table); the perforation runs at the "
             "test suite's coarse mesh and is not shown converged (machine time). Read its "
             "element-to-element differences, not its last digits.", "",
             "**What is measured against what.** Measured values are used only where one is on "
             "record here with its source; the status of each is given. Where none is (the "
             "perforation), the rung records the two formulations' "
             "results and the physics checks that need no measurement (no fracture in a Taylor "
             "bar; the free-surface plateau of a symmetric impact).", ""]
    lines += ["## Taylor bars", "",
              "Rods of 7.62 mm diameter with the lengths of the experiments they are compared "
              "with (copper 25.4 mm, the 6061-T6 rod 23.47 mm, the 4340 rods 25.4, 12.7 and "
              "8.1 mm) onto a rigid frictionless wall, with the library's failure data, the "
              "default spall criterion (`[fracture] spall_criterion = \"tuler-butcher\"` on "
              "`spall_pressure = \"lesser\"`: the tension both the cell and its patch carry, "
              "integrated over time; docs/fracture.md) and no ductile criterion (the default, "
              "`ductile_criterion = \"none\"`; docs/fracture.md says why). Length and foot diameter of the "
              "last frame against the measured ones; `damaged (ductile)` counts the cells "
              "damaged, by spall or the ductile criterion, and in brackets those of the ductile "
              "criterion (rows without brackets are older runs, spall only). With the "
              "instantaneous cell criterion of [D19] (the default before) the 6061-T6 bar at "
              "373 m/s (25.4 mm, h = 1 mm) fractured 2,175 cells with tet4 and 280 with anp, "
              "and the tet4 4340 bar 272: tet4's pressure checkerboard holds single cells of "
              "the compressed foot at 7-12 GPa of tension for tens of microseconds, and the "
              "lateral release converging on the 6061 bar's axis puts it above 1.6 GPa for "
              "under 0.4 us (docs/fracture.md).", "",
              "| rung | element | h [mm] | elements | steps | wall s | length [mm] | measured "
              "[mm] | error | foot [mm] | measured [mm] | error | damaged (ductile) | "
              "energy balance |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]

    def _err(v, ref):
        return f"{100 * (v - ref) / ref:+.1f} %" if ref else "–"

    order = {n: k for k, n in enumerate(dict.fromkeys(t[0] for t in TAYLORS))}
    for r in sorted((r for r in results if r["rung"] in TAYLOR_RUNGS),
                    key=lambda r: (order[r["rung"]], r["element"], -r["h_mm"])):
        ref = REFERENCES.get(r["rung"], {})
        lref, fref = ref.get("length_mm"), ref.get("foot_mm")
        dam = (f"{r['damaged_cells']} ({r['ductile_cells']})" if "damaged_cells" in r
               else f"{r['fractured_cells']}")
        lines.append(f"| {r['rung']} | {r['element']} | {r['h_mm']} | {r['elements']:,} | "
                     f"{r['steps']:,} | {r['wall_s']:.1f} | {r['length_mm']:.2f} | "
                     f"{f'{lref:.2f}' if lref else '–'} | {_err(r['length_mm'], lref)} | "
                     f"{r['foot_diameter_mm']:.2f} | {f'{fref:.2f}' if fref else '–'} | "
                     f"{_err(r['foot_diameter_mm'], fref)} | {dam} | "
                     f"{r['energy_balance_error']:+.1e} |")
    cu = {r["element"]: r for r in results if r["rung"] == "taylor-cu-190"}
    ref = REFERENCES["taylor-cu-190"]["length_mm"]
    if len(cu) == 2:
        d_el = abs(cu["tet4"]["length_mm"] - cu["anp"]["length_mm"]) / ref
        err = (cu["anp"]["length_mm"] - ref) / ref
        lines += ["", f"**Where the copper bar's length error comes from.** Both formulations end "
                  f"{100 * err:+.1f} % (anp) from the length on record; they differ from each "
                  f"other by {100 * d_el:.1f} %, and the length is converged in the mesh within "
                  "0.2 % (docs/accuracy.md, taylor-mesh: 17.34 mm at 0.635 mm, anp). Neither "
                  "the element nor the mesh is the source. What is left: the material constants "
                  "(the 1983 Johnson-Cook fit of OFHC copper, from torsion and Hopkinson-bar "
                  "tests to strains of about 1, drives a foot that reaches plastic strains of "
                  "2-3), the frictionless wall, or the measured value, which we have through two "
                  "transcriptions (the case file and Banerjee's collection, which agree: "
                  "L_f / L0 = 0.638), not from the paper. No study here separates those three. "
                  "The foot diameter is where the element matters: tet4's is "
                  f"{100 * (cu['tet4']['foot_diameter_mm'] / cu['anp']['foot_diameter_mm'] - 1):+.0f} "
                  "% from anp's (volumetric locking), see docs/physics.md; anp's is "
                  f"{100 * (cu['anp']['foot_diameter_mm'] / REFERENCES['taylor-cu-190']['foot_mm'] - 1):+.1f}"
                  " % from the measured 13.56 mm."]
    al = [r for r in results if r["rung"] == "taylor-6061-373"]
    if al:
        ref = REFERENCES["taylor-6061-373"]["length_mm"]
        errs = [100 * (r["length_mm"] - ref) / ref for r in al]
        lines += ["", f"**The 6061-T6 bar's length.** All four runs end {min(errs):+.1f} to "
                  f"{max(errs):+.1f} % from the length on record, the formulations and meshes "
                  "moving it by about half a per cent. Left for the length: the Johnson-Cook "
                  "constants of 6061-T6 (the library's are marked 'check'), the frictionless "
                  "wall, and the recorded value itself, read from a digitised figure and not "
                  "confirmed against the paper. Cells damaged by spall (the calibrated 0.03 us "
                  "spall time, plate rung below): "
                  + ", ".join(f"{r['element']} {r['h_mm']} mm: {r['damaged_cells']}" for r in al)
                  + " (with session 7's 0.2 us none of them spalled, but the plate's pull-back "
                  "then read 3.1 GPa against the 1.6 given: one Tuler-Butcher time does not "
                  "give both, and no published constants for this alloy are in our sources; a "
                  "known departure, issue 17). With the ductile criterion on (`ductile_criterion = \"johnson-cook\"`, "
                  "not the default) the rim of the foot cracks, and more so the finer the mesh: "
                  "the library's 6061-T6 D1..D5 (marked 'check') give eps_f of about 1 at the "
                  "rim's triaxiality and temperature, where the plastic strain reaches 1-1.8; "
                  "anp at 0.7 mm then damaged 1,947 cells in 60,372 steps and its foot read "
                  "+41 % (session 8). A local damage law localises without a length scale; "
                  "that, and the issue's demand that no Taylor bar fracture, is why the "
                  "criterion is off by default (docs/fracture.md)."]
    st = [r for r in results if r["rung"].startswith("taylor-4340-") and "foot_mm" in
          REFERENCES.get(r["rung"], {})]
    if st:
        el = [100 * (r["length_mm"] / REFERENCES[r["rung"]]["length_mm"] - 1) for r in st]
        ef = [100 * (r["foot_diameter_mm"] / REFERENCES[r["rung"]]["foot_mm"] - 1) for r in st]
        lines += ["", f"**The 4340 bars (Johnson & Cook 1983).** Three rods of one steel (Rc 30, "
                  "the temper of the library's Johnson-Cook set) of 25.4, 12.7 and 8.1 mm at 208, "
                  f"282 and 343 m/s. Lengths {min(el):+.1f} to {max(el):+.1f} % from the "
                  f"measured, foot diameters {min(ef):+.1f} to {max(ef):+.1f} % (both "
                  "formulations, both meshes). The shortest rod at the highest speed is the "
                  "furthest off in length and the least converged (the convergence list below: "
                  "its 8.1 mm are only 8 to 12 cells long); the element moves the lengths by 1-3 "
                  "% and the feet by 5-7 % (tet4 narrower, locking). Not separated here: the "
                  "Johnson-Cook constants (fitted to 1983 data of this steel, to strains below "
                  "those of the foot), the frictionless wall, and the transcription. The measured "
                  "foot diameters are not monotonic in the speed (10.4 mm at 282 m/s, 11.1 at "
                  "208): the rods differ in length, and the values are one transcription of "
                  "the paper's figures. No cell of any 4340 bar is damaged, by spall or by the "
                  "ductile criterion (Johnson & Cook's 1985 D1..D5 give eps_f of about 3.5 in "
                  "shear), as the recovered specimens show none."]
    conv = []
    for name in ("taylor-6061-373", "taylor-4340-208", "taylor-4340-282", "taylor-4340-343"):
        for element in ELEMENTS:
            rs = sorted((r for r in results if r["rung"] == name and r["element"] == element),
                        key=lambda r: -r["h_mm"])
            if len(rs) >= 2:
                a, b = rs[-2], rs[-1]
                conv.append(f"- {name}, {element}, {a['h_mm']} -> {b['h_mm']} mm: length "
                            f"{100 * abs(b['length_mm'] / a['length_mm'] - 1):.2f} %, foot "
                            f"{100 * abs(b['foot_diameter_mm'] / a['foot_diameter_mm'] - 1):.2f}"
                            " %.")
    if conv:
        lines += ["", "**Convergence of the 6061-T6 and 4340 bars.** Change between the two "
                  "mesh levels:", ""] + conv
    lines += ["", "References:", ""]
    for k, v in REFERENCES.items():
        lines.append(f"- {k}: {v['source']}.")
    lines += ["", "![Taylor foot diameters](validation/taylor-foot.png)", ""]
    lines += flow_report(results)
    lines += ["## Symmetric plate impact: free-surface velocity", "",
              "6061-T6 onto 6061-T6 at 500 m/s in uniaxial strain (flyer 2 mm, target 4 mm, "
              "h = 0.1 mm, spall strength 1.6 GPa, spall time and loosening 0.03 from the "
              "library, the default Tuler-Butcher criterion). The rear free surface of the "
              "target jumps by about the impact speed (u_p = V/2 exactly by symmetry; the "
              "free-surface approximation u_fs = 2 u_p holds to a few per cent in an "
              "elastic-plastic release), then the spall's pull-back du (the plateau less the "
              "first minimum that follows) gives the acoustic estimate rho0 c0 du / 2 of the "
              "tension at which the material failed: what a plate-impact experiment reports "
              "as its spall strength. `tension at failure` is the largest axial tension any "
              "cell carried before the first one spalled. Rows `[D19]` run the instantaneous "
              "cell criterion instead of the default.", "",
              "| element | spall | tau [us] | elements | steps | wall s | plateau [m/s] | "
              "2 u_p [m/s] | error | pull-back [m/s] | spall estimate [GPa] | tension at "
              "failure [GPa] | given [GPa] |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        if not r["rung"].startswith("plate-6061-500"):
            continue
        err = 100 * (r["free_surface_plateau"] - r["impact_speed"]) / r["impact_speed"]
        spall = "[D19]" if r["rung"].endswith("-d19") else "default"
        tau = f"{r['spall_time_us']:.2g}" if "spall_time_us" in r and spall == "default" \
            else ("0" if spall == "[D19]" else "0.2")
        ft = f"{r['failure_tension_gpa']:.2f}" if "failure_tension_gpa" in r else "–"
        lines.append(f"| {r['element']} | {spall} | {tau} | {r['elements']:,} | "
                     f"{r['steps']:,} | {r['wall_s']:.1f} | {r['free_surface_plateau']:.1f} | "
                     f"{r['impact_speed']:.0f} | {err:+.1f} % | {r['pullback']:.1f} | "
                     f"{r['spall_estimate_gpa']:.2f} | {ft} | {r['spall_given_gpa']:.2f} |")
    lines += ["", "**Why it read 3.1 GPa, and the spall time now.** The estimate is the "
              "observable a plate-impact experiment reports as the spall strength, so it is "
              "what a simulation of the experiment has to reproduce. Under the Tuler-Butcher "
              "integral a cell fails not at the threshold sigma_0 but once the overstress has "
              "lasted: here the tension at the spall plane rises within about 0.1 us to the "
              "pulse's 3.6 GPa, and with the spall time of 0.2 us chosen before the cells failed "
              "after about 0.16 us at that tension, when the free surface had released to near "
              "rest: the estimate read 3.1 GPa against the 1.6 given (tau = 0.02 / 0.05 / 0.1 / "
              "0.2 us: 1.47 / 2.01 / 2.59 / 3.12 GPa with tet4). No published Tuler-Butcher "
              "constants for 6061-T6 or 2024 were found (below), so the aluminium alloys' tau "
              "is now calibrated to this observable: 0.03 us, with which the simulated plate's "
              "estimate reads the library's 1.6 GPa (tet4 1.60, anp 1.56). The estimate is not "
              "the tension a cell carried: the largest cell tension before the first spall is "
              "3.3 GPa (tet4) at tau = 0.03 us, and under [D19]'s instantaneous criterion the "
              "first cell fails at 1.56 GPa while the estimate reads 0.94: at this mesh the "
              "free surface under-reads the spall plane's tension by about 40 % (the release "
              "and the recompression are smeared over a few cells and by the bulk viscosity), "
              "which is why the criterion has to let the cell tension overshoot to give the "
              "measured observable. The Taylor bars bound tau from below (spall alone, the "
              "ductile criterion off, a 25.4 mm rod): at 0.03 us the "
              "6061-T6 bar at 373 m/s spalls no cell with anp (the default for a plastic body "
              "without contact) at h = 1 and 1.27 mm, nor with tet4 at 1.27 mm, but 20 cells "
              "with tet4 at 1 mm (the part of tet4's pressure checkerboard its patch still "
              "carries); at 0.02 us one cell spalls with either. The calibration holds for this "
              "mesh (h = 0.1 mm) and impact speed; a measured plate-impact series would fix "
              "tau for good. The steels keep 0.2 us (no plate-impact rung for them here).", "",
              "![free-surface velocity](validation/plate-free-surface.png)", ""]
    sp = {r["rung"]: r for r in results if r["rung"].startswith("sphere-plate-2000")}
    if sp:
        lines += ["## Perforation under the defaults: sphere on plate [D19]", "",
                  "`cases/sphere-plate.toml` (4340 sphere r = 10 mm at 2 km/s onto a 2 mm "
                  "2024-T3 plate, 4 us) at the test suite's coarse mesh (plate 1 mm, sphere "
                  "2.4 mm), with the default spall criterion (Tuler-Butcher on the lesser "
                  "tension; the case itself keeps [D19]'s instantaneous one). [D19]'s "
                  "experiment perforates; they give no hole size or residual speed in our "
                  "sources, so the rung checks the outcome, perforated or not.", "",
                  "| ductile criterion | elements | steps | wall s | hole (equivalent "
                  "diameter) [mm] | residual speed [m/s] | damaged | of which ductile | "
                  "particles | energy balance |", "|---|---|---|---|---|---|---|---|---|---|"]
        for name, label in (("sphere-plate-2000", "johnson-cook"),
                            ("sphere-plate-2000-no-ductile", "none (default)")):
            r = sp.get(name)
            if r:
                lines.append(f"| {label} | {r['elements']:,} | {r['steps']:,} | "
                             f"{r['wall_s']:.1f} | {r['hole_diameter_mm']:.1f} | "
                             f"{r['residual_speed']:.0f} | {r['damaged']:,} | {r['ductile']:,} | "
                             f"{r['particles']:,} | {r['energy_balance_error']:+.1e} |")
        lines += ["", "Under the defaults (no ductile criterion) the plate does not perforate: a doming, sheared plate carries tensions near its flow stress "
                  "(0.3-0.5 GPa), far below a 1.6 GPa spall strength. The Johnson-Cook damage "
                  "of the ductile criterion (fracture/ductile.py, the library's 2024 D1..D5) "
                  "opens it; it is not the default because it cracks the aluminium Taylor bars' rims "
                  "(above). A perforation scene asks for it, or for [D19]'s instantaneous spall "
                  "as the bundled sphere-plate cases do. The hole is measured on the plate's "
                  "largest piece.", ""]
    lines += ["## Perforation: oblique sphere [R20]", "",
              "The bundled `cases/oblique-sphere.toml` (52100 sphere 12.7 mm at 1001 m/s, 60 "
              "degrees from the normal, into a 4.9 mm D16T plate) at the coarse mesh of the "
              "test suite (sphere 1.8 mm, plate 1.4 mm), 30 us. [R20] report hole and residual "
              "velocity within about 1 % of their experiment; the measured values are not in "
              "our sources, so the rung compares the formulations only. The case applies the "
              "plate's spall as [D19] do (`spall_criterion = \"instant\"` on the cell's own "
              "pressure); the last row runs it with the default spall criterion instead.", "",
              "| element | spall | elements | steps | wall s | residual speed [m/s] | angle "
              "[deg] | hole diameter [mm] | energy balance |",
              "|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        if not r["rung"].startswith("oblique-sphere-1001"):
            continue
        spall = "default" if r["rung"].endswith("default-spall") else "[D19]"
        lines.append(f"| {r['element']} | {spall} | {r['elements']:,} | {r['steps']:,} | "
                     f"{r['wall_s']:.1f} | {r['residual_speed']:.1f} | {r['angle_deg']:.1f} | "
                     f"{r['hole_diameter_mm']:.1f} | {r['energy_balance_error']:+.1e} |")
    per = {r["element"]: r for r in results if r["rung"] == "oblique-sphere-1001"}
    dflt = next((r for r in results if r["rung"] == "oblique-sphere-1001-default-spall"), None)
    if dflt is not None and "tet4" in per:
        d = (dflt["residual_speed"] - per["tet4"]["residual_speed"]) / per["tet4"]["residual_speed"]
        lines += ["", f"**The spall criterion matters here.** With the default criterion the "
                  f"tet4 sphere's residual speed is {100 * d:+.1f} % from the one with [D19]'s (the "
                  "criterion decides how much of the plate spalls and loosens ahead of the "
                  "sphere): larger than the element's effect and the 1 % [R20] claim. Which is closer to the experiment needs "
                  "[R20]'s measured residual speed, which is not in our sources; the case keeps "
                  "the criterion it was checked with."]
    if len(per) == 2:
        d = (per["anp"]["residual_speed"] - per["tet4"]["residual_speed"]) \
            / per["tet4"]["residual_speed"]
        lines += ["", f"The two formulations differ by {100 * d:+.1f} % in the residual speed "
                  "(not analysed further): at this mesh the element is a first-order source of uncertainty of a perforation, "
                  "larger than the 1 % [R20] claim against their experiment. anp ran this "
                  "contact scene to its end here, but collapsed the step in two others "
                  "(docs/physics.md), so contact scenes keep tet4 by default."]
    lines += [""] + perforation_sweep_report(results)
    lines += [""] + crmo_report(results)
    lines += [""] + sources_report()
    return "\n".join(lines) + "\n"


# Measured records found in the stored corpora (session 10) that no rung runs, with their
# citation and where they were read; sources_report() says why each is not run.
LEDGER = ("a public research ledger that quotes the papers' primary text (the stored code "
          "corpus, a file 'armor-damage SOURCES' of a game-design repository, corpus file id "
          "58282289096, sections 2.2, 3.1 and 5.1)")
FOUND_RECORDS = {
    "borvik-2002-weldox460e": {
        "what": "12 mm Weldox 460 E plates struck by 20 mm, 197 g hardened (HRC 53) steel "
                "projectiles, gas gun, 24 shots: ballistic limits (the mean of the highest "
                "non-perforating and the lowest perforating striking speed)",
        "ballistic_limit_m_s": {"blunt": 184.5, "hemispherical": 292.1, "conical": 290.6},
        "source": "Borvik, Langseth, Hopperstad & Malo (2002), Perforation of 12 mm thick steel "
                  "plates by 20 mm diameter projectiles with flat, hemispherical and conical "
                  "noses, Part I: experimental study, Int. J. Impact Eng. 27:19-35, Tables 1-3, "
                  "as quoted in " + LEDGER,
        "not_run": "no Weldox 460 E entry: its Johnson-Cook strength and damage constants "
                   "(Borvik et al. 2001, Part II) are named in public decks but not reproduced "
                   "in any source found, and a 12 mm steel plate perforated by an 80 mm long "
                   "projectile, with the plug's shear band resolved, is beyond this machine's "
                   "budget for a sweep",
    },
    "qiang-2022-ss304": {
        "what": "a clamped 304 stainless disc, 0.71 mm thick, 100 mm free diameter, struck by a "
                "rigid 12.7 mm, 8.3 g steel sphere: single-impact ballistic limit, and the "
                "limit of a second impact at the same point",
        "ballistic_limit_m_s": {"single": 205.1, "second at the same point": 127.2},
        "source": "the experiment (their ref. 23) quoted in Qiang, Zhang, Zhao, Ren, Ni, Zhao & "
                  "Lu (2022), Multiple ballistic impacts of thin metallic plates, Proc. IMechE "
                  "C, doi 10.1177/09544062221080139, Table 2, as quoted in " + LEDGER,
        "not_run": "no 304 stainless strength in the library (steel-generic is elastic), and "
                   "two cells through 0.71 mm over a 100 mm disc take about 10^6 tets",
    },
}


def sources_report() -> list[str]:
    """What was searched for and not found, and the records found but not run: issue 17's
    missing pieces, for the lead to judge which are blocked."""
    lines = ["## Sources not available here", "",
             "Searched for in session 9 and again in session 10 (the stored web pages, "
             "documentation, issue threads and public code: the `search` tool's four corpora "
             "with many phrasings, exact strings over the code corpus, and the repositories "
             "that carry impact data as test inputs). What was found and what was not:", "",
             "**Perforation with measured residual velocities: not available for a pairing "
             "this library can run.** Exact strings searched: 'Weldox 460' (three spellings), "
             "'Piekutowski', 'Recht-Ipson', 'ballistic limit velocity of', 'ballistic limit "
             "of 6061', 'residual velocities', '1100-H12', 'Borvik et al'; phrasings: Borvik "
             "Weldox blunt projectiles residual velocity, Piekutowski / Forrestal ogive rods "
             "into 6061-T651, Gupta / Iqbal aluminium plates, OpenRadioss / Radioss example "
             "guide perforation, perforation examples with experimental comparison, the "
             "Weldox 460 E Johnson-Cook constants. Titles, abstracts and decks citing the "
             "papers 'without republishing' the tables were found; no tabulated "
             "striking-residual series. Two measured ballistic limits were found, both as "
             "quoted in a secondary source (below); neither can be run here. The sweep above "
             "stays without an error column; a measured series for a pairing with constants "
             "on record goes into PERFORATION_REFERENCE (benchmarks/validate.py).", ""]
    for name, r in FOUND_RECORDS.items():
        lim = ", ".join(f"{k} {v:g} m/s" for k, v in r["ballistic_limit_m_s"].items())
        lines.append(f"- {name}: {r['what']}: {lim}. Source: {r['source']}. Not run: "
                     f"{r['not_run']}.")
    lines += ["", "**Plate-impact free-surface velocity (VISAR / PDV) records and pull-back "
              "tables: not found.** Exact strings: 'pullback velocity', 'pull-back velocity', "
              "'Spall Pullback Velocity (m/s)', 'spall strength of 6061', 'Johnson and Barker "
              "1969'; phrasings on VISAR records, spall strength tables of 6061-T6, OFHC "
              "copper, Armco iron and tantalum. Repositories opened: B. Banerjee's "
              "HighRateExptData (flow curves and Taylor data only) and ParSim/Vaango (flyer-"
              "plate and Taylor inputs, no measurements); SPADE (a spall-analysis toolkit that "
              "reads a literature table, combined_lit_table.csv, which is not in the "
              "repository); pyko-enhanced (simulated histories only); the scripts of a CEA "
              "1-D code (xvof/xfv) that plot a tantalum record (TA5.TXT) kept outside the "
              "repository; Spheral's flyer-plate tests (a sapphire / Ta / WC / PMMA stack, no "
              "measured trace in the repository); a literature-extraction pipeline whose "
              "'Spall Pullback Velocity' columns hold test values only. The plate rung's spall time stays calibrated to its own "
              "pull-back (above).", "",
              "**Tuler-Butcher constants (sigma_0, lambda, K) for 6061-T6, 2024 or the "
              "steels: not found** (same searches). The aluminium spall time is calibrated to "
              "the plate's pull-back (above), the steels' is the choice of docs/fracture.md.",
              "",
              "**Johnson & Cook's 1985 damage constants D1..D5: no copy of the paper's table "
              "found.** More transcriptions were found (exact strings '3.44, -2.12', '4.89, "
              "-3.03', '-2.20, 5.43'): the library's 4340 set (0.05, 3.44, -2.12, 0.002, "
              "0.61) in an Abaqus script, and its D1..D4 attributed to 'Johnson & Cook "
              "[1985]' in the unit tests of a public LS-DYNA-to-Radioss deck converter "
              "(k2rad; corpus file id 57766010176); the copper set (0.54, 4.89, -3.03, 0.014, "
              "1.12) in an Abaqus script without attribution; no Armco iron set. They agree "
              "with the library, which is not the paper: the entries keep their '(check)' "
              "(impactsim/materials/library.toml).", "",
              "**Other.** The single-wall ballistic limit equation of hypervelocity shielding "
              "(Cour-Palais 1987, Int. J. Impact Eng. 5:221; Christiansen, NASA "
              "TP-2003-210788) is in public code, but resolving its millimetre projectiles at "
              "6-7 km/s takes about 10^6 tets. The Taylor values above come from one "
              "transcription (Banerjee's collection) of the papers' tables and figures, not "
              "from the papers.", ""]
    return lines


def store(results: list[dict]) -> None:
    """The cheap rungs' references (tests/verification/test_validation_rung.py): the copper
    bar's anp result at the ladder's resolution and the coarse perforation at 1000 m/s; an entry
    whose rung did not run keeps its stored value."""
    stored = json.loads(STORED.read_text()) if STORED.exists() else {}
    ref = next((r for r in results if r["rung"] == "taylor-cu-190" and r["element"] == "anp"),
               None)
    if ref is not None:
        stored["taylor-cu-190-anp"] = {"h_mm": ref["h_mm"], "length_mm": ref["length_mm"],
                                       "foot_diameter_mm": ref["foot_diameter_mm"]}
    hs, hp = PERFORATION_MESHES[0]
    ref = next((r for r in results if r["rung"] == "perforation-1000" and r["h_mm"] == hp),
               None)
    if ref is not None:
        stored["perforation-1000-tet4"] = {"h_mm": hp, "h_sphere_mm": hs,
                                           "residual_speed": ref["residual_speed"]}
    stored["measured_records_not_run"] = FOUND_RECORDS
    STORED.write_text(json.dumps(stored, indent=1) + "\n")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--report-only", action="store_true")
    ap.add_argument("--rungs", nargs="+", metavar="NAME",
                    help="run only the rungs whose names start with these (e.g. taylor-6061 "
                         "plate); the others' results are kept from "
                         "benchmarks/validation_results.json")
    args = ap.parse_args(argv)
    if args.report_only:
        results = load_results()
    else:
        results = run_all(args.rungs)
        store(results)
    plots(results)
    DOC.write_text(report(results))
    print(f"wrote {DOC}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
