"""Orientation: signed tet volumes, fixing inverted tets, and placing a body in the world.

A tet (x0, x1, x2, x3) is positively oriented when det[x1-x0, x2-x0, x3-x0] > 0; its volume is
that determinant over 6 (ALGORITHMS.md 2). Every mesh handed to the solver is positive.

Placement: a body is meshed around the origin (the primitive's centre), then rotated by the
intrinsic x-y-z Euler angles (a, b, c) of ``Body.rotation``, R = Rx(a) @ Ry(b) @ Rz(c), and
translated so the centre lands on ``Body.position``: x_world = position + R @ x_local.
R is a proper rotation (det R = +1), so placement keeps every tet's orientation.
"""

from __future__ import annotations

import numpy as np

# A tet is degenerate when |det| <= DEGENERATE_RTOL * (its longest edge)^3. A regular tet has
# |det| = l^3 / sqrt(2); 1e-10 flags only tets flat to rounding of the coordinates.
DEGENERATE_RTOL = 1.0e-10


def signed_dets(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """det[x1-x0, x2-x0, x3-x0] per tet: (e,) float64 [m^3], six times the signed volume.

    points: (n, 3) float64 [m]; tets: (e, 4) integer node indices.
    """
    x0 = points[tets[:, 0]]
    a = points[tets[:, 1]] - x0
    b = points[tets[:, 2]] - x0
    c = points[tets[:, 3]] - x0
    return np.einsum("ij,ij->i", a, np.cross(b, c))


def signed_volumes(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Signed volume per tet: (e,) float64 [m^3]; negative means inverted."""
    return signed_dets(points, tets) / 6.0


def degenerate_tets(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Indices of tets whose volume is zero up to rounding (see DEGENERATE_RTOL): (k,) int64."""
    det = signed_dets(points, tets)
    pairs = np.array([(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)])
    edges = points[tets[:, pairs[:, 1]]] - points[tets[:, pairs[:, 0]]]
    longest = np.sqrt(np.einsum("ijk,ijk->ij", edges, edges).max(axis=1))
    return np.flatnonzero(np.abs(det) <= DEGENERATE_RTOL * longest**3)


def fix_orientation(points: np.ndarray, tets: np.ndarray) -> tuple[np.ndarray, int]:
    """Return (tets with every negative tet's nodes 2 and 3 swapped, number of tets swapped).

    The input array is not modified. Degenerate tets are not detected here (see degenerate_tets).
    """
    out = np.array(tets, dtype=np.int32, copy=True)
    negative = signed_dets(points, out) < 0.0
    out[negative, 2], out[negative, 3] = tets[negative, 3], tets[negative, 2]
    return out, int(np.count_nonzero(negative))


def rotation_matrix(angles: tuple[float, float, float]) -> np.ndarray:
    """R = Rx(a) @ Ry(b) @ Rz(c), (3, 3) float64, for intrinsic x-y-z Euler angles [rad]."""
    a, b, c = (float(t) for t in angles)
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, ca, -sa], [0.0, sa, ca]])
    ry = np.array([[cb, 0.0, sb], [0.0, 1.0, 0.0], [-sb, 0.0, cb]])
    rz = np.array([[cc, -sc, 0.0], [sc, cc, 0.0], [0.0, 0.0, 1.0]])
    return rx @ ry @ rz


def place(points: np.ndarray, rotation: tuple[float, float, float],
          position: tuple[float, float, float]) -> np.ndarray:
    """World coordinates position + R @ x of local points (n, 3) [m]: a new (n, 3) float64 array.

    With zero rotation the points are only translated (no rounding from multiplying by identity).
    """
    out = np.array(points, dtype=np.float64, copy=True)
    if any(float(t) != 0.0 for t in rotation):
        out = out @ rotation_matrix(rotation).T
    out += np.asarray(position, dtype=np.float64)
    return out
