"""Plain data of a quasi-static problem, in SI units, independent of the case file.

A ``Problem`` is what the solvers need: bodies (a tet mesh, element order, material, boundary
conditions), contact rules and iteration settings. Everything here pickles, so a body can be
shipped to a Dask worker and built there.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class ThermoMaterial:
    name: str
    youngs_modulus: float
    poisson_ratio: float
    expansion: float = 0.0  # linear thermal expansion coefficient [1/K]
    conductivity: float = 1.0  # [W/(m K)]
    conductivity_table: tuple[tuple[float, ...], tuple[float, ...]] | None = None  # (T, k)
    density: float = 1.0
    heat_capacity: float = 1.0  # specific heat [J/(kg K)]
    reference_temperature: float = 293.15  # stress-free temperature

    @property
    def lame(self) -> tuple[float, float]:
        e, nu = self.youngs_modulus, self.poisson_ratio
        return e * nu / ((1 + nu) * (1 - 2 * nu)), e / (2 * (1 + nu))

    def k_of(self, temperature: np.ndarray) -> np.ndarray:
        """Conductivity at `temperature` (table: linear interpolation, constant outside)."""
        if self.conductivity_table is None:
            return np.full_like(np.asarray(temperature, dtype=float), self.conductivity)
        t, k = self.conductivity_table
        return np.interp(temperature, t, k)


@dataclass
class Condition:
    """A boundary condition on a set of boundary facets, or a volume source.

    kind: temperature (value), flux (value, into the body), exchange (value = coefficient,
    ambient), source (value [W/m^3], whole body), displacement (components: 3 values or None),
    traction (vector), pressure (value, along the inward normal).
    """

    kind: str
    facets: np.ndarray | None = None  # boundary facet indices of the body's skfem mesh
    value: float = 0.0
    ambient: float = 0.0
    vector: tuple[float | None, float | None, float | None] | None = None
    ramp: bool = False  # scaled by t / end_time
    name: str = ""


@dataclass
class BodyModel:
    name: str
    points: np.ndarray  # (3, n) world coordinates
    tets: np.ndarray  # (4, e)
    order: int  # 1 tet4, 2 tet10
    material: ThermoMaterial
    conditions: list[Condition] = field(default_factory=list)
    initial_temperature: float = 293.15
    # weak springs tie the body to its reference position across this axis (to its previous
    # iterate along it): a body whose lateral position nothing else fixes (a pellet in a column)
    centering_axis: tuple[float, float, float] | None = None

    def mesh(self):
        import skfem as fem

        return fem.MeshTet(np.ascontiguousarray(self.points, dtype=np.float64),
                           np.ascontiguousarray(self.tets, dtype=np.int64))

    @property
    def fixed(self) -> bool:
        """Held by a prescribed displacement somewhere (not floating)."""
        return any(c.kind == "displacement" for c in self.conditions)


@dataclass
class ContactRule:
    """Properties of the contacts between bodies matching two name patterns (fnmatch)."""

    first: str = "*"
    second: str = "*"
    friction: float = 0.0
    conductance: float = 0.0  # gap heat-transfer coefficient [W/(m^2 K)]; 0: no heat exchange
    gap_tolerance: float | None = None
    tied: bool = False  # bonded: every matched node stays in contact, tension allowed
    # Robin (mixed) conditions on both sides instead of kinematic / force: the spring
    # stiffness alpha [Pa/m] of p = p_other - alpha gap; 0: Dirichlet-Neumann (schwarz.py)
    robin: float = 0.0


@dataclass
class Settings:
    times: list[float]  # load step end times
    heat_transient: bool = True
    relaxation: float = 0.5
    aitken: bool = True
    max_iterations: int = 200
    gap_tolerance: float = 1e-4  # relative mismatch of normal displacements
    pressure_tolerance: float = 1e-3  # relative mismatch of contact pressures
    heat_tolerance: float = 1e-6  # relative change of the interface temperatures
    max_heat_iterations: int = 200
    picard_tolerance: float = 1e-6
    max_picard: int = 30
    detect_tolerance: float = 1e-4  # [m] surfaces closer than this are in contact
    regularization: float = 1e-6  # weak springs, relative to diag(K) (floating bodies)
    detect: bool = True
    coarse: bool = True  # rigid shifts passed down the anchor tree in one iteration
    anderson: int = 0  # depth of Anderson acceleration of the interface values (0: off)
    solver: str = "auto"  # direct (SuperLU), amg (pyamg + CG), auto: amg above direct_limit
    direct_limit: int = 300_000  # free dofs of a body above which auto uses amg


@dataclass
class Problem:
    bodies: list[BodyModel]
    rules: list[ContactRule]
    settings: Settings
    pairs: list[tuple[str, str]] | None = None  # listed pairs (detect = false)
