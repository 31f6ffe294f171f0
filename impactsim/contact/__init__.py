"""Contact between bodies (ALGORITHMS.md 3): the symmetric node-face pass and the edge-edge pass
of [D19], with their surfaces, broad phase and an independent penetration measure.

Modules: surface (boundary faces/edges/nodes, incremental under erosion), broadphase (swept boxes
in a spatial hash), cubic (coplanarity in time and its roots), nodeface (3.1), edgeedge (3.2),
diagnostics (max_penetration), passes (the passes bound to the model).
"""

from impactsim.contact.diagnostics import PenetrationMeter, max_penetration
from impactsim.contact.passes import (ContactContext, EdgeEdgePass, NodeFacePass,
                                      make_contact_passes)
from impactsim.contact.surface import Surface

__all__ = ["ContactContext", "EdgeEdgePass", "NodeFacePass", "PenetrationMeter", "Surface",
           "make_contact_passes", "max_penetration"]
