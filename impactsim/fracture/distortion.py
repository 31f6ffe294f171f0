"""Distortion erosion [Z] (ALGORITHMS.md 4.3): delete only the elements that are truly distorted.

Checked every interval T of the case (``[fracture] distortion_interval``, longer than the step),
for tets and hexes alike, whatever fracture method the material has (or none). An element is
deleted when one of these holds (counted under the first that does, in this order):

A. ``extent``: its extent along a global axis exceeds r1 * L_ch, L_ch its largest axis extent
   at t = 0 (the characteristic length at meshing, per element, so graded meshes are judged
   cell by cell);
B. ``volume``: the product of its three axis extents (its bounding box volume) exceeds r2 times
   the initial product;
C. ``piercing``: at some corner, the Jacobian of the three edges from that corner (a right-handed
   frame at t = 0) has changed sign: a node has passed through the opposite face.

A pure rotation leaves B's product within a factor 3 sqrt(3) and A's extent within sqrt(3) of the
initial values, so r1 > sqrt(3) and r2 > 5.2 never delete a rigidly rotated cube; the defaults
(r1 = 3, r2 = 8: [Z] gives no values in our sources) were chosen so that a large but regular
plastic strain (a stretch of 2, a shear of 1) deletes nothing, while the sheared-out rim cells
and slivers that throttle the time step do go (docs/fracture.md). A tet's corner Jacobians are
all 6V, so C is inversion for tets; for hexes it catches a corner pushed through the element
while the total volume is still positive.

One numba kernel, one pass over the elements, no allocation; run only every T.
"""

from __future__ import annotations

import numba
import numpy as np

from impactsim.model import ERODED

EXTENT, VOLUME, PIERCING = 1, 2, 3
CRITERIA = {EXTENT: "extent", VOLUME: "volume", PIERCING: "piercing"}

# the three edge ends of each corner, a right-handed frame for a positive element
TET_CORNER_EDGES = np.array([[1, 2, 3], [2, 0, 3], [0, 1, 3], [0, 2, 1]], dtype=np.int64)
HEX_CORNER_EDGES = np.array([[1, 3, 4], [2, 0, 5], [3, 1, 6], [0, 2, 7],
                             [7, 5, 0], [4, 6, 1], [5, 7, 2], [6, 4, 3]], dtype=np.int64)


def corner_edges(corners: int) -> np.ndarray:
    return TET_CORNER_EDGES if corners == 4 else HEX_CORNER_EDGES


@numba.njit(cache=True)
def _extents(x, conn, e):
    k = conn.shape[1]
    lo0 = hi0 = x[conn[e, 0], 0]
    lo1 = hi1 = x[conn[e, 0], 1]
    lo2 = hi2 = x[conn[e, 0], 2]
    for j in range(1, k):
        i = conn[e, j]
        lo0 = min(lo0, x[i, 0])
        hi0 = max(hi0, x[i, 0])
        lo1 = min(lo1, x[i, 1])
        hi1 = max(hi1, x[i, 1])
        lo2 = min(lo2, x[i, 2])
        hi2 = max(hi2, x[i, 2])
    return hi0 - lo0, hi1 - lo1, hi2 - lo2


@numba.njit(cache=True)
def _corner_jacobian(x, conn, e, c, edges):
    i = conn[e, c]
    a = conn[e, edges[c, 0]]
    b = conn[e, edges[c, 1]]
    d = conn[e, edges[c, 2]]
    ax, ay, az = x[a, 0] - x[i, 0], x[a, 1] - x[i, 1], x[a, 2] - x[i, 2]
    bx, by, bz = x[b, 0] - x[i, 0], x[b, 1] - x[i, 1], x[b, 2] - x[i, 2]
    dx, dy, dz = x[d, 0] - x[i, 0], x[d, 1] - x[i, 1], x[d, 2] - x[i, 2]
    return ax * (by * dz - bz * dy) + ay * (bz * dx - bx * dz) + az * (bx * dy - by * dx)


@numba.njit(cache=True)
def reference(x0, conn, edges, lch, box0, sign0):
    """Per element at the reference state x0: L_ch (largest axis extent), the product of the
    three axis extents, and the sign (+1 / -1) of every corner Jacobian."""
    for e in range(conn.shape[0]):
        a, b, c = _extents(x0, conn, e)
        lch[e] = max(a, max(b, c))
        box0[e] = a * b * c
        for j in range(conn.shape[1]):
            sign0[e, j] = 1 if _corner_jacobian(x0, conn, e, j, edges) >= 0.0 else -1


