"""Memory of a run: the bytes its arrays take, per element and per node, before it is built.

The state is flat arrays (impactsim/model.py), so its size is a sum over arrays of
(entities x bytes per entity). The tables below are those sums, array by array, for the
state the run keeps (`Model`, the integrator's buffers in `solver/loop.py` and
`solver/scatter.py`), the contact surface (`contact/surface.py`) and the fracture state
(`fracture/`); tests/unit/test_footprint.py checks them against the bytes numpy actually
holds after a built run has taken steps. Setup needs more for a moment (meshing and the
force rows' sort): PEAK_FACTOR, and the process itself BASE_BYTES.

``run_bytes(n_elem, n_node, ...)`` is the estimate; ``memory_warning(...)`` the message to
print before a run whose estimate exceeds the memory the machine has available. It is meant
to be called by the check estimate (case/estimate.py) and before a run starts.
"""

from __future__ import annotations

import os

# bytes per element of the state every run keeps
ELEMENT = {
    "conn (4 int32)": 16, "elem_body, elem_mat (int32)": 8, "status (int8)": 1,
    "sdev (6 float64)": 48,
    "pressure, q, eps_p, eps_rate, temperature, energy, damage, vol, vol0, elem_mass": 80,
    "n2e (4 int64)": 32,
    "yield caches hardening, thermal, vol_now (float64)": 24,
    "force rows (4 int32)": 16,
}
# bytes per node of the state every run keeps
NODE = {
    "x, v, x0, force (3 float64)": 96, "mass (float64)": 8, "node_body (int32)": 4,
    "n2e_ptr (int64)": 8, "jnode (float64)": 8, "extra_ptr (int64)": 8,
    # force rows: about 1.1 extra rows per node (parts of 2048 Morton-ordered tets), 3 float64
    # each plus their int64 index, besides the node's own row
    "fext and extra_rows": 24 + 1.1 * (24 + 8),
}
ANP_ELEMENT = 8  # vol_eos (float64)
# the contact surface: its copies of conn and elem_body, mesh edges (2 int64, about 1.2 per
# element), elem_edges (6 int64), face adjacency (4 int64), alive and face flags, and the
# per-face and per-edge rows of the boundary (counted per element: a bulk bound)
CONTACT_ELEMENT = 16 + 4 + 1.2 * 16 + 48 + 32 + 1 + 4 + 16
# the kept candidate lists (contact/skin.py) that follow the surface through erosion: per pass
# the build positions of every node (3 float64; two passes), and the identities, pair maps,
# row positions and left-out-row occupancy of the surface's entities (counted per element: a
# bulk bound, measured 66 bytes at 48k elements)
CONTACT_NODE = 2 * 24
CONTACT_FOLLOW_ELEMENT = 64
# the fracture state: Boundary (conn, elem_body copies, adjacency 4 int64, face flags, face
# positions 4 int64, alive), action (int8), ids (int64), eps_p_prev and the Tuler-Butcher
# accumulator spall_k (float64)
FRACTURE_ELEMENT = 16 + 4 + 32 + 4 + 32 + 1 + 1 + 8 + 8 + 8
FRACTURE_NODE = 4  # node_live (int32)
# peak during setup over the kept state: 1.2-1.35 measured for a block on a wall at 1M-2M
# elements (benchmarks/bench_scale.py), up to 1.6 with contact and fracture at 120k-160k
PEAK_FACTOR = 1.8
BASE_BYTES = 300 * 2**20  # the interpreter, numpy, numba and the loaded kernels (~290 MB)


def run_bytes(n_elem: int, n_node: int, contact: bool = False, fracture: bool = False,
              anp: bool = False) -> float:
    """Bytes of the arrays a run keeps (module docstring), without the output buffers and
    the particles (which grow with the fracture)."""
    per_elem = sum(ELEMENT.values()) + (ANP_ELEMENT if anp else 0)
    per_node = sum(NODE.values())
    if contact:
        per_elem += CONTACT_ELEMENT + CONTACT_FOLLOW_ELEMENT
        per_node += CONTACT_NODE
    if fracture:
        per_elem += FRACTURE_ELEMENT
        per_node += FRACTURE_NODE
    return float(n_elem * per_elem + n_node * per_node)


def peak_bytes(n_elem: int, n_node: int, **kw) -> float:
    """What the run's process needs at its peak (setup), from run_bytes."""
    return BASE_BYTES + PEAK_FACTOR * run_bytes(n_elem, n_node, **kw)


def available_bytes() -> int | None:
    """The memory the machine can give a new process now (MemAvailable of /proc/meminfo, else
    the physical pages), or None when it cannot be told."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def memory_warning(n_elem: int, n_node: int, available: int | None = None, **kw) -> str | None:
    """A one-line warning when the run's peak would not fit in the available memory, else
    None. ``kw``: contact, fracture, anp as in run_bytes."""
    need = peak_bytes(n_elem, n_node, **kw)
    have = available_bytes() if available is None else available
    if have is None or need <= have:
        return None
    return (f"this run needs about {need / 2**30:.1f} GiB ({n_elem:,} elements, "
            f"{need / n_elem:.0f} bytes each at the peak), more than the "
            f"{have / 2**30:.1f} GiB available: it may fail or swap; use a coarser mesh_size")


def case_memory_warning(case, n_elem: int, n_node: int, available: int | None = None):
    """``memory_warning`` for a case (its passes decide what is counted), once the mesh sizes
    are known: run_case calls it before building the state."""
    contact = bool(case.contact.passes) and (len(case.bodies) > 1 or case.contact.self_contact)
    fracture = any(m.failure.active for m in case.materials.values())
    return memory_warning(n_elem, n_node, available, contact=contact, fracture=fracture,
                          anp=case.run.element == "anp")
