"""Case + meshes -> Model: the initial state of a run."""

from __future__ import annotations

import numpy as np

from impactsim.case.schema import Body, Case, NodeSelector
from impactsim.materials.params import DUCTILE, T_INIT, material_table
from impactsim.model import ElementBlock, Model
from impactsim.solver import hugepages


def select_nodes(sel: NodeSelector, x: np.ndarray) -> np.ndarray:
    """Boolean mask over the rows of x (n,3) of the nodes a selector picks (world coordinates)."""
    p = sel.params
    if sel.kind == "all":
        return np.ones(len(x), dtype=bool)
    if sel.kind == "box":
        lo, hi = np.asarray(p["lo"], float), np.asarray(p["hi"], float)
        return np.all((x >= lo) & (x <= hi), axis=1)
    if sel.kind == "outside-radius":
        c, a = np.asarray(p["center"], float), np.asarray(p["axis"], float)
        a = a / np.linalg.norm(a)
        r = x - c
        radial = r - np.outer(r @ a, a)
        return np.linalg.norm(radial, axis=1) > p["radius"]
    if sel.kind == "plane":
        pt, nrm = np.asarray(p["point"], float), np.asarray(p["normal"], float)
        nrm = nrm / np.linalg.norm(nrm)
        return np.abs((x - pt) @ nrm) <= p["tolerance"]
    raise ValueError(f"unknown node selector kind {sel.kind!r}")


def node_to_element(conn: np.ndarray, n_node: int) -> tuple[np.ndarray, np.ndarray]:
    """CSR index from nodes to element corners (entries e*4 + local), ascending per node."""
    flat = conn.ravel().astype(np.int64)
    order = np.argsort(flat, kind="stable")
    counts = np.bincount(flat, minlength=n_node)
    ptr = np.zeros(n_node + 1, dtype=np.int64)
    np.cumsum(counts, out=ptr[1:])
    return ptr, order.astype(np.int64)


def tet_volumes(x: np.ndarray, conn: np.ndarray) -> np.ndarray:
    a = x[conn[:, 1]] - x[conn[:, 0]]
    b = x[conn[:, 2]] - x[conn[:, 0]]
    c = x[conn[:, 3]] - x[conn[:, 0]]
    return np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0


def build_model(case: Case, meshes: list[tuple[np.ndarray, np.ndarray]] | None = None) -> Model:
    """Assemble the initial state. meshes[i] = (points, tets) of case.bodies[i]; meshed here if
    not given (impactsim.mesh.mesh_body)."""
    if meshes is None:
        from impactsim.mesh import mesh_body

        meshes = [mesh_body(b) for b in case.bodies]
    mat_names = list(case.materials)
    mat_index = {name: i for i, name in enumerate(mat_names)}
    mat_params = material_table([case.materials[n] for n in mat_names])
    if case.fracture.ductile_criterion == "none":  # fracture/ductile.py
        mat_params[:, DUCTILE] = 0.0

    xs, conns, vs, node_body, elem_body, elem_mat = [], [], [], [], [], []
    node_start, elem_start = [0], [0]
    bc_nodes, bc_mask, bc_vel = [], [], []
    hexes = HexCollector()
    separable = []
    for b, (body, (pts, tets)) in enumerate(zip(case.bodies, meshes)):
        pts = np.asarray(pts, dtype=np.float64)
        tets = np.asarray(tets, dtype=np.int64)
        separable.append(case.materials[body.material].failure.fracture_strain is not None)
        if separable[-1]:  # node separation: one node copy per element corner
            from impactsim.mesh.split import split_points

            pts, tets = split_points(pts, tets)
        off = node_start[-1]
        xs.append(pts)
        hexes.body(b, body, tets if tets.shape[1] == 8 else None, off, mat_index[body.material])
        if tets.shape[1] == 8:  # a hex body: its elements go to the hex block
            tets = np.zeros((0, 4), np.int64)
        conns.append(tets + off)
        vs.append(_initial_velocity(body, pts))
        node_body.append(np.full(len(pts), b, dtype=np.int32))
        elem_body.append(np.full(len(tets), b, dtype=np.int32))
        elem_mat.append(np.full(len(tets), mat_index[body.material], dtype=np.int32))
        for con in body.constraints:
            sel = np.nonzero(select_nodes(con.nodes, pts))[0]
            mask = np.array([c is not None for c in con.velocity])
            vel = np.array([0.0 if c is None else c for c in con.velocity])
            bc_nodes.append(sel + off)
            bc_mask.append(np.tile(mask, (len(sel), 1)))
            bc_vel.append(np.tile(vel, (len(sel), 1)))
        node_start.append(off + len(pts))
        elem_start.append(elem_start[-1] + len(tets))

    x = np.concatenate(xs)
    conn = np.ascontiguousarray(np.concatenate(conns).astype(np.int32))
    n_node, n_elem = len(x), len(conn)
    emat = np.concatenate(elem_mat)
    vol0 = tet_volumes(x, conn)
    if np.any(vol0 <= 0.0):
        raise ValueError("the mesh has inverted or degenerate tetrahedra")
    elem_mass = mat_params[emat, 0] * vol0
    mass = np.zeros(n_node)
    np.add.at(mass, conn.ravel(), np.repeat(elem_mass / 4.0, 4))
    blocks = hexes.blocks(x, mat_params, mass)
    ptr, n2e = node_to_element(conn, n_node)

    if bc_nodes:
        nodes = np.concatenate(bc_nodes)
        masks = np.concatenate(bc_mask)
        vels = np.concatenate(bc_vel)
        # a node in several sets keeps the last set's values: keep the last occurrence
        _, last = np.unique(nodes[::-1], return_index=True)
        keep = np.sort(len(nodes) - 1 - last)
        nodes, masks, vels = nodes[keep], masks[keep], vels[keep]
    else:
        nodes, masks, vels = np.zeros(0, np.int64), np.zeros((0, 3), bool), np.zeros((0, 3))
    v = np.concatenate(vs)
    v[nodes] = np.where(masks, vels, v[nodes])

    walls = np.array([[*w.point, *(np.asarray(w.normal) / np.linalg.norm(w.normal)), w.friction]
                      for w in case.walls], dtype=np.float64).reshape(-1, 7)
    temp0 = mat_params[emat, T_INIT].copy()
    model = Model(
        x=x, v=v, x0=x.copy(), mass=mass, force=np.zeros((n_node, 3)),
        node_body=np.concatenate(node_body),
        conn=conn, elem_body=np.concatenate(elem_body), elem_mat=emat,
        status=np.zeros(n_elem, np.int8), sdev=np.zeros((n_elem, 6)), pressure=np.zeros(n_elem),
        q=np.zeros(n_elem), eps_p=np.zeros(n_elem), eps_rate=np.zeros(n_elem),
        temperature=temp0, energy=np.zeros(n_elem), damage=np.zeros(n_elem),
        vol=vol0.copy(), vol0=vol0, elem_mass=elem_mass,
        n2e_ptr=ptr, n2e=n2e, mat_params=mat_params, material_names=mat_names,
        body_names=[b.name for b in case.bodies],
        node_start=np.array(node_start, np.int64), elem_start=np.array(elem_start, np.int64),
        bc_nodes=nodes.astype(np.int32), bc_mask=masks, bc_velocity=vels, walls=walls,
        energy_terms={"contact_dissipated": 0.0, "external_work": 0.0, "viscous": 0.0,
                      "eroded": 0.0, **({"hourglass": 0.0} if blocks else {})},
        blocks=blocks, separable_bodies=tuple(separable),
    )
    # the state arrays onto huge pages, before anything else holds them (hugepages.py)
    hugepages.pack(model, *model.blocks)
    return model


