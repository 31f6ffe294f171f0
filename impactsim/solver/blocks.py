"""The kernels of the element blocks beyond the tets (Model.blocks), for the time loop.

The tet kernel (element.py) writes Model.force from the tets' rows; then every further block
runs its own kernel, which adds its elements' forces through force rows of its own
(scatter.force_rows with the block's corner count) in part order. The sum at a node is thus
(tets in part order) + (block 1 in part order) + ...: the same on any number of threads.
"""

from __future__ import annotations

import numba
import numpy as np

from impactsim.model import ElementBlock, Model
from impactsim.solver import element as E
from impactsim.solver import hex8 as H
from impactsim.solver import hugepages
from impactsim.solver.scatter import force_rows


class BlockRunner:
    """Buffers and caches of one further element block and the call of its kernel."""

    def __init__(self, model: Model, block: ElementBlock, part_size: int = H.PART):
        if block.kind != "hex8":
            raise ValueError(f"unknown element block kind {block.kind!r}")
        self.block = block
        self.rows = force_rows(block.conn, model.n_node, part_size)
        self.fext = np.zeros((self.rows.n_rows, 3))
        self.chunk_out = np.zeros((H.n_chunks(block.n_elem), H.N_OUT))
        self.hard, self.thermal = np.zeros(block.n_elem), np.zeros(block.n_elem)
        E.yield_cache(block.elem_mat, model.mat_params, block.eps_p, block.temperature,
                      self.hard, self.thermal)
        hugepages.pack(self, self.rows)  # onto huge pages (hugepages.py)

    def update(self, model: Model, dt: float, cq: float, cl: float, assign: bool = False
               ) -> np.ndarray:
        """Run the block's kernel (adds to model.force, or writes it with `assign`); returns its
        per-chunk results."""
        b, fr = self.block, self.rows
        H.hex_update(model.x, model.v, b.conn, b.elem_mat, b.status, b.sdev, b.pressure, b.q,
                     b.eps_p, b.eps_rate, b.temperature, self.hard, self.thermal, b.energy,
                     b.vol, b.elem_mass, b.hg, b.hg_visc, b.hg_stiff, model.mat_params, dt, cq,
                     cl, model.force, fr.rows, self.fext, fr.extra_ptr, fr.extra_rows,
                     fr.part_size // H.CHUNK, self.chunk_out, numba.get_num_threads(), assign)
        return self.chunk_out


def update_blocks(runners: list[BlockRunner], model: Model, dt: float, cq: float, cl: float,
                  assign: bool = False) -> tuple[float, int, float, float, int]:
    """All further blocks after the tets: (min stable dt, its block element as
    -(1 + index in the block), viscous work, hourglass work, inverted count). With `assign`
    (no tets ran) the first block writes model.force instead of adding to it."""
    dt_min, worst, qwork, hgwork, inverted = np.inf, -1, 0.0, 0.0, 0
    for k, r in enumerate(runners):
        out = r.update(model, dt, cq, cl, assign and k == 0)
        k = int(np.argmin(out[:, H.OUT_DT]))
        if out[k, H.OUT_DT] < dt_min:
            dt_min = float(out[k, H.OUT_DT])
            worst = -(1 + int(out[k, H.OUT_WORST]))
        qwork += float(out[:, H.OUT_QWORK].sum())
        hgwork += float(out[:, H.OUT_HGWORK].sum())
        inverted += int(out[:, H.OUT_INVERTED].sum())
    return dt_min, worst, qwork, hgwork, inverted


def block_internal_energy(model: Model) -> float:
    """Sum of m_e e_e over the live elements of the further blocks [J]."""
    from impactsim.solver.nodal import internal_energy

    return sum(internal_energy(b.energy, b.elem_mass, b.status) for b in model.blocks)


HOURGLASS_WARN = 0.1  # hourglass over internal energy above which the run warns


def hourglass_warning(energies: dict) -> str:
    """A warning when the hourglass work exceeds HOURGLASS_WARN of the internal energy (the
    usual industry flag: the mesh is too coarse for the flow, or the control too weak), else
    ''."""
    hg, ie = energies.get("hourglass_energy", 0.0), energies.get("internal_energy", 0.0)
    if ie > 0.0 and hg > HOURGLASS_WARN * ie:
        return (f"hourglass energy {hg:.4g} J is {100 * hg / ie:.0f} % of the internal energy "
                f"({ie:.4g} J): refine the hex mesh or raise body.hourglass_coefficient (the "
                "stiffness form holds large plastic flow better)")
    return ""


@numba.njit(cache=True)
def _hex_forces(x, v, conn, elem_mat, status, sdev, pressure, q, eps_p, eps_rate, temperature,
                hard, thermal, energy, vol, elem_mass, hg, hg_visc, hg_stiff, mat_params, cq,
                cl, rows, fext, half):
    w = np.empty(H.SCRATCH)
    for e in range(conn.shape[0]):
        H._hex_element(e, x, v, conn, elem_mat, status, sdev, pressure, q, eps_p, eps_rate,
                     temperature, hard, thermal, energy, vol, elem_mass, hg, hg_visc, hg_stiff,
                     mat_params, half, 0.0, cq, cl, rows, fext, w)


def hex_corner_forces(model, blk, runner, ids, cq: float, cl: float, dt: float = 0.0,
                      status=None) -> np.ndarray:
    """(len(ids), 8, 3) the corner forces hexes ``ids`` added to model.force at the last element
    update of step ``dt``: the kernel re-run with no increment on copies of their state (the
    same stress, bulk viscosity and hourglass resultants at the same positions and velocities,
    the velocity gradient on the same mid-step geometry x - dt/2 v: the forces the update added,
    to round-off, so that a deleted hex's orphaned corners take no force with them and momentum
    is conserved)."""
    n = ids.shape[0]
    rows = np.arange(8 * n, dtype=np.int32).reshape(n, 8)
    fext = np.zeros((8 * n, 3))
    # still live: called before the deletion; ``status`` the hexes' status at that update
    # (the fracture criteria may have damaged them since)
    st = (blk.status if status is None else status)[ids].copy()
    _hex_forces(model.x, model.v, np.ascontiguousarray(blk.conn[ids]), blk.elem_mat[ids], st,
                blk.sdev[ids], blk.pressure[ids], blk.q[ids], blk.eps_p[ids],
                blk.eps_rate[ids], blk.temperature[ids], runner.hard[ids], runner.thermal[ids],
                blk.energy[ids], blk.vol[ids], blk.elem_mass[ids], blk.hg[ids],
                blk.hg_visc[ids], blk.hg_stiff[ids], model.mat_params, cq, cl, rows, fext,
                0.5 * dt)
    return fext.reshape(n, 8, 3)