@numba.njit(cache=True)
def distortion_check(x, conn, status, active, edges, lch, box0, sign0, r1, r2, which):
    """Mark the live elements (``active[e]``) that are distorted: which[e] = EXTENT, VOLUME,
    PIERCING or 0 (module docstring). Returns the number marked."""
    n = 0
    for e in range(conn.shape[0]):
        which[e] = 0
        if status[e] == ERODED or not active[e]:
            continue
        a, b, c = _extents(x, conn, e)
        code = 0
        if max(a, max(b, c)) > r1 * lch[e]:
            code = EXTENT
        elif a * b * c > r2 * box0[e]:
            code = VOLUME
        else:
            for j in range(conn.shape[1]):
                jac = _corner_jacobian(x, conn, e, j, edges)
                if jac * sign0[e, j] <= 0.0:
                    code = PIERCING
                    break
        if code:
            which[e] = code
            n += 1
    return n


class DistortionCheck:
    """The reference measures of one element set (the tets or a block) and its check.

    ``active (n,) bool``: which elements may be deleted (bodies whose material erodes by
    distortion: all of them, distortion erosion is a case-wide setting).
    """

    def __init__(self, x0, conn, r1: float, r2: float, active=None):
        n, k = conn.shape
        self.conn = conn
        self.edges = corner_edges(k)
        self.lch, self.box0 = np.zeros(n), np.zeros(n)
        self.sign0 = np.zeros((n, k), np.int8)
        reference(x0, conn, self.edges, self.lch, self.box0, self.sign0)
        self.r1, self.r2 = float(r1), float(r2)
        self.active = np.ones(n, bool) if active is None else np.asarray(active, bool)
        self.which = np.zeros(n, np.int8)

    def check(self, x, conn, status) -> np.ndarray:
        """Ascending ids of the distorted elements; their criteria are in ``self.which``."""
        if conn.shape[0] == 0:
            return np.zeros(0, np.int64)
        n = distortion_check(x, conn, status, self.active, self.edges, self.lch, self.box0,
                             self.sign0, self.r1, self.r2, self.which)
        if not n:
            return np.zeros(0, np.int64)
        return np.flatnonzero(self.which).astype(np.int64)


class Distortion:
    """Distortion erosion of a run: the checks of the tets and of every element block, the next
    check time, the counts per criterion (summary.json ``fracture.distortion``)."""

    def __new__(cls, case, model):
        if case.fracture.distortion_interval is None:
            return None
        return super().__new__(cls)

    def __init__(self, case, model):
        f = case.fracture
        self.interval = float(f.distortion_interval)
        self.next = self.interval
        self.tets = DistortionCheck(model.x0, model.conn, f.distortion_extent,
                                    f.distortion_volume)
        self.blocks = [DistortionCheck(model.x0, b.conn, f.distortion_extent,
                                       f.distortion_volume) for b in model.blocks]
        self.counts = {name: 0 for name in CRITERIA.values()}
        self.checks = 0

    def due(self, model, dt: float) -> bool:
        """True once per interval: at the first step ending at or after the next check time."""
        if model.time + dt < self.next * (1.0 - 1e-12):
            return False
        while self.next <= (model.time + dt) * (1.0 + 1e-12):
            self.next += self.interval
        return True

    def _count(self, which, ids) -> None:
        codes = np.bincount(which[ids], minlength=4)
        for code, name in CRITERIA.items():
            self.counts[name] += int(codes[code])

    def check(self, model):
        """(tet ids, [(block, ids)]) of the distorted live elements, counted per criterion."""
        self.checks += 1
        tets = self.tets.check(model.x, model.conn, model.status)
        self._count(self.tets.which, tets)
        out = []
        for blk, chk in zip(model.blocks, self.blocks):
            ids = chk.check(model.x, blk.conn, blk.status)
            if ids.shape[0]:
                self._count(chk.which, ids)
                out.append((blk, ids))
        return tets, out

    def summary(self) -> dict:
        return {"interval": self.interval, "checks": self.checks,
                "deleted": sum(self.counts.values()), **self.counts}
