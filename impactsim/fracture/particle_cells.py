"""The cells the particles touch: which free faces can meet a particle this step.

The particle broad phase hashes the free faces whose swept boxes meet the particles' bounding
box (``particles.faces_near``). Once the debris spreads, that box spans the scene and holds
nearly every free face, while most faces are far from every particle: on oblique-sphere at step
2,200, 23,197 faces met the box and 9,071 of them touched a cell of a particle's box (cells of
the hash's size; docs/performance.md, session 26). A face whose box touches no such cell
overlaps no particle's box, so it can be in no pair of the hash's query: leaving it out changes
no pair, and since the kept faces keep their order, the sweep corrects the same pairs in the
same order (the same bits).

The grid is ``contact.broadphase.Occupancy``'s (generations instead of clearing; its cell
index is monotone in the coordinate, so two boxes that overlap share the cell of the larger of
their lower corners along each axis: the test keeps every face that overlaps a particle's box).
``mark_particles`` sets the cells of every particle box to the grid's generation;
``touches_marked`` tells whether a face's box touches one.
"""

from __future__ import annotations

import numba
import numpy as np

from impactsim.contact.broadphase import Occupancy, _occ_range

OCC_CELL = 1.0  # the grid's cell, a multiple of the hash's: x2 kept 10 % more faces at 2,200


@numba.njit(cache=True)
def mark_particles(lo, hi, n, origin, inv_c, dims, gen, g):
    """Every cell of the grid (origin, 1 / inv_c, dims (3,)) that one of the first n boxes
    (lo, hi)[p] touches gets generation g."""
    for p in range(n):
        x0, x1, y0, y1, z0, z1 = _occ_range(lo, hi, p, origin, inv_c, dims)
        for ix in range(x0, x1 + 1):
            for iy in range(y0, y1 + 1):
                c = (ix * dims[1] + iy) * dims[2]
                for iz in range(z0, z1 + 1):
                    gen[c + iz] = g


@numba.njit(cache=True, inline="always")
def touches_marked(lo, hi, k, origin, inv_c, dims, gen, g):
    """Whether box k of (lo, hi) touches a cell of generation g (``mark_particles``)."""
    x0, x1, y0, y1, z0, z1 = _occ_range(lo, hi, k, origin, inv_c, dims)
    for ix in range(x0, x1 + 1):
        for iy in range(y0, y1 + 1):
            c = (ix * dims[1] + iy) * dims[2]
            for iz in range(z0, z1 + 1):
                if gen[c + iz] == g:
                    return True
    return False


class ParticleCells(Occupancy):
    """The cells the particle boxes of the step touch (the module docstring)."""

    def mark_boxes(self, lo, hi, n, cloud, cell) -> None:
        """A grid over ``cloud (2, 3)`` (the boxes' bounds) of cells ``OCC_CELL * cell``, and the
        cells of the first n boxes (lo, hi) marked in a new generation."""
        self.grid(cloud[0].copy(), cloud[1].copy(), OCC_CELL * cell)
        mark_particles(lo, hi, n, self.origin, self.inv_c, self.dims, self.gen, np.int32(self.g))

    def args(self) -> tuple:
        """(origin, inv_c, dims, gen, g): what ``touches_marked`` reads."""
        return self.origin, float(self.inv_c), self.dims, self.gen, np.int32(self.g)
