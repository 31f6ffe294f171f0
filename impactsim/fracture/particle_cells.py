"""The cells the particles touch: which free faces can meet a particle this step.

The particle broad phase hashes the free faces whose swept boxes meet the particles' bounding
box (``particles.faces_near``). Once the debris spreads, that box spans the scene and holds
nearly every free face, while most faces are far from every particle: on oblique-sphere at step
2,200, 23,197 faces met the box and 9,071 of them touched a cell of a particle's box (cells of
the hash's size; docs/performance.md, session 26). A face whose box touches no such cell
overlaps no particle's box, so it can be in no pair of the hash's query: leaving it out changes
no pair, and since the kept faces keep their order, the sweep corrects the same pairs in the
same order (the same bits).

The grid is ``contact.broadphase.occupancy_grid``'s over the particles' bounding box, one bit a
cell (at most OCC_MAX_CELLS / 8 bytes; 78 kB on oblique-sphere at step 2,900). Its cell index is monotone in the coordinate
and clamped at the grid's ends, so two boxes that overlap share the cell of the larger of their
lower corners along each axis: the test keeps every face that overlaps a particle's box.
``mark_particles`` sets the bits of the cells of every particle box; ``touches_marked`` tells
whether a face's box touches one.
"""

from __future__ import annotations

import numba
import numpy as np

from impactsim.contact.broadphase import _occ_range, occupancy_grid

OCC_CELL = 1.0  # the grid's cell, a multiple of the hash's: x2 kept 10 % more faces at 2,200
# ``touches_marked``'s arguments for a grid of one marked cell: every box touches it, so the
# selection keeps every face that meets the particles' bounding box (the tests' and the
# benchmark's reference)
EVERY_CELL = (np.zeros(3), 0.0, np.ones(3, np.int64), np.ones(1, np.uint64))


@numba.njit(cache=True)
def mark_particles(lo, hi, n, origin, inv_c, dims, bits):
    """Set the bit of every cell of the grid (origin, 1 / inv_c, dims (3,)) that one of the
    first n boxes (lo, hi)[p] touches (``bits``: uint64 words, zero on entry)."""
    for p in range(n):
        x0, x1, y0, y1, z0, z1 = _occ_range(lo, hi, p, origin, inv_c, dims)
        if x1 - x0 <= 1 and y1 - y0 <= 1 and z1 - z0 <= 1:
            # at most two cells along each axis (nearly every particle: its box is a third of
            # a cell wide): the eight corners' cells, some of them twice, without the loops'
            # branches on trip counts of one or two
            for ix in (x0, x1):
                for iy in (y0, y1):
                    c = (ix * dims[1] + iy) * dims[2]
                    _set_bit(bits, c + z0)
                    _set_bit(bits, c + z1)
            continue
        for ix in range(x0, x1 + 1):
            for iy in range(y0, y1 + 1):
                c = (ix * dims[1] + iy) * dims[2]
                for iz in range(z0, z1 + 1):
                    _set_bit(bits, c + iz)


@numba.njit(cache=True, inline="always")
def _set_bit(bits, c):
    """Set bit c of the uint64 words ``bits``."""
    w = np.uint64(c)
    bits[w >> np.uint64(6)] |= np.uint64(1) << (w & np.uint64(63))


@numba.njit(cache=True, inline="always")
def touches_marked(lo, hi, k, origin, inv_c, dims, bits):
    """Whether box k of (lo, hi) touches a cell whose bit is set (``mark_particles``)."""
    x0, x1, y0, y1, z0, z1 = _occ_range(lo, hi, k, origin, inv_c, dims)
    for ix in range(x0, x1 + 1):
        for iy in range(y0, y1 + 1):
            c = (ix * dims[1] + iy) * dims[2]
            for iz in range(z0, z1 + 1):
                w = np.uint64(c + iz)
                if (bits[w >> np.uint64(6)] >> (w & np.uint64(63))) & np.uint64(1):
                    return True
    return False


class ParticleCells:
    """The cells the particle boxes of the step touch (the module docstring)."""

    def __init__(self):
        self.origin, self.inv_c, self.dims = np.zeros(3), 1.0, np.ones(3, np.int64)
        self.words = np.zeros(16, np.uint64)
        self.bits = self.words[:1]

    def mark_boxes(self, lo, hi, n, cloud, cell) -> None:
        """A grid over ``cloud (2, 3)`` (the boxes' bounds) of cells ``OCC_CELL * cell``, and the
        cells of the first n boxes (lo, hi) marked."""
        self.origin, self.inv_c, self.dims = occupancy_grid(cloud[0].copy(), cloud[1],
                                                            OCC_CELL * cell)
        words = (int(self.dims.prod()) + 63) // 64
        if self.words.shape[0] < words:
            self.words = np.zeros(words + words // 2, np.uint64)
        self.bits = self.words[:words]
        self.bits[:] = 0
        mark_particles(lo, hi, n, self.origin, self.inv_c, self.dims, self.bits)

    def args(self) -> tuple:
        """(origin, inv_c, dims, bits): what ``touches_marked`` reads."""
        return self.origin, self.inv_c, self.dims, self.bits
