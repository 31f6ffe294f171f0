"""What depends on the connectivity, followed in place after a node-separation release
(fracture/separation.py, ``SeparationPass.refresh``), at a cost in proportion to the moved
corners instead of a rebuild of the whole structure (O(N log N): about 30 ms per release step on
the 6,912-tet plate of tests/hard/test_separation_hard.py, most of the separation pass's time in
the shield).

A release repoints corners (element e, corner j) from their old rep to a new one, always a copy
that was dormant until then (no element corner, no mass, no force row); it only ever opens faces.

- Free faces of the fracture passes (``reconnect_boundary``, fracture/boundary.py): the faces a
  release opened become free faces of both sides, and the free faces of the moved tets take
  their new nodes; the rows are then put in slot order. The arrays equal those of a Boundary
  built afresh (whose rows are in slot order; erosion appends to them between releases).
- Live corners per node (``move_node_live``): one count from the old rep to the new one per
  moved live corner.
- Force rows of the element kernels (``reconnect_rows``, solver/scatter.py): a new rep gets its
  own index as the row of the first part (of consecutive elements) that now touches it and one
  extra row, appended after the existing rows, for each further part, listed in part order; the
  old rep keeps its rows (a part that no longer touches it adds nothing there). Every row keeps
  one writer and every node sums its rows in part order, so the forces are the bits of rows
  built afresh (a row left empty adds +0.0), on any thread count.
- Node-to-element indices (``move_node_elements``, solver/build.py ``node_to_element``): each
  moved corner's entry leaves its old node's list for its new node's, lists kept ascending; the
  entry count is unchanged, so only the nodes between the smallest and the largest moved node
  are rewritten (no sort).
- The hex blocks' free quads: ``fracture.hexes.reconnect_hex_boundary`` (with
  ``_open_faces_k``, the adjacency cut for any face shape).
"""

from __future__ import annotations

import numba
import numpy as np

from impactsim.contact.surface import _open_faces
from impactsim.mesh.topology import LOCAL_FACES
from impactsim.model import ERODED
from impactsim.solver.scatter import ForceRows


@numba.njit(cache=True)
def _reflag_faces(elems, changed_mask, conn, elem_body, adj, alive, face_flag, local_faces,
                  faces, face_slot, face_body, pos, n):
    """Free faces of ``elems`` (the moved tets and their neighbours) after ``_open_faces``: a
    face that became free is appended, a free face of a moved tet takes its new nodes.
    Returns the new row count (the arrays need room for 4 more rows per element)."""
    for k in range(elems.shape[0]):
        e = elems[k]
        for i in range(4):
            s = 4 * e + i
            nb = adj[e, i]
            free = alive[e] and not (nb >= 0 and alive[nb])
            if free and not face_flag[s]:
                face_flag[s] = True
                for q in range(3):
                    faces[n, q] = conn[e, local_faces[i, q]]
                face_slot[n] = s
                face_body[n] = elem_body[e]
                pos[s] = n
                n += 1
            elif free and changed_mask[e]:
                r = pos[s]
                for q in range(3):
                    faces[r, q] = conn[e, local_faces[i, q]]
    return n


def reconnect_boundary(b, conn: np.ndarray, changed: np.ndarray) -> None:
    """Follow a release in the fracture passes' free faces ``b`` (a fracture.boundary.Boundary):
    ``changed`` the tets whose corners were repointed in ``conn`` (module docstring)."""
    changed = np.unique(np.asarray(changed, dtype=np.int64))
    if changed.shape[0] == 0:
        return
    b.conn[changed] = conn[changed]
    nbs = b.adj[changed].reshape(-1)
    touched = np.unique(np.concatenate([changed, nbs[nbs >= 0]]))
    _open_faces(changed, b.conn, b.adj, LOCAL_FACES)
    need = b.n + 4 * touched.shape[0]
    if need > b.capacity:
        b.grows += 1
        b._alloc(max(need, int(1.5 * b.capacity)))
    mask = np.zeros(b.conn.shape[0], np.bool_)
    mask[changed] = True
    n = b.n = int(_reflag_faces(touched, mask, b.conn, b.elem_body, b.adj, b.alive,
                                b.face_flag, LOCAL_FACES, b.faces, b.face_slot, b.face_body,
                                b.pos, b.n))
    # the rows in slot order, the order of a Boundary built afresh: the particles take their
    # face impacts in row order, so a run keeps the bits of the rebuilding one (with the
    # appended order, particles hitting faces took another order: another, equally
    # deterministic run). Sorting the free faces costs far less than rebuilding from the tets.
    order = np.argsort(b.face_slot[:n], kind="stable")
    b.faces[:n] = b.faces[:n][order]
    b.face_slot[:n] = b.face_slot[:n][order]
    b.face_body[:n] = b.face_body[:n][order]
    b.pos[b.face_slot[:n]] = np.arange(n)


def move_node_live(node_live: np.ndarray, status: np.ndarray, e: np.ndarray, old: np.ndarray,
                   new: np.ndarray) -> None:
    """The live-corner counts follow the moved corners (e, old -> new) of live elements."""
    live = status[e] != ERODED
    np.subtract.at(node_live, old[live], 1)
    np.add.at(node_live, new[live], 1)


