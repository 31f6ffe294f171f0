"""The pass protocol: everything the time loop does besides the core element update is a pass.

A pass has a ``name`` (printed at start, the key of its timing in summary.json), a ``stage`` and a
``run(model, dt)`` that calls numba kernels on the model's arrays. The pipeline is built from the
case (``impactsim.solver.pipeline``): a pass exists only if the scene asks for its effect.

Stages, in the order the loop calls them within one step (ALGORITHMS.md 1):
  "velocity"  after the predictor U* = U^n + dt F/m, before positions move: boundary conditions,
              rigid walls, contact passes (they correct U* of boundary nodes)
  "fracture"  after the element update of the new step: spall, loosening, erosion, particles
Passes may also offer ``history(model) -> dict[str, float]`` (extra history.csv columns, called
on history rows only), ``summary(model) -> dict`` (merged into summary.json) and
``frame(model) -> {name: (points (k, 3), point data)}``: series of their own, written with every
frame of the mesh as ``<name>_*.vtu`` listed in ``<name>.pvd`` (the particles).
"""

from __future__ import annotations

import abc


class Pass(abc.ABC):
    name: str = "pass"
    stage: str = "velocity"

    @abc.abstractmethod
    def run(self, model, dt: float) -> None:
        """Advance this pass's effect over one step of length dt [s]."""

    def history(self, model) -> dict[str, float]:
        return {}

    def summary(self, model) -> dict:
        return {}
