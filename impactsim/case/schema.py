"""The validated, resolved case: typed dataclasses, SI units everywhere.

This is the contract between the case reader (``impactsim.case.load``) and the rest of the code.
Every quantity here is a plain float in SI units (m, s, kg, Pa, K, J); angles are radians.
The reader fills every default, so code downstream never looks for a missing key.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path


@dataclass
class Strength:
    """Deviatoric strength model (ALGORITHMS.md 2)."""

    model: str = "elastic"  # "elastic" | "ideal-plastic" | "johnson-cook"
    yield_stress: float = 0.0  # [Pa] ideal-plastic Y0
    A: float = 0.0  # [Pa] Johnson-Cook
    B: float = 0.0  # [Pa]
    n: float = 1.0  # [-]
    C: float = 0.0  # [-]
    m: float = 1.0  # [-]
    strain_rate_ref: float = 1.0  # [1/s] reference plastic strain rate eps_dot0
    room_temperature: float = 293.15  # [K]
    melt_temperature: float = 1.0e9  # [K]


@dataclass
class EOS:
    """Pressure model (ALGORITHMS.md 2)."""

    model: str = "linear"  # "linear" | "mie-gruneisen"
    c0: float = 0.0  # [m/s] bulk sound speed of the linear Us-up Hugoniot
    s: float = 0.0  # [-] slope of Us = c0 + s up
    gamma0: float = 0.0  # [-] Grueneisen coefficient at the reference density


@dataclass
class Failure:
    """Fracture and erosion data (ALGORITHMS.md 4). None switches a mechanism off."""

    spall_strength: float | None = None  # [Pa] max tensile principal stress -> damaged
    # [s] Tuler-Butcher time tau: damaged once the integral of (s1 / spall_strength - 1)+ dt
    # reaches it (fracture/spall.py); None: the instantaneous threshold of [D19]
    spall_time: float | None = None
    loosening: float | None = None  # [-] chi* : damaged -> fully fractured when 1 - V0/V > chi*
    erosion: str | None = None  # "plastic-strain" | "jc-damage" | "principal-strain" | "fractured"
    erosion_value: float | None = None  # threshold of the erosion criterion (strain, or D = 1)
    jc_damage: tuple[float, float, float, float, float] | None = None  # D1..D5
    fracture_strain: float | None = None  # node separation [Z]; not accepted by the loader yet

    @property
    def active(self) -> bool:
        """True when the material can fail (spall, loosening or erosion): fracture passes run."""
        return any(v is not None for v in (self.spall_strength, self.loosening, self.erosion))


@dataclass
class Material:
    name: str
    density: float  # [kg/m^3] reference density rho0
    shear_modulus: float  # [Pa] G
    bulk_modulus: float  # [Pa] K (for "linear" EOS; for Mie-Grueneisen rho0 c0^2 if not given)
    specific_heat: float = 450.0  # [J/(kg K)] c_v, for adiabatic heating
    taylor_quinney: float = 0.9  # [-] share of plastic work that heats
    initial_temperature: float = 293.15  # [K]
    strength: Strength = field(default_factory=Strength)
    eos: EOS = field(default_factory=EOS)
    failure: Failure = field(default_factory=Failure)
    source: str = ""  # where the numbers come from (library entries carry their reference)


@dataclass
class NodeSelector:
    """A set of nodes of one body, chosen geometrically in world coordinates after placement.

    kind "box": nodes with lo <= x <= hi componentwise (params: lo, hi).
    kind "outside-radius": nodes farther than `radius` from the line through `center` along `axis`
      (the rim of a round plate; params: center, axis, radius).
    kind "plane": nodes within `tolerance` of the plane through `point` with normal `normal`.
    kind "all": every node of the body.
    """

    kind: str
    params: dict = field(default_factory=dict)  # SI floats / 3-tuples


@dataclass
class Constraint:
    """Prescribed velocity on a node set; a None component stays free. fixed == all zeros."""

    nodes: NodeSelector
    velocity: tuple[float | None, float | None, float | None] = (0.0, 0.0, 0.0)  # [m/s]


@dataclass
class Body:
    name: str
    material: str  # key into Case.materials
    shape: str  # "box" | "plate" | "cylinder" | "sphere" | "file" | "cube12"
    # shape parameters, SI: box/plate: size (3,) ; cylinder: radius, height, axis (3,) ;
    # sphere: radius ; file: path (Path, resolved against the case file), scale ;
    # cube12: size (edge length, scalar)
    dimensions: dict = field(default_factory=dict)
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)  # [m] centre of the primitive
    rotation: tuple[float, float, float] = (0.0, 0.0, 0.0)  # [rad] intrinsic x-y-z Euler angles
    mesh_size: float = 0.0  # [m] target edge length
    mesher: str = "gmsh"  # "gmsh" | "structured"
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)  # [m/s]
    angular_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)  # [rad/s] about `position`
    constraints: list[Constraint] = field(default_factory=list)
    element: str = "tet"  # "tet" (run.element's tet) | "hex8" (one-point hex, solver/hex8.py)
    hourglass: str = "viscous"  # hex8: "viscous" | "stiffness" (Flanagan & Belytschko 1981)
    hourglass_coefficient: float = 0.1  # hex8: c_v (viscous) or c_s (stiffness) [-]


# the usual hourglass coefficients of the two forms (ALGORITHMS.md 7.1: 0.05-0.15 viscous,
# 0.01-0.05 stiffness; LS-DYNA's default QH = 0.1)
HOURGLASS_DEFAULTS = {"viscous": 0.1, "stiffness": 0.03}


@dataclass
class Wall:
    """Rigid planar wall: the half space (x - point) . normal < 0 is forbidden."""

    point: tuple[float, float, float] = (0.0, 0.0, 0.0)  # [m]
    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)  # unit, points into the allowed side
    friction: float = 0.0  # Coulomb coefficient; 0 = frictionless sliding


MAX_SUBCYCLE = 4  # run.subcycle at most: parts updated every 16 steps (solver/subcycle.py)


@dataclass
class Run:
    name: str
    end_time: float  # [s]
    cfl: float = 0.6  # Courant number
    # "auto" | "tet4" | "anp" (averaged nodal pressure tet, Bonet & Burton 1998); "auto": anp
    # with plastic materials, else tet4 (impactsim.solver.formulation)
    element: str = "auto"
    q_quadratic: float = 1.2  # artificial viscosity C_q (q uses C_q^2 = 1.44, close to LS-DYNA Q1 = 1.5)
    q_linear: float = 0.06  # artificial viscosity C_l
    max_steps: int = 10_000_000
    dt_collapse: float = 1.0e-3  # stop when dt < dt_collapse * initial dt
    threads: int = 0  # numba threads; 0 = automatic (1 below 50k elements, else all)
    subcycle: int = 0  # levels of subcycling (tets updated every 2^k steps, k <= it); 0 = off


@dataclass
class Output:
    directory: Path | None = None  # None = out/<run.name> relative to the working directory
    frames: int = 20  # evenly spaced frames after the initial one (ignored if times given)
    times: list[float] | None = None  # [s] explicit frame times
    history_every: int = 1  # write a history row every N steps
    fields: list[str] | None = None  # None = all fields
    compression: str = "zlib"  # VTU data blocks: "zlib" or "none"
    checkpoint_every: int | float = 0  # int: every N steps; float: every so much time [s]; 0: off
    fragment_histogram: bool = False  # fragments.png: the fragment-size histogram at the end


@dataclass
class Contact:
    passes: list[str] = field(default_factory=lambda: ["node-face", "edge-edge"])
    friction: float = 0.0  # Coulomb coefficient
    self_contact: bool = False


@dataclass
class Fracture:
    particles_per_element: int = 1
    particle_collisions: bool = False
    erosion_region: str = "surface"  # "surface" | "anywhere"
    # how spall reads the tension (fracture/spall.py): "tuler-butcher" integrates it over time
    # for materials with failure.spall_time, "instant" is the threshold of [D19]
    spall_criterion: str = "tuler-butcher"
    # the pressure spall reads: the lesser tension of the element's own pressure and its patch
    # mean ("lesser"), the element's own ("cell", [D19]) or the patch mean ("patch")
    spall_pressure: str = "lesser"
    # ductile fracture (fracture/ductile.py): Johnson-Cook damage D >= 1 damages a cell of a
    # material with failure.jc_damage and no erosion criterion ("johnson-cook"), or not ("none")
    ductile_criterion: str = "none"
    # distortion erosion [Z] (fracture/distortion.py): checked every interval [s]; None = off
    distortion_interval: float | None = None
    distortion_extent: float = 3.0  # r1: axis extent > r1 * L_ch deletes
    distortion_volume: float = 8.0  # r2: product of the axis extents > r2 * initial deletes
    # node separation [Z] (fracture/separation.py), for materials with failure.fracture_strain
    separation_measure: str = "mean"  # "mean" | "max" of the adjoining elements' plastic strain
    separation_release: str = "faces"  # "faces" (partial, along failed faces) | "nodes" (whole)


@dataclass
class Checks:
    """[checks]: conditions watched before and during a run, each with its action
    (impactsim/checks/; docs/user-guide.md, Checks)."""

    initial_penetration: str = "error"  # error | warn | ignore
    negative_volume: str = "error"  # error | erode
    time_step_floor: float = 0.0  # [s] 0 = off
    time_step_floor_action: str = "error"  # error | erode
    energy_balance: float = 0.05  # largest accepted energy gain, share of the reference energy
    energy_balance_action: str = "error"  # error | warn | ignore
    hourglass_share: float = 0.1  # hourglass energy / (kinetic + internal)
    hourglass_share_action: str = "warn"  # error | warn | ignore
    unconverged_contact: str = "warn"  # error | warn | ignore
    # unconverged steps / steps in contact beyond which unconverged_contact acts (the bundled
    # scenes: 0.5-11 %)
    unconverged_contact_share: float = 0.25


@dataclass
class Case:
    source: Path | None  # the case file (None when built in Python)
    run: Run
    materials: dict[str, Material]
    bodies: list[Body]
    walls: list[Wall] = field(default_factory=list)
    output: Output = field(default_factory=Output)
    contact: Contact = field(default_factory=Contact)
    fracture: Fracture = field(default_factory=Fracture)
    checks: Checks = field(default_factory=Checks)
