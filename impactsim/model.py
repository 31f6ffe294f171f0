"""The simulation state: flat structure-of-arrays for nodes, elements, bodies and walls.

Every array has its shape, dtype and unit written once, here. Kernels receive these arrays;
passes hold a reference to the Model and call kernels on its arrays. Node and element numbering
is contiguous per body (body b owns nodes node_start[b]:node_start[b+1] and elements
elem_start[b]:elem_start[b+1]).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

# element status codes (Model.status)
INTACT = 0
DAMAGED = 1  # spalled: bulk compression only (ALGORITHMS.md 4.1)
FRACTURED = 2  # loosened: no pressure either
ERODED = 3  # removed from the mesh; its arrays stay, its forces are zero


@dataclass
class ElementBlock:
    """Elements of one further type (beside the tets, which are the Model's own element arrays),
    like a meshio cell block: its own connectivity width, kernel and per-element state, with the
    same names, shapes and units as the Model's element arrays. Nodes are shared with the tets.

    kind "hex8": the one-point hex of solver/hex8.py, conn (n, 8) in the VTK node order.
    """
    kind: str
    conn: np.ndarray  # (n, k) int32 node indices, positive orientation
    elem_body: np.ndarray  # (n,) int32
    elem_mat: np.ndarray  # (n,) int32
    status: np.ndarray  # (n,) int8
    sdev: np.ndarray  # (n, 6) float64 [Pa]
    pressure: np.ndarray  # (n,) float64 [Pa]
    q: np.ndarray  # (n,) float64 [Pa]
    eps_p: np.ndarray  # (n,) float64 [-]
    eps_rate: np.ndarray  # (n,) float64 [1/s]
    temperature: np.ndarray  # (n,) float64 [K]
    energy: np.ndarray  # (n,) float64 [J/kg]
    damage: np.ndarray  # (n,) float64 [-]
    vol: np.ndarray  # (n,) float64 [m^3]
    vol0: np.ndarray  # (n,) float64 [m^3]
    elem_mass: np.ndarray  # (n,) float64 [kg]
    body_start: np.ndarray  # (n_body + 1,) int64: body b owns rows body_start[b]:body_start[b+1]
    # hex8: hourglass resultants of the stiffness form (4 modes x 3) [N] and the coefficients of
    # the viscous and stiffness forms per element [-] (solver/hex8.py)
    hg: np.ndarray | None = None  # (n, 12) float64
    hg_visc: np.ndarray | None = None  # (n,) float64
    hg_stiff: np.ndarray | None = None  # (n,) float64

    @property
    def n_elem(self) -> int:
        return self.conn.shape[0]


@dataclass
class Model:
    # --- nodes -------------------------------------------------------------------------------
    x: np.ndarray  # (n_node, 3) float64 [m] current positions
    v: np.ndarray  # (n_node, 3) float64 [m/s] velocities (U^{n+1/2} between steps)
    x0: np.ndarray  # (n_node, 3) float64 [m] initial positions
    mass: np.ndarray  # (n_node,) float64 [kg] lumped nodal mass (a quarter of each element's)
    force: np.ndarray  # (n_node, 3) float64 [N] internal + viscous force (element kernel)
    node_body: np.ndarray  # (n_node,) int32 body index
    # --- elements ----------------------------------------------------------------------------
    conn: np.ndarray  # (n_elem, 4) int32 node indices, positive orientation
    elem_body: np.ndarray  # (n_elem,) int32 body index
    elem_mat: np.ndarray  # (n_elem,) int32 row of mat_params
    status: np.ndarray  # (n_elem,) int8 INTACT / DAMAGED / FRACTURED / ERODED
    sdev: np.ndarray  # (n_elem, 6) float64 [Pa] deviatoric Cauchy stress xx,yy,zz,xy,yz,zx
    pressure: np.ndarray  # (n_elem,) float64 [Pa] EOS pressure (positive in compression)
    q: np.ndarray  # (n_elem,) float64 [Pa] artificial bulk viscosity pressure
    eps_p: np.ndarray  # (n_elem,) float64 [-] effective plastic strain
    eps_rate: np.ndarray  # (n_elem,) float64 [1/s] effective strain rate
    temperature: np.ndarray  # (n_elem,) float64 [K]
    energy: np.ndarray  # (n_elem,) float64 [J/kg] specific internal energy
    damage: np.ndarray  # (n_elem,) float64 [-] Johnson-Cook damage sum (0 when unused)
    vol: np.ndarray  # (n_elem,) float64 [m^3] current volume
    vol0: np.ndarray  # (n_elem,) float64 [m^3] initial volume
    elem_mass: np.ndarray  # (n_elem,) float64 [kg]
    # --- node -> element index (CSR): nodal volume ratios, force refresh after erosion ---------
    n2e_ptr: np.ndarray  # (n_node + 1,) int64
    n2e: np.ndarray  # (4 n_elem,) int64 entries e*4 + local corner
    # --- materials ---------------------------------------------------------------------------
    mat_params: np.ndarray  # (n_mat, N_PARAM) float64, columns in impactsim.materials.params
    material_names: list[str]
    # --- bodies ------------------------------------------------------------------------------
    body_names: list[str]
    node_start: np.ndarray  # (n_body + 1,) int64
    elem_start: np.ndarray  # (n_body + 1,) int64
    # --- prescribed velocities ---------------------------------------------------------------
    bc_nodes: np.ndarray  # (n_bc,) int32 constrained nodes
    bc_mask: np.ndarray  # (n_bc, 3) bool True where the component is prescribed
    bc_velocity: np.ndarray  # (n_bc, 3) float64 [m/s]
    # --- rigid walls -------------------------------------------------------------------------
    walls: np.ndarray  # (n_wall, 7) float64 point (3) [m], unit normal (3), friction coefficient
    # --- energy bookkeeping (all [J], accumulated since t = 0) ---------------------------------
    energy_terms: dict = field(default_factory=dict)
    # --- further element blocks (hexahedra); the tets above are the first block -----------------
    blocks: list = field(default_factory=list)  # ElementBlock
    # --- node separation [Z]: per body, True when its nodes are split into element copies
    # (fracture/separation.py: conn points at each tied family's rep, the others are dormant)
    separable_bodies: tuple = ()
    time: float = 0.0  # [s]
    dtv: float = 0.0  # [s] velocity step of the current predictor U* = U + dtv F/m
    step: int = 0

    @property
    def n_node(self) -> int:
        return self.x.shape[0]

    @property
    def n_elem(self) -> int:
        return self.conn.shape[0]

    @property
    def n_body(self) -> int:
        return len(self.body_names)
