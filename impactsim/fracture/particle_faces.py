"""The faces near the particles on the threads: ``particles.faces_near`` for a large surface.

``faces_near`` walks the free faces once, on one thread: each face's swept box from its three
nodes (gathered from x and v, rows far apart), the faces whose box meets the particle cloud's
kept in order, their nodes packed into the sweep's table. On oblique-sphere (28-30k free
faces, nearly all near the cloud) that walk was 1.2 ms of a 7.5 ms particle pass, every step.
Here the same in three parallel loops, each over fixed chunks (so the result does not depend
on the number of threads, and no two threads write one place):

1. per chunk of faces: every face's box into the scratch rows of the face, whether it is near
   the cloud and touches a particle's cell (``particle_cells``), the chunk's count and the
   bounds of its near faces;
2. per chunk, at the chunk's offset (the counts' prefix): the near faces' rows, bodies and
   boxes, in face order;
3. per chunk of nodes: every node's row of the sweep's table (``pack_all_nodes``: a stream
   over all nodes instead of three scattered rows for each near face, which packed most nodes
   about six times; the sweep reads only the rows of its faces' nodes).
The selection, boxes, bounds and table rows are ``faces_near``'s, bit for bit.
"""

from __future__ import annotations

import numba
import numpy as np

from impactsim.fracture.particle_cells import touches_marked
from impactsim.fracture.particles import face_box, pack_node

FACE_CHUNK = 2048  # faces per task (fixed: the chunks do not depend on the threads)
NODE_CHUNK = 4096  # nodes per task of the table
THREADED_FACES = 4 * FACE_CHUNK  # fewer faces: faces_near on one thread (a launch costs more)


@numba.njit(cache=True, parallel=True)
def faces_near_threads(x, v, tau, faces, face_body, n_faces, pad, cloud, origin, inv_c, dims,
                       bits, lo, hi, sel, sel_body, bounds, box_lo, box_hi, near, counts,
                       chunk_bounds):
    """``particles.faces_near`` without the table (``pack_all_nodes`` fills it), on the
    threads. Scratch: box_lo, box_hi (n_faces, 3), near (n_faces,) uint8, counts (n_chunk,)
    int64, chunk_bounds (n_chunk, 2, 3), n_chunk = ceil(n_faces / FACE_CHUNK). Writes the near
    faces' rows to sel, sel_body, lo, hi (in order), widens bounds; returns their number."""
    n_chunk = (n_faces + FACE_CHUNK - 1) // FACE_CHUNK
    for c in numba.prange(n_chunk):
        cnt = 0
        for d in range(3):
            chunk_bounds[c, 0, d] = np.inf
            chunk_bounds[c, 1, d] = -np.inf
        for f in range(c * FACE_CHUNK, min(n_faces, (c + 1) * FACE_CHUNK)):
            inside = (face_box(x, v, tau, faces, f, pad, cloud, box_lo, box_hi, f)
                      and touches_marked(box_lo, box_hi, f, origin, inv_c, dims, bits))
            near[f] = 1 if inside else 0
            if inside:
                cnt += 1
                for d in range(3):
                    chunk_bounds[c, 0, d] = min(chunk_bounds[c, 0, d], box_lo[f, d])
                    chunk_bounds[c, 1, d] = max(chunk_bounds[c, 1, d], box_hi[f, d])
        counts[c] = cnt
    k = 0
    for c in range(n_chunk):  # offsets, and the bounds (min and max: any order, same bits)
        cnt = counts[c]
        counts[c] = k
        k += cnt
        for d in range(3):
            bounds[0, d] = min(bounds[0, d], chunk_bounds[c, 0, d])
            bounds[1, d] = max(bounds[1, d], chunk_bounds[c, 1, d])
    for c in numba.prange(n_chunk):
        r = counts[c]
        for f in range(c * FACE_CHUNK, min(n_faces, (c + 1) * FACE_CHUNK)):
            if near[f]:
                for j in range(3):
                    sel[r, j] = faces[f, j]
                sel_body[r] = face_body[f]
                for d in range(3):
                    lo[r, d] = box_lo[f, d]
                    hi[r, d] = box_hi[f, d]
                r += 1
    return k


@numba.njit(cache=True, parallel=True)
def pack_all_nodes(x, v, mass, xv):
    """Every node's row of the sweep's table ``xv (n_node, NODE_COLS)``: position, predicted
    velocity, mass (``particles.pack_node``), in chunks over the threads."""
    n = x.shape[0]
    for c in numba.prange((n + NODE_CHUNK - 1) // NODE_CHUNK):
        for i in range(c * NODE_CHUNK, min(n, (c + 1) * NODE_CHUNK)):
            pack_node(i, x, v, mass, xv)


def threaded_faces_wanted(n_faces: int) -> bool:
    """Whether the faces near the particles are found on the threads."""
    return n_faces >= THREADED_FACES and numba.get_num_threads() > 1

