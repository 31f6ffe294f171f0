"""What `make accuracy` measures in a finished run (benchmarks/accuracy.py).

Each function takes the loaded case, the run's output folder and its summary dict, and returns
name -> Quantity. A quantity with ``exact`` set has an analytic value (its error is relative, or
absolute when the exact value is 0); ``theory`` is a value of a simpler theory shown next to the
converged result but not used as the reference (the 1-D bar theory of a 3-D bar).

Analytic values (1-D elastic waves, e.g. Graff, Wave Motion in Elastic Solids, 1975, sec. 2.2):
a bar of length L and wave speed c hitting a rigid wall at v presses on it with rho c v for 2L/c
and then leaves at v; two identical bars, one at rest, press on each other with rho c v / 2 for
2L/c, after which the striker is at rest. c = sqrt(E/rho) for a slender bar free at its sides,
c = sqrt((K + 4G/3)/rho) in uniaxial strain (the sides held).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from impactsim.results import history_array


@dataclass
class Quantity:
    value: float
    exact: float | None = None  # analytic value: the reference of the error
    theory: float | None = None  # a simpler theory's value, for comparison only
    unit: str = ""  # unit of value as shown in the report
    scale: float = 1.0  # value in the report = value * scale
    floor: float = 0.0  # exact value 0: errors up to this are round-off, not a discretisation error


def read_history(out: Path) -> np.ndarray:
    return history_array(Path(out) / "history.csv")


def _wave_speed(case, uniaxial: bool) -> tuple[float, float]:
    mat = case.materials[case.bodies[0].material]
    G, K, rho = mat.shear_modulus, mat.bulk_modulus, mat.density
    modulus = K + 4.0 * G / 3.0 if uniaxial else 9.0 * K * G / (3.0 * K + G)
    return rho, float(np.sqrt(modulus / rho))


def _contact_interval(time: np.ndarray, on: np.ndarray) -> tuple[float, float]:
    t_on = time[on]
    return (float(t_on[0]), float(t_on[-1])) if t_on.size else (0.0, 0.0)


def bar_on_wall(case, out: Path, summary: dict, uniaxial: bool) -> dict[str, Quantity]:
    """Elastic bar on a rigid wall: contact stress plateau (median wall force over the contact
    / cross-section), contact duration (first to last step with a wall force), rebound speed
    (mean velocity at the end) and the L1 distance of the wall-force pulse from the analytic
    square pulse, relative to the pulse's impulse. Uniaxial strain: all analytic; a free bar:
    the 1-D theory is shown but the reference is the finest run."""
    body = case.bodies[0]
    lx, ly, length = body.dimensions["size"]
    area = lx * ly
    v = abs(body.velocity[2])
    rho, c = _wave_speed(case, uniaxial)
    h = read_history(out)
    t, force = h["time"], h["wall_force"]
    on = force > 0
    t0, t1 = _contact_interval(t, on)
    stress, duration = rho * c * v, 2.0 * length / c
    gap = body.position[2] - 0.5 * length
    start = gap / v  # the bar reaches the wall
    exact_force = np.where((t >= start) & (t < start + duration), stress * area, 0.0)
    dt = np.diff(t, append=t[-1])
    l1 = float(np.sum(np.abs(force - exact_force) * dt) / (stress * area * duration))
    rebound = float(summary["bodies"][body.name]["mean_velocity"][2])

    def q(value, exact, unit, scale):
        return Quantity(value, exact if uniaxial else None, None if uniaxial else exact,
                        unit, scale)

    out_q = {"stress": q(float(np.median(force[on])) / area if on.any() else 0.0, stress,
                         "MPa", 1e-6),
             "duration": q(t1 - t0, duration, "us", 1e6),
             "rebound": q(rebound, v, "m/s", 1.0)}
    if uniaxial:
        out_q["pulse_L1"] = Quantity(l1, 0.0, None, "", 1.0)
    return out_q


def bar_column(case, out, summary):
    return bar_on_wall(case, out, summary, uniaxial=True)


def bar_free(case, out, summary):
    return bar_on_wall(case, out, summary, uniaxial=False)


def last_frame(out: Path):
    import meshio

    frames = sorted(Path(out).glob("frame_*.vtu"))
    return meshio.read(frames[-1])


def taylor_bar(case, out: Path, summary: dict) -> dict[str, Quantity]:
    """Final length (highest minus lowest node along the rod's axis) and foot diameter (twice the
    largest distance of a node from the axis) of the deformed rod in the last frame."""
    body = case.bodies[0]
    axis = np.asarray(body.dimensions.get("axis", (0.0, 0.0, 1.0)), dtype=float)
    axis /= np.linalg.norm(axis)
    x = np.asarray(last_frame(out).points, dtype=float)
    along = x @ axis
    radial = x - np.outer(along, axis)
    centre = np.asarray(body.position, dtype=float)
    centre = centre - (centre @ axis) * axis
    r = np.linalg.norm(radial - centre, axis=1)
    return {"length": Quantity(float(along.max() - along.min()), unit="mm", scale=1e3),
            "foot_diameter": Quantity(float(2.0 * r.max()), unit="mm", scale=1e3)}


# [m] 0.1 um, 1e-5 of the bodies' width and a tenth of the band (1e-3 h at h = 1 mm) in which the
# contact passes take a node as touching: below this there is no penetration to speak of
PENETRATION_FLOOR = 1e-7


def mid_contact_force(time: np.ndarray, impulse: np.ndarray, t0: float, duration: float) -> float:
    """Mean contact force over the middle half of the contact: the contact impulses of the steps
    in [t0 + D/4, t0 + 3D/4] over that time. A step's impulse alone jumps from step to step as
    pairs come and go; their sum over many steps does not."""
    lo, hi = t0 + 0.25 * duration, t0 + 0.75 * duration
    mid = (time > lo) & (time <= hi)
    return float(impulse[mid].sum() / (hi - lo)) if mid.any() else 0.0


def two_bars_column(case, out: Path, summary: dict) -> dict[str, Quantity]:
    """Two identical bars end-on in uniaxial strain (the striker is the moving one): the largest
    penetration over the run (exact: none), the interface stress (mid_contact_force over the
    cross-section, with the analytic duration 2L/c_L for the window; exact rho c_L v / 2) and
    the striker's final speed (exact: at rest)."""
    striker = max(case.bodies, key=lambda b: float(np.linalg.norm(b.velocity)))
    lx, ly, length = striker.dimensions["size"]
    v = abs(striker.velocity[2])
    rho, c = _wave_speed(case, uniaxial=True)
    h = read_history(out)
    t = h["time"]
    t0, _ = _contact_interval(t, h["contact_pairs"] > 0)
    stress = mid_contact_force(t, np.nan_to_num(h["contact_impulse"]), t0,
                               2.0 * length / c) / (lx * ly)
    final = abs(float(summary["bodies"][striker.name]["mean_velocity"][2]))
    return {"penetration": Quantity(float(np.nanmax(h["max_penetration"])), 0.0, None, "um",
                                    1e6, PENETRATION_FLOOR),
            "stress": Quantity(stress, 0.5 * rho * c * v, None, "MPa", 1e-6),
            "striker_speed": Quantity(final, 0.0, None, "m/s", 1.0)}


