"""Deterministic parallel assembly of element forces onto nodes: parts and their force rows.

The element kernel adds each element's four corner forces to nodes. Two threads adding to one
node at once would race, and a sum whose order depends on the schedule would change the bits
with the number of threads. So the elements are split into fixed parts of consecutive elements
(`part_size` of them, the same for any number of threads), and every (node, part) pair gets a
row of its own in an extended force array `fext`:

- a node touched by one part only (most nodes) has one row, its own index;
- a node touched by several parts (on the border between parts) has its own index for the
  first of them and one extra row, after the n_node node rows, for each further part.

A part is run by one thread, its elements in order, so every row has one writer and one order
of summation. `take_node` then sums each node's rows in part order. The result does not depend on
which thread ran which part, nor on how many threads there are, and each thread walks its
parts in element (and so, after the Morton renumbering, in spatial) order, which keeps the node
data in cache: chunks coloured so that chunks of one colour share no node were 15-20 % slower
on one thread, because each colour sweeps the whole mesh (docs/performance.md).

Rows are int32 (n_elem, 4) like `Model.conn`; the extra rows are 0.6-1.1 per node for parts of
2048 to 8192 elements of a Morton-ordered tet mesh.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np


@dataclass
class ForceRows:
    """Where each element corner adds its force (see the module docstring).

    rows: (n_elem, k) int32 row of `fext` for corner k of element e (k = 4 tets, 8 hexes);
    extra_ptr: (n_node + 1,) int64, extra_rows: (n_extra,) int64: the further rows of node i
    are extra_rows[extra_ptr[i]:extra_ptr[i + 1]], in part order;
    n_rows: n_node + n_extra, the length of `fext`;
    part_size: elements per part.
    """
    rows: np.ndarray
    extra_ptr: np.ndarray
    extra_rows: np.ndarray
    n_rows: int
    part_size: int


def force_rows(conn: np.ndarray, n_node: int, part_size: int) -> ForceRows:
    """The rows of every element corner for parts of `part_size` consecutive elements."""
    n_elem, corners = conn.shape[0], conn.shape[1]  # 4 for tets, 8 for hexes
    n_parts = max(1, (n_elem + part_size - 1) // part_size)
    part = np.repeat(np.arange(n_elem, dtype=np.int64) // part_size, corners)
    key = conn.reshape(-1).astype(np.int64) * n_parts + part
    pairs, corner_pair = np.unique(key, return_inverse=True)  # sorted node-major, part-minor
    node = pairs // n_parts
    extra = np.zeros(pairs.shape[0], bool)
    extra[1:] = node[1:] == node[:-1]  # not the node's first part
    row = node.copy()
    # extra rows numbered part by part, so that a part's rows lie together in fext
    by_part = np.argsort(pairs[extra] % n_parts, kind="stable")
    extra_row = np.empty(by_part.shape[0], np.int64)
    extra_row[by_part] = n_node + np.arange(by_part.shape[0])
    row[extra] = extra_row
    extra_ptr = np.zeros(n_node + 1, np.int64)
    np.cumsum(np.bincount(node[extra], minlength=n_node), out=extra_ptr[1:])
    return ForceRows(rows=row[corner_pair].reshape(n_elem, corners).astype(np.int32),
                     extra_ptr=extra_ptr, extra_rows=row[extra].astype(np.int64),
                     n_rows=n_node + int(np.count_nonzero(extra)), part_size=part_size)


@numba.njit(cache=True, inline="always")
def take_node(i, fext, extra_ptr, extra_rows):
    """The sum of node i's rows of fext, its own row first, then in part order; leaves those
    rows zero for the next step (every row is one node's, so the kernels need no separate pass
    zeroing fext, only a zero fext at the start)."""
    fx, fy, fz = fext[i, 0], fext[i, 1], fext[i, 2]
    fext[i, 0] = 0.0
    fext[i, 1] = 0.0
    fext[i, 2] = 0.0
    for k in range(extra_ptr[i], extra_ptr[i + 1]):
        r = extra_rows[k]
        fx += fext[r, 0]
        fy += fext[r, 1]
        fz += fext[r, 2]
        fext[r, 0] = 0.0
        fext[r, 1] = 0.0
        fext[r, 2] = 0.0
    return fx, fy, fz
