"""Face adjacency and surface preparation on a cube of about 5.3 million tetrahedra
(ALGORITHMS.md 4.2: [R20] needed 12 s on a 64-core workstation after their optimisation, 1091 s
before). Run: python benchmarks/bench_adjacency.py [cells per axis, default 96 -> 5,308,416 tets].

Times: face adjacency by sorting packed sorted-triple keys (impactsim.mesh.topology), the full
contact/fracture Surface (adjacency, unique edges, boundary flags and counts), and incremental
surface updates: deleting 1000 surface elements batch by batch, compared with one rebuild.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from impactsim.contact.surface import Surface
from impactsim.mesh.structured import structured_box
from impactsim.mesh.topology import face_adjacency
from impactsim.model import ERODED


def main(n: int = 96) -> dict:
    t = time.perf_counter()
    _, tets = structured_box((1.0, 1.0, 1.0), 1.0 / n)
    t_mesh = time.perf_counter() - t
    print(f"cube {n}^3 cells: {len(tets):,} tets ({t_mesh:.1f} s to build)", flush=True)
    t = time.perf_counter()
    adj = face_adjacency(tets)
    t_adj = time.perf_counter() - t
    print(f"face adjacency: {t_adj:.2f} s ({(adj < 0).sum():,} boundary faces)", flush=True)
    t = time.perf_counter()
    surf = Surface(tets, np.zeros(len(tets), np.int32))
    t_surf = time.perf_counter() - t
    print(f"surface (adjacency + edges + boundary): {t_surf:.2f} s, {surf.n_faces:,} faces",
          flush=True)
    ids = np.unique(surf.face_elem)[:1000]
    t = time.perf_counter()
    for batch in np.array_split(ids, 10):
        surf.remove_elements(batch)
    t_inc = (time.perf_counter() - t) / 10
    status = np.zeros(len(tets), np.int8)
    status[ids] = ERODED
    t = time.perf_counter()
    surf.rebuild(status)
    t_rebuild = time.perf_counter() - t
    print(f"incremental update (100 elements): {t_inc:.3f} s per batch; "
          f"rebuild from flags: {t_rebuild:.2f} s", flush=True)
    return {"tets": len(tets), "adjacency_s": t_adj, "surface_s": t_surf,
            "incremental_batch_s": t_inc, "rebuild_s": t_rebuild}


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 96)