def two_cylinders(case, out: Path, summary: dict) -> dict[str, Quantity]:
    """A striker flattening on a target: the largest penetration over the run (exact: none),
    the striker's length along its axis in the last frame (highest minus lowest node) and its
    mean axial speed at the end (the momentum it has kept). Frame points are the bodies' nodes
    in case order (summary "bodies" counts them)."""
    striker = max(case.bodies, key=lambda b: float(np.linalg.norm(b.velocity)))
    start = 0
    for body in case.bodies:
        n = summary["bodies"][body.name]["nodes"]
        if body is striker:
            break
        start += n
    x = np.asarray(last_frame(out).points, dtype=float)[start:start + n]
    axis = np.asarray(striker.dimensions.get("axis", (0.0, 0.0, 1.0)), dtype=float)
    axis /= np.linalg.norm(axis)
    along = x @ axis
    speed = abs(float(np.asarray(summary["bodies"][striker.name]["mean_velocity"]) @ axis))
    h = read_history(out)
    return {"penetration": Quantity(float(np.nanmax(h["max_penetration"])), 0.0, None, "um",
                                    1e6, PENETRATION_FLOOR),
            "striker_length": Quantity(float(along.max() - along.min()), unit="mm", scale=1e3),
            "striker_speed": Quantity(speed, unit="m/s")}


MEASURES = {"bar_column": bar_column, "bar_free": bar_free, "taylor_bar": taylor_bar,
            "two_bars_column": two_bars_column,
            "two_cylinders": two_cylinders}