def _initial_velocity(body: Body, pts: np.ndarray) -> np.ndarray:
    v = np.tile(np.asarray(body.velocity, dtype=np.float64), (len(pts), 1))
    w = np.asarray(body.angular_velocity, dtype=np.float64)
    if np.any(w):
        v += np.cross(w, pts - np.asarray(body.position, dtype=np.float64))
    return v


class HexCollector:
    """Gathers the hex bodies of a case into one ElementBlock("hex8") (solver/hex8.py)."""

    def __init__(self):
        self.conns, self.bodies, self.mats, self.visc, self.stiff = [], [], [], [], []
        self.start = [0]

    def body(self, b: int, body: Body, cells, offset: int, mat: int) -> None:
        n = 0 if cells is None else len(cells)
        if n:
            self.conns.append(np.asarray(cells, np.int64) + offset)
            self.bodies.append(np.full(n, b, np.int32))
            self.mats.append(np.full(n, mat, np.int32))
            coef = float(body.hourglass_coefficient)
            viscous = body.hourglass == "viscous"
            self.visc.append(np.full(n, coef if viscous else 0.0))
            self.stiff.append(np.full(n, 0.0 if viscous else coef))
        self.start.append(self.start[-1] + n)

    def blocks(self, x: np.ndarray, mat_params: np.ndarray, mass: np.ndarray) -> list:
        """[] without hex bodies, else [the hex block]; adds the hexes' mass (1/8 per corner)."""
        if not self.conns:
            return []
        from impactsim.solver.hex8 import hex_volumes

        conn = np.ascontiguousarray(np.concatenate(self.conns).astype(np.int32))
        emat = np.concatenate(self.mats)
        vol0 = hex_volumes(x, conn)
        if np.any(vol0 <= 0.0):
            raise ValueError("the mesh has inverted or degenerate hexahedra")
        elem_mass = mat_params[emat, 0] * vol0
        np.add.at(mass, conn.ravel(), np.repeat(elem_mass / 8.0, 8))
        n = len(conn)
        return [ElementBlock(
            kind="hex8", conn=conn, elem_body=np.concatenate(self.bodies), elem_mat=emat,
            status=np.zeros(n, np.int8), sdev=np.zeros((n, 6)), pressure=np.zeros(n),
            q=np.zeros(n), eps_p=np.zeros(n), eps_rate=np.zeros(n),
            temperature=mat_params[emat, T_INIT].copy(), energy=np.zeros(n),
            damage=np.zeros(n), vol=vol0.copy(), vol0=vol0, elem_mass=elem_mass,
            body_start=np.array(self.start, np.int64), hg=np.zeros((n, 12)),
            hg_visc=np.concatenate(self.visc), hg_stiff=np.concatenate(self.stiff))]
