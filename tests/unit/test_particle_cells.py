"""The cells the particles touch (fracture/particle_cells.py): a face box that overlaps a
particle's box always touches one of its marked cells (closed intervals: boxes that only share a
boundary plane count, as in the hash's query), also outside the grid's range where the cells
are clamped; and boxes far from every particle do not."""

import numpy as np

from impactsim.fracture.particle_cells import ParticleCells, touches_marked
from impactsim.fracture.particles import particle_boxes
from tests.unit.test_fracture_particle_contact import _overlapping


def _touching(lo, hi, cells):
    """touches_marked for every box of (lo, hi)."""
    args = cells.args()
    return np.array([touches_marked(lo, hi, k, *args) for k in range(lo.shape[0])])


def test_every_box_that_overlaps_a_particle_touches_a_marked_cell():
    rng = np.random.default_rng(5)
    n, nf, cell = 200, 4000, 1e-4
    px = rng.uniform(0.0, 2e-3, (n, 3))
    pv = rng.normal(0.0, 1e3, (n, 3))
    pr = rng.uniform(0.1 * cell, 1.5 * cell, n)
    plo, phi, cloud = np.empty((n, 3)), np.empty((n, 3)), np.empty((2, 3))
    particle_boxes(px, pv, pr, n, 1e-8, 1e-9, plo, phi, cloud)
    cells = ParticleCells()
    cells.mark_boxes(plo, phi, n, cloud, cell)
    # face boxes from a tenth of a cell to two cells wide, over and beyond the cloud
    lo = rng.uniform(-5e-4, 2.5e-3, (nf, 3))
    hi = lo + rng.uniform(0.1 * cell, 2 * cell, (nf, 3))
    # and boxes whose upper corner is a particle box's lower one (they touch at a corner), or
    # whose lower corner is its upper one
    pick = rng.integers(0, n, 200)
    lo[:100], hi[:100] = plo[pick[:100]] - 0.3 * cell, plo[pick[:100]]
    lo[100:200], hi[100:200] = phi[pick[100:]], phi[pick[100:]] + 0.3 * cell
    over = _overlapping(lo, hi, plo, phi)
    touch = _touching(lo, hi, cells)
    assert over[:200].all()
    assert touch[over].all()  # no pair lost
    assert over.sum() > 600 and (~touch).sum() > nf // 2  # and most far boxes left out


def test_the_grid_of_a_wide_cloud_has_larger_cells():
    """A cloud that would need more than OCC_MAX_CELLS cells of the hash's size gets larger
    ones (broadphase.occupancy_grid): the test stays a superset of the overlaps."""
    from impactsim.contact.broadphase import OCC_MAX_CELLS

    rng = np.random.default_rng(6)
    n = 500
    px = np.concatenate([rng.uniform(0.0, 1e-3, (n - 1, 3)), [[5.0, 5.0, 5.0]]])
    pv = np.zeros((n, 3))
    pr = np.full(n, 2e-5)
    plo, phi, cloud = np.empty((n, 3)), np.empty((n, 3)), np.empty((2, 3))
    particle_boxes(px, pv, pr, n, 1e-8, 0.0, plo, phi, cloud)
    cells = ParticleCells()
    cells.mark_boxes(plo, phi, n, cloud, 1e-4)
    assert int(np.prod(cells.dims)) <= OCC_MAX_CELLS
    lo = rng.uniform(-1e-4, 1.1e-3, (2000, 3))
    hi = lo + 5e-5
    over = _overlapping(lo, hi, plo, phi)
    assert over.sum() > 20 and _touching(lo, hi, cells)[over].all()