def reconnect_rows(fr: ForceRows, conn: np.ndarray, e: np.ndarray, j: np.ndarray,
                   new: np.ndarray) -> tuple[ForceRows, int]:
    """The force rows after corners (e, j) moved to the new reps ``new`` (``conn`` already
    repointed): (the rows, how many rows were added; ``fext`` grows by as many zero rows).
    The module docstring gives the rule; the new reps must have had no corner before."""
    n_node = fr.extra_ptr.shape[0] - 1
    part = e.astype(np.int64) // fr.part_size
    n_parts = max(1, (conn.shape[0] + fr.part_size - 1) // fr.part_size)
    key = new.astype(np.int64) * n_parts + part
    pairs, inv = np.unique(key, return_inverse=True)  # node-major, part-minor
    node = pairs // n_parts
    extra = np.zeros(pairs.shape[0], bool)
    extra[1:] = node[1:] == node[:-1]
    row = node.copy()
    m = int(np.count_nonzero(extra))
    row[extra] = fr.n_rows + np.arange(m)  # appended after the existing rows
    rows = fr.rows
    rows[e, j] = row[inv].astype(np.int32)
    if m == 0:
        return fr, 0
    xnode = node[extra]  # ascending, parts ascending within a node
    extra_rows = np.insert(fr.extra_rows, fr.extra_ptr[xnode], row[extra])
    extra_ptr = fr.extra_ptr.copy()
    extra_ptr[1:] += np.cumsum(np.bincount(xnode, minlength=n_node))
    return ForceRows(rows=rows, extra_ptr=extra_ptr, extra_rows=extra_rows,
                     n_rows=fr.n_rows + m, part_size=fr.part_size), m


# --- the node-to-element index ----------------------------------------------------------------
@numba.njit(cache=True)
def _move_entries(ptr, n2e, ent, by_old, old, by_new, new, buf):
    """In place: the entries ``ent`` (element * corners + corner) leave the lists of their
    nodes ``old`` for those of ``new``; ``by_old``, ``by_new`` the moves ordered by (old, entry)
    and (new, entry). Only the nodes from the smallest to the largest of old and new are
    rewritten (the entry count is unchanged, so the lists outside keep their place); each list
    stays ascending, as ``solver.build.node_to_element`` builds it. ``buf`` scratch of at least
    that span's entries."""
    m = ent.shape[0]
    lo = min(old[by_old[0]], new[by_new[0]])
    hi = max(old[by_old[m - 1]], new[by_new[m - 1]])
    start = ptr[lo]
    w = 0
    a = 0  # next removal (by_old)
    b = 0  # next insertion (by_new)
    for i in range(lo, hi + 1):
        k = ptr[i]
        end = ptr[i + 1]
        ptr[i] = start + w
        while k < end or (b < m and new[by_new[b]] == i):
            if k < end:
                x = n2e[k]
                if a < m and old[by_old[a]] == i and ent[by_old[a]] == x:
                    a += 1  # removed
                    k += 1
                    continue
                if b < m and new[by_new[b]] == i and ent[by_new[b]] < x:
                    buf[w] = ent[by_new[b]]
                    b += 1
                else:
                    buf[w] = x
                    k += 1
            else:
                buf[w] = ent[by_new[b]]
                b += 1
            w += 1
    for t in range(w):
        n2e[start + t] = buf[t]
    return w


def move_node_elements(ptr: np.ndarray, n2e: np.ndarray, corners: int, e: np.ndarray,
                       j: np.ndarray, old: np.ndarray, new: np.ndarray) -> None:
    """The node-to-element index (ptr, n2e; ``solver.build.node_to_element`` of a conn with
    ``corners`` columns) after the corners (e, j) moved from ``old`` to ``new``, in place and
    equal to the index built afresh, at the cost of the nodes between the smallest and the
    largest moved-to or moved-from node (no sort of the whole index)."""
    if e.shape[0] == 0:
        return
    ent = e.astype(np.int64) * corners + j
    old = old.astype(np.int64)
    new = new.astype(np.int64)
    by_old = np.lexsort((ent, old))
    by_new = np.lexsort((ent, new))
    lo = min(old[by_old[0]], new[by_new[0]])
    hi = max(old[by_old[-1]], new[by_new[-1]])
    buf = np.empty(int(ptr[hi + 1] - ptr[lo]), np.int64)
    _move_entries(ptr, n2e, ent, by_old, old, by_new, new, buf)


# --- the free quads of a hex block --------------------------------------------------------------
@numba.njit(cache=True)
def _open_faces_k(changed, conn, adj, local_faces):
    """``contact.surface._open_faces`` for any face shape (hex quads: 6 faces of 4 nodes): cut
    the adjacency across every face of ``changed`` whose two sides no longer share its nodes."""
    nf, w = local_faces.shape[0], local_faces.shape[1]
    for k in range(changed.shape[0]):
        e = changed[k]
        for i in range(nf):
            nb = adj[e, i]
            if nb < 0:
                continue
            for jn in range(nf):
                if adj[nb, jn] != e:
                    continue
                same = 0
                for q in range(w):
                    c = conn[nb, local_faces[jn, q]]
                    for r in range(w):
                        if c == conn[e, local_faces[i, r]]:
                            same += 1
                            break
                if same < w:
                    adj[e, i] = -1
                    adj[nb, jn] = -1
                break
