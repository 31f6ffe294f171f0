"""Node copies for node separation [Z] (impactsim.fracture.separation): every element corner gets
a node of its own."""

from __future__ import annotations

import numpy as np


def split_points(pts: np.ndarray, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(copies (n k, 3), conn (n, k)) of a body made separable: copy e k + j of corner j of
    element e, and the connectivity pointing at each family's rep (its smallest copy)."""
    cells = np.asarray(cells, np.int64)
    n, k = cells.shape
    copies = np.ascontiguousarray(np.asarray(pts, np.float64)[cells.reshape(-1)])
    fam = cells.reshape(-1)
    rep = np.full(len(pts), n * k, np.int64)
    np.minimum.at(rep, fam, np.arange(n * k, dtype=np.int64))
    return copies, rep[fam].reshape(n, k)
