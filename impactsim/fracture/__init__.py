"""Fracture (ALGORITHMS.md 4.1-4.2): spall and loosening, particles from fully fractured
boundary cells, erosion with mass-conserving orphan handling and an incremental surface update.

Modules: principal (principal stress and stretch), criteria (spall, loosening, JC damage,
erosion and distortion-guard decisions per element), removal (erosion and particle conversion),
boundary (the free faces, updated in O(removed elements)), particles (particle arrays,
particle-face and particle-particle contact, motion), measures (residual velocity, hole size,
debris), passes (the passes bound to the model).
"""

from impactsim.fracture.passes import (FracturePass, FractureState, ParticlePass,
                                       make_fracture_passes)

__all__ = ["FracturePass", "FractureState", "ParticlePass", "make_fracture_passes"]
